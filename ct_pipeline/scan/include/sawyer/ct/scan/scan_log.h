// The scan of a log as one call (issue 20, item 5): a CT source in; the log model (stem and
// knots, in the scanner frame, with the scan's QA verdict), the passes' records, the verdict's
// detail and a brief summary out. `sawyer scan`, `sawyer run`, the benches and the tests all go
// through here, so that they measure the same recipe.
//
//   auto src = open_ct(folder);                       // then to_scanner_axes()
//   ScanOptions o;  o.id = "log 17";  o.species = "spruce";
//   Result<ScanResult> r = scan_log(*src.value(), o, progress);
//   r.value().log          // LogModel: stem, knots, scanner_frame, qa
//   r.value().qa.verdict   // also in log.qa
//   write_scan_qa_images(r.value(), *src.value(), dir / "qa", 4);
//
// The stem pass reads the scan once; the knot pass reads it again, window by window along the
// log (knot_detect.h KnotWindowOptions), and takes the QA's unrolled views on the way, so that
// no stage holds the log's voxels (ScanOptions::keep_volume keeps them, for tools and tests, and
// runs the knot pass on them in one window). memory_plan.h sizes the windows for a budget.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/knots/log_volume.h"
#include "sawyer/ct/scan/knot_scan.h"
#include "sawyer/ct/scan/scan_qa.h"
#include "sawyer/ct/scan/stem_scan.h"
#include "sawyer/model/log_model.h"

namespace sawyer::ct {

struct ScanOptions {
  // Its `volume` is set by scan_log. The stem at most kDefaultStemStepMm apart (stem_scan.h): so
  // that the stem, the knot pass's view of it and every table built on the model (sawing,
  // rendering, maps) grow with the log's length, not its slices.
  StemScanOptions stem = [] {
    StemScanOptions s;
    s.stem_step_mm = kDefaultStemStepMm;
    return s;
  }();
  KnotScanOptions knots;
  QaOptions qa;
  bool find_knots = true;
  // Keep the log's voxels through the stem pass (cropped, 16 bits) in ScanResult::volume and run
  // the knot pass on them in one grid (tools and tests that look at them). By default no voxels
  // are kept: the knot pass reads the scan again in windows (knot_detect.h).
  bool keep_volume = false;
  // The slices whose records keep their outline and heartwood radii (StemSliceRecord::contour
  // and heartwood, 5.8 KB a slice) once the QA's per-slice figures are taken from them: -1 every
  // slice (benches and tools that compare them with a truth); k >= 0 only the k slices the QA
  // images draw (qa_image_slices), so that the records of a scan of fine slices do not grow the
  // knot pass's peak (issue 24; `sawyer scan` and `sawyer run`).
  int outline_slices = -1;
  int threads = 0;  // 0: every core; overrides the passes' own
  // The model's id, species and the name its provenance gives the source ("" : "scan").
  std::string id, species = "unknown", source_name;
};

// The log's voxels on the cylinder r mm around the pith, unrolled (azimuth 0..2π across, height
// down, the same px_per_mm both ways), HU windowed -700..+200 to 8 bits: the scan QA's unrolled
// views (qa/unrolled_r*.png), taken before the voxels are released.
struct UnrolledView {
  double r_mm = 0, z_first = 0, px_per_mm = 1;
  int width = 0, height = 0;
  std::vector<std::uint8_t> grey;  // rows top to bottom
};
UnrolledView unroll_view(const LogVolume& volume, const Stem& stem, double r_mm);

// The same view built slice by slice, from kept planes or from slices as they are read (the
// streamed knot pass hands each slice on): rows take the nearest slice, as above.
class UnrolledViewBuilder {
 public:
  UnrolledViewBuilder(const VolumeGeometry& geometry, const Stem& stem, double r_mm);
  void add(int i, const LogVolume& volume);
  void add(int i, const Slice& slice);  // slice i, as read
  UnrolledView take() { return std::move(view_); }

 private:
  template <class Sample>
  void fill(int i, const Sample& hu_at);
  const Stem* stem_;
  std::vector<double> z_;
  double sx_ = 1, sy_ = 1;
  std::vector<std::vector<int>> rows_of_;  // per slice, the rows that take it
  UnrolledView view_;
};

struct ScanResult {
  LogModel log;   // scanner frame (place_in_scanner_frame), qa set
  StemScan stem;  // the passes' records, in the slices' own axes (pixel (0, 0) at 0, 0)
  KnotScan knots;
  // The voxels the knot pass read: null unless ScanOptions::keep_volume. voxel_bytes: what they
  // took, or without them the largest window's unrolled grid.
  std::unique_ptr<LogVolume> volume;
  std::size_t voxel_bytes = 0;
  std::vector<UnrolledView> unrolled;  // at 30, 60 and 90 mm from the pith
  ScanQaDetail qa;
  double seconds = 0;
};

// (stage, done, total): "stem" per slice read and analysed, then "knots" 0/1 and 1/1.
using ScanProgress = std::function<void(const char* stage, int done, int total)>;

// Errors: a slice that cannot be read, no log in any slice (the stem pass's messages).
Result<ScanResult> scan_log(SliceSource& source, const ScanOptions& options,
                            const ScanProgress& progress = {});

// The summary a terminal shows: slices, speed, stem, knots, and the QA headline.
std::string scan_brief(const ScanResult& scan, const std::string& input);

// The slices (indices, ascending) that write_scan_qa_images draws of a scan of n slices.
std::vector<int> qa_image_slices(int n, int slices);

// QA images into `dir` (created): `slices` slices with the pith, outline and heartwood border
// drawn, pith_track.png (pith against z, suspect heights shaded), unrolled_r30/60/90.png (the
// cylinders at those pith distances with the fitted knots) and knots.csv. Reads the slices
// again through `source` (the scanned one).
Status write_scan_qa_images(const ScanResult& scan, SliceSource& source,
                            const std::filesystem::path& dir, int slices = 4);

}  // namespace sawyer::ct
