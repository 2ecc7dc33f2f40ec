// The stem pass of `sawyer scan` (issue 4): every slice of a CT scan through the per-slice
// detectors of stem_detect.h, the pith tracked from slice to slice and smoothed along z with an
// outlier-robust filter, the contours re-centred on the smoothed pith, and the result assembled
// into the stem of a LogModel.
//
//   auto src = open_ct(folder);
//   Result<StemScan> s = scan_stem(*src.value(), {}, [](int done, int all) { ... });
//   LogModel log; log.stem = s.value().stem;
//
// The scan streams: slices are read once, in order, on as many threads as asked (each thread
// owns a contiguous run of slices and tracks the pith within it); memory holds one slice per
// thread plus the per-slice results.
#pragma once

#include <functional>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/ct/slice_source.h"
#include "sawyer/ct/stem_detect.h"
#include "sawyer/model/log_model.h"

namespace sawyer::ct {

struct StemScanOptions {
  PithOptions pith;
  ContourOptions contour;
  HeartwoodOptions heartwood;
  int threads = 0;  // 0: hardware concurrency
  // Robust smoothing of the pith along z: a running median over this many slices on each side
  // rejects jumps (knot whorls, cracks), then a moving average of the same half-width.
  int pith_half_window = 3;
  // A raw pith farther than this from the running median is an outlier and is replaced.
  double pith_outlier_mm = 3.0;
};

struct StemSliceRecord {
  double z = 0;               // mm, from the scan's geometry
  PithResult pith_raw;        // the detector's answer (tracked within a thread's run)
  Vec2 pith;                  // after robust smoothing along z
  bool pith_outlier = false;  // the raw pith was replaced
  ContourResult contour;      // around `pith` (re-centred from pith_raw)
  HeartwoodResult heartwood;  // around `pith`
};

struct StemScan {
  std::vector<StemSliceRecord> slices;
  Stem stem;
  double seconds = 0;  // wall time of the whole pass, reading included
  int threads = 1;
  double slices_per_second() const { return seconds > 0 ? slices.size() / seconds : 0; }
};

// Errors: a slice that cannot be read (its message), or no log found in any slice.
Result<StemScan> scan_stem(SliceSource& source, const StemScanOptions& options,
                           const std::function<void(int, int)>& progress = {});

// Re-expresses a closed contour given as radius per equally spaced azimuth around `from` as
// radius per equally spaced azimuth around `to` (same count). Invalid entries stay invalid where
// no valid neighbour covers them. Used after the pith is smoothed; exposed for tests.
void recentre_contour(const Vec2& from, const Vec2& to, std::vector<double>& radius,
                      std::vector<bool>& valid);

// Robust pith track: running median (half-window h) to find outliers, outliers replaced by the
// median, then a moving average. Slices with found == false are filled from their neighbours.
std::vector<Vec2> smooth_pith(const std::vector<PithResult>& raw, int half_window,
                              double outlier_mm, std::vector<bool>* outlier);

}  // namespace sawyer::ct
