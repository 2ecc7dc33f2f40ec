// Reading and writing CT slice folders.
//
// Every reader hides behind SliceSource: it reports the volume geometry up front and then hands
// out one slice at a time, in z order, as float HU. Nothing here needs the whole volume in memory
// (a 4 m log at 1 mm spacing is 4000 slices of 512 x 512); readers keep at most a few slices.
//
//   auto src = open_ct("scans/log_0042", {});
//   if (!src) { std::cerr << src.error().message() << "\n"; return 1; }
//   Slice s;
//   for (int i = 0; i < src.value()->geometry().slice_count(); ++i) {
//     if (Status st = src.value()->read(i, s); !st) { ... }
//     use(s.hu);                                  // width * height floats, row-major, HU
//   }
//
// Frames (docs/architecture.md 3): x along a row (column index), y down the rows (row index), both
// in mm in the slice plane from the centre of pixel (0, 0); z in mm along the log, 0 at the first
// slice, increasing with slice index. Where that lies in the scanner is `origin`, `orientation` and
// `slice_dir`; to_scanner_axes() (scanner_frame.h) turns an axial scan so that x and y run along
// the scanner's +x and +y, which the scan pass relies on.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/core/vec.h"

namespace sawyer::ct {

enum class Format { kDicom, kTiffStack, kMultiPageTiff, kPngStack, kVti, kMetaImage, kNrrd };

// What make_uniform_z() did to put a source on an even z grid (all zero / false when the
// source was even already, or only snapped within 1 % of a spacing).
struct ZResampling {
  bool resampled = false;    // slices come out interpolated along z
  int source_slices = 0;     // slices in the file(s)
  int invented_slices = 0;   // output slices standing in for missing ones (no source slice)
  int gaps = 0;              // gaps with missing slices
  double widest_gap_mm = 0;  // the widest distance between neighbouring slices present
  double widest_gap_z0 = 0;  // where it starts (mm, relative to the first slice)
};

// "DICOM series", "TIFF stack", ... for messages and `sawyer info`.
const char* format_name(Format f);

struct VolumeGeometry {
  int width = 0;           // columns (x)
  int height = 0;          // rows (y)
  double spacing_x = 0.0;  // mm between columns
  double spacing_y = 0.0;  // mm between rows
  // Slice positions along the log axis in mm, strictly increasing, z[0] == 0. After the
  // uniform-z wrapper (see below) these are evenly spaced.
  std::vector<double> z;
  // Scanner position of the centre of pixel (0, 0) of slice 0, mm (DICOM Image Position
  // (Patient) of the first slice in z order; 0 for formats without one).
  Vec3 origin;
  // Direction cosines of a row (x) and of a column (y) in the scanner frame, DICOM Image
  // Orientation (Patient) order.
  std::array<double, 6> orientation{1, 0, 0, 0, 1, 0};
  // Scanner direction in which z (the slice index) grows: DICOM's slice normal row × column
  // (slices are ordered along it), a volume's third axis, a stack's row × column.
  Vec3 slice_dir{0, 0, 1};
  // Set by to_scanner_axes() (scanner_frame.h) when it mirrored or transposed the slices: the
  // file's own origin and orientation, which `origin` and `orientation` no longer are.
  struct FileAxes {
    Vec3 origin;
    std::array<double, 6> orientation{1, 0, 0, 0, 1, 0};
  };
  std::optional<FileAxes> file_axes;
  // The stored value -> HU rescale the file declares (for reporting; slices come out in HU).
  // For DICOM with per-slice rescale these are the first slice's.
  double rescale_slope = 1.0;
  double rescale_intercept = 0.0;
  int bits_stored = 16;  // 8, 12, 16 or 32 (float data)
  bool pixel_signed = false;
  ZResampling z_resampling;

  int slice_count() const { return static_cast<int>(z.size()); }
  // Median distance between neighbouring slices (0 for one slice).
  double slice_spacing() const;
  double z_extent() const { return z.empty() ? 0.0 : z.back() - z.front(); }
};

// One slice in HU, row-major: hu[row * width + col].
struct Slice {
  int index = -1;
  double z = 0.0;
  int width = 0;
  int height = 0;
  std::vector<float> hu;

  float at(int col, int row) const { return hu[static_cast<size_t>(row) * width + col]; }
};

class SliceSource {
 public:
  virtual ~SliceSource() = default;

  virtual Format format() const = 0;
  virtual const VolumeGeometry& geometry() const = 0;
  // What was opened, one line: e.g. "DICOM series 1.2.840...7 (CT, 'ACME LogScan'), 812 files".
  virtual std::string description() const = 0;
  // Problems found and handled (resampled gaps, ignored files, ...), one line each.
  virtual const std::vector<std::string>& notes() const = 0;

  // Reads slice `i` (0 <= i < slice_count) into `out`, reusing its buffer. Any order is allowed;
  // ascending order is the fast path. Errors name the file and slice.
  virtual Status read(int i, Slice& out) = 0;
};

// What to do with non-uniform slice positions (missing slices, uneven spacing).
enum class ZPolicy {
  kResample,  // linear interpolation onto an even grid at the median spacing; a note says where
  kReject,    // an Error naming the positions
};

struct OpenOptions {
  // DICOM: which series when a folder holds several (SeriesInstanceUID, a unique prefix of it,
  // or the 1-based number in the list the refusal prints). Empty: the only series, or refuse.
  std::string series;
  // Image stacks: spacing from the command line; overrides the sidecar.
  std::optional<double> pixel_spacing;  // mm, x and y
  std::optional<double> slice_spacing;  // mm
  // Image stacks and volume files: stored value -> HU, overrides the sidecar / file.
  std::optional<double> rescale_slope;
  std::optional<double> rescale_intercept;
  ZPolicy z_policy = ZPolicy::kResample;
  // Gaps wider than this many median spacings count as missing slices.
  double gap_tolerance = 1.5;
  // kResample refuses to invent more than `max_invented_fraction` of the output slices, or to
  // fill one gap wider than `max_gap_mm` (defaults kMaxInventedFraction, 10 %, and kMaxGapMm,
  // 50 mm, in limits.h), unless `allow_gaps` (the command line's --allow-gaps).
  bool allow_gaps = false;
  double max_invented_fraction = 0.10;
  double max_gap_mm = 50.0;
  // Memory the volume may use is checked against this (bytes) instead of /proc/meminfo's
  // MemAvailable when set (see check_memory in limits.h).
  std::optional<std::uint64_t> memory_available_bytes;
};

// Opens a folder (DICOM series, TIFF/PNG stack, or a folder with one volume file) or a single
// file (.vti, .mha, .mhd, .nrrd, .nhdr, multi-page .tif/.tiff, or one DICOM file of a series,
// which opens its folder). The result reads slices in z order on an even z grid.
Result<std::unique_ptr<SliceSource>> open_ct(const std::filesystem::path& path,
                                             const OpenOptions& options = {});

// Wraps a source whose z positions may be uneven: rejects or resamples according to `options`.
// Duplicate positions are always an error. Sources with an even grid pass through unchanged.
Result<std::unique_ptr<SliceSource>> make_uniform_z(std::unique_ptr<SliceSource> source,
                                                    const OpenOptions& options);

// One line on how the slices were put on an even z grid, for `run`/`scan` output, run.json and
// the report, e.g. "resampled along z: 38 slices in the files, 41 out at 5.0 mm; 3 invented
// (7.3 %) in 1 gap, widest 20.0 mm at z=120.0..140.0 mm". Empty when nothing was resampled.
std::string resampling_summary(const VolumeGeometry& geometry);

}  // namespace sawyer::ct
