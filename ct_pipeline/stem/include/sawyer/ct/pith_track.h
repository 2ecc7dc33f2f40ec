// Pith along z (issue 4): slice-to-slice tracking with detect_pith and an outlier-robust
// smoothing of the raw track.
//
//   PithTracker tracker(geometry, {});
//   for (...) raw.push_back(tracker.next(slice));           // slices in z order
//   std::vector<Vec2> pith = smooth_pith_track(geometry.z, raw, {});
//
// Units: mm, scanner frame (DESIGN.md 3). Pure functions, thread-safe; a PithTracker holds the
// last pith and is used by one thread.
#pragma once

#include <optional>
#include <vector>

#include "sawyer/core/vec.h"
#include "sawyer/ct/slice_source.h"
#include "sawyer/ct/stem_detect.h"

namespace sawyer::ct {

// Feeds slices in z order, each searched near the last confident pith; falls back to a search
// of the whole slice when the prior is lost (no log near it, or a weak answer).
class PithTracker {
 public:
  PithTracker(const VolumeGeometry& geometry, const PithOptions& options,
              double min_confidence = 0.25);
  PithResult next(const Slice& slice);

 private:
  VolumeGeometry geometry_;
  PithOptions options_;
  double min_confidence_;
  std::optional<Vec2> last_;
};

struct PithTrackOptions {
  // Half-width (mm along z) of the local linear fit; the pith of a log bends slowly, and the
  // per-slice detections are noisy (see pith.cpp), so the window is wide.
  double window_mm = 30.0;
  // Tukey (biweight) scale for robustness iterations, in robust sigmas (MAD) of the residuals,
  // and a floor (mm) so a clean track does not reject good slices.
  double tukey_k = 4.685;
  double min_scale_mm = 0.3;
  int robust_iterations = 4;
};

// Smoothed pith at every z in `z` (mm, increasing) from raw detections `raw` (same size):
// LOWESS-style local linear fits (tricube kernel over window_mm, weights raw confidence) with
// biweight reweighting of the residuals, so isolated wrong slices (a knot whorl, a crack) are
// ignored. Slices with found = false get no weight and are interpolated. Returns an empty vector
// when no slice was found; sizes must agree (asserts).
std::vector<Vec2> smooth_pith_track(const std::vector<double>& z,
                                    const std::vector<PithResult>& raw,
                                    const PithTrackOptions& options);

}  // namespace sawyer::ct
