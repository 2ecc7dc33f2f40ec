// The stem pass: read every slice once, track the pith, measure contour and heartwood on worker
// threads, smooth the pith along z, re-centre, assemble the Stem.
#include "sawyer/ct/scan/stem_scan.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <ctime>
#include <deque>
#include <mutex>
#include <thread>

#include "sawyer/core/stats.h"
#include "sawyer/ct/stem/pith_whorl.h"
#include "sawyer/model/log_json.h"

namespace sawyer::ct {

namespace {

double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// A bounded queue of slices for the contour workers.
struct Job {
  int index;
  Slice slice;
  Vec2 pith;
};

// Slices done with, kept for the next read: a slice is a megabyte, and allocating a fresh one
// per read (mapping, faulting in and unmapping its pages) costs about as much as copying it.
class SlicePool {
 public:
  void put(Slice&& s) {
    std::lock_guard<std::mutex> lock(m_);
    if (free_.size() < 8) free_.push_back(std::move(s));
  }
  Slice take() {
    std::lock_guard<std::mutex> lock(m_);
    if (free_.empty()) return Slice{};
    Slice s = std::move(free_.back());
    free_.pop_back();
    return s;
  }

 private:
  std::mutex m_;
  std::vector<Slice> free_;
};

class JobQueue {
 public:
  explicit JobQueue(size_t capacity) : capacity_(capacity) {}
  void push(Job job) {
    std::unique_lock<std::mutex> lock(m_);
    not_full_.wait(lock, [&] { return q_.size() < capacity_; });
    q_.push_back(std::move(job));
    not_empty_.notify_one();
  }
  bool pop(Job& job) {
    std::unique_lock<std::mutex> lock(m_);
    not_empty_.wait(lock, [&] { return !q_.empty() || closed_; });
    if (q_.empty()) return false;
    job = std::move(q_.front());
    q_.pop_front();
    not_full_.notify_one();
    return true;
  }
  void close() {
    std::lock_guard<std::mutex> lock(m_);
    closed_ = true;
    not_empty_.notify_all();
  }

 private:
  std::mutex m_;
  std::condition_variable not_full_, not_empty_;
  std::deque<Job> q_;
  size_t capacity_;
  bool closed_ = false;
};

// The whorl cue (pith_whorl.h): every slice's knot streaks in the frame of its shape centre,
// pooled over neighbouring slices (a whorl's knots leave the pith over some 50 mm of height, and
// at coarse slice spacing each knot shows in one or two slices), meet where the pith stands off
// the shape centre. That offset changes slowly along a stem (in the real Gran_1 spruce by up to
// 5 mm per 100 mm): between whorls it is interpolated, beyond them carried, with an error that
// grows with the distance, and weighed against the shape cue's own.
constexpr double kWhorlPoolSigmaMm = 25.0;  // pooling weight along z (Gaussian); reach 2 sigma
constexpr double kWhorlReachMm = 300.0;     // meetings this close in z are compared
constexpr double kWhorlNodeMm = 30.0;       // kept meetings this close in z are averaged
constexpr double kOffsetDriftPerMm = 0.04;  // the pith-shape offset's change along a stem

// The median of a contour's valid radii; 0 when none is valid (median of nothing).
double median_radius(const std::vector<double>& radius, const std::vector<bool>& valid) {
  std::vector<double> r;
  for (size_t k = 0; k < radius.size(); ++k)
    if (valid[k]) r.push_back(radius[k]);
  return median(r);
}

struct WhorlOffsets {
  std::vector<double> z, e;  // nodes, ascending z
  std::vector<Vec2> o;
  bool empty() const { return z.empty(); }
  // Nodes from kept meetings (z ascending): runs closer than kWhorlNodeMm averaged.
  void build(const std::vector<double>& mz, const std::vector<double>& me,
             const std::vector<Vec2>& mo) {
    for (size_t k = 0; k < mz.size();) {
      size_t j = k;
      double sw = 0, sz = 0, ew = 0;
      Vec2 m{0, 0};
      while (j < mz.size() && mz[j] - mz[k] <= kWhorlNodeMm) {
        const double w = 1.0 / (me[j] * me[j]);
        sw += w, sz += w * mz[j], ew += w * me[j], m = m + w * mo[j];
        ++j;
      }
      z.push_back(sz / sw), e.push_back(ew / sw), o.push_back((1.0 / sw) * m);
      k = j;
    }
  }
  // The offset at height zz and the error to expect of it.
  Vec2 at(double zz, double* error) const {
    size_t hi = 0;
    while (hi < z.size() && z[hi] < zz) ++hi;
    if (hi == 0 || hi == z.size()) {
      const size_t k = hi == 0 ? 0 : z.size() - 1;
      *error = std::hypot(e[k], kOffsetDriftPerMm * std::abs(zz - z[k]));
      return o[k];
    }
    const size_t lo = hi - 1;
    const double t = (zz - z[lo]) / (z[hi] - z[lo]);
    const double d = std::min(zz - z[lo], z[hi] - zz);
    *error = std::hypot((1 - t) * e[lo] + t * e[hi], kOffsetDriftPerMm * d);
    return (1 - t) * o[lo] + t * o[hi];
  }
};

// The ring pith's offset from the shape centre, measured on each stretch of resolved slices
// (kMinRingStretch at least), as WhorlOffsets nodes (at most kWhorlNodeMm long): a node's
// offset is its slices' median, its error their spread (robust) over the square root of their
// count, at least a pixel.
constexpr int kMinRingStretch = 3;
WhorlOffsets ring_offsets(const std::vector<double>& z, const std::vector<char>& resolved,
                          const std::vector<Vec2>& track, const std::vector<Vec2>& shape,
                          double pixel_mm) {
  std::vector<double> nz, ne;
  std::vector<Vec2> no;
  const int n = static_cast<int>(resolved.size());
  for (int i = 0; i < n;) {
    if (!resolved[static_cast<size_t>(i)]) {
      ++i;
      continue;
    }
    int j = i;
    while (j < n && resolved[static_cast<size_t>(j)]) ++j;
    if (j - i >= kMinRingStretch) {
      for (int a = i; a < j;) {  // nodes of at most kWhorlNodeMm along the stretch
        int b = a;
        std::vector<double> ox, oy, zz;
        while (b < j && z[static_cast<size_t>(b)] - z[static_cast<size_t>(a)] <= kWhorlNodeMm) {
          const Vec2 o = track[static_cast<size_t>(b)] - shape[static_cast<size_t>(b)];
          ox.push_back(o.x), oy.push_back(o.y), zz.push_back(z[static_cast<size_t>(b)]);
          ++b;
        }
        const Vec2 m{median(ox), median(oy)};
        std::vector<double> dev;
        for (size_t k = 0; k < ox.size(); ++k) dev.push_back((Vec2{ox[k], oy[k]} - m).norm());
        const double spread = 1.4826 * median(dev) / std::sqrt(static_cast<double>(ox.size()));
        nz.push_back(median(zz)), ne.push_back(std::max(spread, pixel_mm)), no.push_back(m);
        a = b;
      }
    }
    i = j;
  }
  WhorlOffsets w;
  w.z = std::move(nz), w.e = std::move(ne), w.o = std::move(no);
  return w;
}

// The innermost rings' pass (StemScanOptions::inner_rings): every refined slice lined up again
// on the rings near the pith, around the settled track and then around the last smoothed inner
// track, and the inner track used where it earns it (the gate in StemScanOptions). `first` is the
// first track (corrections beyond max_correction_mm from it are not believed, as in the passes
// before); `outlines_around(track)` gives each slice's outline around a track.
template <typename Outlines>
void inner_rings_pass(StemScan& scan, const std::vector<double>& z, const CropStore& crops,
                      const StemScanOptions& options, const VolumeGeometry& g,
                      const PithRefineOptions& ro, const std::vector<Vec2>& first,
                      Outlines outlines_around, const std::vector<PithResult>& refined,
                      std::vector<Vec2>& track) {
  const int n = static_cast<int>(track.size());
  if (!options.inner_rings || refined.empty()) return;
  std::vector<double> period, outer_dev;
  std::vector<bool> which(static_cast<size_t>(n), false);
  for (int i = 0; i < n; ++i) {
    const PithResult& q = refined[static_cast<size_t>(i)];
    if (!q.found) continue;
    which[static_cast<size_t>(i)] = true;
    if (q.ring_period_mm > 0) period.push_back(q.ring_period_mm);
    outer_dev.push_back((q.pith_mm - track[static_cast<size_t>(i)]).norm());
  }
  if (period.size() < 3) return;
  const double inner = std::clamp(options.inner_ring_periods * median(period),
                                  options.inner_ring_min_mm, options.inner_ring_max_mm);
  if (inner < options.inner_min_px * std::max(g.spacing_x, g.spacing_y)) return;
  PithRefineOptions io = ro;
  io.ring_max_mm = inner;
  io.search_radius_mm = options.inner_search_mm;
  io.search_drift = false;
  std::vector<Vec2> t = track;
  std::vector<PithResult> r;
  for (int it = 0; it < std::max(1, options.inner_iterations); ++it) {
    // The first search wide, the others as narrow as the passes' around the track they correct.
    if (it > 0)
      io.search_radius_mm = std::min(options.inner_search_mm, options.refine.search_radius_mm);
    const std::vector<std::vector<double>> outlines = outlines_around(t);
    r = refine_pith_track(crops, z, t, g, options.pith, io, &outlines, &which);
    for (int i = 0; i < n; ++i) {
      PithResult& q = r[static_cast<size_t>(i)];
      scan.pith_refinements += q.found;
      if (q.found && (q.pith_mm - first[static_cast<size_t>(i)]).norm() > options.max_correction_mm)
        q.found = false;
    }
    t = smooth_pith_track(z, r, options.track);
    if (t.empty()) return;
  }
  // The same inner rings' signal share at the settled track: what moving earns.
  PithRefineOptions at = io;
  at.search_radius_mm = 0;
  const std::vector<std::vector<double>> outlines = outlines_around(track);
  const std::vector<PithResult> r0 =
      refine_pith_track(crops, z, track, g, options.pith, at, &outlines, &which);
  for (const PithResult& q : r0) scan.pith_refinements += q.found;
  std::vector<double> dev, shift, gain;
  for (int i = 0; i < n; ++i) {
    const PithResult& q = r[static_cast<size_t>(i)];
    if (!q.found) continue;
    dev.push_back((q.pith_mm - t[static_cast<size_t>(i)]).norm());
    shift.push_back((t[static_cast<size_t>(i)] - track[static_cast<size_t>(i)]).norm());
    if (r0[static_cast<size_t>(i)].found)
      gain.push_back(q.confidence - r0[static_cast<size_t>(i)].confidence);
  }
  if (dev.size() < 3 || gain.empty()) return;
  scan.inner_ring_mm = inner;
  scan.inner_scatter_mm = median(dev);
  scan.outer_scatter_mm = outer_dev.empty() ? 0.0 : median(outer_dev);
  scan.inner_shift_mm = median(shift);
  scan.inner_gain = median(gain);
  scan.inner_used =
      scan.inner_gain >= options.inner_min_gain &&
      scan.inner_scatter_mm <= std::max(options.inner_max_scatter_mm,
                                        options.inner_scatter_ratio * scan.outer_scatter_mm);
  if (scan.inner_used) track = std::move(t);
}

// The pith from every cue (issue 20). The ring track (`track`, from `refined`) stands where the
// rings were resolved; elsewhere (coarse pixels, faint rings, rot over the centre, or a ring
// track that left the heart of the log) the pith follows the centre of the log's shape (the
// heartwood border where there is one, else the outline), shifted by the pith's offset from it
// that the knot whorls showed nearby (pith_whorl.h) or, without whorls, by the eccentricity the
// rings showed where resolved. Fills the records' diagnostics and the summary; `track` is
// updated. `research(centres, which)` refines the slices `which` marks again around `centres`.
template <typename Research, typename Inner>
void fuse_pith_cues(StemScan& scan, const std::vector<double>& z, std::vector<PithResult> refined,
                    std::vector<Vec2>& track, const CropStore& crops,
                    const StemScanOptions& options, const VolumeGeometry& g, Research research,
                    Inner inner) {
  const int n = static_cast<int>(scan.slices.size());
  std::vector<PithResult> shape_raw(static_cast<size_t>(n));
  std::vector<double> radius(static_cast<size_t>(n), 0.0);
  for (int i = 0; i < n; ++i) {
    const StemSliceRecord& rec = scan.slices[static_cast<size_t>(i)];
    if (!rec.measured) continue;
    Vec2 c;
    bool ok = false;
    if (rec.heartwood.present)
      ok = contour_centre(rec.centre, rec.heartwood.radius, rec.heartwood.valid, &c);
    if (!ok) ok = contour_centre(rec.centre, rec.contour.radius, rec.contour.valid, &c);
    if (!ok) continue;
    PithResult& q = shape_raw[static_cast<size_t>(i)];
    q.pith_mm = c, q.confidence = 1.0, q.found = true;
    radius[static_cast<size_t>(i)] = median_radius(rec.contour.radius, rec.contour.valid);
  }
  const std::vector<Vec2> shape = smooth_pith_track(z, shape_raw, options.track);
  if (shape.empty()) {
    for (StemSliceRecord& rec : scan.slices) {
      rec.pith_cue = PithCue::rings;
      rec.pith_expected_error_mm = 5.0 * g.spacing_x;  // nothing else to go by
    }
    return;
  }
  const double pixel_mm = std::max(g.spacing_x, g.spacing_y);
  // A ring pith far from the shape centre may be a lock onto a knot's rings, one ring off or
  // onto noise, from a first track that drifted: the rings get a second search around the shape
  // centre, and the stronger alignment stands. Strong rings too: in the robustness sweep a dried
  // pine with cracks and a second log beside it locked 8 mm off with a signal of 0.8-0.86 (#176;
  // 0.05 mm after the second search). A pith near the shape centre is not searched again.
  if (!refined.empty()) {
    std::vector<bool> which(static_cast<size_t>(n), false);
    bool any = false;
    for (int i = 0; i < n; ++i)
      if (refined[static_cast<size_t>(i)].found &&
          (track[static_cast<size_t>(i)] - shape[static_cast<size_t>(i)]).norm() > 2 * pixel_mm)
        which[static_cast<size_t>(i)] = any = true;
    if (any) {
      const std::vector<PithResult> alt = research(shape, which);
      bool changed = false;
      for (int i = 0; i < n; ++i) {
        const PithResult& a = alt[static_cast<size_t>(i)];
        PithResult& r = refined[static_cast<size_t>(i)];
        if (which[static_cast<size_t>(i)] && a.found && a.confidence > r.confidence)
          r = a, changed = true;
      }
      if (changed) {
        std::vector<Vec2> t = smooth_pith_track(z, refined, options.track);
        if (!t.empty()) track = std::move(t);
      }
    }
  }
  // Then the innermost rings, around the ring track that stood.
  if (!refined.empty()) inner(refined, track);
  // Ring signal per slice: the refined slices' signal shares, a running median along z over the
  // refinement's averaging window, so one slice through a whorl does not flip the decision.
  std::vector<double> zr, sr, pr;
  for (int i = 0; i < n; ++i)
    if (!refined.empty() && refined[static_cast<size_t>(i)].found) {
      zr.push_back(z[static_cast<size_t>(i)]);
      sr.push_back(refined[static_cast<size_t>(i)].confidence);
      pr.push_back(refined[static_cast<size_t>(i)].ring_period_mm);
    }
  const double half = std::max(options.refine.average_half_window_mm, 2.0 * g.slice_spacing());
  double rsum = 0;
  int rcount = 0;
  for (double r : radius)
    if (r > 0) rsum += r, ++rcount;
  const double r_log = rcount ? rsum / rcount : 0.0;
  std::vector<char> resolved(static_cast<size_t>(n), 0);
  std::vector<Vec2> offsets;
  for (int i = 0; i < n; ++i) {
    StemSliceRecord& rec = scan.slices[static_cast<size_t>(i)];
    std::vector<double> near, period;
    for (size_t k = 0; k < zr.size(); ++k)
      if (std::abs(zr[k] - z[static_cast<size_t>(i)]) <= half)
        near.push_back(sr[k]), period.push_back(pr[k]);
    rec.ring_signal = median(near);
    rec.ring_period_mm = median(period);
    rec.pith_shape = shape[static_cast<size_t>(i)];
    const double R = radius[static_cast<size_t>(i)] > 0 ? radius[static_cast<size_t>(i)] : r_log;
    const Vec2 d = track[static_cast<size_t>(i)] - shape[static_cast<size_t>(i)];
    rec.rings_resolved = rec.ring_signal >= options.min_ring_signal &&
                         rec.ring_period_mm >= options.min_ring_period_px * pixel_mm &&
                         d.norm() <= options.max_eccentricity * R;
    resolved[static_cast<size_t>(i)] = rec.rings_resolved;
    if (rec.rings_resolved) offsets.push_back(d);
  }
  // The whorls: each slice's knot streaks (pith_whorl.h) inside the heartwood, or the inner
  // part of the section (wet sapwood is as bright as a knot), in the frame of the shape centre.
  const double noise = scan.levels.valid ? scan.levels.noise_hu() : 0.0;
  std::vector<std::vector<WhorlStreak>> streaks(static_cast<size_t>(n));
  std::vector<double> region(static_cast<size_t>(n), 0.0);
  for (int i = 0; i < n; ++i) {
    const StemSliceRecord& rec = scan.slices[static_cast<size_t>(i)];
    if (!rec.measured) continue;
    const std::shared_ptr<const SliceCrop> crop = crops.get(i);
    if (crop->hu.empty()) continue;
    const double heart =
        rec.heartwood.present ? median_radius(rec.heartwood.radius, rec.heartwood.valid) : 0.0;
    const double reg = heart > 0 ? 0.9 * heart : 0.6 * radius[static_cast<size_t>(i)];
    region[static_cast<size_t>(i)] = reg;
    streaks[static_cast<size_t>(i)] =
        knot_streaks(*crop, g, shape[static_cast<size_t>(i)], reg, noise, options.whorl);
    for (WhorlStreak& st : streaks[static_cast<size_t>(i)])
      st.centre_mm = st.centre_mm - shape[static_cast<size_t>(i)];
  }
  // Where the streaks within reach along z meet, per unresolved slice.
  std::vector<double> wz, we;
  std::vector<Vec2> wo;
  std::vector<int> wi, wd;
  for (int i = 0; i < n; ++i) {
    if (region[static_cast<size_t>(i)] <= 0) continue;
    std::vector<WhorlStreak> pool;
    std::vector<double> weight;
    for (int j = 0; j < n; ++j) {
      const double dz = z[static_cast<size_t>(j)] - z[static_cast<size_t>(i)];
      if (std::abs(dz) > 2 * kWhorlPoolSigmaMm) continue;
      for (WhorlStreak st : streaks[static_cast<size_t>(j)]) {
        st.dz_mm = dz;
        pool.push_back(st);
        weight.push_back(std::exp(-0.5 * dz * dz / (kWhorlPoolSigmaMm * kWhorlPoolSigmaMm)));
      }
    }
    if (pool.size() < 2) continue;
    const WhorlPith w = meet_streaks(std::move(pool), std::move(weight), {0, 0},
                                     region[static_cast<size_t>(i)], pixel_mm, options.whorl);
    // As for the rings: a pith this far off the shape centre is not believed.
    const double R = radius[static_cast<size_t>(i)] > 0 ? radius[static_cast<size_t>(i)] : r_log;
    if (!w.found || w.pith_mm.norm() > options.max_eccentricity * R) continue;
    double dz2 = 0;
    int c = 0;
    for (const WhorlStreak& st : w.streaks)
      if (st.inlier) dz2 += st.dz_mm * st.dz_mm, ++c;
    const double we_i = std::hypot(w.expected_error_mm, kOffsetDriftPerMm * std::sqrt(dz2 / c));
    StemSliceRecord& rec = scan.slices[static_cast<size_t>(i)];
    rec.whorl_found = true;
    rec.pith_whorl = shape[static_cast<size_t>(i)] + w.pith_mm;
    rec.whorl_knots = w.distinct;
    rec.whorl_error_mm = we_i;
    wz.push_back(z[static_cast<size_t>(i)]);
    we.push_back(we_i);
    wo.push_back(w.pith_mm);
    wi.push_back(i);
    wd.push_back(w.distinct);
  }
  // Kept: a meeting of three knots' lines at least (two lines always meet), or of two that an
  // independent meeting agrees with (one whose pool of streaks is another: more than two pooling
  // reaches away along z, within kWhorlReachMm); never against most of the meetings within
  // kWhorlReachMm (a false meeting, say a metal streak across a knot, or two resin pockets,
  // stands alone).
  std::vector<double> kz, ke;
  std::vector<Vec2> ko;
  for (size_t k = 0; k < wz.size(); ++k) {
    int near = 0, agree = 0, independent = 0;
    for (size_t j = 0; j < wz.size(); ++j) {
      const double dz = std::abs(wz[j] - wz[k]);
      if (j == k || dz > kWhorlReachMm) continue;
      ++near;
      const bool same =
          (wo[j] - wo[k]).norm() <= 2.0 * std::hypot(we[j], we[k]) + kOffsetDriftPerMm * dz;
      agree += same;
      independent += same && dz > 4 * kWhorlPoolSigmaMm;
    }
    if ((independent >= 1 || wd[k] >= 3) && 2 * agree >= near) {
      scan.slices[static_cast<size_t>(wi[k])].whorl_used = true;
      // Where the rings were resolved the meeting is a check on them (the QA verdict compares
      // the two), not a cue: the rings are the more precise.
      if (!resolved[static_cast<size_t>(wi[k])])
        kz.push_back(wz[k]), ke.push_back(we[k]), ko.push_back(wo[k]);
    }
  }
  WhorlOffsets whorls;
  whorls.build(kz, ke, ko);
  // The pith's offset from the shape centre changes slowly along a log, but real piths sit up to
  // 20-25 % of the radius off it and wander (wind, compression wood; an S-shaped pith turns the
  // offset round along the log): each stretch of slices with resolved rings measures it where it
  // is, and an unresolved slice carries the offset of the nearest stretches along z (between
  // two, interpolated), with an error that grows with the distance (ring_offsets). A stretch of
  // fewer than kMinRingStretch slices (rings that lined up by chance) measures nothing.
  const WhorlOffsets rings = ring_offsets(z, resolved, track, shape, pixel_mm);
  PithSummary& sum = scan.pith_summary;
  {
    std::vector<double> ox, oy;
    for (const Vec2& o : offsets) ox.push_back(o.x), oy.push_back(o.y);
    sum.eccentricity_mm = offsets.empty() ? 0.0 : Vec2{median(ox), median(oy)}.norm();
  }
  // Without resolved rings anywhere, the shape cue's error is a tenth of the radius (the
  // eccentricity of most logs; up to a quarter in some, which the QA's limits then flag).
  const double shape_error = std::max(0.1 * r_log, g.spacing_x);
  std::vector<PithResult> fused(static_cast<size_t>(n));
  std::vector<double> errors, signals;
  int shape_slices = 0, whorl_slices = 0, resolved_slices = 0, run_from = -1, best_from = -1,
      best_to = -1;
  for (int i = 0; i <= n; ++i) {
    const bool use_shape = i < n && !resolved[static_cast<size_t>(i)];
    if (use_shape && run_from < 0) run_from = i;
    if (!use_shape && run_from >= 0) {
      if (best_from < 0 || i - 1 - run_from > best_to - best_from)
        best_from = run_from, best_to = i - 1;
      run_from = -1;
    }
    if (i == n) break;
    StemSliceRecord& rec = scan.slices[static_cast<size_t>(i)];
    PithResult& f = fused[static_cast<size_t>(i)];
    f.found = true;
    if (use_shape) {
      // The offsets the resolved rings nearby and the whorls show here, each weighed by its
      // error; with neither, the shape centre itself.
      double er = shape_error, ew = 0;
      const Vec2 o_rings = rings.empty() ? Vec2{0, 0} : rings.at(z[static_cast<size_t>(i)], &er);
      const Vec2 o_whorls = whorls.empty() ? Vec2{0, 0} : whorls.at(z[static_cast<size_t>(i)], &ew);
      const double b = 1.0 / (er * er), a = whorls.empty() ? 0.0 : 1.0 / (ew * ew);
      f.pith_mm = shape[static_cast<size_t>(i)] + (1.0 / (a + b)) * (a * o_whorls + b * o_rings);
      f.confidence = a >= b ? 0.7 : 0.5;
      rec.pith_cue = a >= b ? PithCue::whorls : PithCue::shape;
      rec.pith_expected_error_mm = std::max(1.0 / std::sqrt(a + b), 0.5 * pixel_mm);
      ++(a >= b ? whorl_slices : shape_slices);
    } else {
      f.pith_mm = track[static_cast<size_t>(i)];
      f.confidence = 1.0;
      rec.pith_cue = PithCue::rings;
      // A few tenths of a pixel where the rings stand well out of the noise, growing as they
      // sink into it.
      rec.pith_expected_error_mm = 0.25 * g.spacing_x / std::max(rec.ring_signal, 0.05);
      ++resolved_slices;
    }
    rec.pith_confidence =
        std::clamp(rec.pith_cue == PithCue::rings ? rec.ring_signal
                                                  : 0.5 * g.spacing_x / rec.pith_expected_error_mm,
                   0.0, 1.0);
    errors.push_back(rec.pith_expected_error_mm);
    signals.push_back(rec.ring_signal);
  }
  if (shape_slices + whorl_slices > 0) {
    // Both cues in one scan: one smooth track through them (the shape cue's slices weigh less).
    const std::vector<Vec2> t =
        resolved_slices > 0 ? smooth_pith_track(z, fused, options.track) : std::vector<Vec2>{};
    for (int i = 0; i < n; ++i) {
      if (!resolved[static_cast<size_t>(i)] || t.empty())
        track[static_cast<size_t>(i)] =
            t.empty() ? fused[static_cast<size_t>(i)].pith_mm : t[static_cast<size_t>(i)];
    }
  }
  sum.rings_resolved_share = n ? static_cast<double>(resolved_slices) / n : 0.0;
  sum.shape_share = n ? static_cast<double>(shape_slices) / n : 0.0;
  sum.whorl_share = n ? static_cast<double>(whorl_slices) / n : 0.0;
  sum.whorl_slices = static_cast<int>(kz.size());
  sum.ring_signal = median(signals);
  sum.median_expected_error_mm = median(errors);
  sum.max_expected_error_mm =
      errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end());
  if (best_from >= 0)
    sum.uncertain_from_z = z[static_cast<size_t>(best_from)],
    sum.uncertain_to_z = z[static_cast<size_t>(best_to)];
}

}  // namespace

void recentre_contour(const Vec2& from, const Vec2& to, std::vector<double>& radius,
                      std::vector<bool>& valid) {
  const int n = static_cast<int>(radius.size());
  if (n == 0 || (from - to).norm() < 1e-9) return;
  // The angles' cosines and sines, once per angle count and thread (the stem pass calls this
  // for every slice and, in drop_z_outliers, four times more).
  thread_local std::vector<Vec2> dirs;
  if (static_cast<int>(dirs.size()) != n) {
    dirs.resize(static_cast<size_t>(n));
    for (int k = 0; k < n; ++k) {
      const double w = kTwoPi * k / n;
      dirs[static_cast<size_t>(k)] = {std::cos(w), std::sin(w)};
    }
  }
  // Points of the contour in the slice plane, then their azimuth and distance around `to`.
  struct Polar {
    double w, r;
  };
  std::vector<Polar> pts;
  pts.reserve(static_cast<size_t>(n));
  size_t first = 0;  // the point of smallest azimuth
  for (int k = 0; k < n; ++k) {
    if (!valid[k]) continue;
    const Vec2& u = dirs[static_cast<size_t>(k)];
    const Vec2 d = Vec2{from.x + radius[k] * u.x, from.y + radius[k] * u.y} - to;
    pts.push_back({wrap_angle(std::atan2(d.y, d.x)), d.norm()});
    if (pts.back().w < pts[first].w) first = pts.size() - 1;
  }
  std::vector<double> out(n, 0.0);
  std::vector<bool> ok(n, false);
  if (pts.size() < 2) {
    radius = out;
    valid = ok;
    return;
  }
  // Seen from a point inside the outline, the azimuths follow the contour's order: turned to
  // start at the smallest, they are sorted already. Sorted here only when they are not.
  std::rotate(pts.begin(), pts.begin() + static_cast<long>(first), pts.end());
  auto by_w = [](const Polar& a, const Polar& b) { return a.w < b.w; };
  if (!std::is_sorted(pts.begin(), pts.end(), by_w)) std::sort(pts.begin(), pts.end(), by_w);
  // Linear interpolation in azimuth between consecutive contour points (circular). A gap wider
  // than 3 angular steps was a run of invalid angles: keep it invalid.
  const double max_gap = 3.0 * kTwoPi / n + 1e-9;
  const size_t m = pts.size();
  size_t j = 0;  // the first point at or past azimuth w (w grows with k)
  for (int k = 0; k < n; ++k) {
    const double w = kTwoPi * k / n;
    while (j < m && pts[j].w < w) ++j;
    const Polar& b = j == m ? pts.front() : pts[j];
    const Polar& a = j == 0 ? pts[m - 1] : pts[j - 1];
    double span = b.w - a.w;
    if (span <= 0) span += kTwoPi;
    double t = w - a.w;
    if (t < 0) t += kTwoPi;
    if (span > max_gap) continue;
    out[k] = a.r + (b.r - a.r) * (span > 0 ? t / span : 0.0);
    ok[k] = true;
  }
  radius = out;
  valid = ok;
}

ScannerFrame scanner_frame_of(const VolumeGeometry& g) {
  ScannerFrame f;
  const VolumeGeometry::FileAxes file =
      g.file_axes.value_or(VolumeGeometry::FileAxes{g.origin, g.orientation});
  const auto& o = file.orientation;
  f.origin_mm = file.origin;
  f.row_dir = Vec3{o[0], o[1], o[2]}.normalized();
  f.col_dir = Vec3{o[3], o[4], o[5]}.normalized();
  // z runs along the slices: the scanner axis their normal is nearest (to_scanner_axes() has
  // made sure it is along one), its sign and the first slice's coordinate on it.
  f.slice_dir = g.slice_dir.normalized() + Vec3{0, 0, 0};  // + 0: no "-0" in log.json
  const int axis = f.slice_axis();
  const double along = axis == 0 ? f.slice_dir.x : axis == 1 ? f.slice_dir.y : f.slice_dir.z;
  f.z_dir = along < 0 ? -1.0 : 1.0;
  f.z0_mm = axis == 0 ? g.origin.x : axis == 1 ? g.origin.y : g.origin.z;
  // An axial model's z is the scanner's z alone (ScannerFrame): its slice_dir is exact.
  if (axis == 2) f.slice_dir = {0, 0, f.z_dir};
  return f;
}

namespace {

// A stem row (radius per azimuth around its slice's pith) that leaves its neighbours along z: at
// each azimuth, a value farther than kZOutlierMm (or kZOutlierShare of the radius) from the
// median of the rows within kZOutlierHalf samples either side, each re-expressed around this
// row's pith (the pith moves between slices, and the radius at one azimuth with it), is
// replaced by that median. A slice whose outline took in a chain lying on the log, or whose
// heartwood walk started there, does not carry into the model (the knot pass reads its wood
// from the stem). Returns the values replaced.
constexpr int kZOutlierHalf = 2;
constexpr double kZOutlierMm = 5.0, kZOutlierShare = 0.05;
int drop_z_outliers(std::vector<std::vector<double>>& rows, const std::vector<Vec2>& piths) {
  const int n = static_cast<int>(rows.size());
  if (n < 2 * kZOutlierHalf + 1 || piths.size() != rows.size()) return 0;
  const std::vector<std::vector<double>> in = rows;
  int replaced = 0;
  std::vector<double> near;
  std::vector<std::vector<double>> around(2 * kZOutlierHalf + 1);
  for (int i = 0; i < n; ++i) {
    const int a = std::max(0, std::min(i - kZOutlierHalf, n - 1 - 2 * kZOutlierHalf));
    for (int j = a; j <= a + 2 * kZOutlierHalf; ++j) {
      std::vector<double>& r = around[static_cast<size_t>(j - a)];
      r = in[static_cast<size_t>(j)];
      if (j != i) {
        std::vector<bool> ok(r.size(), true);
        recentre_contour(piths[static_cast<size_t>(j)], piths[static_cast<size_t>(i)], r, ok);
        for (size_t k = 0; k < r.size(); ++k)
          if (!ok[k]) r[k] = NAN;
      }
    }
    for (size_t k = 0; k < rows[static_cast<size_t>(i)].size(); ++k) {
      near.clear();
      for (const std::vector<double>& r : around)
        if (k < r.size() && std::isfinite(r[k])) near.push_back(r[k]);
      if (near.size() < 3) continue;
      std::nth_element(near.begin(), near.begin() + static_cast<long>(near.size() / 2), near.end());
      const double m = near[near.size() / 2];
      double& v = rows[static_cast<size_t>(i)][k];
      if (std::abs(v - m) > std::max(kZOutlierMm, kZOutlierShare * m)) {
        v = m;
        ++replaced;
      }
    }
  }
  return replaced;
}

// Each slice's own levels (for its contour) from this many pixels: enough for the air and wood
// modes (the scan's, from kLevelSamples each, are the reference), a small share of the slice's
// time.
constexpr int kSliceLevelSamples = 8000;

// The options' HU thresholds from levels (scan_levels.h): wood between the air/log threshold and
// the dense one; the under-bark edge midway between the densest wood mode and the slice's bark
// (detect_contour measures it); the brightest sample allowed under a surface as far above the
// dense threshold again and a quarter (the belt's +200 HU at the nominal calibration is above
// the dense threshold, the rails' +2200 far above the peak); a dry core as many noise sigmas.
void apply_levels(const ScanLevels& l, double heartwood_sigmas, PithOptions* p, ContourOptions* c,
                  HeartwoodOptions* h) {
  if (!l.valid) return;
  const double sigma = std::max(1.0, l.noise_hu());
  if (p) {
    p->wood_min_hu = l.log_hu;
    p->wood_max_hu = l.dense_hu;
  }
  if (c) {
    c->wood_hu = l.log_hu;
    c->air_hu = l.air_hu;
    c->outer_wood_hu = l.wood_high_hu;
    c->noise_hu = sigma;
    c->wood_max_hu = l.dense_median_hu;  // a median of a few samples: tighter than a pixel's
    c->wood_peak_hu = l.wood_high_hu + 2.25 * (l.dense_hu - l.wood_high_hu);
    c->dried = l.dried;
  }
  if (h) h->min_contrast_hu = heartwood_sigmas * sigma;
}

}  // namespace

Result<StemScan> scan_stem(SliceSource& source, const StemScanOptions& options_in,
                           const std::function<void(int, int)>& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  const VolumeGeometry& g = source.geometry();
  const int n = g.slice_count();
  StemScan scan;
  scan.slices.resize(n);
  // The scan's levels from a few slices spread along it (not the ends: log ends, the bed only).
  StemScanOptions options = options_in;
  if (options.levels_from_scan && n > 0) {
    const int m = std::clamp(options.level_slices, 1, n);
    std::vector<ScanLevels> sampled;
    Slice probe;
    for (int k = 0; k < m; ++k) {
      const int i = static_cast<int>((k + 0.5) * n / m);
      const Status st = source.read(i, probe);
      if (!st) return st.error();
      sampled.push_back(estimate_levels(probe));
    }
    scan.levels = pool_levels(sampled);
    apply_levels(scan.levels, options.heartwood_sigmas, &options.pith, &options.contour,
                 &options.heartwood);
  }
  scan.pith_options = options.pith;
  scan.contour_options = options.contour;
  scan.heartwood_options = options.heartwood;
  int threads =
      options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, 16);
  scan.threads = threads;

  // Workers measure contour and heartwood; the reading thread tracks the pith (it needs the
  // previous slice's answer) and feeds them.
  JobQueue queue(static_cast<size_t>(2 * threads));
  SlicePool pool;
  std::mutex cpu_mutex;
  const double reader_c0 = thread_cpu_seconds();
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&] {
      const double c0 = thread_cpu_seconds();
      Job job;
      while (queue.pop(job)) {
        StemSliceRecord& rec = scan.slices[job.index];
        if (rec.measured) {
          // This slice's own levels where they agree with the scan's.
          ContourOptions co = options.contour;
          HeartwoodOptions ho = options.heartwood;
          if (scan.levels.valid) {
            rec.levels = estimate_levels(job.slice, kSliceLevelSamples);
            apply_levels(slice_levels_or_scan(rec.levels, scan.levels), options.heartwood_sigmas,
                         nullptr, &co, &ho);
          }
          rec.contour = detect_contour(job.slice, g, job.pith, co);
          rec.heartwood = detect_heartwood(job.slice, g, job.pith, rec.contour, ho);
          // The slice's bark figure; the angles' own stay until the stem is built (the model's
          // bark at every angle: a butt log's bark runs 2-10 mm round one section, and one
          // figure put the real logs' bark surface 2 mm off).
          std::vector<double> bark;
          for (double b : rec.contour.bark_mm)
            if (b > 0) bark.push_back(b);
          rec.bark_mm = median(bark);
          if (options.volume) {
            double rmax = 0;
            for (size_t k = 0; k < rec.contour.radius.size(); ++k)
              if (rec.contour.valid[k]) rmax = std::max(rmax, rec.contour.radius[k]);
            if (rmax > 0)
              options.volume->keep(job.index, job.slice, job.pith, rmax + options.volume_margin_mm);
          }
        }
        pool.put(std::move(job.slice));
      }
      std::lock_guard<std::mutex> lock(cpu_mutex);
      scan.cpu_contours += thread_cpu_seconds() - c0;
    });
  }
  // The reading thread tracks the pith (each slice's search starts from the previous answer)
  // on slices averaged along z, a few slices behind the input, and feeds the workers.
  Status status = Status::Ok();
  PithTracker tracker(g, options.pith, options.tracker);
  CropStore crops(n, options.crop_memory_bytes);
  auto dispatch = [&](std::vector<TrackedSlice> done) {
    for (TrackedSlice& t : done) {
      StemSliceRecord& rec = scan.slices[static_cast<size_t>(t.index)];
      rec.z = g.z[static_cast<size_t>(t.index)];
      rec.pith_raw = t.pith;
      rec.measured = t.has_centre;
      rec.centre = t.centre;
      crops.put(t.index, std::move(t.crop));
      Job job;
      job.index = t.index;
      job.pith = t.centre;
      job.slice = std::move(t.slice);
      queue.push(std::move(job));
      if (progress) progress(t.index + 1, n);
    }
  };
  for (int i = 0; i < n; ++i) {
    Slice slice = pool.take();
    status = source.read(i, slice);
    if (!status) break;
    dispatch(tracker.push(std::move(slice)));
  }
  if (status) dispatch(tracker.finish());
  scan.cpu_reading_tracking = thread_cpu_seconds() - reader_c0;
  scan.pith_full_searches = tracker.full_searches();
  scan.crop_bytes_in_memory = crops.bytes_in_memory();
  scan.crop_bytes_spilled = crops.bytes_spilled();
  queue.close();
  for (auto& w : workers) w.join();
  if (!status) return status.error();

  std::vector<PithResult> raw(static_cast<size_t>(n));
  int found = 0;
  for (int i = 0; i < n; ++i) {
    raw[static_cast<size_t>(i)] = scan.slices[static_cast<size_t>(i)].pith_raw;
    found += raw[static_cast<size_t>(i)].found;
  }
  if (found == 0) return Error(source.description(), "no log found in any slice");
  const auto t_tracked = std::chrono::steady_clock::now();
  scan.seconds_tracking = std::chrono::duration<double>(t_tracked - t0).count();
  std::vector<double> z(g.z.begin(), g.z.begin() + n);
  // The first track, then refinement passes on drift-compensated averages with the rings
  // assumed homothetic to the outer contour (pith_track.h), each smoothed again.
  std::vector<bool> outlier;  // of the piths the final track was smoothed from
  std::vector<Vec2> track = smooth_pith_track(z, raw, options.first_track, &outlier);
  auto outlines_around = [&](const std::vector<Vec2>& centre) {
    std::vector<std::vector<double>> outlines(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) {
      const StemSliceRecord& rec = scan.slices[static_cast<size_t>(i)];
      if (!rec.measured) continue;
      std::vector<double> r = rec.contour.radius;
      std::vector<bool> v = rec.contour.valid;
      recentre_contour(rec.centre, centre[static_cast<size_t>(i)], r, v);
      if (fill_circular(r, v)) outlines[static_cast<size_t>(i)] = std::move(r);
    }
    return outlines;
  };
  // Refinement passes, each around the last smoothed track and with its drift; after the first,
  // only around the slices whose track moved.
  PithRefineOptions ro = options.refine;
  ro.threads = threads;
  std::vector<PithResult> refined;
  std::vector<bool> which(static_cast<size_t>(n), true);
  const int half =
      slices_within(g, options.refine.average_half_window_mm, options.refine.max_half_slices);
  const std::vector<Vec2> first = track;
  // The rings' share of the outline's shape, measured on a few slices along the log with the
  // first pass's wide search: the share whose rings line up best. Then, on the same slices, how
  // far the rings' centre drifts with their radius (eccentric growth).
  const int np_wanted =
      std::max(options.ring_shape_shares.size() > 1 ? options.ring_shape_probes : 0,
               options.ring_drift_probes);
  if (np_wanted > 0) {
    const int every = slice_step(g, ro.refine_spacing_mm);
    std::vector<int> candidates;
    for (int i = 0; i < n; ++i)
      if (refined_slice(i, n, every) && scan.slices[static_cast<size_t>(i)].measured)
        candidates.push_back(i);
    auto probes = [&](int want) {
      std::vector<bool> probe(static_cast<size_t>(n), false);
      const int np = std::min<int>(want, static_cast<int>(candidates.size()));
      for (int k = 0; k < np; ++k)
        probe[static_cast<size_t>(
            candidates[static_cast<size_t>((2 * k + 1) * candidates.size() / (2 * np))])] = true;
      return np > 0 ? probe : std::vector<bool>{};
    };
    const std::vector<std::vector<double>> outlines = outlines_around(track);
    PithRefineOptions po = ro;
    po.search_radius_mm = options.first_search_mm;
    const std::vector<bool> share_probe = probes(options.ring_shape_probes);
    if (options.ring_shape_shares.size() > 1 && !share_probe.empty()) {
      double best = -1;
      for (double share : options.ring_shape_shares) {
        po.ring_shape_share = share;
        std::vector<double> conf;
        for (const PithResult& q :
             refine_pith_track(crops, z, track, g, options.pith, po, &outlines, &share_probe))
          if (q.found) conf.push_back(q.confidence);
        const double m = conf.empty() ? 0.0 : median(conf);
        if (m > best) best = m, ro.ring_shape_share = share;
      }
    }
    const std::vector<bool> drift_probe = probes(options.ring_drift_probes);
    if (!drift_probe.empty() && options.ring_drift_max > 0) {
      po.ring_shape_share = ro.ring_shape_share;
      po.search_drift = true;
      po.drift_search.max_mm_per_mm = options.ring_drift_max;
      // The drift each probe's sectors show; the log's is their median, used where the probes
      // agree on it and the rings, taken as drifting so, line up nearly as well as concentric
      // ones or better (a drift that loses much of the ring signal does not describe them).
      std::vector<double> dx, dy, gain;
      for (const PithResult& q :
           refine_pith_track(crops, z, track, g, options.pith, po, &outlines, &drift_probe))
        if (q.found)
          dx.push_back(q.ring_drift.x), dy.push_back(q.ring_drift.y), gain.push_back(q.drift_gain);
      if (!gain.empty()) {
        const Vec2 d{median(dx), median(dy)};
        std::vector<double> dev;
        for (size_t k = 0; k < dx.size(); ++k) dev.push_back((Vec2{dx[k], dy[k]} - d).norm());
        scan.ring_drift_measured = d;
        scan.ring_drift_spread = median(dev);
        scan.ring_drift_gain = median(gain);
        if (dx.size() >= 3 && d.norm() >= options.ring_drift_min &&
            d.norm() >= options.ring_drift_consistency * scan.ring_drift_spread &&
            scan.ring_drift_gain >= options.ring_drift_min_gain)
          ro.ring_drift = d;
      }
    }
  }
  scan.ring_drift = ro.ring_drift;
  scan.ring_shape_share = ro.ring_shape_share;
  for (int pass = 0; pass <= options.refine_iterations; ++pass) {
    // The first pass searches wide (the first track lags where the pith turns), the others
    // narrowly around the track they correct.
    ro.search_radius_mm = pass == 0 ? options.first_search_mm : options.refine.search_radius_mm;
    const std::vector<std::vector<double>> outlines = outlines_around(track);
    std::vector<PithResult> r = refine_pith_track(crops, z, track, g, options.pith, ro, &outlines,
                                                  pass > 0 ? &which : nullptr);
    for (const PithResult& q : r) scan.pith_refinements += q.found;
    if (pass > 0)  // slices not refined again keep their last answer
      for (int i = 0; i < n; ++i)
        if (!which[static_cast<size_t>(i)])
          r[static_cast<size_t>(i)] = refined[static_cast<size_t>(i)];
    // Refined piths farther than max_correction_mm from the first track are not believed (a
    // refinement that walked off along the alignments one ring off, pass after pass).
    for (int i = 0; i < n; ++i)
      if (r[static_cast<size_t>(i)].found &&
          (r[static_cast<size_t>(i)].pith_mm - first[static_cast<size_t>(i)]).norm() >
              options.max_correction_mm)
        r[static_cast<size_t>(i)].found = false;
    std::vector<bool> rejected;
    std::vector<Vec2> t2 = smooth_pith_track(z, r, options.track, &rejected);
    if (t2.empty()) break;  // nothing refined (no contour anywhere): keep the track so far
    // The next pass refines again where the track moved (and the slices averaged with those).
    std::fill(which.begin(), which.end(), false);
    bool again = false;
    for (int i = 0; i < n; ++i) {
      const bool moved = (t2[static_cast<size_t>(i)] - track[static_cast<size_t>(i)]).norm() >
                         options.converged_mm;
      if (moved)
        for (int j = std::max(0, i - half); j <= std::min(n - 1, i + half); ++j)
          which[static_cast<size_t>(j)] = true;
      again = again || moved;
    }
    refined = std::move(r);
    track = std::move(t2);
    outlier = std::move(rejected);
    ++scan.pith_refine_passes;
    if (!again) break;
  }
  fuse_pith_cues(
      scan, z, refined, track, crops, options, g,
      [&](const std::vector<Vec2>& centres, const std::vector<bool>& marked) {
        PithRefineOptions wide = ro;
        wide.search_radius_mm = options.first_search_mm;  // as the first pass: a fair comparison
        const std::vector<std::vector<double>> outlines = outlines_around(centres);
        std::vector<PithResult> r =
            refine_pith_track(crops, z, centres, g, options.pith, wide, &outlines, &marked);
        for (const PithResult& q : r) scan.pith_refinements += q.found;
        return r;
      },
      [&](const std::vector<PithResult>& ring_results, std::vector<Vec2>& ring_track) {
        inner_rings_pass(scan, z, crops, options, g, ro, first, outlines_around, ring_results,
                         ring_track);
      });
  scan.seconds_refining =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_tracked).count();
  for (int i = 0; i < n; ++i) {
    StemSliceRecord& rec = scan.slices[static_cast<size_t>(i)];
    rec.pith = track[static_cast<size_t>(i)];
    if (!refined.empty()) rec.pith_refined = refined[static_cast<size_t>(i)];
    rec.pith_outlier = outlier[static_cast<size_t>(i)];
    if (!rec.measured) continue;
    // The bark's outer surface around the pith, as the outline is recentred below: bark per
    // angle = that surface minus the outline (where the bark was not measured, the slice's
    // figure).
    if (rec.contour.bark_mm.size() == rec.contour.radius.size()) {
      std::vector<double> over = rec.contour.radius;
      std::vector<bool> over_ok = rec.contour.valid;
      for (size_t k = 0; k < over.size(); ++k)
        over[k] += rec.contour.bark_mm[k] > 0 ? rec.contour.bark_mm[k] : rec.bark_mm;
      recentre_contour(rec.centre, rec.pith, over, over_ok);
      for (size_t k = 0; k < over.size(); ++k)
        if (!over_ok[k]) over[k] = -1;
      rec.contour.bark_mm = std::move(over);  // now the bark surface's radius, -1: none
    }
    recentre_contour(rec.centre, rec.pith, rec.contour.radius, rec.contour.valid);
    if (rec.heartwood.present)
      recentre_contour(rec.centre, rec.pith, rec.heartwood.radius, rec.heartwood.valid);
  }

  // The stem covers the slices from the first to the last with a contour.
  int lo = -1, hi = -1;
  for (int i = 0; i < n; ++i) {
    const auto& v = scan.slices[i].contour.valid;
    if (std::count(v.begin(), v.end(), true) > static_cast<long>(v.size() / 2)) {
      if (lo < 0) lo = i;
      hi = i;
    }
  }
  if (lo < 0) return Error(source.description(), "no slice has a closed outer contour");
  Stem& st = scan.stem;
  st.z0_mm = g.z[lo];
  st.dz_mm = g.slice_spacing() > 0 ? g.slice_spacing() : 1.0;
  st.n_angles = options.contour.n_angles;
  int heartwood_slices = 0;
  for (int i = lo; i <= hi; ++i) heartwood_slices += scan.slices[i].heartwood.present;
  const bool with_heartwood = heartwood_slices * 2 > hi - lo + 1;
  std::vector<double> last_radius, last_heart;
  for (int i = lo; i <= hi; ++i) {
    StemSliceRecord& rec = scan.slices[i];
    std::vector<double> row = rec.contour.radius;
    if (row.size() != static_cast<size_t>(st.n_angles) || !fill_circular(row, rec.contour.valid))
      row = last_radius;  // a slice without a contour between two with one
    last_radius = row;
    st.pith.push_back(rec.pith);
    st.radius.push_back(row);
    if (with_heartwood) {
      std::vector<double> h = rec.heartwood.radius;
      if (!rec.heartwood.present || h.size() != static_cast<size_t>(st.n_angles) ||
          !fill_circular(h, rec.heartwood.valid))
        h = last_heart.empty() ? std::vector<double>(st.n_angles, 0.0) : last_heart;
      last_heart = h;
      st.heartwood.push_back(h);
    }
    st.bark_mm.push_back(rec.bark_mm);
  }
  if (std::all_of(st.bark_mm.begin(), st.bark_mm.end(), [](double b) { return b <= 0; }))
    st.bark_mm.clear();
  // The outline as measured, to tell which values the z filter replaces (only with bark).
  const std::vector<std::vector<double>> measured_radius =
      st.bark_mm.empty() ? std::vector<std::vector<double>>{} : st.radius;
  scan.outline_z_outliers = drop_z_outliers(st.radius, st.pith);
  // The bark at every angle: the bark surface minus the outline, where both were measured and
  // the outline kept (an outline value the z filter replaced took in something that was not
  // the log, and its bark surface with it: the slice's figure there).
  if (!st.bark_mm.empty()) {
    st.bark.assign(st.radius.size(), {});
    for (int i = lo; i <= hi; ++i) {
      StemSliceRecord& rec = scan.slices[i];
      const size_t row = static_cast<size_t>(i - lo);
      std::vector<double>& b = st.bark[row];
      b.assign(static_cast<size_t>(st.n_angles), st.bark_mm[row]);
      const std::vector<double>& surface = rec.contour.bark_mm;
      if (surface.size() == b.size() && rec.contour.valid.size() == b.size())
        for (size_t k = 0; k < b.size(); ++k)
          if (surface[k] > 0 && rec.contour.valid[k] &&
              st.radius[row][k] == measured_radius[row][k])
            b[k] = std::clamp(surface[k] - st.radius[row][k], 0.0, log_limits::kMaxBarkMm);
    }
  }
  for (int i = 0; i < n; ++i) std::vector<double>().swap(scan.slices[i].contour.bark_mm);
  if (!st.heartwood.empty()) {
    scan.heartwood_z_outliers = drop_z_outliers(st.heartwood, st.pith);
    for (size_t i = 0; i < st.heartwood.size(); ++i)  // the heartwood lies inside the log
      for (size_t k = 0; k < st.heartwood[i].size() && k < st.radius[i].size(); ++k)
        st.heartwood[i][k] = std::min(st.heartwood[i][k], st.radius[i][k]);
  }
  // The records say what the model says: a measured value the stem replaced is replaced in its
  // slice's record too (the QA images, the QA verdict's per-slice checks and the benches read
  // the records).
  const auto write_back = [](const std::vector<double>& row, std::vector<double>& radius,
                             const std::vector<bool>& valid) {
    if (row.size() != radius.size() || valid.size() != radius.size()) return;
    for (size_t k = 0; k < row.size(); ++k)
      if (valid[k]) radius[k] = row[k];
  };
  for (int i = lo; i <= hi; ++i) {
    StemSliceRecord& rec = scan.slices[i];
    const size_t row = static_cast<size_t>(i - lo);
    write_back(st.radius[row], rec.contour.radius, rec.contour.valid);
    if (!st.heartwood.empty() && rec.heartwood.present)
      write_back(st.heartwood[row], rec.heartwood.radius, rec.heartwood.valid);
  }
  // Finer slices than the outline needs: the stem averaged to fewer samples (issue 24: the
  // stem is held beside the records through the knot pass, and is the model's).
  if (options.stem_step_mm > 0) st = resample_stem(st, options.stem_step_mm);
  scan.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return scan;
}

}  // namespace sawyer::ct
