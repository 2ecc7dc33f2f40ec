// The scan's verdict on itself (issue 20, item 4): for each stage of the scan (levels, pith,
// outline, heartwood, knots) a confidence, the heights where it is unsure and why, counts of what
// was rejected, and whether the stage is to be trusted; assembled into the LogModel's ScanQa
// (log.json "qa", run.json, the CLI summary, the report's first page).
//
//   ScanQaDetail d = assess_scan(stem_scan, &knot_scan, geometry, {});
//   log.qa = d.verdict;           // trusted, warnings, stages
//   d.slices[i].pith_suspect      // per slice: why the pith there is not to be believed
//
// The checks are consistency checks that need no ground truth: how sharply the rings line up
// around the pith that was chosen, whether the refined piths agree with the smoothed track,
// where the pith sits in the log's outline and heartwood border (a pith near the bark or
// outside the dry core is not a pith), how rough and how steady along z the outline is, how
// many knots per metre and how many candidates looked like rings. Their thresholds are set in
// QaOptions and documented with the sweep that calibrated them (docs/scan.md "QA verdict").
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/scan/knot_scan.h"
#include "sawyer/ct/scan/stem_scan.h"
#include "sawyer/model/log_model.h"

namespace sawyer::ct {

struct QaOptions {
  // Levels: an apparent calibration shift (the air mode off -1000 HU) at least this large is
  // reported (the thresholds follow the scan's own levels either way).
  double levels_shift_note_hu = 75.0;
  // Pith. A refined pith whose ring alignment (signal share, 0..1) is below this is weak
  // evidence; one further than pith_residual_mm from the smoothed track disagrees with its
  // neighbours.
  double pith_min_ring_share = 0.2;
  double pith_residual_mm = 1.5;
  // The pith's distance from the centre of the outline (area centroid), as a fraction of the
  // mean radius: real logs stay under about 0.4 (compression wood, strong lean); beyond
  // pith_max_eccentricity the "pith" is something else.
  double pith_max_eccentricity = 0.45;
  // A slice's pith is suspect when the ring evidence is weak AND the track disagrees, or when
  // it is out of place in the outline. The stage fails when more than this share of the
  // measured slices is suspect, or a run of suspect slices is longer than pith_max_run_mm.
  double pith_max_suspect_share = 0.25;
  double pith_max_run_mm = 300.0;
  // The pith's expected error (StemSliceRecord::pith_expected_error_mm, from the cue the pith
  // follows and how well it stood out) against what a sawing decision needs, by scan class:
  // fine scans (pixels <= fine_pixel_mm, slices < coarse_slice_mm) with resolved rings
  // median <= 0.5 mm, 95th percentile <= 1.5 mm; fine scans without, 1.5 and 3 mm; coarse
  // scans median <= 2 mm (and 95th percentile <= 4 mm).
  double fine_pixel_mm = 1.0, coarse_slice_mm = 10.0;
  double pith_fine_median_mm = 0.5, pith_fine_p95_mm = 1.5;
  double pith_narrow_median_mm = 1.5, pith_narrow_p95_mm = 3.0;
  double pith_coarse_median_mm = 2.0, pith_coarse_p95_mm = 4.0;
  // A resolved ring pith this far (plus twice the combined expected errors) from where a kept
  // whorl's knot axes meet is suspect.
  double pith_whorl_disagree_mm = 2.0;
  // Outline. Per slice: the share of azimuths where no surface was found (filled in), the RMS
  // of the radius about its own ±5° running median (bark flakes, a touching log, streaks) and
  // the median change of the radius from the slice before per mm of z (a log's outline
  // changes slowly).
  double outline_max_filled = 0.15;
  double outline_max_roughness_mm = 1.5;
  double outline_max_jump_mm_per_mm = 0.3;
  double outline_max_suspect_share = 0.2;
  // The log is cut by the image (field of view too small, or the log off centre) when more than
  // this share of a slice's outline lies within 1.5 pixels of the image's edge: the outline there
  // is the image's, not the log's.
  double outline_max_at_edge = 0.02;
  // The under-bark edge is a level midway between the outer wood and the bark. It is uncertain
  // where the bark is lighter than the wood by fewer than outline_min_bark_sigmas of the wood's
  // own spread (noise and ring texture, ScanLevels::noise_wood_hu: a ring's latewood swing is
  // as large as the wood-bark step), or by less than outline_min_bark_share of the wood-air
  // span: bark nearly as dense as the wood (a dried log: wood about -600 HU, bark 50-120 HU
  // lighter, against 400-500 HU under a green log's sapwood), so the bark's own gradient from
  // its dense inner layer to its light outer one moves the crossing into the bark. The stage
  // fails when more than outline_max_weak_bark_share of the slices where bark was seen are so.
  double outline_min_bark_sigmas = 3.0;
  double outline_min_bark_share = 0.3;
  double outline_max_weak_bark_share = 0.5;
  // Knots: more than this many per metre (of a section at least 0.5 m long) is not a log's.
  double knots_max_per_m = 60.0;
};

struct QaSlice {
  double z = 0;                  // mm, from the scan's geometry (first slice 0)
  bool measured = false;         // the stem pass measured this slice
  double ring_share = 0;         // the refined pith's ring alignment (0 when not refined)
  double expected_error_mm = 0;  // the stem pass's expected pith error here
  double pith_residual_mm = 0;   // refined pith to the smoothed track
  double eccentricity = 0;       // pith to outline centroid / mean radius
  bool pith_suspect = false;
  std::string pith_why;     // "rings weak", "off the track", "near the bark", ...
  double filled_share = 0;  // outline azimuths filled in
  double roughness_mm = 0;
  double jump_mm_per_mm = 0;
  double at_edge_share = 0;  // outline azimuths at the image's edge
  // Outer wood minus this slice's bark level, over the wood's spread and as a share of the
  // wood-air span (NaN where no bark was seen: a debarked log, or bark no lighter than the wood).
  double bark_step_sigmas = std::numeric_limits<double>::quiet_NaN();
  double bark_step_share = std::numeric_limits<double>::quiet_NaN();
  bool outline_suspect = false;
};

struct ScanQaDetail {
  ScanQa verdict;
  std::vector<QaSlice> slices;  // one per scanned slice
  // The figures the verdict rests on (also in the stages' notes), for benches and tests.
  double pith_suspect_share = 0, pith_longest_run_mm = 0, pith_median_ring_share = 0;
  // The pith's expected error over the measured slices (mm) and the limits it was held to.
  double pith_expected_median_mm = 0, pith_expected_p95_mm = 0;
  double pith_limit_median_mm = 0, pith_limit_p95_mm = 0;
  double rings_resolved_share = 0;
  bool coarse = false;
  double outline_suspect_share = 0;
  double outline_at_edge_share = 0;  // slices cut by the image's edge
  // Of the slices where bark was seen, the share whose bark step is weak (QaOptions); the median
  // step in noise sigmas and as a share of the wood-air span (NaN when no bark was seen).
  double outline_weak_bark_share = 0;
  double outline_bark_step_sigmas = std::numeric_limits<double>::quiet_NaN();
  double outline_bark_step_share = std::numeric_limits<double>::quiet_NaN();
  double knots_per_m = 0;
  int knot_candidates_rejected = 0;           // traces not fitted
  int knot_candidates_rejected_as_rings = 0;  // shaped as rings (KnotScan::rejected_as_rings)
};

// `knots` may be null (a stem-only scan). `geometry` is the scanned source's.
ScanQaDetail assess_scan(const StemScan& stem, const KnotScan* knots,
                         const VolumeGeometry& geometry, const QaOptions& options = {});
// The per-slice figures alone (ScanQaDetail::slices): the only part that reads the records'
// outline and heartwood radii, so that a scan can take them before it releases those
// (ScanOptions::outline_slices) ...
std::vector<QaSlice> assess_slices(const StemScan& stem, const VolumeGeometry& geometry,
                                   const QaOptions& options = {});
// ... and the verdict from them later (the same as assess_scan on the whole records).
ScanQaDetail assess_scan(const StemScan& stem, const KnotScan* knots,
                         const VolumeGeometry& geometry, const QaOptions& options,
                         std::vector<QaSlice> slices);

// One line for a terminal: "QA: trusted" or "QA: NOT TRUSTED — <first warning> (+N more)".
std::string qa_headline(const ScanQa& qa);

}  // namespace sawyer::ct
