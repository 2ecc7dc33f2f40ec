// Stem analysis of one CT slice (issue 4): where the pith is, the outer contour under bark as a
// radius per angle around it, and the heartwood/sapwood border. Per-slice detectors here; the
// tracking and refinement along z are in pith_track.h, the assembly into a LogModel's Stem in
// stem_scan.h.
//
// Frames (docs/architecture.md 3): slice pixels (col, row) map to x = col * spacing_x, y = row *
// spacing_y (mm, relative to the slice's pixel (0, 0)); azimuth omega = atan2(y - pith_y, x -
// pith_x).
//
//   PithResult p = detect_pith(slice, geometry, {}, nullptr);      // no prior: whole slice
//   PithResult q = detect_pith(next, geometry, {}, &p.pith_mm);    // prior: search near it
//   ContourResult c = detect_contour(slice, geometry, p.pith_mm, {});
//   HeartwoodResult h = detect_heartwood(slice, geometry, p.pith_mm, c, {});
//
// All functions are pure (no state between calls) and thread-safe; scratch memory is per call
// unless a Workspace is given.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include "sawyer/core/vec.h"
#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct {

// Denser than any wood on the phantom's calibration: the bed's rubber belt (+200 HU), its rails
// and clutter steel. The pith code no longer uses it (the wood window comes from each slice's
// own levels, wood_levels()); kept for callers that still read a fixed window.
inline constexpr double kMaxWoodHu = 150.0;

struct PithOptions {
  // Search radius around the prior (mm) when one is given.
  double prior_radius_mm = 15.0;
  // The window of wood (and bark) values, HU: above wood_min_hu is not air, below wood_max_hu not
  // the bed or steel. NaN (the default): read from each slice's own histogram (wood_levels), so
  // a shifted or scaled HU calibration, a dried log or a windowed 8-bit export is read as well
  // as a green log on the phantom's calibration. A scan-level estimate (ScanLevels) slots in here.
  double wood_min_hu = std::numeric_limits<double>::quiet_NaN();
  double wood_max_hu = std::numeric_limits<double>::quiet_NaN();
  // With a prior and no wood near it: search the whole slice (true) or report not found.
  bool fall_back_to_whole_slice = true;
};

// Grey levels of a slice from its own histogram (issue 20). Values below -1500 HU (padding outside
// the reconstruction circle: nothing is less dense than air on any calibration) are ignored; the
// rest is split in two by Otsu's threshold, air below, the log (wood, bark, knots) and the bed
// above; each side's median is its level. The wood window reaches 30 % of the way down towards
// air (bark and dry wood stay in, noise in the air does not) and above the wood level by 20 % of
// the air-wood step or four wood spreads, whichever is more (knots and latewood in, the belt and
// steel out). `options` fields that are set replace the window's ends.
struct WoodLevels {
  bool found = false;  // false: no two classes (an empty or flat slice)
  double air_hu = 0;   // median below the split
  double wood_hu = 0;  // median above it
  double min_hu = 0;   // wood window
  double max_hu = 0;
  double sigma_hu = 0;  // robust spread (1.4826 MAD) of the wood pixels: noise and ring signal
  bool contains(double v) const { return v > min_hu && v < max_hu; }
};
WoodLevels wood_levels(const Slice& slice, const PithOptions& options);

struct PithResult {
  Vec2 pith_mm;           // sub-pixel
  double confidence = 0;  // 0..1: how sharply the evidence peaks
  bool found = false;     // false: no log in the slice (air only, or too small)
  // refine_pith_concentric only: the ring period (mm) its profile shows around the answer,
  // from the profile's zero crossings (noise adds crossings, so never overstated); 0 elsewhere.
  double ring_period_mm = 0;
  // refine_pith_concentric with a RingDriftSearch only: the drift of the rings' centre (mm per
  // mm of ring radius) the slice's ring sectors show, and the ring signal (energy less its expected
  // noise) of the rings taken as drifting so, around their own best centre, over that of concentric
  // rings, less 1 (0.1: a tenth more; -0.5: half as much, the drift does not describe these rings).
  Vec2 ring_drift;
  double drift_gain = 0;
};

// The log's section in a slice: centroid and equivalent radius (mm) of the largest connected
// wood area (the wood window of `options`, wood_levels). False when there is none of a log's
// size.
bool log_section(const Slice& slice, const VolumeGeometry& geometry, const PithOptions& options,
                 Vec2* centre_mm, double* radius_mm);

PithResult detect_pith(const Slice& slice, const VolumeGeometry& geometry,
                       const PithOptions& options, const Vec2* prior_mm);

// Where the pith of a slice with no prior may be: the strongest peaks of the whole-slice vote
// (at least 8 mm apart), those of a second vote that lets strong edges in (crisp real rings
// are strong edges) and the section's centroid, each voted on again nearby (`vote`), then
// moved to where the rings (circles) line up best within 6 mm (`rings`, the centre `score` is
// measured around: wide_ring_score). The strongest vote peak comes first. Empty when the slice
// holds no log.
struct PithCandidate {
  Vec2 vote;
  Vec2 rings;
  double vote_confidence = 0;
  double score = 0;
};
std::vector<PithCandidate> pith_candidates(const Slice& slice, const VolumeGeometry& geometry,
                                           const PithOptions& options);

// How well the annual rings of `slice` line up around `centre` out to half the log's radius
// (24 to 60 mm), taken as homothetic to the outer contour measured around `centre` (the outer
// rings follow the log's shape; circles that far out lean towards the centre of an eccentric
// section): the median over 12 mm bands of radius of each band's ring-profile signal share
// (refine_pith_concentric), 0..1. A knot has rings of its own, but only out to its own radius,
// and one strong step in the profile (a knot's rim) lifts one band only. 0 without a contour.
double wide_ring_score(const Slice& slice, const VolumeGeometry& geometry, Vec2 centre);

// Ring-profile refinement: the centre within search_mm of `start` around which the slice's
// annual rings line up best. For each candidate centre the wood within ring_max_mm is binned by
// ring radius and the energy of the binned profile's ring-scale detail is scored (a matched filter
// for concentric rings: every pixel of a ring adds coherently, where per-pixel gradient
// directions drown in noise); pixels far from the wood level (knots, the heartwood step,
// cracks) are left out. With `outline` (the outer radius under bark at equally spaced azimuths
// around `start`) the rings are taken as homothetic to it about the pith, as the log model's
// stem time has them (docs/architecture.md 5); without, as circles, which leans towards the centre
// of an eccentric section by a fraction of a millimetre. `shape_share` (0..1) takes the rings as
// following only that share of the outline's departure from a circle (real inner rings are often
// rounder than the log: the stem pass measures the share per log). Best on a slice averaged
// along z (pith_track.h). confidence: signal share of the profile energy (0..1).
inline constexpr double kRingProfileMaxMm = 24.0;
// `ring_min_mm` (at least 1.5 mm) leaves the innermost rings out: a band of the profile alone.
//
// Rings grown eccentrically (compression wood, wind: wider on one side year after year) are not
// centred on the pith: the ring of radius r is centred at pith + ring_drift * r, so the rings
// out to 24 mm line up best around a point between the pith and the larger rings' centre.
// `ring_drift` takes the rings so (a pixel at distance q in direction u from the pith lies on
// the ring of radius q / (1 + ring_drift . u), on top of the outline's shape). With `drift` the
// drift is measured as well, sector by sector around the concentric answer: in `sectors`
// sectors, each sector's ring profile is the whole profile moved out by a + b r (a ring of
// radius r centred at pith + drift r lies (pith - centre) . u + (drift . u) r farther out in
// direction u); each sector's (a, b) is where its profile matches the whole one best (a grid
// within offset_search_mm and max_mm_per_mm, then a finer one around its best), and the first
// harmonics of a and b round the circle are the pith's offset and the drift (the rest is the
// rings' own shape, which each sector takes up instead of biasing the two). The answer is then
// the drifted rings' best centre (PithResult::ring_drift, drift_gain).
struct RingDriftSearch {
  double max_mm_per_mm = 0.3;
  double drift_step = 0.01;  // the finest grid's steps; the first grid's are four times these
  double offset_search_mm = 2.0;
  double offset_step = 0.05;
  int sectors = 16;
};
PithResult refine_pith_concentric(const Slice& slice, const VolumeGeometry& geometry, Vec2 start,
                                  double search_mm, const std::vector<double>* outline,
                                  double ring_max_mm = kRingProfileMaxMm, double ring_min_mm = 0.0,
                                  double shape_share = 1.0, Vec2 ring_drift = {},
                                  const RingDriftSearch* drift = nullptr);
// The pixels refine_pith_concentric reads lie within this distance (mm) of `start`.
inline double ring_profile_reach_mm(double search_mm, double ring_max_mm = kRingProfileMaxMm) {
  return ring_max_mm + search_mm + 1.0;
}

struct ContourOptions {
  int n_angles = 360;
  // Air / log threshold (a ray stops after 10 mm below it) and the air level.
  double wood_hu = -700.0;
  double air_hu = -1000.0;
  // Level between wood (wet sapwood, knots) and the inner bark: the under-bark edge is where a
  // ray from the pith falls through it for the last time with wood inside (about midway
  // between sapwood, -50 HU, and inner bark, -450 HU).
  double under_bark_hu = -250.0;
  // Wood inside a surface candidate: the median of 1-4 mm under it within [wood_min_hu,
  // wood_max_hu], no sample above wood_peak_hu (the bed's belt and rails, clutter).
  double wood_min_hu = -380.0, wood_max_hu = 120.0, wood_peak_hu = 400.0;
  // From the scan's levels (the stem pass sets these and the fields above from ScanLevels):
  // when outer_wood_hu is set (not NaN), each slice measures its bark level on a few rays (the
  // median just inside the log's edge with air) and takes under_bark_hu midway between
  // outer_wood_hu (the densest wood mode) and that bark, or midway to air where the bark is not
  // lighter than the wood by bark_sigmas standard errors of its median (noise_hu over the square
  // root of the rays); and wood_min_hu a quarter of the wood-bark step under that level.
  double outer_wood_hu = NAN;
  double noise_hu = 20.0;
  double bark_sigmas = 3.0;
  // A dried log (ScanLevels::dried: one wood mode, near air): its bark is barely lighter than
  // the wood, so the surface under it is found from the bark's level and texture under the edge
  // with air on many rays together, not by a level on one ray (contour.cpp, refine_weak_bark).
  bool dried = false;
};

struct ContourResult {
  // Outer radius under bark (mm) at n_angles equally spaced azimuths, the first at omega = 0;
  // 0 where no surface was found (then `valid` marks it).
  std::vector<double> radius;
  std::vector<bool> valid;
  // Bark thickness where measurable (mm), else 0.
  std::vector<double> bark_mm;
  // The levels this slice's contour used: bark measured just inside the edge with air (NaN
  // when not measured) and the under-bark level.
  double bark_hu = NAN;
  double under_bark_hu = NAN;
  // The bark was lighter than the outer wood by enough to set the level (else the level is
  // midway to air: a debarked log, or bark no lighter than the wood).
  bool bark_seen = false;
};

// Fills the entries of a circular row (radius per azimuth) that `valid` does not mark by linear
// interpolation between the nearest marked entries on either side. Returns false when no entry
// is marked.
bool fill_circular(std::vector<double>& row, const std::vector<bool>& valid);

ContourResult detect_contour(const Slice& slice, const VolumeGeometry& geometry,
                             const Vec2& pith_mm, const ContourOptions& options);

struct HeartwoodOptions {
  int n_angles = 360;
  // Least sapwood-minus-heartwood contrast (HU, slice medians) for a dry core to count as
  // present. The stem pass sets it from the scan's noise (many noise sigmas: ScanLevels).
  double min_contrast_hu = 150.0;
};

struct HeartwoodResult {
  // Heartwood radius (mm) per azimuth. Where no border was seen (a knot across it) the value
  // comes from the slice's robust angular fit, so every azimuth is valid when `present`.
  std::vector<double> radius;
  std::vector<bool> valid;
  bool present = false;  // false: no dry core (e.g. a fully wet log)
};

HeartwoodResult detect_heartwood(const Slice& slice, const VolumeGeometry& geometry,
                                 const Vec2& pith_mm, const ContourResult& contour,
                                 const HeartwoodOptions& options);

}  // namespace sawyer::ct
