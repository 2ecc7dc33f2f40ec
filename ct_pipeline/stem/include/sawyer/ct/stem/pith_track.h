// Pith along z (issue 4): slice-to-slice tracking with detect_pith on a short stack of slices
// averaged along z, an outlier-robust smoothing of a track, and the ring-profile refinement of
// a track on drift-compensated averages (stem_scan.cpp strings them together).
//
//   PithTracker tracker(geometry, {}, {});
//   for (Slice& s : slices_in_z_order)
//     for (TrackedSlice& t : tracker.push(std::move(s))) keep(t);   // slice, pith, crop
//   for (TrackedSlice& t : tracker.finish()) keep(t);
//   std::vector<Vec2> track = smooth_pith_track(z, raw, {});
//   std::vector<PithResult> fine = refine_pith_track(crops, z, track, geometry, {}, {}, &outlines);
//
// Why average: at the noise of industrial and medical log CT (about 20 HU) the annual rings'
// few-percent density modulation is barely above the noise in one slice, and single-slice pith
// estimates err by millimetres. Annual rings run along the stem, so the rings of the slices
// within a few centimetres are nearly the same picture while the noise is independent: the mean
// of the 2k + 1 slices around a slice has sqrt(2k + 1) less noise and the same rings. Slices
// whose log cross-section differs much from the centre slice's (past a log end) are left out.
//
// Units: mm, scanner frame (docs/architecture.md 3). A PithTracker is used by one thread; the
// functions are pure and thread-safe.
#pragma once

#include <cstdint>
#include <cstdio>
#include <deque>
#include <memory>
#include <optional>
#include <vector>

#include "sawyer/core/vec.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/stem/stem_detect.h"

namespace sawyer::ct {

// Slices on each side within half_window_mm along z (at least 1 when the window is positive, at
// most max_slices; 0 for no window), and the step k that takes every k-th slice no closer than
// spacing_mm (at least 1), for the geometry's slice spacing.
int slices_within(const VolumeGeometry& geometry, double half_window_mm, int max_slices);
int slice_step(const VolumeGeometry& geometry, double spacing_mm);
// The slices refine_pith_track refines (of n): every `every`-th (slice_step of
// PithRefineOptions::refine_spacing_mm) and the last.
inline bool refined_slice(int i, int n, int every) { return i % every == 0 || i == n - 1; }

// The evidence the final pith follows at a height (issue 20): the annual rings lined up around it
// (resolved rings); where they are not (coarse pixels, faint rings, rot or cracks over the
// centre), the centre of the log's outline and heartwood border shifted by the pith's offset
// from it that the knot whorls nearby showed (pith_whorl.h), or else by the one the rings
// showed elsewhere in the scan.
enum class PithCue { none, rings, whorls, shape };
inline const char* pith_cue_name(PithCue c) {
  return c == PithCue::rings    ? "rings"
         : c == PithCue::whorls ? "whorls"
         : c == PithCue::shape  ? "shape"
                                : "none";
}

// Centre (mm) of the closed contour given as radius per equally spaced azimuth around `around`
// where `valid` (the area centroid of the polygon); false with fewer than half the azimuths valid.
bool contour_centre(const Vec2& around, const std::vector<double>& radius,
                    const std::vector<bool>& valid, Vec2* centre);

struct PithTrackerOptions {
  // Slices within this distance (mm along z) of a slice are averaged with it before its pith is
  // detected; 0: single slices. At least one neighbour each side is used when the spacing is
  // wider than the window, at most max_half_slices.
  double average_half_window_mm = 20.0;
  int max_half_slices = 20;
  // A detection weaker than this near the prior triggers a search of the whole slice; only
  // detections at least this confident (and not jumping) become the next prior.
  double min_confidence = 0.25;
  // Largest accepted pith move (mm) between consecutive tracked slices.
  double max_step_mm = 4.0;
  // The first track needs no more than a detection every this many mm along z (the smoothing
  // interpolates); the slices between are not searched (found = false, pith_mm = the prior).
  double detect_spacing_mm = 15.0;
  // Search radius (mm) of each detection around the track's last confident pith (detections
  // are at most detect_spacing_mm apart, and a pith leans well under 0.2 mm per mm).
  double search_radius_mm = 8.0;
  // Each detection near the prior is then refined by the ring profile (circles) within this
  // radius (mm); 0: not.
  double ring_search_mm = 2.0;
  // The pith lies inside the heart of the log (1-5 % of the radius off the section's centre in
  // most logs, rarely beyond 20 %): a detection farther than this share of the section's radius
  // from its centre (a knot, noise near the bark at coarse pixels, the bed) is replaced by the
  // centre, at the least confidence that still makes it the next prior (re-acquisition).
  double max_centre_offset = 0.25;
};

// A full-resolution window of a slice around its pith, kept for the refinement pass; pixel
// (x0, y0) of the slice is the window's (0, 0).
struct SliceCrop {
  int x0 = 0, y0 = 0, width = 0, height = 0;
  std::int64_t wood_cells = 0;  // the whole slice's coarse wood count (log-end test)
  // The whole slice's wood window (wood_levels), for the level near the pith.
  double wood_min_hu = 0, wood_max_hu = 0;
  std::vector<float> hu;
};

// Bytes of one slice's crop (its pixels) at this geometry's pixel size, away from the edges.
std::size_t pith_crop_bytes(const VolumeGeometry& geometry);

// The crops of every slice, held until the pith track is refined: in memory up to a budget, the
// rest in an unlinked temporary file read back on demand (the last few dozen read are held), so
// that a long or finely sampled scan's crops (0.4 mm pixels, 2 mm apart: 100 MB a metre) do not
// grow the process with the log's length.
//
//   CropStore crops(n, 32 << 20);
//   crops.put(i, std::move(crop));                       // each slice once, from one thread
//   std::shared_ptr<const SliceCrop> c = crops.get(i);   // any thread; stays valid while held
class CropStore {
 public:
  explicit CropStore(int slices = 0, std::size_t memory_bytes = static_cast<std::size_t>(-1));
  ~CropStore();
  CropStore(const CropStore&) = delete;
  CropStore& operator=(const CropStore&) = delete;
  int size() const { return static_cast<int>(entries_.size()); }
  // Kept in memory while within the budget (or when the temporary file cannot be written).
  void put(int i, SliceCrop crop);
  std::shared_ptr<const SliceCrop> get(int i) const;
  std::size_t bytes_in_memory() const { return in_memory_; }
  std::size_t bytes_spilled() const { return spilled_; }

 private:
  struct Entry {
    std::shared_ptr<const SliceCrop> held;  // in memory (or the metadata of an empty crop)
    SliceCrop meta;                         // spilled: everything but the pixels
    std::int64_t offset = -1;               // spilled: where the pixels are in the file
  };
  std::vector<Entry> entries_;
  std::size_t budget_, in_memory_ = 0, spilled_ = 0;
  std::FILE* file_ = nullptr;
  struct Cache;
  std::unique_ptr<Cache> cache_;
};

// One slice whose pith has been decided: the slice itself (as pushed, not averaged), the raw
// detection and a crop around the tracked pith.
struct TrackedSlice {
  int index = -1;  // push order, from 0
  Slice slice;
  PithResult pith;
  SliceCrop crop;
  // Best guess of the pith for measuring around it (the detection, or the track's last
  // confident pith on slices not searched); false before any pith was found.
  bool has_centre = false;
  Vec2 centre;
};

// Feeds slices in z order; each is searched near the last confident pith on the average of its
// neighbours, falling back to a search of the whole slice when the prior is lost. The first pith
// is chosen among the whole slice's candidates (pith_candidates) by how well the rings line up
// around each on this and the next three searched slices. Results come out in order, a few
// slices behind the input (the averaging window's half-width; before the first pith, the
// windows of the next searched slices too).
class PithTracker {
 public:
  PithTracker(const VolumeGeometry& geometry, const PithOptions& options,
              const PithTrackerOptions& tracker);
  std::vector<TrackedSlice> push(Slice slice);
  std::vector<TrackedSlice> finish();
  // Searches of a whole slice so far (the first slice, and wherever the track was lost).
  int full_searches() const { return full_searches_; }

 private:
  struct Held {
    int index = -1;
    Slice slice;
    std::int64_t wood_cells = 0;  // coarse count of wood pixels, to recognise log ends
    WoodLevels levels;            // the slice's own (wood_levels)
    PithResult pith;              // once decided
    SliceCrop crop;               // once decided
    bool has_centre = false;
    Vec2 centre;
  };
  void decide(int centre);
  // options_ with the wood window of slice `centre` (held).
  PithOptions with_levels(int centre) const;
  // The first pith: the whole slice's candidates, judged on this and the next searched slices.
  PithResult acquire(int centre);
  void release(std::vector<TrackedSlice>& out, bool all);
  // The mean of the slices around `centre`: over the whole slice without a box centre, else over
  // a box around it returned as its own image, slice pixel `origin` (mm) at its (0, 0).
  Slice averaged(int centre, const Vec2* box_centre, Vec2* origin) const;

  VolumeGeometry geometry_;
  PithOptions options_;
  PithTrackerOptions tracker_;
  int half_ = 0;
  int every_ = 1;
  int pushed_ = 0;
  int full_searches_ = 0;
  int next_ = 0;           // next index to decide
  std::deque<Held> held_;  // indices next_ - half_ .. pushed_ - 1 (those still needed)
  std::optional<Vec2> last_;
  std::optional<Vec2> pending_;  // a confident detection that jumped from last_
  int acquisitions_ = 0;         // first-pith searches (acquire) that found something
};

struct PithRefineOptions {
  // Neighbours within this distance (mm along z) are shifted by the track's drift and averaged.
  double average_half_window_mm = 20.0;
  int max_half_slices = 20;
  // Search radius (mm) around the smoothed track.
  double search_radius_mm = 1.5;
  // Refine every k-th slice with k = this / spacing (at least 1), and the last slice.
  double refine_spacing_mm = 10.0;
  int threads = 1;
  // How far the rings follow the outline's shape (refine_pith_concentric's shape_share): 1, the
  // rings homothetic to the outline about the pith; 0, circles. The stem pass measures it per
  // log (StemScanOptions::ring_shape_shares).
  double ring_shape_share = 1.0;
  // The drift of the rings' centre with their radius (refine_pith_concentric's ring_drift),
  // and whether to search it per slice (PithResult::ring_drift; the stem pass measures it per
  // log, StemScanOptions::ring_drift_probes).
  Vec2 ring_drift;
  bool search_drift = false;
  RingDriftSearch drift_search;
  // The rings lined up out to this radius (mm) from the pith (refine_pith_concentric's
  // ring_max_mm): the stem pass's last look at the innermost rings takes fewer.
  double ring_max_mm = kRingProfileMaxMm;
};

// Second pass over the crops of a first, smoothed track: each slice's pith is detected again on
// the mean of its neighbours' crops, each shifted by the track's drift between the two slices
// (so the rings near the pith stay sharp where the pith leans), searching near the track.
// `crops`, `z` and `track` have one entry per slice; slices with an empty crop are not found,
// nor those `which` (when given) marks false.
std::vector<PithResult> refine_pith_track(
    const CropStore& crops, const std::vector<double>& z, const std::vector<Vec2>& track,
    const VolumeGeometry& geometry, const PithOptions& options, const PithRefineOptions& refine,
    const std::vector<std::vector<double>>* outlines = nullptr,
    const std::vector<bool>* which = nullptr);

struct PithTrackOptions {
  // Half-width (mm along z) of the local linear fit; the pith of a log bends slowly.
  double window_mm = 30.0;
  // Tukey (biweight) scale for robustness iterations, in robust sigmas (MAD) of the residuals,
  // and a floor (mm) so a clean track does not reject good slices.
  double tukey_k = 4.685;
  double min_scale_mm = 0.3;
  int robust_iterations = 4;
  // Detections less confident than this fraction of the median confidence get no weight (when
  // at least half of them and three remain).
  double min_relative_confidence = 0.7;
};

// Smoothed pith at every z in `z` (mm, increasing) from raw detections `raw` (same size):
// LOWESS-style local linear fits (tricube kernel over window_mm, weights raw confidence) with
// biweight reweighting of the residuals, so isolated wrong slices (a knot whorl, a crack) are
// ignored. Slices with found = false get no weight and are interpolated. `outlier`, when given,
// marks the found slices given no weight in the end (rejected by the robust fit, or far less
// confident than the typical one). Returns an empty vector
// when no slice was found; sizes must agree (asserts).
std::vector<Vec2> smooth_pith_track(const std::vector<double>& z,
                                    const std::vector<PithResult>& raw,
                                    const PithTrackOptions& options,
                                    std::vector<bool>* outlier = nullptr);

}  // namespace sawyer::ct
