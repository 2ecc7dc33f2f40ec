// The DICOM reader behind open_ct(): a folder of DICOM files (or one file of it) -> one series,
// sorted along the slice normal, streamed slice by slice as HU.
//
// Every file first goes through the structural walk of dicom_structure.cpp (element headers,
// lengths, sequences, fragments; no values), so GDCM only ever sees files whose structure is
// sound; the walk also locates the Pixel Data value.
// Opening scans headers only (GDCM reads up to Pixel Data and stops), groups files by Series
// Instance UID, picks the series, checks it (sizes, spacing, orientation, positions, pixel data
// length) and sorts it by Image Position (Patient) projected on the slice normal, falling back
// to Slice Location; never by file name. Reading a slice is dicom_decode.cpp's: native pixel
// data in one pread, encapsulated (JPEG, JPEG-LS, JPEG 2000, RLE) through GDCM's codecs once
// dicom_codestream.cpp has checked the compressed stream's own header.
// Sequential reads prefetch the next slice on a worker thread, so at most three slices (the
// caller's, the prefetched one, one raw buffer per thread) are alive at any time.
#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmFileMetaInformation.h>
#include <gdcmReader.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "dicom_decode.h"
#include "dicom_structure.h"
#include "readers.h"
#include "sawyer/ct/io/limits.h"
#include "text_parse.h"

namespace sawyer::ct::detail {

namespace {

// Positions closer than this along the normal are the same slice (mm).
constexpr double kDuplicateTolerance = 1e-3;
// Positions farther out are corrupt values, and differences of them would overflow (mm).
constexpr double kMaxPosition = 1e7;

// A multi-valued Decimal String ("a\b\c") with exactly n numbers, or nothing.
std::optional<std::vector<double>> parse_ds_list(const std::string& s, size_t n) {
  return parse_number_list(s, '\\', n, kBlanksAndNul);
}

// GDCM prints warnings about odd files to stderr; Sawyer reports problems itself.
void quiet_gdcm() {
  static std::once_flag once;
  std::call_once(once, [] {
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
  });
}

// ---------------------------------------------------------------------------------------------
// Header scan

// What one file's header says, before any series-level checks.
struct DicomHeader {
  fs::path path;
  bool is_image = false;  // has Rows/Columns or Pixel Data
  bool has_pixel_data = false;
  bool has_sop_class = false;
  std::string series_uid, series_description, modality, manufacturer, model;
  std::optional<long long> series_number, instance_number;
  std::string position_text, orientation_text, spacing_text, slice_location_text;
  std::string slope_text, intercept_text, photometric;
  int rows = 0, cols = 0, samples = 1, frames = 1;
  int bits_allocated = 0, bits_stored = 0, high_bit = -1;
  bool pixel_signed = false;
  std::string transfer_syntax;
  // Pixel Data element as found in the file: value offset and length (0xffffffff: undefined,
  // i.e. encapsulated). native == the value is the raw pixels at that offset.
  bool native = false;
  bool big_endian = false;
  int64_t pixel_offset = 0;
  uint32_t pixel_length = 0;
  int64_t file_size = 0;
};

std::string get_string(const gdcm::DataSet& ds, uint16_t g, uint16_t e) {
  const gdcm::Tag t(g, e);
  if (!ds.FindDataElement(t)) return {};
  const gdcm::DataElement& de = ds.GetDataElement(t);
  const gdcm::ByteValue* bv = de.GetByteValue();
  if (!bv || bv->GetLength() == 0) return {};
  return trim(std::string(bv->GetPointer(), bv->GetLength()), kBlanksAndNul);
}

// Unsigned short values: GDCM has already put them in host order, also for big endian files.
std::optional<int> get_us(const gdcm::DataSet& ds, uint16_t g, uint16_t e) {
  const gdcm::Tag t(g, e);
  if (!ds.FindDataElement(t)) return std::nullopt;
  const gdcm::ByteValue* bv = ds.GetDataElement(t).GetByteValue();
  if (!bv || bv->GetLength() < 2) return std::nullopt;
  const auto* p = reinterpret_cast<const unsigned char*>(bv->GetPointer());
  return static_cast<int>(p[0] | (p[1] << 8));
}

// Reads one file's header with GDCM, stopping at Pixel Data (its value is never loaded), and
// locates the Pixel Data value in the file for the native fast path.
Result<DicomHeader> scan_header(const fs::path& path) {
  const std::string where = path.string();
  DicomHeader h;
  h.path = path;
  Structure st;
  {
    Fd fd(path);
    if (!fd.ok()) return Error(where, std::string("cannot read: ") + std::strerror(errno));
    h.file_size = fd.size();
    if (h.file_size == 0) return Error(where, "empty file");
    if (std::string err = check_structure(fd, h.file_size, st); !err.empty())
      return Error(where, st.plain_message ? err : "corrupt DICOM: " + err);
  }
  gdcm::Reader reader;
  reader.SetFileName(path.c_str());
  bool ok = false;
  try {
    ok = reader.ReadUpToTag(kPixelDataTag, {kPixelDataTag});
  } catch (...) {
    ok = false;
  }
  if (!ok) return Error(where, "corrupt DICOM: GDCM cannot parse the header");
  const gdcm::File& file = reader.GetFile();
  const gdcm::DataSet& ds = file.GetDataSet();
  h.transfer_syntax = st.transfer_syntax;

  h.has_sop_class = !get_string(ds, 0x0008, 0x0016).empty() ||
                    !get_string(file.GetHeader(), 0x0002, 0x0002).empty();
  h.modality = get_string(ds, 0x0008, 0x0060);
  h.manufacturer = get_string(ds, 0x0008, 0x0070);
  h.model = get_string(ds, 0x0008, 0x1090);
  h.series_description = get_string(ds, 0x0008, 0x103e);
  h.series_uid = get_string(ds, 0x0020, 0x000e);
  h.series_number = parse_int(get_string(ds, 0x0020, 0x0011), kBlanksAndNul);
  h.instance_number = parse_int(get_string(ds, 0x0020, 0x0013), kBlanksAndNul);
  h.position_text = get_string(ds, 0x0020, 0x0032);
  h.orientation_text = get_string(ds, 0x0020, 0x0037);
  h.slice_location_text = get_string(ds, 0x0020, 0x1041);
  h.spacing_text = get_string(ds, 0x0028, 0x0030);
  h.intercept_text = get_string(ds, 0x0028, 0x1052);
  h.slope_text = get_string(ds, 0x0028, 0x1053);
  h.photometric = get_string(ds, 0x0028, 0x0004);
  h.rows = get_us(ds, 0x0028, 0x0010).value_or(0);
  h.cols = get_us(ds, 0x0028, 0x0011).value_or(0);
  h.samples = get_us(ds, 0x0028, 0x0002).value_or(1);
  h.bits_allocated = get_us(ds, 0x0028, 0x0100).value_or(0);
  h.bits_stored = get_us(ds, 0x0028, 0x0101).value_or(h.bits_allocated);
  h.high_bit = get_us(ds, 0x0028, 0x0102).value_or(h.bits_stored - 1);
  h.pixel_signed = get_us(ds, 0x0028, 0x0103).value_or(0) == 1;
  if (const auto frames = parse_int(get_string(ds, 0x0028, 0x0008), kBlanksAndNul)) {
    h.frames = static_cast<int>(std::clamp<long long>(*frames, 0, 1 << 30));
  }

  h.has_pixel_data = st.has_pixel_data;
  h.native = st.has_pixel_data && !st.pixel_encapsulated;
  h.big_endian = st.encoding == Encoding::kExplicitBig;
  h.pixel_offset = st.pixel_offset;
  h.pixel_length = st.pixel_length;
  h.is_image = h.has_pixel_data || (h.rows > 0 && h.cols > 0);
  return h;
}

// ---------------------------------------------------------------------------------------------
// The source

class DicomSeriesSource final : public SliceSource {
 public:
  DicomSeriesSource(VolumeGeometry geometry, std::vector<SliceFile> slices, std::string description,
                    std::vector<std::string> notes)
      : geometry_(std::move(geometry)),
        slices_(std::move(slices)),
        description_(std::move(description)),
        notes_(std::move(notes)) {}

  ~DicomSeriesSource() override {
    if (worker_.joinable()) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
      }
      cv_.notify_all();
      worker_.join();
    }
  }

  Format format() const override { return Format::kDicom; }
  const VolumeGeometry& geometry() const override { return geometry_; }
  std::string description() const override { return description_; }
  const std::vector<std::string>& notes() const override { return notes_; }

  Status read(int i, Slice& out) override {
    const int n = static_cast<int>(slices_.size());
    if (i < 0 || i >= n)
      return Error(description_,
                   "slice " + std::to_string(i) + " is out of range 0.." + std::to_string(n - 1));
    // Take the prefetched slice if it is the one asked for. Either way wait for the worker, so
    // that only one decode runs at a time (GDCM codecs are not known to be reentrant).
    bool prefetched = false;
    Status status;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return !pending_; });
      if (result_index_ == i) {
        prefetched = true;
        status = result_status_;
      }
      result_index_ = -1;
    }
    if (prefetched) {
      if (status) out.hu.swap(prefetch_hu_);
    } else {
      status = decoder_.decode(slices_[static_cast<size_t>(i)], geometry_.width, geometry_.height,
                               out.hu);
    }
    if (!status) return status;
    out.index = i;
    out.z = geometry_.z[static_cast<size_t>(i)];
    out.width = geometry_.width;
    out.height = geometry_.height;
    if (i == last_read_ + 1 && i + 1 < n) schedule(i + 1);
    last_read_ = i;
    return Status::Ok();
  }

 private:
  void schedule(int i) {
    if (!worker_.joinable()) worker_ = std::thread([this] { work(); });
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = i;
      pending_ = true;
    }
    cv_.notify_all();
  }

  void work() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      cv_.wait(lock, [&] { return stop_ || pending_; });
      if (stop_) return;
      const int i = job_;
      lock.unlock();
      // prefetch_hu_ and prefetch_decoder_ belong to the worker while pending_ is set.
      Status st = prefetch_decoder_.decode(slices_[static_cast<size_t>(i)], geometry_.width,
                                           geometry_.height, prefetch_hu_);
      lock.lock();
      result_status_ = std::move(st);
      result_index_ = i;
      pending_ = false;
      cv_.notify_all();
    }
  }

  VolumeGeometry geometry_;
  std::vector<SliceFile> slices_;
  std::string description_;
  std::vector<std::string> notes_;
  SliceDecoder decoder_;
  int last_read_ = -1;

  // Prefetch of the next slice; guarded by mutex_.
  std::thread worker_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  bool pending_ = false;
  int job_ = -1;
  int result_index_ = -1;
  Status result_status_;
  std::vector<float> prefetch_hu_;
  SliceDecoder prefetch_decoder_;
};

// ---------------------------------------------------------------------------------------------
// Series grouping, choice and checks

struct Series {
  std::string uid;
  std::vector<const DicomHeader*> files;
  std::optional<long long> number;
  std::string description, modality, manufacturer;
};

std::string in_quotes(const std::string& s) { return "\"" + s + "\""; }

std::string series_line(int number, const Series& s) {
  std::string line = std::to_string(number) + ": " +
                     (s.uid.empty() ? std::string("(no Series Instance UID)") : s.uid);
  if (!s.description.empty()) line += " " + in_quotes(s.description);
  if (!s.modality.empty()) line += " " + s.modality;
  line += ", " + std::to_string(s.files.size()) + (s.files.size() == 1 ? " file" : " files");
  return line;
}

std::string series_list(const std::vector<Series>& all) {
  std::string list;
  for (size_t k = 0; k < all.size(); ++k)
    list += (k ? "; " : "") + series_line(static_cast<int>(k) + 1, all[k]);
  return list;
}

std::string name_list(const std::vector<fs::path>& files, size_t max_names = 5) {
  std::string s;
  for (size_t k = 0; k < files.size() && k < max_names; ++k)
    s += (k ? ", " : "") + files[k].filename().string();
  if (files.size() > max_names) s += " and " + std::to_string(files.size() - max_names) + " more";
  return s;
}

bool has_dicom_ext(const fs::path& p) {
  const std::string e = lower(p.extension().string());
  return e == ".dcm" || e == ".ima" || e == ".dicom" || e == ".dic";
}

// Picks the series `wanted` names: exact UID, then a 1-based number, then a unique UID prefix.
Result<size_t> choose_series(const std::vector<Series>& all, const std::string& wanted,
                             const std::string& where) {
  for (size_t k = 0; k < all.size(); ++k)
    if (all[k].uid == wanted) return k;
  if (const auto number = parse_int(wanted, kBlanksAndNul);
      number && wanted.find('.') == std::string::npos) {
    if (*number >= 1 && *number <= static_cast<long long>(all.size()))
      return static_cast<size_t>(*number - 1);
    return Error(where, "OpenOptions::series " + wanted + ": there are only " +
                            std::to_string(all.size()) + " series: " + series_list(all));
  }
  std::vector<size_t> matches;
  for (size_t k = 0; k < all.size(); ++k)
    if (all[k].uid.starts_with(wanted)) matches.push_back(k);
  if (matches.size() == 1) return matches[0];
  if (matches.empty())
    return Error(where, "no DICOM series matches OpenOptions::series " + in_quotes(wanted) +
                            "; the folder holds: " + series_list(all));
  return Error(where, "OpenOptions::series " + in_quotes(wanted) + " matches " +
                          std::to_string(matches.size()) +
                          " series; give more of the UID or the number: " + series_list(all));
}

struct Orientation {
  Vec3 row, col, normal;
};

Result<Orientation> parse_orientation(const DicomHeader& h) {
  const auto v = parse_ds_list(h.orientation_text, 6);
  if (!v)
    return Error(h.path.string(), "Image Orientation (Patient) " + in_quotes(h.orientation_text) +
                                      " is not six numbers");
  Vec3 row{(*v)[0], (*v)[1], (*v)[2]};
  Vec3 col{(*v)[3], (*v)[4], (*v)[5]};
  // Scanners round the cosines to a few digits; anything further off is not an orientation.
  if (std::abs(row.norm() - 1) > 1e-2 || std::abs(col.norm() - 1) > 1e-2 ||
      std::abs(dot(row, col)) > 1e-2)
    return Error(h.path.string(), "Image Orientation (Patient) " + in_quotes(h.orientation_text) +
                                      " is not two orthogonal unit vectors");
  row = row.normalized();
  col = col.normalized();
  return Orientation{row, col, cross(row, col).normalized()};
}

// The checks on one file of the chosen series that do not compare it with others.
Status check_pixel_format(const DicomHeader& h) {
  const std::string where = h.path.string();
  if (h.frames > 1)
    return Error(where, "multi-frame DICOM (" + std::to_string(h.frames) +
                            " frames in one file) is not supported; export one file per slice");
  if (h.samples != 1 ||
      (!h.photometric.empty() && h.photometric != "MONOCHROME1" && h.photometric != "MONOCHROME2"))
    return Error(where, "Photometric Interpretation " +
                            (h.photometric.empty() ? std::string("(none)") : h.photometric) +
                            " with " + std::to_string(h.samples) +
                            " samples per pixel: not a grey-scale CT slice");
  if (h.rows <= 0 || h.cols <= 0)
    return Error(where, "no image size (Rows/Columns missing or zero)");
  if (static_cast<int64_t>(h.rows) * h.cols > kMaxSlicePixels)
    return Error(where, std::to_string(h.cols) + " x " + std::to_string(h.rows) +
                            " pixels is larger than Sawyer reads (8192 x 8192)");
  if (h.bits_allocated != 8 && h.bits_allocated != 16)
    return Error(where, "Bits Allocated " + std::to_string(h.bits_allocated) +
                            " is not supported (8 or 16)");
  if (h.bits_stored < 1 || h.bits_stored > h.bits_allocated)
    return Error(where, "Bits Stored " + std::to_string(h.bits_stored) + " does not fit in " +
                            std::to_string(h.bits_allocated) + " bits allocated");
  if (!h.has_pixel_data) return Error(where, "no Pixel Data (truncated file?)");
  return Status::Ok();
}

// Native pixel data must be all there; checked at open so a truncated file is reported before
// anything is written.
Status check_pixel_length(const DicomHeader& h) {
  if (!h.native) return Status::Ok();
  const std::string where = h.path.string();
  const int64_t expected = static_cast<int64_t>(h.rows) * h.cols * (h.bits_allocated / 8);
  if (static_cast<int64_t>(h.pixel_length) < expected)
    return Error(where, "Pixel Data holds " + std::to_string(h.pixel_length) + " bytes, expected " +
                            std::to_string(expected) + " (" + std::to_string(h.cols) + " x " +
                            std::to_string(h.rows) + " x " + std::to_string(h.bits_allocated) +
                            " bits)");
  if (h.pixel_offset + expected > h.file_size)
    return Error(where, "truncated: the pixel data needs " + std::to_string(expected) +
                            " bytes from byte " + std::to_string(h.pixel_offset) +
                            ", but the file ends at byte " + std::to_string(h.file_size));
  return Status::Ok();
}

Result<std::unique_ptr<SliceSource>> build_source(const fs::path& folder, const Series& series,
                                                  std::vector<std::string> notes) {
  const std::string folder_name = folder.string();
  // Reference file: the lowest instance number (then name) - what a viewer shows first.
  std::vector<const DicomHeader*> files = series.files;
  std::sort(files.begin(), files.end(), [](const DicomHeader* a, const DicomHeader* b) {
    const long long ia = a->instance_number.value_or(0), ib = b->instance_number.value_or(0);
    return ia != ib ? ia < ib : a->path < b->path;
  });
  const DicomHeader& ref = *files.front();
  const std::string ref_name = ref.path.filename().string();

  for (const DicomHeader* h : files) {
    if (Status st = check_pixel_format(*h); !st) return st.error();
  }
  if (files.size() < 2)
    return Error(folder_name, "DICOM series " + series.uid + " has only 1 slice (" + ref_name +
                                  "); a CT volume needs at least 2 slices");

  // Size and pixel spacing: one for the whole series.
  const auto ref_spacing = parse_ds_list(ref.spacing_text, 2);
  for (const DicomHeader* h : files) {
    const std::string where = h->path.string();
    if (h->rows != ref.rows || h->cols != ref.cols)
      return Error(where, std::to_string(h->cols) + " x " + std::to_string(h->rows) +
                              " pixels, but " + ref_name + " in the same series is " +
                              std::to_string(ref.cols) + " x " + std::to_string(ref.rows) +
                              " (mixed image sizes)");
    if (h->spacing_text.empty())
      return Error(where, "no Pixel Spacing (0028,0030); cannot size the pixels in mm");
    const auto sp = parse_ds_list(h->spacing_text, 2);
    if (!sp)
      return Error(where, "Pixel Spacing " + in_quotes(h->spacing_text) + " is not two numbers");
    if (!((*sp)[0] > 0) || !((*sp)[1] > 0))
      return Error(where, "Pixel Spacing " + in_quotes(h->spacing_text) + " must be positive (mm)");
    for (double v : *sp) {
      if (Status st = check_spacing(where, "Pixel Spacing " + in_quotes(h->spacing_text) + ":", v);
          !st)
        return st.error();
    }
    if (std::abs((*sp)[0] - (*ref_spacing)[0]) > 1e-4 * (*ref_spacing)[0] ||
        std::abs((*sp)[1] - (*ref_spacing)[1]) > 1e-4 * (*ref_spacing)[1])
      return Error(where, "Pixel Spacing " + in_quotes(h->spacing_text) + " differs from " +
                              ref_name + " (" + in_quotes(ref.spacing_text) + ")");
  }

  // Orientation: one for the whole series; the normal orders the slices.
  Orientation orient{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const bool has_orientation = !ref.orientation_text.empty();
  if (has_orientation) {
    auto o = parse_orientation(ref);
    if (!o) return o.error();
    orient = o.value();
  } else {
    notes.push_back("no Image Orientation (Patient) in " + ref_name + "; assuming axial slices");
  }
  const std::optional<std::vector<double>> ref_iop =
      has_orientation ? parse_ds_list(ref.orientation_text, 6) : std::nullopt;
  for (const DicomHeader* h : files) {
    const std::string where = h->path.string();
    if (h->orientation_text.empty() != !has_orientation)
      return Error(where,
                   "Image Orientation (Patient) " +
                       (h->orientation_text.empty() ? std::string("missing")
                                                    : in_quotes(h->orientation_text)) +
                       ", but " + ref_name + " has " +
                       (has_orientation ? in_quotes(ref.orientation_text) : std::string("none")) +
                       " (inconsistent orientation within the series)");
    if (!has_orientation) continue;
    const auto v = parse_ds_list(h->orientation_text, 6);
    if (!v)
      return Error(where, "Image Orientation (Patient) " + in_quotes(h->orientation_text) +
                              " is not six numbers");
    for (size_t k = 0; k < 6; ++k) {
      if (std::abs((*v)[k] - (*ref_iop)[k]) > 1e-3)
        return Error(where, "Image Orientation (Patient) " + in_quotes(h->orientation_text) +
                                " differs from " + ref_name + " (" +
                                in_quotes(ref.orientation_text) +
                                "): inconsistent orientation within the series");
    }
  }

  // Order: Image Position (Patient) on the normal; Slice Location when a file has no position.
  struct Keyed {
    const DicomHeader* h;
    double key;
    Vec3 position;
  };
  std::vector<Keyed> keyed;
  bool use_location = false;
  for (const DicomHeader* h : files) {
    if (h->position_text.empty()) use_location = true;
  }
  for (const DicomHeader* h : files) {
    const std::string where = h->path.string();
    if (!use_location) {
      const auto p = parse_ds_list(h->position_text, 3);
      if (!p)
        return Error(where, "Image Position (Patient) " + in_quotes(h->position_text) +
                                " is not three numbers");
      const Vec3 pos{(*p)[0], (*p)[1], (*p)[2]};
      if (pos.norm() > kMaxPosition)
        return Error(where, "Image Position (Patient) " + in_quotes(h->position_text) +
                                " is more than 10 km from the origin");
      keyed.push_back({h, dot(pos, orient.normal), pos});
    } else {
      if (h->slice_location_text.empty())
        return Error(where,
                     "neither Image Position (Patient) nor Slice Location; cannot order "
                     "the slices (Sawyer never orders them by file name)");
      const auto loc = parse_double(h->slice_location_text, kBlanksAndNul);
      if (!loc || std::abs(*loc) > kMaxPosition)
        return Error(where, "Slice Location " + in_quotes(h->slice_location_text) +
                                " is not a usable number");
      keyed.push_back({h, *loc, *loc * orient.normal});
    }
  }
  if (use_location)
    notes.push_back(
        "some files have no Image Position (Patient); slices ordered by Slice "
        "Location");
  std::stable_sort(keyed.begin(), keyed.end(),
                   [](const Keyed& a, const Keyed& b) { return a.key < b.key; });
  for (size_t k = 1; k < keyed.size(); ++k) {
    if (keyed[k].key - keyed[k - 1].key < kDuplicateTolerance)
      return Error(folder_name,
                   "duplicate slice position z=" + fixed(keyed[k].key - keyed[0].key, 3) +
                       " mm: " + keyed[k - 1].h->path.filename().string() + " and " +
                       keyed[k].h->path.filename().string());
    // Not a duplicate, but closer than any CT slices are: a corrupt position.
    if (const double d = keyed[k].key - keyed[k - 1].key; d < kMinSpacingMm)
      return Error(folder_name, keyed[k - 1].h->path.filename().string() + " and " +
                                    keyed[k].h->path.filename().string() + " are " + fixed(d, 3) +
                                    " mm apart; slice spacing must be " + fixed(kMinSpacingMm, 2) +
                                    "-" + fixed(kMaxSpacingMm, 0) + " mm");
  }

  // Per-file pixel data and rescale.
  std::vector<SliceFile> slices;
  slices.reserve(keyed.size());
  bool rescale_varies = false, rescale_missing = false;
  double max_shift = 0;
  for (const Keyed& k : keyed) {
    const DicomHeader& h = *k.h;
    const std::string where = h.path.string();
    if (Status st = check_pixel_length(h); !st) return st.error();
    SliceFile s;
    s.path = h.path;
    s.z = k.key - keyed.front().key;
    if (h.slope_text.empty() && h.intercept_text.empty()) rescale_missing = true;
    if (!h.slope_text.empty()) {
      const auto m = parse_double(h.slope_text, kBlanksAndNul);
      if (!m || *m == 0)
        return Error(
            where, "Rescale Slope " + in_quotes(h.slope_text) + " cannot map stored values to HU");
      s.slope = *m;
    }
    if (!h.intercept_text.empty()) {
      const auto b = parse_double(h.intercept_text, kBlanksAndNul);
      if (!b)
        return Error(where,
                     "Rescale Intercept " + in_quotes(h.intercept_text) + " is not a number");
      s.intercept = *b;
    }
    if (Status st = check_rescale(where, s.slope, s.intercept, "Rescale"); !st) return st.error();
    s.bits_allocated = h.bits_allocated;
    s.bits_stored = h.bits_stored;
    s.high_bit = (h.high_bit >= h.bits_stored - 1 && h.high_bit < h.bits_allocated)
                     ? h.high_bit
                     : h.bits_stored - 1;
    s.pixel_signed = h.pixel_signed;
    s.native = h.native;
    s.big_endian = h.big_endian;
    s.pixel_offset = h.pixel_offset;
    s.transfer_syntax = h.transfer_syntax;
    if (!slices.empty() &&
        (s.slope != slices.front().slope || s.intercept != slices.front().intercept))
      rescale_varies = true;
    // In-plane drift of the positions (gantry tilt): reported, not corrected.
    const Vec3 d = k.position - keyed.front().position;
    max_shift = std::max(max_shift, (d - dot(d, orient.normal) * orient.normal).norm());
    slices.push_back(std::move(s));
  }
  if (rescale_missing)
    notes.push_back(
        "some files have no Rescale Slope/Intercept; their stored values are taken "
        "as HU");
  if (rescale_varies) notes.push_back("Rescale Slope/Intercept vary per slice; applied per slice");
  if (max_shift > 0.05)
    notes.push_back("slice positions drift up to " + fixed(max_shift, 1) +
                    " mm within the slice plane (gantry tilt?); slices are stacked along the "
                    "slice normal without shear correction");
  if (ref.photometric == "MONOCHROME1")
    notes.push_back("MONOCHROME1 (inverted display); HU come from the rescale as usual");

  VolumeGeometry g;
  g.width = ref.cols;
  g.height = ref.rows;
  g.spacing_y = (*ref_spacing)[0];  // DICOM order: row spacing, then column spacing
  g.spacing_x = (*ref_spacing)[1];
  g.z.reserve(slices.size());
  for (const SliceFile& s : slices) g.z.push_back(s.z);
  g.origin = keyed.front().position;
  g.orientation = {orient.row.x, orient.row.y, orient.row.z,
                   orient.col.x, orient.col.y, orient.col.z};
  g.slice_dir = orient.normal;  // the slices were ordered along it
  g.rescale_slope = slices.front().slope;
  g.rescale_intercept = slices.front().intercept;
  g.bits_stored = ref.bits_stored;
  g.pixel_signed = ref.pixel_signed;

  std::vector<std::string> parts;
  if (!series.modality.empty()) parts.push_back(series.modality);
  std::string maker = ref.manufacturer;
  if (!ref.model.empty()) maker += (maker.empty() ? "" : " ") + ref.model;
  if (!maker.empty()) parts.push_back(in_quotes(maker));
  if (!series.description.empty()) parts.push_back(in_quotes(series.description));
  std::string description =
      "DICOM series " + (series.uid.empty() ? std::string("(no UID)") : series.uid);
  if (!parts.empty()) {
    description += " (";
    for (size_t k = 0; k < parts.size(); ++k) description += (k ? ", " : "") + parts[k];
    description += ")";
  }
  description += ", " + std::to_string(slices.size()) + " files";

  return std::unique_ptr<SliceSource>(new DicomSeriesSource(
      std::move(g), std::move(slices), std::move(description), std::move(notes)));
}

}  // namespace

Result<std::unique_ptr<SliceSource>> open_dicom(const fs::path& path, const OpenOptions& options) {
  quiet_gdcm();
  std::error_code ec;
  const bool single_file = fs::is_regular_file(path, ec);
  const fs::path folder =
      single_file ? (path.parent_path().empty() ? fs::path(".") : path.parent_path()) : path;
  const std::string folder_name = folder.string();

  // List the folder (sorted only so that messages are reproducible; order comes from headers).
  std::vector<fs::path> candidates, not_dicom, unreadable_others;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& p = it->path();
    if (p.filename().string().starts_with(".")) continue;
    std::error_code fec;
    const auto st = it->status(fec);
    if (fec || !fs::exists(st)) {
      // A broken link or a link loop: an error if it is named like a slice, else a note.
      if (has_dicom_ext(p) || p.extension().empty()) {
        return Error(p.string(),
                     "cannot read: " + (fec ? fec.message() : std::string("broken link")));
      }
      unreadable_others.push_back(p);
      continue;
    }
    if (!fs::is_regular_file(st)) continue;
    candidates.push_back(p);
  }
  if (ec) return Error(folder_name, "cannot list the folder: " + ec.message());
  std::sort(candidates.begin(), candidates.end());

  std::vector<DicomHeader> headers;
  headers.reserve(candidates.size());
  std::vector<fs::path> non_image;
  for (const fs::path& p : candidates) {
    if (!has_dicom_ext(p) && !looks_like_dicom(p)) {
      // looks_like_dicom() is false also for files we cannot open; those must not vanish
      // silently when they might be slices.
      Fd fd(p);
      if (!fd.ok() && p.extension().empty())
        return Error(p.string(), std::string("cannot read: ") + std::strerror(errno));
      not_dicom.push_back(p);
      continue;
    }
    auto h = scan_header(p);
    if (!h) return h.error();
    if (!h.value().is_image) {
      // DICOMDIR, structured reports, dose sheets: well-formed DICOM without pixels.
      if (!h.value().has_sop_class)
        return Error(p.string(), "corrupt DICOM: no SOP Class UID and no image data");
      non_image.push_back(p);
      continue;
    }
    headers.push_back(std::move(h).value());
  }

  std::vector<std::string> notes;
  if (!not_dicom.empty())
    notes.push_back("ignored " + std::to_string(not_dicom.size()) + " non-DICOM file" +
                    (not_dicom.size() == 1 ? "" : "s") + ": " + name_list(not_dicom));
  if (!unreadable_others.empty())
    notes.push_back("ignored " + std::to_string(unreadable_others.size()) + " unreadable entr" +
                    (unreadable_others.size() == 1 ? "y" : "ies") + ": " +
                    name_list(unreadable_others));
  if (!non_image.empty())
    notes.push_back("ignored " + std::to_string(non_image.size()) + " DICOM file" +
                    (non_image.size() == 1 ? "" : "s") +
                    " without image data: " + name_list(non_image));
  if (headers.empty())
    return Error(single_file ? path.string() : folder_name, "no DICOM images found");

  // Group by series.
  std::map<std::string, Series> by_uid;
  for (const DicomHeader& h : headers) {
    Series& s = by_uid[h.series_uid];
    s.uid = h.series_uid;
    s.files.push_back(&h);
    if (!s.number && h.series_number) s.number = h.series_number;
    if (s.description.empty()) s.description = h.series_description;
    if (s.modality.empty()) s.modality = h.modality;
  }
  std::vector<Series> all;
  for (auto& [uid, s] : by_uid) all.push_back(std::move(s));
  std::stable_sort(all.begin(), all.end(), [](const Series& a, const Series& b) {
    const long long na = a.number.value_or(1LL << 40), nb = b.number.value_or(1LL << 40);
    return na != nb ? na < nb : a.uid < b.uid;
  });

  size_t chosen = 0;
  if (single_file) {
    // The file names its series; --series, if given too, must agree.
    const fs::path canon = fs::weakly_canonical(path, ec);
    std::optional<size_t> owner;
    for (size_t k = 0; k < all.size() && !owner; ++k) {
      for (const DicomHeader* h : all[k].files) {
        std::error_code e2;
        if (h->path == path || fs::weakly_canonical(h->path, e2) == canon) {
          owner = k;
          break;
        }
      }
    }
    if (!owner) return Error(path.string(), "not a DICOM image (no pixel data)");
    chosen = *owner;
    if (!options.series.empty()) {
      auto pick = choose_series(all, options.series, folder_name);
      if (!pick) return pick.error();
      if (pick.value() != chosen)
        return Error(path.string(), "belongs to series " + all[chosen].uid +
                                        ", not to OpenOptions::series " + options.series);
    }
  } else if (!options.series.empty()) {
    auto pick = choose_series(all, options.series, folder_name);
    if (!pick) return pick.error();
    chosen = pick.value();
  } else if (all.size() > 1) {
    return Error(folder_name,
                 "holds " + std::to_string(all.size()) +
                     " DICOM series; choose one with OpenOptions::series (number or UID "
                     "prefix): " +
                     series_list(all));
  }
  if (all.size() > 1)
    notes.push_back("the folder holds " + std::to_string(all.size()) + " DICOM series; reading " +
                    series_line(static_cast<int>(chosen) + 1, all[chosen]));
  return build_source(folder, all[chosen], std::move(notes));
}

}  // namespace sawyer::ct::detail
