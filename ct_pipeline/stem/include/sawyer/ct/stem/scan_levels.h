// The CT levels of a log scan read from the scan itself (issue 20): air, the wood mode(s), the
// noise, and the thresholds the stem pass derives from them, so that a shifted or scaled HU
// calibration, a dried log or a windowed 8-bit export is read as well as a green log scanned at
// the nominal calibration. No absolute HU value decides an outline or a pith; the levels do.
//
//   ScanLevels l = estimate_levels(slice);                 // one slice
//   ScanLevels scan = pool_levels({l0, l1, l2, ...});      // several heights: the scan's
//   ContourOptions c; apply_levels(scan, &c);              // (stem_scan.cpp does this)
//
// Method (estimate_levels): a histogram of a regular subsample of the slice's pixels,
// smoothed, and its modes: peaks standing out of the valleys on both sides (prominence) and
// holding a share of the pixels. Air is the lowest mode holding a large share (a windowed export
// clips it to the window's floor: a spike there is still the lowest mode). The log's pixels are
// those above the air mode by more than half the way to the wood; the dominant wood mode is the
// log's largest mode, and a second mode holding a good share of the log, separated from it by
// many noise sigmas and lighter or denser, makes two wood modes (a dry core in wet sapwood). The
// bed's belt and clutter are small next to the log and are excluded as denser than the densest
// wood mode by a margin (dense_hu). Noise: the robust (MAD) spread of a second difference across
// rows, in air and in wood, scaled to a pixel's sigma.
//
// Units: HU as stored in the scan (after its rescale), whatever its calibration.
#pragma once

#include <string>
#include <vector>

#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct {

struct ScanLevels {
  // An air mode and a wood mode were found (the histogram looks like a log in air).
  bool valid = false;
  double air_hu = -1000;    // air mode
  double wood_hu = 0;       // dominant wood mode (the most log pixels)
  double wood_low_hu = 0;   // lightest wood mode (heartwood where a dry core shows), else wood_hu
  double wood_high_hu = 0;  // densest wood mode (wet sapwood where it shows), else wood_hu
  bool two_wood_modes = false;
  double noise_air_hu = 0;   // noise sigma in air (0 where air is clipped, a windowed export)
  double noise_wood_hu = 0;  // noise sigma in wood (with the finest ring texture)
  // A dried log's spread above its wood mode (latewood bands, one-sided robust sigma; 0 for a
  // green log): dense_hu stays above it, so a dried log's latewood and bark are wood, not the bed.
  double texture_wood_hu = 0;
  // Derived thresholds.
  double log_hu = -700;   // air / log: 60 % of the way from air to the lightest wood mode
  double dense_hu = 150;  // denser than any wood: the bed's belt, rails, clutter
  // The same for the median of a few samples (the contour's test of the wood inside a surface):
  // its noise is a median's, not a pixel's, so a noisy scan does not lift it over the belt.
  double dense_median_hu = 150;
  // The calibration as it looks: air_hu + 1000 ("HU appear shifted by about +N"), and the wood's
  // density over air (HU above air: about kg/m^3 at a slope-1 calibration).
  double shift_hu = 0;
  double wood_over_air_hu = 0;
  // The wood looks dried: one wood mode, light (no wet sapwood mode).
  bool dried = false;
  // Air sits at the data's lowest value (clipped: a windowed export).
  bool air_clipped = false;
  double fraction_log = 0;  // share of the slice's pixels in the log (log_hu .. dense_hu)
  std::string notes;        // what looked odd, for the QA verdict
  double noise_hu() const { return noise_wood_hu > 0 ? noise_wood_hu : noise_air_hu; }
};

// The levels of one slice from about `samples` of its pixels (a regular subsample): modes of a
// few percent of the pixels are then hundreds to thousands of samples. 40 000 cost about a
// millisecond; the stem pass's per-slice levels use fewer. Not valid (with notes) for a slice of
// air only, or a histogram without both an air and a wood mode.
inline constexpr int kLevelSamples = 40000;
ScanLevels estimate_levels(const Slice& slice, int samples = kLevelSamples);

// The scan's levels from several slices' (valid ones only): the median of each level, the flags
// by majority; notes joined. Not valid when none is.
ScanLevels pool_levels(const std::vector<ScanLevels>& slices);

// A slice's own levels where they agree with the scan's (valid, the same number of wood modes,
// wood within a few noise sigmas and a tenth of the wood-air span); else the scan's. So a slice
// through a log end, a knot whorl or a gap does not move the thresholds of its contour.
ScanLevels slice_levels_or_scan(const ScanLevels& slice, const ScanLevels& scan);

// One line for logs and reports: "air -998, wood -52 (two modes -498/-52), noise 21 HU, ...".
std::string describe(const ScanLevels& levels);

}  // namespace sawyer::ct
