// The volume file reader behind open_ct(): .vti (vti_reader.cpp), .mha/.mhd
// (metaimage_reader.cpp), .nrrd/.nhdr (nrrd_reader.cpp), read one slice at a time through the
// VTK pipeline's update extent; geometry, scalar type and HU are worked out here for all three.
// docs/ct_input.md is the user's side of it.
//
// VTK's readers trust their headers, so every file is checked by its format's file first. What
// passes is handed to VTK. Where a reader cannot produce one slice on request it reads the whole
// volume once, and the source says so in a note:
//   - .vti: per slice (VTK's appended/compressed blocks can be read in part);
//   - .mha/.mhd uncompressed: per slice through vtkImageReader2 (vtkMetaImageReader itself
//     writes the whole volume into a buffer sized for the requested slice, a heap overflow, so
//     it is never asked for less than everything);
//   - .mha/.mhd compressed: whole volume through vtkMetaImageReader;
//   - .nrrd/.nhdr raw: per slice through vtkImageReader2 (vtkNrrdReader reads row by row and
//     rereads its header on every update, 2.5 times slower);
//   - .nrrd/.nhdr gzip: whole volume through vtkNrrdReader (it cannot seek in gzip data).
#include <vtkExecutive.h>
#include <vtkInformation.h>
#include <vtkPointData.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <new>
#include <system_error>
#include <type_traits>

#include "readers.h"
#include "sawyer/ct/io/limits.h"
#include "text_parse.h"
#include "volume_common.h"

namespace sawyer::ct::detail {

Status VtkVolumeSource::read(int i, Slice& out) {
  try {
    return read_slice(i, out);
  } catch (const std::bad_alloc&) {
    return Error(file_.string(), "slice " + std::to_string(i) + ": out of memory");
  } catch (const std::exception& e) {
    return Error(file_.string(), "slice " + std::to_string(i) + ": " + e.what());
  } catch (...) {
    return Error(file_.string(), "slice " + std::to_string(i) + ": cannot read the volume");
  }
}

Result<vtkDataArray*> VtkVolumeSource::update(int i, vtkImageData** image) {
  const std::string where = file_.string();
  int ext[6] = {extent_[0], extent_[1], extent_[2], extent_[3], extent_[4] + i, extent_[4] + i};
  if (whole_) {
    std::copy(extent_, extent_ + 6, ext);
    if (whole_loaded_) {
      *image = vtkImageData::SafeDownCast(reader_->GetOutputDataObject(0));
      return (*image)->GetPointData()->GetScalars();
    }
  }
  errors_->clear();
  const int ok = reader_->UpdateExtent(ext);
  vtkImageData* img = vtkImageData::SafeDownCast(reader_->GetOutputDataObject(0));
  if (!ok || errors_->any() || !img) {
    return Error(where, with_detail(whole_ ? std::string("cannot read the volume")
                                           : "cannot read slice " + std::to_string(i),
                                    errors_->first()));
  }
  int got[6];
  img->GetExtent(got);
  for (int a = 0; a < 3; ++a) {
    if (got[2 * a] > ext[2 * a] || got[2 * a + 1] < ext[2 * a + 1])
      return Error(where, "the reader returned less data than the header declares");
  }
  vtkDataArray* scalars = img->GetPointData()->GetScalars();
  if (!scalars && img->GetPointData()->GetNumberOfArrays() > 0)
    scalars = img->GetPointData()->GetArray(0);
  if (!scalars) return Error(where, "holds no point data (no CT values)");
  if (scalars->GetNumberOfComponents() != 1) {
    return Error(where, "has " + std::to_string(scalars->GetNumberOfComponents()) +
                            " values per voxel; CT volumes have one");
  }
  const vtkIdType want =
      static_cast<vtkIdType>(got[1] - got[0] + 1) * (got[3] - got[2] + 1) * (got[5] - got[4] + 1);
  if (scalars->GetNumberOfTuples() < want)
    return Error(where, "the reader returned less data than the header declares");
  if (whole_) whole_loaded_ = true;
  *image = img;
  return scalars;
}

template <typename T>
Status VtkVolumeSource::convert(const T* base, vtkImageData* img, int k, int i, Slice& out) {
  const int w = geometry_.width, h = geometry_.height;
  int got[6];
  img->GetExtent(got);
  const vtkIdType row_stride = got[1] - got[0] + 1;
  const vtkIdType slice_stride = row_stride * (got[3] - got[2] + 1);
  const float s = static_cast<float>(slope_), b = static_cast<float>(intercept_);
  constexpr bool kFloat = std::is_floating_point_v<T>;
  for (int r = 0; r < h; ++r) {
    const T* row = base + (k - got[4]) * slice_stride + (extent_[2] + r - got[2]) * row_stride +
                   (extent_[0] - got[0]);
    float* dst = out.hu.data() + static_cast<size_t>(r) * w;
    for (int c = 0; c < w; ++c) {
      dst[c] = static_cast<float>(row[c]) * s + b;
      if constexpr (kFloat) {
        // Also catches doubles beyond float's range, which become infinite here.
        if (!std::isfinite(dst[c])) {
          return Error(file_.string(), "slice " + std::to_string(i) + ": value " +
                                           (std::isnan(row[c]) ? std::string("NaN") : num(row[c])) +
                                           " at pixel (" + std::to_string(c) + ", " +
                                           std::to_string(r) + ")");
        }
      }
    }
  }
  return Status::Ok();
}

Status VtkVolumeSource::read_slice(int i, Slice& out) {
  if (i < 0 || i >= geometry_.slice_count())
    return Error(file_.string(), "slice " + std::to_string(i) + " out of range");
  vtkImageData* img = nullptr;
  Result<vtkDataArray*> arr = update(i, &img);
  if (!arr) return arr.error();
  std::optional<Scalar> sc = scalar_of_vtk(arr.value()->GetDataType());
  if (!sc || (scalar_ && *sc != *scalar_))
    return Error(file_.string(), "slice " + std::to_string(i) + ": unexpected data type");
  out.index = i;
  out.z = geometry_.z[i];
  out.width = geometry_.width;
  out.height = geometry_.height;
  out.hu.resize(static_cast<size_t>(out.width) * out.height);
  const int k = extent_[4] + i;
  void* p = arr.value()->GetVoidPointer(0);
  switch (*sc) {
    case Scalar::kU8:
      return convert(static_cast<const uint8_t*>(p), img, k, i, out);
    case Scalar::kI8:
      return convert(static_cast<const int8_t*>(p), img, k, i, out);
    case Scalar::kU16:
      return convert(static_cast<const uint16_t*>(p), img, k, i, out);
    case Scalar::kI16:
      return convert(static_cast<const int16_t*>(p), img, k, i, out);
    case Scalar::kF32:
      return convert(static_cast<const float*>(p), img, k, i, out);
    case Scalar::kF64:
      return convert(static_cast<const double*>(p), img, k, i, out);
  }
  return Status::Ok();
}

namespace {

Result<std::unique_ptr<SliceSource>> open_volume(const fs::path& file, const OpenOptions& options) {
  const std::string where = file.string();
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return Error(where, "no such file");
  const std::string e = lower(file.extension().string());

  auto src = std::make_unique<VtkVolumeSource>();
  src->file_ = file;
  src->errors_ = vtkSmartPointer<VtkErrors>::New();
  VolumeHeader h;
  bool scalar_known = true;
  if (e == ".vti") {
    src->format_ = Format::kVti;
    if (Status st = open_vti(file, *src, h); !st) return st.error();
    scalar_known = false;
    if (h.compressed) {
      src->notes_.push_back(
          "compressed .vti: VTK decompresses whole blocks, so each slice costs "
          "more than with raw data");
    }
  } else if (e == ".mha" || e == ".mhd") {
    src->format_ = Format::kMetaImage;
    if (Status st = open_metaimage(file, *src, h); !st) return st.error();
  } else if (e == ".nrrd" || e == ".nhdr") {
    src->format_ = Format::kNrrd;
    if (Status st = open_nrrd(file, *src, h); !st) return st.error();
  } else {
    return Error(where, "not a volume file Sawyer reads (.vti, .mha/.mhd, .nrrd/.nhdr)");
  }
  if (h.dims[2] < 2) return Error(where, "needs at least 2 slices, found 1");

  if (src->format_ != Format::kVti) {
    src->errors_->watch(src->reader_);
    src->errors_->watch(src->reader_->GetExecutive());
    src->errors_->clear();
    src->reader_->UpdateInformation();
    if (src->errors_->any())
      return Error(where, with_detail("cannot read the header", src->errors_->first()));
    vtkInformation* info = src->reader_->GetOutputInformation(0);
    if (!info || !info->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
      return Error(where, "cannot read the header");
    info->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), src->extent_);
    // VTK must see the volume the header check saw.
    for (int a = 0; a < 3; ++a) {
      if (src->extent_[2 * a + 1] - src->extent_[2 * a] + 1 != h.dims[a])
        return Error(
            where, "VTK reads the header differently (size along axis " + std::to_string(a) + ")");
    }
  }

  // Geometry.
  VolumeGeometry& g = src->geometry_;
  g.width = h.dims[0];
  g.height = h.dims[1];
  g.spacing_x = h.spacing[0];
  g.spacing_y = h.spacing[1];
  g.z.resize(h.dims[2]);
  for (int k = 0; k < h.dims[2]; ++k) g.z[k] = k * h.spacing[2];
  // Origin of voxel (extent start), not of index 0 when a .vti's extent starts elsewhere.
  g.origin = h.origin + (src->extent_[0] * h.spacing[0]) * h.axis[0] +
             (src->extent_[2] * h.spacing[1]) * h.axis[1] +
             (src->extent_[4] * h.spacing[2]) * h.axis[2];
  g.orientation = {h.axis[0].x, h.axis[0].y, h.axis[0].z, h.axis[1].x, h.axis[1].y, h.axis[1].z};
  g.slice_dir = h.axis[2];
  if (std::abs(dot(h.axis[0], h.axis[1])) > 1e-3)
    src->notes_.push_back("row and column directions are not perpendicular");
  // Before the first slice is read: sizes, field of view, extent and origin within the limits.
  if (Status st = check_geometry_limits(where, g); !st) return st.error();

  // The scalar type: from the header, or (.vti) from reading the first slice.
  Slice probe;
  if (!scalar_known) {
    vtkImageData* img = nullptr;
    Result<vtkDataArray*> arr = src->update(0, &img);
    if (!arr) return arr.error();
    const int t = arr.value()->GetDataType();
    std::optional<Scalar> sc = scalar_of_vtk(t);
    if (!sc) {
      return Error(where, std::string("data type ") + arr.value()->GetDataTypeAsString() +
                              " is not supported (Sawyer reads int16, uint16, uint8, int8, float, "
                              "double)");
    }
    h.scalar = *sc;
  }
  src->scalar_ = h.scalar;

  // HU: the file's values are HU unless a rescale is given (options, then the MetaImage keys).
  std::optional<double> slope = options.rescale_slope, intercept = options.rescale_intercept;
  if (slope && !(std::isfinite(*slope) && *slope != 0))
    return Error(where, "OpenOptions::rescale_slope must be a non-zero number, got " + num(*slope));
  if (intercept && !std::isfinite(*intercept))
    return Error(where, "OpenOptions::rescale_intercept must be a number, got " + num(*intercept));
  if (!slope && !intercept) {
    slope = h.slope;
    intercept = h.intercept;
  }
  const bool rescaled = slope || intercept;
  src->slope_ = slope.value_or(1.0);
  src->intercept_ = intercept.value_or(0.0);
  if ((h.scalar == Scalar::kU8 || h.scalar == Scalar::kI8) && !rescaled)
    return Error(where,
                 "8-bit volume carries no HU scale: give "
                 "OpenOptions::rescale_slope/OpenOptions::rescale_intercept");
  if (h.scalar == Scalar::kU16 && !rescaled) {
    src->notes_.push_back(
        "unsigned 16-bit values read as HU unchanged; if they are HU + 1024, "
        "give OpenOptions::rescale_intercept -1024");
  }
  if (options.pixel_spacing || options.slice_spacing)
    src->notes_.push_back(
        "OpenOptions::pixel_spacing/OpenOptions::slice_spacing ignored: the volume file gives the "
        "spacing");
  g.rescale_slope = src->slope_;
  g.rescale_intercept = src->intercept_;
  g.bits_stored = static_cast<int>(scalar_bytes(h.scalar) * 8);
  if (g.bits_stored == 64) g.bits_stored = 32;  // "32 (float data)": doubles are float data too
  g.pixel_signed = h.scalar != Scalar::kU8 && h.scalar != Scalar::kU16;

  src->description_ = std::string(format_name(src->format_)) + " " + file.filename().string() +
                      ", " + std::to_string(g.width) + " x " + std::to_string(g.height) + " x " +
                      std::to_string(g.slice_count()) + ", " + scalar_name(h.scalar) +
                      (h.compressed ? ", compressed" : "");
  return std::unique_ptr<SliceSource>(std::move(src));
}

}  // namespace

Result<std::unique_ptr<SliceSource>> open_vtk_volume(const fs::path& file,
                                                     const OpenOptions& options) {
  try {
    return open_volume(file, options);
  } catch (const std::bad_alloc&) {
    return Error(file.string(), "out of memory reading the header");
  } catch (const std::exception& e) {
    return Error(file.string(), with_detail("cannot read the volume", e.what()));
  } catch (...) {
    return Error(file.string(), "cannot read the volume");
  }
}

}  // namespace sawyer::ct::detail
