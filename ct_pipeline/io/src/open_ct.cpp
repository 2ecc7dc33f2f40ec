// open_ct(): decides what a path holds and hands it to the right reader; create_ct_writer()
// picks the writer for a format.
#include <algorithm>
#include <cctype>
#include <string>
#include <vector>

#include "readers.h"
#include "sawyer/ct/io/limits.h"
#include "text_parse.h"

namespace sawyer::ct {

namespace fs = std::filesystem;

const char* format_name(Format f) {
  switch (f) {
    case Format::kDicom:
      return "DICOM series";
    case Format::kTiffStack:
      return "TIFF stack";
    case Format::kMultiPageTiff:
      return "multi-page TIFF";
    case Format::kPngStack:
      return "PNG stack";
    case Format::kVti:
      return "VTK image data (.vti)";
    case Format::kMetaImage:
      return "MetaImage (.mha/.mhd)";
    case Format::kNrrd:
      return "NRRD";
  }
  return "unknown";
}

double VolumeGeometry::slice_spacing() const {
  if (z.size() < 2) return 0.0;
  std::vector<double> d(z.size() - 1);
  for (size_t i = 1; i < z.size(); ++i) d[i - 1] = z[i] - z[i - 1];
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

namespace {

std::string lower_ext(const fs::path& p) { return detail::lower(p.extension().string()); }

bool is_volume_ext(const std::string& e) {
  return e == ".vti" || e == ".mha" || e == ".mhd" || e == ".nrrd" || e == ".nhdr";
}
bool is_image_ext(const std::string& e) { return e == ".tif" || e == ".tiff" || e == ".png"; }

Result<std::unique_ptr<SliceSource>> open_raw(const fs::path& path, const OpenOptions& options) {
  std::error_code ec;
  const auto st = fs::status(path, ec);
  if (ec || !fs::exists(st)) return Error(path.string(), "no such file or folder");

  if (fs::is_regular_file(st)) {
    const std::string e = lower_ext(path);
    if (is_volume_ext(e)) return detail::open_vtk_volume(path, options);
    if (e == ".tif" || e == ".tiff") return detail::open_image_stack(path, options);
    if (e == ".png")
      return Error(path.string(), "one PNG is a single slice; give the folder of the stack");
    if (e == ".dcm" || detail::looks_like_dicom(path)) return detail::open_dicom(path, options);
    return Error(path.string(),
                 "not a CT file Sawyer reads (DICOM, TIFF, .vti, .mha/.mhd, .nrrd/.nhdr)");
  }
  if (!fs::is_directory(st)) return Error(path.string(), "neither a file nor a folder");

  int n_files = 0, n_dicom = 0, n_image = 0;
  std::vector<fs::path> volumes;
  for (fs::directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& p = it->path();
    if (p.filename().string().starts_with(".")) continue;
    std::error_code fec;
    if (!it->is_regular_file(fec)) continue;
    ++n_files;
    const std::string e = lower_ext(p);
    if (is_volume_ext(e)) {
      volumes.push_back(p);
    } else if (is_image_ext(e)) {
      ++n_image;
    } else if (e == ".dcm" || e == ".ima" || detail::looks_like_dicom(p)) {
      ++n_dicom;
    }
  }
  if (ec) return Error(path.string(), "cannot list the folder: " + ec.message());
  if (n_files == 0) return Error(path.string(), "the folder is empty");
  if (n_dicom > 0) return detail::open_dicom(path, options);
  if (n_image > 0) return detail::open_image_stack(path, options);
  if (volumes.size() == 1) {
    return detail::open_vtk_volume(volumes[0], options);
  }
  if (volumes.size() > 1) {
    // Several volumes (or an .nhdr beside a .nrrd) are ambiguous: the user names the file.
    std::string list;
    std::sort(volumes.begin(), volumes.end());
    for (const auto& v : volumes) list += (list.empty() ? "" : ", ") + v.filename().string();
    return Error(path.string(), "holds " + std::to_string(volumes.size()) + " volume files (" +
                                    list + "); give the one to read");
  }
  return Error(path.string(), "no CT slices found among " + std::to_string(n_files) +
                                  " files (expected DICOM, TIFF, PNG, .vti, .mha/.mhd or .nrrd)");
}

}  // namespace

Result<std::unique_ptr<SliceSource>> open_ct(const fs::path& path, const OpenOptions& options) {
  auto raw = open_raw(path, options);
  if (!raw) return raw.error();
  // Each reader checks its numbers where it reads them; this holds every format to the same
  // limits once more, before anything is resampled or allocated from them.
  const std::string where = path.string();
  if (Status st = check_geometry_limits(where, raw.value()->geometry()); !st) return st.error();
  auto uniform = detail::make_uniform_z(std::move(raw).value(), options, where);
  if (!uniform) return uniform.error();
  // The even grid may hold more slices than the files (missing ones filled in).
  const VolumeGeometry& g = uniform.value()->geometry();
  if (Status st = check_geometry_limits(where, g); !st) return st.error();
  if (Status st = check_memory(where, g, options.memory_available_bytes); !st) return st.error();
  return uniform;
}

Result<std::unique_ptr<SliceSink>> create_ct_writer(const fs::path& out,
                                                    const VolumeGeometry& geometry,
                                                    const WriteOptions& options) {
  if (geometry.width <= 0 || geometry.height <= 0 || geometry.z.empty())
    return Error(out.string(), "nothing to write: empty geometry");
  if (!(geometry.spacing_x > 0) || !(geometry.spacing_y > 0))
    return Error(out.string(), "pixel spacing must be positive");
  switch (options.format) {
    case Format::kDicom:
      return detail::create_dicom_writer(out, geometry, options);
    case Format::kTiffStack:
    case Format::kMultiPageTiff:
    case Format::kPngStack:
      return detail::create_image_stack_writer(out, geometry, options);
    case Format::kVti:
    case Format::kMetaImage:
    case Format::kNrrd:
      return detail::create_volume_writer(out, geometry, options);
  }
  return Error(out.string(), "unknown output format");
}

}  // namespace sawyer::ct
