// The stem pass of `sawyer scan` (issue 4): the pith tracked from slice to slice on slices
// averaged along z (pith_track.h), the outer contour and heartwood border of every slice
// measured around it on worker threads (stem_detect.h), the track smoothed, refined twice on
// drift-compensated averages with the rings taken as homothetic to the contour, smoothed again,
// the contours re-centred on the final pith, and the result assembled into a LogModel's Stem.
//
//   auto src = open_ct(folder);
//   Result<StemScan> s = scan_stem(*src.value(), {}, [](int done, int all) { ... });
//   LogModel log; log.stem = s.value().stem;
//
// Levels: before the pass, a few slices spread along the scan (level_slices) are read for the
// scan's own levels (scan_levels.h: air, wood modes, noise), which set every HU threshold of
// the pith, contour and heartwood options; each slice's contour then uses its own levels where
// they agree with the scan's. So a dried log, a shifted calibration or a windowed export is read
// like a green log at the nominal calibration.
//
// The scan streams: slices are read once, in order (and those few before); memory holds the
// averaging window's slices (about 2 x 20 mm of them), a 90 mm square crop around the pith of every
// slice (32 KB at 0.8 mm) and the per-slice results.
#pragma once

#include <cstddef>
#include <functional>
#include <limits>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/knots/log_volume.h"
#include "sawyer/ct/stem/pith_track.h"
#include "sawyer/ct/stem/pith_whorl.h"
#include "sawyer/ct/stem/scan_levels.h"
#include "sawyer/ct/stem/stem_detect.h"
#include "sawyer/model/log_model.h"

namespace sawyer::ct {

// 4 mm: finer than the bundled Gran_1 scan's 5 mm slices and an industrial intake scanner's
// ~10 mm, so their stems keep a sample a slice; the outline and pith change little over it.
inline constexpr double kDefaultStemStepMm = 4.0;

struct StemScanOptions {
  PithOptions pith;
  ContourOptions contour;
  HeartwoodOptions heartwood;
  // The HU thresholds of pith, contour and heartwood from the scan's levels, read from this many
  // slices spread along the scan (false: the options' own thresholds, the nominal calibration
  // of a green log). A dry core counts as present only when its contrast with the sapwood is
  // heartwood_sigmas noise sigmas or more.
  bool levels_from_scan = true;
  int level_slices = 9;
  double heartwood_sigmas = 6.0;
  int threads = 0;  // 0: hardware concurrency
  // The pith: tracked on slices averaged along z, smoothed (LOWESS), then refined on
  // drift-compensated averages searching refine.search_radius_mm around the track and smoothed,
  // again around each new track until it settles.
  PithTrackerOptions tracker;
  // Smoothing of the first track (few, noisy detections: a wide window) and of the refined ones.
  PithTrackOptions first_track{.window_mm = 60.0};
  PithTrackOptions track;
  PithRefineOptions refine;
  // Refinement passes after the first: at most refine_iterations, each only around the slices
  // whose track moved by more than converged_mm in the previous pass; none moved: done.
  int refine_iterations = 5;
  // Search radius (mm) of the first refinement pass (refine.search_radius_mm: the others), and
  // the largest correction of the first track believed.
  double first_search_mm = 4.0;
  double max_correction_mm = 6.0;
  double converged_mm = 0.25;
  // Rings count as resolved where the ring profile's signal share (smoothed along z) reaches
  // this (clear rings score 0.95 and more, resolved but faint ones 0.65-0.8; a lock one ring
  // off, onto a knot or onto noise 0.2-0.6 in the robustness sweep), wherever the ring pith lies
  // in the section: real piths sit up to 20-25 % of the radius off the outline's centre (wind,
  // compression wood; Lapland pines average 12 %), and the pith is where the rings say. Only a
  // ring pith beyond max_eccentricity of the radius, next to the bark where no log has its
  // pith (the QA verdict's "near the bark", QaOptions::pith_max_eccentricity), is not believed;
  // the same bound holds for where a whorl's knots meet.
  double min_ring_signal = 0.6;
  double max_eccentricity = 0.45;
  // ... and where the ring period the profile shows is at least this many pixels: narrower
  // rings are not resolved, and what lines up there is aliasing, knots or the heartwood step
  // (real rings are 0.8-3 mm: at 1.5-2 mm pixels they never are).
  double min_ring_period_px = 2.0;
  // How far a log's inner rings follow its outline's shape (PithRefineOptions::ring_shape_share)
  // is measured before the refinement, not assumed: each share here is tried on up to
  // ring_shape_probes slices spread along the log (the first pass's wide search), and the one
  // whose rings line up best there (the median signal share; the first on a tie) is used for
  // every slice. A model log's rings follow its outline exactly; real logs' inner rings are
  // often rounder (rings laid down when the stem was young and round): on the real slices of
  // bench/real_slices three quarters of the outline's departure fits four of the five logs.
  std::vector<double> ring_shape_shares = {1.0, 0.75};
  int ring_shape_probes = 8;
  // How far the rings' centre drifts with their radius (PithRefineOptions::ring_drift): rings
  // grown wider on one side year after year (compression wood, wind) are centred the farther
  // from the pith the larger they are, and rings lined up as concentric put the pith between
  // the two. Measured per log on ring_drift_probes slices (refine_pith_concentric's sector
  // search, within ring_drift_max mm per mm) and used when it is at least ring_drift_min and
  // ring_drift_consistency times the probes' median deviation from it (a drift the rings show
  // all along the log, not one noise or a knot makes on a few slices), and the rings taken as
  // drifting so keep at least 1 + ring_drift_min_gain of the concentric rings' signal (median
  // over the probes; on two of the sweep's conditions with strong compression wood the sectors
  // agree on a drift that the rings' centres do not have, and the signal falls by more than
  // half; where the drift is right it changes by -0.22 to +0.15: a limit set from the phantom
  // sweep, not from real logs, on none of which the probes agree on a drift). 0 probes: not
  // measured.
  int ring_drift_probes = 8;
  double ring_drift_max = 0.3;
  double ring_drift_min = 0.01;
  double ring_drift_consistency = 2.5;
  double ring_drift_min_gain = -0.35;
  // The innermost rings, last: once the track has settled, every refined slice is lined up
  // again on the rings within inner_ring_periods ring periods of the pith (the scan's median
  // ring period, within inner_ring_min_mm..inner_ring_max_mm), searching inner_search_mm around
  // the track, then inner_iterations - 1 times more within refine.search_radius_mm around the
  // last smoothed inner track. The pith is the centre of the innermost rings; all rings out to
  // 24 mm line up around a point between it and the larger rings' centres wherever the rings'
  // centre moves with their radius in any way (growth that changed with age, which the one
  // drift above does not describe; the real dried disc of bench/real_slices: 6 px, 2.6 mm).
  // The inner track is used only where the inner rings line up clearly better there than at
  // the settled track (their signal share up by inner_min_gain, median over the slices), and
  // the inner piths follow a smooth track more tightly than the full rings' piths do (their
  // median distance from their own smoothed track at most inner_scatter_ratio times the full
  // rings', or inner_max_scatter_mm): where the full rings are a compromise between inner and
  // outer centres, the compromise wanders from slice to slice and the pith's own rings do not;
  // a few rings also line up around a crack's, a knot's or a rot's rim, and those scatter
  // (sweep #120, rot by the pith: +0.36 signal for a 3 mm move, scatter 0.26 mm against 0.29;
  // the disc: +0.28 for 3.2 mm, 0.03 against 0.10; the real SPR3B's crack: -0.02). Fine scans
  // only: the inner radius at least inner_min_px pixels.
  bool inner_rings = true;
  double inner_ring_periods = 3.0;
  double inner_ring_min_mm = 10.0;
  double inner_ring_max_mm = 16.0;
  double inner_search_mm = 4.0;
  int inner_iterations = 3;
  double inner_max_scatter_mm = 0.05;
  double inner_scatter_ratio = 0.5;
  double inner_min_gain = 0.15;
  double inner_min_px = 10.0;
  // The whorl cue (pith_whorl.h) where the rings are not resolved.
  WhorlPithOptions whorl;
  // When set (an empty_like volume of the source's geometry), every slice with a contour is
  // also kept here, cropped to the contour's largest radius plus volume_margin_mm around the
  // first track's pith (which the refinement moves by at most max_correction_mm): the knot
  // pass reads these instead of the scan a second time.
  LogVolume* volume = nullptr;
  double volume_margin_mm = 20.0;
  // The pith crops of every slice (pith_track.h CropStore) held in memory up to this; the rest
  // go to a temporary file until the track is refined.
  std::size_t crop_memory_bytes = std::size_t{32} << 20;
  // The stem (StemScan::stem) samples at most this far apart along z (mm; resample_stem,
  // log_model.h): finer slices are averaged, after the outliers along z are replaced; the
  // records keep every slice. 0: one sample per slice (ScanOptions: kDefaultStemStepMm).
  double stem_step_mm = 0;
};

struct StemSliceRecord {
  double z = 0;           // mm, from the scan's geometry
  PithResult pith_raw;    // the tracker's answer (first pass; not every slice is searched)
  bool measured = false;  // contour and heartwood measured around `centre`
  Vec2 centre;
  PithResult pith_refined;    // the last refinement pass's answer
  Vec2 pith;                  // after robust smoothing along z
  bool pith_outlier = false;  // the robust smoothing rejected the refined pith
  ContourResult contour;      // around `pith` (re-centred from pith_raw); bark_mm emptied:
  double bark_mm = 0;         // the median of the contour's bark over its angles (0: none seen)
  HeartwoodResult heartwood;  // around `pith`
  ScanLevels levels;          // this slice's own (valid = false where not measured)
  // Pith diagnostics for the QA verdict (issue 20): the cue `pith` follows here, a confidence
  // (0..1) and the error to expect (mm, a typical radial error, not a bound).
  PithCue pith_cue = PithCue::none;
  double pith_confidence = 0;
  double pith_expected_error_mm = 0;
  // The rings around the pith stood out of their noise (ring_signal, the ring profile's signal
  // share 0..1 smoothed along z, at least StemScanOptions::min_ring_signal), at a period of two
  // pixels or more.
  bool rings_resolved = false;
  double ring_signal = 0;
  double ring_period_mm = 0;  // the ring profile's period, smoothed along z as ring_signal
  Vec2 pith_shape;  // centre of the outline (heartwood border where present), smoothed along z
  // Where a whorl's knot streaks met in this slice (pith_whorl.h; whorl_knots streaks), and
  // whether that meeting point agreed with the whorls nearby (only those move the pith).
  bool whorl_found = false, whorl_used = false;
  Vec2 pith_whorl;
  int whorl_knots = 0;
  double whorl_error_mm = 0;  // the meeting point's expected error
};

// The scan's pith in a few figures (issue 20), for the QA verdict.
struct PithSummary {
  double rings_resolved_share = 0;  // of the slices with a pith
  double shape_share = 0;           // slices whose pith follows the shape cue
  double whorl_share = 0;           // slices whose pith follows the whorls' offset
  int whorl_slices = 0;             // slices where a whorl's knot streaks met (and agreed)
  double ring_signal = 0;           // median over the slices
  double median_expected_error_mm = 0, max_expected_error_mm = 0;
  // The offset of the ring pith from the shape centre where the rings were resolved (mm, the
  // median over those slices); unresolved slices carry the offset of the nearest resolved
  // stretch along z. 0 when no slice had resolved rings.
  double eccentricity_mm = 0;
  // The longest run of slices following the shape cue (z, mm); NaN when none.
  double uncertain_from_z = std::numeric_limits<double>::quiet_NaN();
  double uncertain_to_z = std::numeric_limits<double>::quiet_NaN();
};

struct StemScan {
  std::vector<StemSliceRecord> slices;
  // The scan's levels (pooled over StemScanOptions::level_slices slices) and the thresholds the
  // pass used (the options after the levels were applied).
  ScanLevels levels;
  PithOptions pith_options;
  ContourOptions contour_options;
  HeartwoodOptions heartwood_options;
  Stem stem;
  double seconds = 0;  // wall time of the whole pass, reading included
  // Of which: reading, first pith track, contour and heartwood (overlapped); pith refinement.
  double seconds_tracking = 0, seconds_refining = 0;
  // Processor time (s): the reading thread (reading, first pith track), the workers (contour,
  // heartwood). The refinement's is about its wall time times its threads.
  double cpu_reading_tracking = 0, cpu_contours = 0;
  int threads = 1;
  int pith_full_searches = 0;  // slices searched whole by the first track (lost or first)
  int pith_refinements = 0;    // ring-profile refinements, all passes
  int pith_refine_passes = 0;
  double ring_shape_share = 1.0;  // the share the refinement used (StemScanOptions)
  Vec2 ring_drift;                // the rings' drift the refinement used (mm per mm; 0: none)
  Vec2 ring_drift_measured;       // the probes' median drift, used or not
  double ring_drift_spread = 0;   // the probes' median deviation from it (mm per mm)
  double ring_drift_gain = 0;     // median ring signal with it over concentric rings, less 1
  // The innermost rings' pass (StemScanOptions::inner_rings): the radius it lined up (mm; 0:
  // not run), how far the inner piths lie from their smoothed track and the full rings' piths
  // from theirs (medians, mm), whether it was used, and the median move it made (mm).
  double inner_ring_mm = 0;
  double inner_scatter_mm = 0, outer_scatter_mm = 0;
  bool inner_used = false;
  double inner_shift_mm = 0;
  double inner_gain = 0;  // median signal share of the inner rings there over at the track
  std::size_t crop_bytes_in_memory = 0, crop_bytes_spilled = 0;  // the pith crops (CropStore)
  // Stem values replaced because they left their neighbours along z (a chain on the log, a bad
  // slice): outer radius and heartwood, in azimuth samples.
  int outline_z_outliers = 0, heartwood_z_outliers = 0;
  PithSummary pith_summary;
  double slices_per_second() const { return seconds > 0 ? slices.size() / seconds : 0; }
};

// Errors: a slice that cannot be read (its message), or no log found in any slice.
Result<StemScan> scan_stem(SliceSource& source, const StemScanOptions& options,
                           const std::function<void(int, int)>& progress = {});

// Re-expresses a closed contour given as radius per equally spaced azimuth around `from` as
// radius per equally spaced azimuth around `to` (same count). Invalid entries stay invalid where
// no valid neighbour covers them. Used after the pith is smoothed; exposed for tests.
// The scanner frame of a source turned by to_scanner_axes() (or already along the axes): the
// file's origin and row/column directions, the slices' direction, and the scanner coordinate of
// the first slice along it with the sign of z along it (axial: the scanner's z).
// place_in_scanner_frame(log, {g.origin.x, g.origin.y}, scanner_frame_of(g)) puts a model
// measured on the source into it (a coronal or sagittal model stays in the slices' axes).
ScannerFrame scanner_frame_of(const VolumeGeometry& g);

void recentre_contour(const Vec2& from, const Vec2& to, std::vector<double>& radius,
                      std::vector<bool>& valid);

}  // namespace sawyer::ct
