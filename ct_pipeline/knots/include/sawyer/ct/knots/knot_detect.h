// Knot detection and segmentation (issue 5): from the log's voxels and its stem (pith track,
// outer radius, heartwood radius), every knot as a trace of per-shell measurements from near the
// pith outwards, ready for the knot-formula fit (knot_fit.h).
//
// Coordinates: the volume is unrolled around the pith track into (r, ω, z): pith distance r
// (mm), azimuth ω = atan2(y − pith_y, x − pith_x) in [0, 2π) (docs/architecture.md 3), height z
// (scanner mm, the slice positions). A knot is then a near-straight tube rising slowly with r.
//
//   KnotDetectOptions o;
//   std::vector<KnotTrace> traces = detect_knots(volume, stem, o);
//
// The wood level, and so the contrast, is taken per wood class (heartwood and sapwood from the
// stem's heartwood radius, or, for a stem without one, from a border estimated from the voxels,
// where the sector-median HU drops 200 HU going inwards) and per ring (bins of the outline-
// normalised radius: rings follow the outline). Thresholds follow the scan's own noise and
// ring signal; candidates shaped as rings (sheets along or round the log, arcs sliding round
// it) are rejected and counted (KnotDetectSummary).
//
// Thread-safe (pure); uses up to options.threads threads. Memory: the unrolled grid, 2 bytes a
// sample (800 slices x 125 shells x 360 azimuths: 72 MB).
#pragma once

#include <cmath>
#include <cstddef>
#include <functional>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"

#include "sawyer/ct/knots/log_volume.h"
#include "sawyer/model/log_model.h"

namespace sawyer::ct {

struct KnotDetectOptions {
  double dr_mm = 1.0;  // radial step of the unrolled volume (shells at dr, 2·dr, ...)
  int n_omega = 360;   // azimuth samples (1°: 1.7 mm of arc at r = 100 mm)
  // Planes of the unrolled volume along the log: slices closer than this (mm) are averaged in
  // runs of floor(grid_dz_mm / spacing) consecutive slices (at most 8) into one plane (at their
  // mean height), so that a fine scan's grid is that of a ~grid_dz_mm one (issue 24: memory and
  // time of 1 mm and finer slices; a 10 mm knot still spans five planes). Slices this far apart
  // or farther are one plane each. 0: one plane per slice.
  double grid_dz_mm = 2.0;
  double min_diameter_mm = 4;  // smaller blobs are noise, not knots
  double min_r_mm = 5;         // segment from here outwards (the pith itself is not a knot)
  // Segmentation (contrast = HU minus the wood level of the same slice, wood class and ring):
  // blobs of samples >= the low threshold holding one >= the high threshold. Knots in dry
  // heartwood are about +500 (sound) and +320 (dead); in wet sapwood +50 and -130 only, which
  // is why knots are segmented where they are strong and followed from there (see follow_*).
  // The thresholds are the scan's own: low_sigmas and high_sigmas times the spread of the
  // contrast where there is no knot (noise and the rings the levels left, measured per scan,
  // KnotDetectSummary), never under low_contrast and high_contrast (a clean scan's spread is
  // some 10-20 HU: the floors hold there).
  double low_contrast = 120;
  double high_contrast = 250;
  double low_sigmas = 4;
  double high_sigmas = 7;
  double min_length_mm = 4;   // shorter segmented runs along r are noise
  double max_axis_slope = 2;  // steeper runs (|dz/dr|, least squares) lie along the log: no knot
  // Rings told from knots by shape (knot_detect.cpp): a shell's blob taller along the log than
  // sheet_z_mm and 2.5 times its width, or wider round it than sheet_arc_mm and three times its
  // height (from sheet_min_r_mm out, beyond the whorls merging near the pith), is a sheet; a
  // run whose centre moves round the log by more than max_arc_slope mm per mm of r is a ring
  // cut into arcs; a run (with its followed part) shorter along r than min_length_diameters
  // times its median diameter is a pocket (resin, wet wood, rot), not a branch.
  double sheet_z_mm = 60;
  // A blob whose z span (less two slice spacings, the slices' partial volume) is over
  // streak_min_z_mm and streak_ratio times its width is a line, not a knot's cross-section
  // (a knot rising at the steepest max_axis_slope is at most sqrt(1 + 4) = 2.24 times as tall
  // as wide): a metal streak repeated over the slices of a nail or a chain link, a crack's
  // dense rim, a ring seen edge-on where the pith is off.
  double streak_min_z_mm = 20;
  double streak_ratio = 4;
  double sheet_arc_mm = 60;
  double sheet_min_r_mm = 30;
  double max_arc_slope = 2;
  double min_length_diameters = 1.0;
  // Two blobs of one knot's shell whose centroids are this far apart (on the cylinder) are two
  // knots that touched further out; closer, they are one knot broken up by noise.
  double min_split_mm = 8;
  // Slices either side pooled for the wood level (whorls): those within ±20 mm, at least this.
  int level_half_window = 3;
  // Following outwards along the extrapolated axis: a shell is evidence when the mean contrast
  // of three shells is beyond ± the follow threshold (or the ring below twice its negative);
  // the knot ends after follow_misses shells without evidence. The threshold is follow_sigmas
  // times the scan's contrast spread, at least follow_min_contrast.
  double follow_min_contrast = 20;
  double follow_sigmas = 1.0;
  int follow_misses = 3;
  double surface_mm = 4;  // reaches_surface: last seen within this of the outer radius
  // Shell diameter from the widest arc instead of the partial-volume area (see KnotShell).
  bool diameter_from_arc = false;
  int threads = 0;  // 0: hardware concurrency
};

// One cylindrical shell (pith distance r) cut through a knot: where the knot crosses it and how
// big and dense it is there.
struct KnotShell {
  double r = 0;      // pith distance of the shell, mm
  double omega = 0;  // azimuth of the knot's centre on the shell, rad
  double z = 0;      // height of the knot's centre on the shell, mm (scanner z)
  // Equivalent diameter of the knot's cross-section on the shell, mm: from its area on the
  // cylinder, each sample counting for the fraction (contrast / knot contrast) of its r·dω by
  // slice-spacing cell (slices are 5 mm apart and as thick: a 10 mm knot covers two or three
  // slices, mostly partly, so counting whole samples would quantise the area in z). On
  // predicted shells, the mean diameter of the last segmented shells (not measured).
  double diameter = 0;
  double contrast = 0;     // knot HU minus the wood's HU (median of the same slice, r and wood
                           // class over ω), mean over the knot's samples on the shell
  double ring_hu = 0;      // contrast of a thin ring just outside the knot (1-3 mm of arc beside
                           // it; on predicted shells a 2 mm ring around the disc). Negative:
                           // encased bark or resin, a dead knot's sign
  double core_hu = NAN;    // HU (not contrast) of the knot's core on the shell: sound knots are
                           // denser than dead ones whatever the wood around them (NaN: unknown)
  int voxels = 0;          // samples of the unrolled shell inside the knot (dω by slice)
  bool predicted = false;  // followed by the axis prediction (weak contrast: sapwood), not
                           // segmented by threshold
};

// One knot's evidence: shells ordered by r (ascending, one per r step at most).
struct KnotTrace {
  std::vector<KnotShell> shells;
  double r_last_seen = 0;        // the outermost r with knot evidence (mm): where the knot ends;
                                 // the last shell's r (the outermost 2 mm under the bark are not
                                 // searched, so a knot cut by the surface ends ~2 mm short of it)
  bool reaches_surface = false;  // r_last_seen within surface_mm of the outer radius
};

// What the pass did and how long each step took (wall seconds).
struct KnotDetectSummary {
  int shells = 0, slices = 0, omegas = 0;  // the unrolled grid
  int blobs = 0;                           // segmented 2D blobs, all shells
  int tracks = 0;                          // linked runs before the length/size filters
  int traces = 0;                          // knots returned
  // The scan's own signal (HU): noise (neighbouring slices), the contrast's residual spread,
  // the ring signal the levels took out; the thresholds that followed from them.
  double noise_hu = 0, residual_hu = 0, ring_hu = 0;
  double low_hu = 0, high_hu = 0, follow_hu = 0;
  // Candidates rejected, by reason: shell blobs shaped as sheets (along or round the log),
  // runs sliding round the log (ring arcs), runs too short along r, too steep in z, too thin,
  // or stubby (pockets).
  int rejected_sheet_blobs = 0, rejected_drift = 0, rejected_short = 0, rejected_steep = 0,
      rejected_small = 0, rejected_stubby = 0;
  int rejected_as_rings() const { return rejected_sheet_blobs + rejected_drift; }
  // unroll_s includes estimating the heartwood border (stems without one); follow_s includes
  // measuring the segmented shells.
  double unroll_s = 0, contrast_s = 0, segment_s = 0, track_s = 0, follow_s = 0, total_s = 0;
  // Streamed (detect_knots over a SliceSource): windows along the log, the largest window's
  // grid, and the range of the high threshold over the windows (each window measures its own
  // signal; the signal figures above are the windows' mean, weighted by their own slices).
  int windows = 1;
  std::size_t grid_bytes = 0;
  double high_hu_min = 0, high_hu_max = 0;
  double read_s = 0;  // reading the slices again (streamed only; inside unroll_s)
};

// The streamed knot pass reads the scan again in windows along the log: each window is its own
// stretch of core_mm plus margin_mm read either side (a knot's whole tube, from its innermost
// shell out, and the ±20 mm the wood levels pool over), and keeps the traces whose innermost
// shell lies in its core. Memory is one window's grid, whatever the log's length. A scan no
// longer than one window plus its margins is one window: the same grid, thresholds and traces
// as detect_knots on the kept volume.
struct KnotWindowOptions {
  double core_mm = 1000;
  double margin_mm = 170;  // a knot rises at most ~0.8 mm per mm of r over ~150 mm, ± its radius
};

// Bytes of the unrolled grid for `planes` planes (KnotDetectOptions::grid_dz_mm) of a stem
// whose largest outer radius is `r_max_mm` (2 bytes a sample, plus the per-shell masks of the
// segmentation: ~1.3x).
std::size_t knot_grid_bytes(int planes, double r_max_mm, const KnotDetectOptions& options);
// Slices of this geometry averaged into one plane of the unrolled grid (1: one plane a slice).
int knot_plane_run(const VolumeGeometry& geometry, const KnotDetectOptions& options);
// Planes in the largest window the streamed pass unrolls for this geometry.
int knot_window_planes(const VolumeGeometry& geometry, const KnotWindowOptions& window,
                       const KnotDetectOptions& options);

// Called once per slice the streamed pass reads, in ascending index order, with the slice as
// read: for what else wants the voxels on the way (the QA's unrolled views).
using KnotSliceVisitor = std::function<void(int index, const Slice& slice)>;

// Traces ordered by the height, then azimuth, of their innermost shell. Empty for an empty
// volume or stem. `summary` (optional) receives counts and timings.
std::vector<KnotTrace> detect_knots(const LogVolume& volume, const Stem& stem,
                                    const KnotDetectOptions& options,
                                    KnotDetectSummary* summary = nullptr);

// The same, streamed: `source` (the scan the stem came from, in its own axes) read again slice
// by slice in windows (KnotWindowOptions). `has_log[i]` (optional, one per slice): whether the
// stem pass found the log's outline on slice i (the kept volume's non-empty planes); without it
// every slice within the stem's z range is unrolled. Errors: a slice that cannot be read.
Result<std::vector<KnotTrace>> detect_knots(SliceSource& source, const Stem& stem,
                                            const std::vector<char>* has_log,
                                            const KnotDetectOptions& options,
                                            const KnotWindowOptions& window,
                                            KnotDetectSummary* summary = nullptr,
                                            const KnotSliceVisitor& visit = {});

}  // namespace sawyer::ct
