// Pith tracking along z and its robust smoothing (see pith_track.h).
#include "sawyer/ct/stem/pith_track.h"

#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <list>
#include <mutex>
#include <thread>
#include <unordered_map>

#include "sawyer/core/stats.h"

namespace sawyer::ct {

int slices_within(const VolumeGeometry& geometry, double half_window_mm, int max_slices) {
  if (!(half_window_mm > 0) || max_slices <= 0) return 0;
  const double dz = geometry.slice_spacing();
  const int k = dz > 0 ? static_cast<int>(half_window_mm / dz + 1e-9) : 1;
  return std::clamp(k, 1, max_slices);
}

int slice_step(const VolumeGeometry& geometry, double spacing_mm) {
  const double dz = geometry.slice_spacing();
  if (!(dz > 0) || !(spacing_mm > dz)) return 1;
  return std::max(1, static_cast<int>(spacing_mm / dz + 1e-9));
}

namespace {

// Half-width (mm) of the averaged box around a prior: the prior search radius, the voters 20 mm
// beyond it and the refinement disc (pith.cpp), with a margin.
constexpr double kBoxBeyondSearchMm = 40.0;
// The first pith of a scan: candidates followed through this many searched slices, each time
// within kAcquireFollowMm (mm) of where the last one put them.
constexpr int kAcquireSearches = 4;
constexpr double kAcquireFollowMm = 2.0;
constexpr int kMaxAcquisitions = 12;
// A neighbour whose wood area differs from the centre slice's by more than this fraction is past
// a log end (or a gap in the log) and is not averaged in.
constexpr double kMaxAreaChange = 0.25;

std::int64_t count_wood(const Slice& s, const WoodLevels& lv) {
  std::int64_t n = 0;
  if (!lv.found) return n;
  for (int y = 0; y < s.height; y += 4)
    for (int x = 0; x < s.width; x += 4) n += lv.contains(s.at(x, y));
  return n;
}

// Half-width (mm) of the crop kept for the refinement pass: the refinement's search radius, its
// voters 20 mm beyond and the tensor margins, plus room for the first track's error.
constexpr double kCropHalfMm = 45.0;

// The crop's half-width in pixels along x and y.
int crop_half_px(double spacing) { return static_cast<int>(kCropHalfMm / spacing); }

SliceCrop make_crop(const Slice& s, const VolumeGeometry& g, Vec2 c, std::int64_t wood,
                    const WoodLevels& lv) {
  SliceCrop k;
  k.wood_cells = wood;
  k.wood_min_hu = lv.min_hu, k.wood_max_hu = lv.max_hu;
  const int hx = crop_half_px(g.spacing_x), hy = crop_half_px(g.spacing_y);
  const int cx = static_cast<int>(std::lround(c.x / g.spacing_x));
  const int cy = static_cast<int>(std::lround(c.y / g.spacing_y));
  k.x0 = std::clamp(cx - hx, 0, s.width);
  k.y0 = std::clamp(cy - hy, 0, s.height);
  k.width = std::clamp(cx + hx + 1, 0, s.width) - k.x0;
  k.height = std::clamp(cy + hy + 1, 0, s.height) - k.y0;
  if (k.width <= 0 || k.height <= 0) return SliceCrop{};
  k.hu.resize(static_cast<size_t>(k.width) * k.height);
  for (int y = 0; y < k.height; ++y)
    std::copy_n(&s.hu[static_cast<size_t>(k.y0 + y) * s.width + k.x0], k.width,
                &k.hu[static_cast<size_t>(y) * k.width]);
  return k;
}

// Knots, cracks and the heartwood border are not annual rings: before averaging, a slice's pixels
// farther than kOutlierSigmas robust spreads (noise and ring signal) from its wood level near the
// pith are left out (knots in dry heartwood are 300-500 HU above it, cracks and the sapwood step
// as far), so a whorl blurred along z does not leak into the rings. Level and spread: median and
// MAD of the pixels within kLevelRadiusMm of the pith in the wood window (wood_min_hu,
// wood_max_hu). The first track's boxes (PithTracker) take the slice's window, whose top (the
// scan's dense threshold) keeps the bed and clutter out where a lost track's box reaches them.
// The refinement's, around the settled track by the pith where no bed lies, have no top: there a
// dense threshold cuts into the wood itself (dense juvenile or compression wood, a dried log's
// latewood on a calibration that reads it 400 HU higher: the real disc of bench/real_slices lost
// the wood beside its pith to the cut, and the ring profile took the hole's rim for rings), and
// the MAD, not a threshold, keeps the knots out.
constexpr float kOutlierSigmas = 4.f;
constexpr double kLevelRadiusMm = 15.0;
constexpr double kNoUpperBound = std::numeric_limits<double>::infinity();

struct Level {
  float level = NAN;
  float cut = 0;  // pixels farther than this from `level` are left out
};

Level wood_level(const float* img, int w, int h, double cx, double cy, double rx, double ry,
                 double wood_min_hu, double wood_max_hu) {
  std::vector<float> v;
  const int x0 = std::max(0, static_cast<int>(cx - rx)),
            x1 = std::min(w - 1, static_cast<int>(cx + rx) + 1);
  const int y0 = std::max(0, static_cast<int>(cy - ry)),
            y1 = std::min(h - 1, static_cast<int>(cy + ry) + 1);
  for (int y = y0; y <= y1; y += 2)
    for (int x = x0; x <= x1; x += 2) {
      const double dx = (x - cx) / rx, dy = (y - cy) / ry;
      if (dx * dx + dy * dy > 1) continue;
      const float q = img[static_cast<size_t>(y) * w + x];
      if (q > wood_min_hu && q < wood_max_hu) v.push_back(q);
    }
  if (v.size() < 8) return {};
  Level l;
  l.level = static_cast<float>(median_inplace(v));
  for (float& q : v) q = std::abs(q - l.level);
  l.cut = kOutlierSigmas * 1.4826f * static_cast<float>(median_inplace(v));
  return l;
}

// Adds the in-level pixels of src[xa, xb) to sum and count.
inline void add_row(const float* src, Level level, int xa, int xb, float* sum, float* cnt) {
  for (int x = xa; x < xb; ++x) {
    const bool in = std::abs(src[x] - level.level) <= level.cut;
    sum[x] += in ? src[x] : 0.f;
    cnt[x] += in ? 1.f : 0.f;
  }
}

bool better(const PithResult& a, const PithResult& b) {
  if (a.found != b.found) return a.found;
  return a.confidence > b.confidence;
}

}  // namespace

PithTracker::PithTracker(const VolumeGeometry& geometry, const PithOptions& options,
                         const PithTrackerOptions& tracker)
    : geometry_(geometry), options_(options), tracker_(tracker) {
  if (tracker.search_radius_mm > 0) options_.prior_radius_mm = tracker.search_radius_mm;
  half_ = slices_within(geometry, tracker.average_half_window_mm, tracker.max_half_slices);
  every_ = slice_step(geometry, tracker.detect_spacing_mm);
}

std::vector<TrackedSlice> PithTracker::push(Slice slice) {
  const WoodLevels lv = wood_levels(slice, options_);
  const std::int64_t wood = count_wood(slice, lv);
  Held h;
  h.levels = lv;
  h.index = pushed_++;
  h.slice = std::move(slice);
  h.wood_cells = wood;
  held_.push_back(std::move(h));
  std::vector<TrackedSlice> out;
  // Before the first pith is found, a slice waits until the windows of the next few searched
  // slices are in (acquire()).
  while (next_ + (last_ ? half_ : (kAcquireSearches - 1) * every_ + half_) < pushed_)
    decide(next_++);
  release(out, false);
  return out;
}

std::vector<TrackedSlice> PithTracker::finish() {
  std::vector<TrackedSlice> out;
  while (next_ < pushed_) decide(next_++);
  release(out, true);
  return out;
}

void PithTracker::release(std::vector<TrackedSlice>& out, bool all) {
  // Slice j is still needed by the centres up to j + half_.
  while (!held_.empty() && (all || held_.front().index < next_ - half_)) {
    Held& h = held_.front();
    out.push_back({h.index, std::move(h.slice), h.pith, std::move(h.crop), h.has_centre, h.centre});
    held_.pop_front();
  }
}

Slice PithTracker::averaged(int centre, const Vec2* box_centre, Vec2* origin) const {
  const int front = held_.front().index;
  const Held& c = held_[static_cast<size_t>(centre - front)];
  std::vector<const Slice*> members;
  for (const Held& h : held_) {
    if (std::abs(h.index - centre) > half_ || h.index == centre) continue;
    if (h.slice.width != c.slice.width || h.slice.height != c.slice.height) continue;
    const double change = std::abs(static_cast<double>(h.wood_cells - c.wood_cells));
    if (change > kMaxAreaChange * static_cast<double>(std::max<std::int64_t>(c.wood_cells, 1)))
      continue;
    members.push_back(&h.slice);
  }
  *origin = {0, 0};
  if (!box_centre) {
    // Whole slice (no prior): a plain mean.
    Slice out = c.slice;
    if (members.empty()) return out;
    const float inv = 1.f / static_cast<float>(members.size() + 1);
    for (int y = 0; y < out.height; ++y) {
      float* dst = &out.hu[static_cast<size_t>(y) * out.width];
      for (const Slice* m : members) {
        const float* src = &m->hu[static_cast<size_t>(y) * out.width];
        for (int x = 0; x < out.width; ++x) dst[x] += src[x];
      }
      for (int x = 0; x < out.width; ++x) dst[x] *= inv;
    }
    return out;
  }
  // A box around the prior, as its own image with pixel (x0, y0) of the slice at (0, 0).
  const double b = options_.prior_radius_mm + kBoxBeyondSearchMm;
  const int x0 = std::max(0, static_cast<int>((box_centre->x - b) / geometry_.spacing_x));
  const int y0 = std::max(0, static_cast<int>((box_centre->y - b) / geometry_.spacing_y));
  const int x1 =
      std::min(c.slice.width, static_cast<int>((box_centre->x + b) / geometry_.spacing_x) + 2);
  const int y1 =
      std::min(c.slice.height, static_cast<int>((box_centre->y + b) / geometry_.spacing_y) + 2);
  Slice out;
  out.index = c.slice.index;
  out.z = c.slice.z;
  out.width = std::max(0, x1 - x0);
  out.height = std::max(0, y1 - y0);
  out.hu.assign(static_cast<size_t>(out.width) * out.height, 0.f);
  *origin = {x0 * geometry_.spacing_x, y0 * geometry_.spacing_y};
  if (out.hu.empty()) return out;
  const int w = c.slice.width;
  const double pcx = box_centre->x / geometry_.spacing_x, pcy = box_centre->y / geometry_.spacing_y;
  const double lrx = kLevelRadiusMm / geometry_.spacing_x,
               lry = kLevelRadiusMm / geometry_.spacing_y;
  members.push_back(&c.slice);
  std::vector<Level> level;
  for (const Slice* m : members)
    level.push_back(wood_level(m->hu.data(), m->width, m->height, pcx, pcy, lrx, lry,
                               c.levels.min_hu, c.levels.max_hu));
  const float centre_level = level.back().level;
  if (std::isnan(centre_level) || !c.levels.found) {
    for (int y = 0; y < out.height; ++y)
      std::copy_n(&c.slice.hu[static_cast<size_t>(y0 + y) * w + x0], out.width,
                  &out.hu[static_cast<size_t>(y) * out.width]);
    return out;
  }
  std::vector<float> cnt(static_cast<size_t>(out.width));
  for (int y = 0; y < out.height; ++y) {
    float* dst = &out.hu[static_cast<size_t>(y) * out.width];
    std::fill(cnt.begin(), cnt.end(), 0.f);
    for (size_t k = 0; k < members.size(); ++k) {
      if (std::isnan(level[k].level)) continue;
      add_row(&members[k]->hu[static_cast<size_t>(y0 + y) * w + x0], level[k], 0, out.width, dst,
              cnt.data());
    }
    for (int x = 0; x < out.width; ++x) dst[x] = cnt[x] > 0 ? dst[x] / cnt[x] : centre_level;
  }
  return out;
}

PithOptions PithTracker::with_levels(int centre) const {
  // The box around a prior holds little or no air: its window comes from the whole slice.
  const Held& c = held_[static_cast<size_t>(centre - held_.front().index)];
  PithOptions o = options_;
  if (c.levels.found) o.wood_min_hu = c.levels.min_hu, o.wood_max_hu = c.levels.max_hu;
  return o;
}

PithResult PithTracker::acquire(int centre) {
  // The candidates of the first searched slice, each followed through the next few searched
  // slices (the rings lined up within kAcquireFollowMm of where it was), scored on each by how
  // well the rings line up out to half the radius: a pith persists along z where a knot's rings,
  // the pull of the section's shape or a noise pattern do not line up slice after slice.
  Vec2 origin;
  const std::vector<PithCandidate> cands =
      pith_candidates(averaged(centre, nullptr, &origin), geometry_, with_levels(centre));
  PithResult r;
  if (cands.empty()) return r;
  std::vector<Vec2> at;
  std::vector<double> total;
  for (const PithCandidate& c : cands) at.push_back(c.rings), total.push_back(c.score);
  int used = 1;
  for (int k = 1; k < kAcquireSearches; ++k) {
    const int d = centre + k * every_;
    if (d >= pushed_ || cands.size() == 1) break;
    const Slice whole = averaged(d, nullptr, &origin);
    for (size_t c = 0; c < cands.size(); ++c) {
      const PithResult q =
          refine_pith_concentric(whole, geometry_, at[c], kAcquireFollowMm, nullptr);
      if (q.found) at[c] = q.pith_mm;
      total[c] += wide_ring_score(whole, geometry_, at[c]);
    }
    ++used;
  }
  size_t best = 0;
  for (size_t c = 1; c < cands.size(); ++c)
    if (total[c] > total[best]) best = c;
  r.found = true;
  r.pith_mm = cands[best].rings;
  r.confidence = total[best] / used;
  return r;
}

void PithTracker::decide(int centre) {
  const int front = held_.front().index;
  Held& h = held_[static_cast<size_t>(centre - front)];
  const Vec2* prior = last_ ? &*last_ : nullptr;
  if (prior && centre % every_ != 0) {
    // Not searched: the track's last confident pith stands in.
    h.pith = PithResult{};
    h.pith.pith_mm = *prior;
    h.has_centre = true;
    h.centre = *prior;
    h.crop = make_crop(h.slice, geometry_, *prior, h.wood_cells, h.levels);
    return;
  }
  PithResult r;
  Vec2 origin;
  if (prior) {
    const Slice box = averaged(centre, prior, &origin);
    const Vec2 local = *prior - origin;
    PithOptions near = with_levels(centre);
    near.fall_back_to_whole_slice = false;  // the box is not the whole slice
    r = detect_pith(box, geometry_, near, &local);
    if (r.found && tracker_.ring_search_mm > 0) {
      // The vote is coarse at this noise: line the rings up around it (circles; the contour
      // is not known yet). Where it strays from the prior (knots, blurred inner rings where the
      // pith leans), the rings also get a chance around the prior; the better alignment wins.
      PithResult q =
          refine_pith_concentric(box, geometry_, r.pith_mm, tracker_.ring_search_mm, nullptr);
      if ((r.pith_mm - local).norm() > tracker_.ring_search_mm) {
        const PithResult p =
            refine_pith_concentric(box, geometry_, local, tracker_.ring_search_mm, nullptr);
        if (p.found && (!q.found || p.confidence > q.confidence)) q = p;
      }
      if (q.found) r.pith_mm = q.pith_mm;
    }
    if (r.found) r.pith_mm = r.pith_mm + origin;
  }
  if (!prior && acquisitions_ < kMaxAcquisitions) {
    // The first pith; tried again on the next slices while its rings are too faint to trust,
    // a bounded number of times (four slices' search each), then the plain way.
    ++full_searches_;
    r = acquire(centre);
    if (r.found) ++acquisitions_;
  } else if (!prior || !r.found || r.confidence < tracker_.min_confidence) {
    // No prior, or lost near it: search the whole (averaged) slice and keep the better answer.
    ++full_searches_;
    const PithResult q =
        detect_pith(averaged(centre, nullptr, &origin), geometry_, with_levels(centre), nullptr);
    if (better(q, r)) r = q;
  }
  {
    Vec2 c;
    double R = 0;
    if (log_section(h.slice, geometry_, with_levels(centre), &c, &R) && r.found &&
        (r.pith_mm - c).norm() > tracker_.max_centre_offset * R) {
      r.pith_mm = c;
      r.confidence = tracker_.min_confidence;
      last_ = c;  // the old prior led here: start again from the centre
      pending_.reset();
    }
  }
  // A pith moves little between detections: a jump is not trusted as the next prior, unless the
  // next detection lands by it too (the pith turned, or the prior was the one astray).
  const bool confident = r.found && r.confidence >= tracker_.min_confidence;
  const bool jump = last_ && r.found && (r.pith_mm - *last_).norm() > tracker_.max_step_mm;
  if (confident && jump && pending_ && (r.pith_mm - *pending_).norm() <= tracker_.max_step_mm) {
    last_ = r.pith_mm;
    pending_.reset();
  } else if (confident && jump) {
    pending_ = r.pith_mm;
  } else if (confident) {
    last_ = r.pith_mm;
    pending_.reset();
  }
  h.pith = r;
  h.has_centre = r.found || last_.has_value();
  h.centre = r.found ? r.pith_mm : (last_ ? *last_ : Vec2{});
  if (last_ || r.found)
    h.crop = make_crop(h.slice, geometry_, last_ ? *last_ : r.pith_mm, h.wood_cells, h.levels);
}

namespace {

PithResult refine_one(const CropStore& crops, const std::vector<double>& z,
                      const std::vector<Vec2>& track, const VolumeGeometry& g,
                      const PithOptions& options, const PithRefineOptions& refine, int half, int i,
                      const std::vector<std::vector<double>>* outlines, Vec2 start,
                      const std::vector<Level>& levels) {
  const std::shared_ptr<const SliceCrop> held = crops.get(i);
  const SliceCrop& c = *held;
  if (c.hu.empty()) return {};
  const int n = crops.size();
  // Only the rows and columns the refinement reads are averaged (the rest stay unused).
  const Vec2 origin{c.x0 * g.spacing_x, c.y0 * g.spacing_y};
  const Vec2 prior = start - origin;
  const double reach = ring_profile_reach_mm(refine.search_radius_mm, refine.ring_max_mm);
  const int ux0 = std::max(0, static_cast<int>((prior.x - reach) / g.spacing_x) - 1);
  const int uy0 = std::max(0, static_cast<int>((prior.y - reach) / g.spacing_y) - 1);
  const int ux1 = std::min(c.width, static_cast<int>((prior.x + reach) / g.spacing_x) + 3);
  const int uy1 = std::min(c.height, static_cast<int>((prior.y + reach) / g.spacing_y) + 3);
  Slice avg;
  avg.width = c.width;
  avg.height = c.height;
  avg.hu.assign(c.hu.size(), 0.f);
  std::vector<float> count(avg.hu.size(), 0.f);
  const float centre_level = levels[static_cast<size_t>(i)].level;
  if (std::isnan(centre_level)) return {};
  for (int j = std::max(0, i - half); j <= std::min(n - 1, i + half); ++j) {
    if (std::abs(z[j] - z[i]) > refine.average_half_window_mm + 1e-9) continue;
    const std::shared_ptr<const SliceCrop> mj = crops.get(j);
    const SliceCrop& m = *mj;
    if (m.hu.empty()) continue;
    const double change = std::abs(static_cast<double>(m.wood_cells - c.wood_cells));
    if (change > kMaxAreaChange * static_cast<double>(std::max<std::int64_t>(c.wood_cells, 1)))
      continue;
    const Level level = levels[static_cast<size_t>(j)];
    if (std::isnan(level.level)) continue;
    // Pixel (x, y) of slice i sees the rings of slice j at (x, y) + drift.
    const Vec2 d = track[j] - track[i];
    const int dx = static_cast<int>(std::lround(d.x / g.spacing_x));
    const int dy = static_cast<int>(std::lround(d.y / g.spacing_y));
    // Crop-i pixel (x, y) -> crop-j pixel (x + ox, y + oy).
    const int ox = c.x0 + dx - m.x0, oy = c.y0 + dy - m.y0;
    const int xa = std::max(ux0, -ox), xb = std::min(ux1, m.width - ox);
    const int ya = std::max(uy0, -oy), yb = std::min(uy1, m.height - oy);
    for (int y = ya; y < yb; ++y)
      add_row(&m.hu[static_cast<size_t>(y + oy) * m.width + ox], level, xa, xb,
              &avg.hu[static_cast<size_t>(y) * c.width], &count[static_cast<size_t>(y) * c.width]);
  }
  for (size_t k = 0; k < avg.hu.size(); ++k)
    avg.hu[k] = count[k] > 0 ? avg.hu[k] / count[k] : centre_level;
  const std::vector<double>* outline = outlines && !(*outlines)[static_cast<size_t>(i)].empty()
                                           ? &(*outlines)[static_cast<size_t>(i)]
                                           : nullptr;
  PithResult r =
      refine_pith_concentric(avg, g, prior, refine.search_radius_mm, outline, refine.ring_max_mm,
                             0.0, refine.ring_shape_share, refine.ring_drift,
                             refine.search_drift ? &refine.drift_search : nullptr);
  if (r.found) r.pith_mm = r.pith_mm + origin;
  return r;
}

}  // namespace

std::vector<PithResult> refine_pith_track(
    const CropStore& crops, const std::vector<double>& z, const std::vector<Vec2>& track,
    const VolumeGeometry& geometry, const PithOptions& options, const PithRefineOptions& refine,
    const std::vector<std::vector<double>>* outlines, const std::vector<bool>* which) {
  assert(static_cast<size_t>(crops.size()) == z.size() && z.size() == track.size());
  const int n = crops.size();
  std::vector<PithResult> out(static_cast<size_t>(n));
  const int half = slices_within(geometry, refine.average_half_window_mm, refine.max_half_slices);
  const int every = slice_step(geometry, refine.refine_spacing_mm);
  const int threads = std::clamp(refine.threads, 1, 64);
  auto refined = [&](int i) {
    return refined_slice(i, n, every) && (!which || (*which)[static_cast<size_t>(i)]);
  };
  // The wood level of every crop an average takes in, around the track, once (each crop is in
  // the averages of several refined slices).
  std::vector<char> needed(static_cast<size_t>(n), 0);
  for (int i = 0; i < n; ++i)
    if (refined(i))
      for (int j = std::max(0, i - half); j <= std::min(n - 1, i + half); ++j) needed[j] = 1;
  std::vector<Level> levels(static_cast<size_t>(n));
  const double lrx = kLevelRadiusMm / geometry.spacing_x, lry = kLevelRadiusMm / geometry.spacing_y;
  std::atomic<int> next{0};
  auto level_work = [&] {
    for (int j = next++; j < n; j = next++) {
      if (!needed[j]) continue;
      const std::shared_ptr<const SliceCrop> mj = crops.get(j);
      const SliceCrop& m = *mj;
      if (m.hu.empty()) continue;
      levels[static_cast<size_t>(j)] = wood_level(
          m.hu.data(), m.width, m.height, track[j].x / geometry.spacing_x - m.x0,
          track[j].y / geometry.spacing_y - m.y0, lrx, lry, m.wood_min_hu, kNoUpperBound);
    }
  };
  auto work = [&] {
    for (int i = next++; i < n; i = next++)
      if (refined(i))
        out[static_cast<size_t>(i)] =
            refine_one(crops, z, track, geometry, options, refine, half, i, outlines,
                       track[static_cast<size_t>(i)], levels);
  };
  auto run = [&](auto& fn) {
    next = 0;
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(fn);
    fn();
    for (auto& t : pool) t.join();
  };
  run(level_work);
  run(work);
  return out;
}

bool contour_centre(const Vec2& around, const std::vector<double>& radius,
                    const std::vector<bool>& valid, Vec2* centre) {
  const size_t n = radius.size();
  std::vector<Vec2> p;
  for (size_t k = 0; k < n; ++k)
    if (valid[k] && radius[k] > 0) {
      const double w = kTwoPi * static_cast<double>(k) / static_cast<double>(n);
      p.push_back({around.x + radius[k] * std::cos(w), around.y + radius[k] * std::sin(w)});
    }
  if (n == 0 || p.size() * 2 < n) return false;
  double a = 0, cx = 0, cy = 0;
  for (size_t k = 0; k < p.size(); ++k) {
    const Vec2 u = p[k] - around, v = p[(k + 1) % p.size()] - around;
    const double c = u.x * v.y - v.x * u.y;
    a += c, cx += (u.x + v.x) * c, cy += (u.y + v.y) * c;
  }
  if (!(std::abs(a) > 1e-9)) return false;
  *centre = around + Vec2{cx / (3 * a), cy / (3 * a)};
  return true;
}

namespace {

// Weighted local linear fit of (z, x), (z, y) at z0; false if the weights are degenerate. `z`
// is increasing, so only the slices within h of z0 are visited.
bool local_linear(const std::vector<double>& z, const std::vector<Vec2>& p,
                  const std::vector<double>& w, double z0, double h, Vec2* out) {
  double s0 = 0, s1 = 0, s2 = 0, tx = 0, ty = 0, ux = 0, uy = 0;
  const size_t lo = static_cast<size_t>(std::lower_bound(z.begin(), z.end(), z0 - h) - z.begin());
  for (size_t i = lo; i < z.size() && z[i] < z0 + h; ++i) {
    if (w[i] <= 0) continue;
    const double d = std::abs(z[i] - z0) / h;
    if (d >= 1) continue;
    const double c = 1 - d * d * d;
    const double k = c * c * c * w[i];  // tricube
    const double dz = z[i] - z0;
    s0 += k, s1 += k * dz, s2 += k * dz * dz;
    tx += k * p[i].x, ty += k * p[i].y;
    ux += k * dz * p[i].x, uy += k * dz * p[i].y;
  }
  if (s0 <= 0) return false;
  const double det = s0 * s2 - s1 * s1;
  if (det <= 1e-9 * s0 * s2 || s2 <= 0) {
    *out = {tx / s0, ty / s0};  // one point or all at one z: local mean
    return true;
  }
  *out = {(s2 * tx - s1 * ux) / det, (s2 * ty - s1 * uy) / det};
  return true;
}

}  // namespace

std::vector<Vec2> smooth_pith_track(const std::vector<double>& z,
                                    const std::vector<PithResult>& raw,
                                    const PithTrackOptions& options, std::vector<bool>* outlier) {
  assert(z.size() == raw.size());
  const size_t n = z.size();
  std::vector<Vec2> p(n);
  std::vector<double> prior_w(n, 0.0);
  std::vector<double> conf;
  for (size_t i = 0; i < n; ++i)
    if (raw[i].found) conf.push_back(raw[i].confidence);
  if (conf.empty()) return {};
  // Detections far less confident than the track's typical one are not trusted at all (a slice
  // whose rings did not line up anywhere near the search start), unless too few remain.
  const double floor = options.min_relative_confidence * median(conf);
  size_t trusted = 0;
  for (double c : conf) trusted += c >= floor;
  const bool gate = trusted >= std::max<size_t>(3, conf.size() / 2);
  for (size_t i = 0; i < n; ++i) {
    p[i] = raw[i].pith_mm;
    if (raw[i].found && (!gate || raw[i].confidence >= floor))
      prior_w[i] = std::max(0.05, raw[i].confidence);
  }
  std::vector<double> robust(n, 1.0), w(n);
  std::vector<Vec2> fit(n);
  auto do_fit = [&](double h) {
    for (size_t i = 0; i < n; ++i) w[i] = prior_w[i] * robust[i];
    for (size_t i = 0; i < n; ++i) {
      // Widen the window until enough support (gaps, dropped or failed slices).
      double hh = h;
      Vec2 f;
      const double span = z.back() - z.front() + h;
      bool ok = false;
      while (!(ok = local_linear(z, p, w, z[i], hh, &f)) && hh < 4 * span) hh *= 2;
      // Every neighbour rejected: fall back to the raw detections' weights.
      if (!ok) local_linear(z, p, prior_w, z[i], 4 * span + h, &f);
      fit[i] = f;
    }
  };
  // Start from a running median so the first fit is already robust to isolated outliers.
  {
    std::vector<double> xs, ys;
    for (size_t i = 0; i < n; ++i) {
      xs.clear(), ys.clear();
      const size_t lo = static_cast<size_t>(
          std::lower_bound(z.begin(), z.end(), z[i] - options.window_mm) - z.begin());
      for (size_t j = lo; j < n && z[j] <= z[i] + options.window_mm; ++j)
        if (prior_w[j] > 0) xs.push_back(p[j].x), ys.push_back(p[j].y);
      if (xs.size() >= 3) {
        const Vec2 m{median(xs), median(ys)};
        const double d = (p[i] - m).norm();
        robust[i] = d > 3.0 ? 0.0 : 1.0;  // grossly off its neighbours' median
      }
    }
  }
  const double h = std::max(options.window_mm, 1e-6);
  do_fit(h);
  for (int it = 0; it < options.robust_iterations; ++it) {
    std::vector<double> res;
    for (size_t i = 0; i < n; ++i)
      if (prior_w[i] > 0) res.push_back((p[i] - fit[i]).norm());
    const double scale = std::max(options.min_scale_mm, 1.4826 * median(res));
    const double c = options.tukey_k * scale;
    for (size_t i = 0; i < n; ++i) {
      const double u = (p[i] - fit[i]).norm() / c;
      robust[i] = u < 1 ? (1 - u * u) * (1 - u * u) : 0.0;
    }
    do_fit(h);
  }
  if (outlier) {
    outlier->assign(n, false);
    for (size_t i = 0; i < n; ++i)
      (*outlier)[i] = raw[i].found && (prior_w[i] <= 0 || robust[i] <= 0);
  }
  return fit;
}

std::size_t pith_crop_bytes(const VolumeGeometry& g) {
  return static_cast<std::size_t>(2 * crop_half_px(g.spacing_x) + 1) *
         static_cast<std::size_t>(2 * crop_half_px(g.spacing_y) + 1) * sizeof(float);
}

// A few dozen crops read back, most recently used first.
struct CropStore::Cache {
  std::mutex mutex;
  std::list<std::pair<int, std::shared_ptr<const SliceCrop>>> order;
  std::unordered_map<int, decltype(order)::iterator> where;
  static constexpr size_t kHeld = 48;
};

CropStore::CropStore(int slices, std::size_t memory_bytes)
    : entries_(static_cast<size_t>(std::max(0, slices))),
      budget_(memory_bytes),
      cache_(std::make_unique<Cache>()) {}

CropStore::~CropStore() {
  if (file_) std::fclose(file_);
}

void CropStore::put(int i, SliceCrop crop) {
  Entry& e = entries_[static_cast<size_t>(i)];
  const std::size_t bytes = crop.hu.size() * sizeof(float);
  if (bytes > 0 && in_memory_ + bytes > budget_) {
    if (!file_) file_ = std::tmpfile();  // removed when closed, or when the process ends
    if (file_) {
      const std::int64_t at = static_cast<std::int64_t>(spilled_);
      if (::pwrite(fileno(file_), crop.hu.data(), bytes, static_cast<off_t>(at)) ==
          static_cast<ssize_t>(bytes)) {
        e.offset = at;
        spilled_ += bytes;
        crop.hu.clear();
        crop.hu.shrink_to_fit();
        e.meta = std::move(crop);
        return;
      }
    }
  }
  in_memory_ += bytes;
  e.held = std::make_shared<const SliceCrop>(std::move(crop));
}

std::shared_ptr<const SliceCrop> CropStore::get(int i) const {
  const Entry& e = entries_[static_cast<size_t>(i)];
  if (e.offset < 0) {
    if (e.held) return e.held;
    static const std::shared_ptr<const SliceCrop> kNone = std::make_shared<const SliceCrop>();
    return kNone;
  }
  Cache& c = *cache_;
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    auto it = c.where.find(i);
    if (it != c.where.end()) {
      c.order.splice(c.order.begin(), c.order, it->second);
      return it->second->second;
    }
  }
  auto crop = std::make_shared<SliceCrop>(e.meta);
  crop->hu.resize(static_cast<size_t>(crop->width) * crop->height);
  const std::size_t bytes = crop->hu.size() * sizeof(float);
  if (::pread(fileno(file_), crop->hu.data(), bytes, static_cast<off_t>(e.offset)) !=
      static_cast<ssize_t>(bytes))
    crop->hu.clear();  // unreadable: as if the slice had no crop
  std::shared_ptr<const SliceCrop> out = std::move(crop);
  std::lock_guard<std::mutex> lock(c.mutex);
  if (c.where.find(i) == c.where.end()) {
    c.order.emplace_front(i, out);
    c.where[i] = c.order.begin();
    while (c.order.size() > Cache::kHeld) {
      c.where.erase(c.order.back().first);
      c.order.pop_back();
    }
  }
  return out;
}

}  // namespace sawyer::ct
