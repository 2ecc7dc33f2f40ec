// The pith from the knots of a whorl (issue 20, item 2): a branch grows out of the pith, so in a
// cross-section through a whorl each knot is a bright streak pointing away from the pith, and
// the lines along the streaks meet there. Where the annual rings are too fine or too faint to
// line up (coarse industrial scans, suppressed growth), the knots still stand 300-500 HU above
// dry heartwood and give the pith to a few millimetres at every whorl; between whorls the
// pith's offset from the log's shape centre, which changes slowly along a stem, is carried over.
//
//   WhorlPith w = whorl_pith(crop, geometry, region_centre, region_radius_mm, noise_hu, {});
//   if (w.found) ... w.pith_mm, w.knots, w.expected_error_mm
//
// The streaks are found from the slice's own levels: the wood level and spread inside the
// region (the heartwood, or the inner part of the section: wet sapwood is as bright as a knot),
// a threshold that many noise and ring spreads above it, connected bright regions that are long
// and narrow. Their axes meet robustly (iteratively reweighted least squares on the distance
// from each axis); an answer needs two streaks at least 25 degrees apart, each with the meeting
// point beyond its inner part (a streak's middle is not its origin). A metal streak, a resin
// pocket or compression wood is one line among the knots and is weighted out.
//
// Units: mm, the slice's frame (pixel (x, y) at (x spacing_x, y spacing_y)). Pure, thread-safe.
#pragma once

#include <vector>

#include "sawyer/core/vec.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/stem/pith_track.h"

namespace sawyer::ct {

struct WhorlPithOptions {
  // A knot pixel stands this many noise sigmas, and this many robust spreads of the region's
  // wood (noise and rings together), above the wood level.
  double noise_sigmas = 6.0;
  double spread_sigmas = 3.5;
  double max_step_hu = 1100;     // brighter than the wood level by more: metal, not a knot
  double min_length_mm = 8.0;    // a streak this long at least (major axis)
  double min_elongation = 2.5;   // length over width
  double min_angle_deg = 25.0;   // the widest pair of inlier streaks at least this far apart
  double max_residual_mm = 3.0;  // inlier: the line passes this close to the meeting point
  double line_error_mm = 2.0;    // a knot axis's own miss of the pith (curved, twisted knots)
  int max_streaks = 24;          // the longest ones (a slice of hundreds is not a whorl)
};

struct WhorlStreak {
  Vec2 centre_mm, direction;  // centroid and unit direction of the major axis
  double length_mm = 0, width_mm = 0;
  double dz_mm = 0;  // pooled from a slice this far along z (meet_streaks' caller sets it)
  bool inlier = false;
};

struct WhorlPith {
  bool found = false;
  Vec2 pith_mm;
  int knots = 0;                     // inlier streaks
  int distinct = 0;                  // their distinct directions (10 degrees apart)
  double residual_mm = 0;            // RMS distance of the inlier lines from pith_mm
  double expected_error_mm = 0;      // residual over the streaks' count, at least half a pixel
  std::vector<WhorlStreak> streaks;  // every candidate, for images and tests
};

// `region_centre` and `region_radius_mm`: the disc the streaks are looked for in (the heartwood
// or the inner part of the section, around the current pith guess); `noise_hu`: the scan's
// noise (ScanLevels::noise_hu()), 0 when unknown. The crop's wood window (wood_min_hu,
// wood_max_hu) gives the pixels the wood level is taken from.
// The two halves of whorl_pith: the slice's knot streaks (the longest max_streaks), and where
// a set of streaks meets. meet_streaks takes streaks of several slices too (pooled along z, in
// one frame, `weight` each; empty: all 1) and its region is the disc the meeting point must lie
// in; `pixel_mm` sets the smallest line error.
std::vector<WhorlStreak> knot_streaks(const SliceCrop& crop, const VolumeGeometry& geometry,
                                      Vec2 region_centre, double region_radius_mm, double noise_hu,
                                      const WhorlPithOptions& options = {});
WhorlPith meet_streaks(std::vector<WhorlStreak> streaks, std::vector<double> weight,
                       Vec2 region_centre, double region_radius_mm, double pixel_mm,
                       const WhorlPithOptions& options = {});

WhorlPith whorl_pith(const SliceCrop& crop, const VolumeGeometry& geometry, Vec2 region_centre,
                     double region_radius_mm, double noise_hu,
                     const WhorlPithOptions& options = {});

}  // namespace sawyer::ct
