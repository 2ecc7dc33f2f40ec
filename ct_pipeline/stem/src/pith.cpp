// Pith of one CT slice (issue 4): gradient-orientation voting, refined at full resolution.
//
// 1. Extent (no prior): 4 x 4 block means, wood = wood_hu < HU < kMaxWoodHu (the bed's belt and
//    rails, clutter steel are denser than any wood), eroded once, largest 4-connected component.
//    No component of a plausible size: found = false.
// 2. Vote: the local ring orientation comes from the smoothed structure tensor of the
//    full-resolution image (sign-free, so both edges of a ring agree; coarser images alias the
//    3-4 pixel rings into moire). Every pixel casts a line along its ring normal into an
//    accumulator (4-pixel cells over +- 0.6 R of the section's centroid; 2-pixel cells over
//    +- prior_radius_mm near a prior), weighted by its anisotropy; pixels above a few times the
//    median anisotropy (knots, cracks, the heartwood border, the outline) do not vote at all:
//    annual rings are faint. The smoothed accumulator's peak is the coarse pith. Without a
//    prior, the five strongest peaks and the section's centroid are candidates, each voted on
//    again nearby; the one around which the rings line up best out to half the radius
//    (refine_pith_concentric, homothetic to the outline measured around it) wins, the
//    strongest peak unless clearly beaten.
// 3. Refine (full resolution, a 12 mm disc): least-squares intersection of the ring-normal lines
//    (I - n n^T)(c - p) = 0, weights 1/r, Tukey weights on the angle between each normal and
//    the direction to c (knot flanks, whose normals are tangential, drop out), iterated until it
//    stops moving. Confidence mixes the weighted fraction of inlier normals and the vote's
//    peak sharpness.
//
// At 20 HU noise the ring orientation of one slice is weak (about 17 HU peak to peak after the
// PSF) and single-slice errors of several mm remain (tests/pith_test.cpp prints them): the stem
// pass runs this detector on slices averaged along z for a first track only, and takes the pith
// from refine_pith_concentric (4., below) on drift-compensated averages.
//
// 4. Ring-profile refinement (refine_pith_concentric): see stem_detect.h.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "sawyer/core/stats.h"
#include "sawyer/ct/stem/stem_detect.h"

namespace sawyer::ct {
namespace {

constexpr int kCoarse = 4;  // block size of the extent mask
constexpr double kRefineRadiusMm = 12.0;
// Ring-profile refinement (refine_pith_concentric): rings between kRingMinMm and kRingMaxMm from
// the centre, binned every kRingBinMm (well under a ring width), the profile's running mean over
// +- kRingSmoothMm removed; pixels farther than kRingOutlierHu from the wood level ignored; a
// first grid of kRingGridMm (under a quarter ring width, so the main peak is not stepped over).
constexpr double kRingMinMm = 1.5;
constexpr double kRingMaxMm = kRingProfileMaxMm;
constexpr double kRingBinMm = 0.4;
constexpr double kRingSmoothMm = 1.6;
// Pixels farther than kRingOutlierSigmas robust spreads (noise and ring signal of the disc
// together) from the wood level are left out: knots, cracks, the heartwood step.
constexpr double kRingOutlierSigmas = 3.5;
constexpr double kRingGridMm = 0.5;
// Searches at least kScreenMinSearchMm wide screen their grid on the rings within
// kScreenRingMm of each grid point and score the kScreenKeep best points on all rings.
constexpr double kScreenMinSearchMm = 2.5;
constexpr double kScreenRingMm = 16.0;
constexpr size_t kScreenKeep = 30;
// Whole-slice search: vote peaks tried (the strongest included), at least this far apart (mm),
// each lined up with the rings within kAcquireRingSearchMm.
constexpr int kAcquireCandidates = 5;
constexpr double kAcquireApartMm = 8.0;
constexpr double kAcquireRingSearchMm = 6.0;
constexpr double kAcquireRingMaxMm = 60.0;
constexpr double kWideBandMm = 12.0;  // wide_ring_score's bands of radius
// Ring-profile signal share (0..1) by which another candidate must beat the strongest peak.
constexpr double kAcquireMargin = 0.1;
constexpr double kTukeyAngle = 0.9;    // rad (about 52 degrees)
constexpr double kMinRadiusMm = 15.0;  // smaller wood blobs are not a log
// Structure-tensor anisotropy above this many medians is an edge, not an annual ring.
constexpr double kEdgeFactor = 4.0;
constexpr double kUncappedEdgeFactor = 1e30;  // every edge votes (candidates_without_prior)
// Box radius (pixels) of the structure tensor: wide where the rings are nearly straight (the
// whole-slice vote and the vote near a prior), narrow for the refinement near the pith.
constexpr int kCoarseTensorRadius = 5;
constexpr int kPriorTensorRadius = 4;
constexpr int kRefineTensorRadius = 2;
// Binomial pre-smoothing passes before the gradient (one pass: sigma 0.71 px, about the
// scanner's PSF, i.e. the matched filter for the ring borders) while a pass's sigma stays
// under kMaxPreSigmaMm: with coarser pixels the scanner's own blur already spans as much of a
// ring (3 mm rings at 1 mm pixels are 3 pixels wide; the pass would take half of what contrast
// the PSF left them, and the vote drifts onto the knots: gran1 at 1 mm pixels, pith median 4.6
// mm with the pass, 0.9 mm without).
constexpr int kPrePasses = 1;
constexpr double kMaxPreSigmaMm = 0.6;
// Knots are bright radial tubes far above the local wood level (cracks and rot far below): their
// flanks are the strongest oriented structure near the pith and would capture the vote. Pixels
// farther than kVoteOutlierSigmas robust spreads from the box's wood level, the mask grown by the
// structure tensor's reach, do not vote as rings.
constexpr double kVoteOutlierSigmas = 3.0;
// Wood window (wood_levels): the share of the air-wood step below the wood level that still
// counts as wood (bark, dry wood), and above it (knots, latewood), or this many spreads.
constexpr double kWindowBelow = 0.7;
constexpr double kWindowAbove = 0.2;
constexpr double kWindowAboveSigmas = 4.0;
// Nothing is less dense than air on any HU calibration: lower values are padding outside the
// reconstruction circle.
constexpr float kPaddingHu = -1500.f;
// Least air-to-wood step, in robust spreads of the air class.
constexpr double kMinStepSpreads = 5.0;

// The ring-profile refinement's pixels, structure of arrays (see refine_pith_concentric).
struct RingPixels {
  const float *x, *y, *ux, *uy, *k, *inv_r;
};

// Each pixel's ring-profile bin around (ddx, ddy): the refinement's inner loop. Compiled twice,
// for AVX2 and for any x86-64, the choice made once at load time; without FMA contraction, so
// both give the same bins to the bit.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
void ring_bins(const RingPixels& p, size_t n, float ddx, float ddy, float lo, float inv_bin,
               float top, std::int32_t* __restrict bins) {
  const float* __restrict x = p.x;
  const float* __restrict y = p.y;
  const float* __restrict ux = p.ux;
  const float* __restrict uy = p.uy;
  const float* __restrict k = p.k;
  const float* __restrict inv_r = p.inv_r;
  for (size_t i = 0; i < n; ++i) {
    const float ex = x[i] - ddx, ey = y[i] - ddy;
    // d * Rm / (R - delta . u) ~ d * k * (1 + delta . u / R)
    const float r =
        std::sqrt(ex * ex + ey * ey) * k[i] * (1.f + (ddx * ux[i] + ddy * uy[i]) * inv_r[i]);
    bins[i] = static_cast<std::int32_t>(std::min(std::max((r - lo) * inv_bin, 0.f), top));
  }
}

// Azimuth of (dx, dy) in [0, 2 pi) within about 1e-5 rad (an odd polynomial for atan on
// [0, 1] and the octant symmetries); used where a full atan2 per pixel would dominate.
double azimuth_fast(double dx, double dy) {
  const double ax = std::abs(dx), ay = std::abs(dy);
  const double mx = std::max(ax, ay);
  if (mx == 0) return 0;
  const double t = std::min(ax, ay) / mx, t2 = t * t;
  double a =
      t * (0.99997726 +
           t2 * (-0.33262347 +
                 t2 * (0.19354346 + t2 * (-0.11643287 + t2 * (0.05265332 + t2 * -0.01172120)))));
  if (ay > ax) a = 0.5 * kPi - a;
  if (dx < 0) a = kPi - a;
  if (dy < 0) a = kTwoPi - a;
  return a >= kTwoPi ? a - kTwoPi : a;
}

bool slice_holds_pixels(const Slice& s) {
  return s.width > 0 && s.height > 0 && s.hu.size() == static_cast<size_t>(s.width) * s.height;
}

struct Grid {
  int w = 0, h = 0;
  std::vector<float> v;
  Grid() = default;
  Grid(int w_, int h_, float fill = 0.f) : w(w_), h(h_), v(static_cast<size_t>(w_) * h_, fill) {}
  float& at(int x, int y) { return v[static_cast<size_t>(y) * w + x]; }
  float at(int x, int y) const { return v[static_cast<size_t>(y) * w + x]; }
};

// Block means of factor f over full-resolution box [x0, x0 + f*w) x [y0, y0 + f*h).
Grid block_mean(const Slice& s, int f, int x0, int y0, int w, int h) {
  Grid g(w, h);
  const float inv = 1.f / static_cast<float>(f * f);
  std::vector<float> row(static_cast<size_t>(w));
  for (int j = 0; j < h; ++j) {
    std::fill(row.begin(), row.end(), 0.f);
    for (int dy = 0; dy < f; ++dy) {
      const float* src = &s.hu[static_cast<size_t>(y0 + j * f + dy) * s.width + x0];
      for (int i = 0; i < w; ++i) {
        float acc = 0.f;
        for (int dx = 0; dx < f; ++dx) acc += src[i * f + dx];
        row[i] += acc;
      }
    }
    for (int i = 0; i < w; ++i) g.at(i, j) = row[i] * inv;
  }
  return g;
}

// Box filter of radius r (clamped at the borders), separable.
void box_filter(Grid& g, int r) {
  Grid tmp(g.w, g.h);
  for (int y = 0; y < g.h; ++y)
    for (int x = 0; x < g.w; ++x) {
      float acc = 0.f;
      int n = 0;
      for (int k = std::max(0, x - r); k <= std::min(g.w - 1, x + r); ++k, ++n) acc += g.at(k, y);
      tmp.at(x, y) = acc / static_cast<float>(n);
    }
  for (int y = 0; y < g.h; ++y)
    for (int x = 0; x < g.w; ++x) {
      float acc = 0.f;
      int n = 0;
      for (int k = std::max(0, y - r); k <= std::min(g.h - 1, y + r); ++k, ++n) acc += tmp.at(x, k);
      g.at(x, y) = acc / static_cast<float>(n);
    }
}

// Ring orientation field of an image: unit normal (nx, ny) in pixel axes and anisotropy
// lambda1 - lambda2 of the structure tensor smoothed with a box of radius `r`.
struct Orientation {
  Grid nx, ny, aniso, coh;  // coh: (lambda1 - lambda2) / (lambda1 + lambda2), 0..1
};

// [1 2 1] / 4 in x and y, `passes` times (sigma 0.71 px per pass).
Grid binomial(const Grid& in, int passes) {
  Grid a = in, t(in.w, in.h);
  for (int p = 0; p < passes; ++p) {
    for (int y = 0; y < a.h; ++y)
      for (int x = 0; x < a.w; ++x) {
        const int l = std::max(0, x - 1), r = std::min(a.w - 1, x + 1);
        t.at(x, y) = 0.25f * (a.at(l, y) + 2.f * a.at(x, y) + a.at(r, y));
      }
    for (int y = 0; y < a.h; ++y)
      for (int x = 0; x < a.w; ++x) {
        const int u = std::max(0, y - 1), d = std::min(a.h - 1, y + 1);
        a.at(x, y) = 0.25f * (t.at(x, u) + 2.f * t.at(x, y) + t.at(x, d));
      }
  }
  return a;
}

Orientation orientation_field(const Grid& raw, int r, double sx, double sy) {
  const Grid img = binomial(raw, 0.71 * std::max(sx, sy) <= kMaxPreSigmaMm ? kPrePasses : 0);
  const int w = img.w, h = img.h;
  Grid jxx(w, h), jxy(w, h), jyy(w, h);
  for (int y = 1; y + 1 < h; ++y)
    for (int x = 1; x + 1 < w; ++x) {
      const double gx = (img.at(x + 1, y) - img.at(x - 1, y)) / (2.0 * sx);
      const double gy = (img.at(x, y + 1) - img.at(x, y - 1)) / (2.0 * sy);
      jxx.at(x, y) = static_cast<float>(gx * gx);
      jxy.at(x, y) = static_cast<float>(gx * gy);
      jyy.at(x, y) = static_cast<float>(gy * gy);
    }
  box_filter(jxx, r);
  box_filter(jxy, r);
  box_filter(jyy, r);
  Orientation o{Grid(w, h), Grid(w, h), Grid(w, h), Grid(w, h)};
  for (size_t k = 0; k < jxx.v.size(); ++k) {
    const double a = jxx.v[k], b = jxy.v[k], c = jyy.v[k];
    const double diff = std::sqrt((a - c) * (a - c) + 4.0 * b * b);
    // Principal eigenvector at half the angle of (a - c, 2b), without trigonometry.
    const double c2 = diff > 0 ? (a - c) / diff : 1.0;
    const double nx = std::sqrt(std::max(0.0, 0.5 * (1 + c2)));
    const double ny = std::copysign(std::sqrt(std::max(0.0, 0.5 * (1 - c2))), b);
    o.nx.v[k] = static_cast<float>(nx);
    o.ny.v[k] = static_cast<float>(ny);
    o.aniso.v[k] = static_cast<float>(diff);
    o.coh.v[k] = a + c > 0 ? static_cast<float>(diff / (a + c)) : 0.f;
  }
  return o;
}

// Vote weight of a pixel: the structure tensor's anisotropy (weighting by coherence instead was
// measured to be worse on the phantoms).
float weight_of(float /*coh*/, float aniso) { return aniso; }

// Median of the positive values of `v` (0 if none).
float median_positive(std::vector<float> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](float x) { return !(x > 0.f); }), v.end());
  if (v.empty()) return 0.f;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Median and robust spread (1.4826 MAD) of `v` (reordered); {NaN, 0} when empty.
std::pair<float, float> level_and_spread(std::vector<float>& v) {
  if (v.empty()) return {NAN, 0.f};
  const float level = static_cast<float>(median_inplace(v));
  for (float& x : v) x = std::abs(x - level);
  return {level, static_cast<float>(1.4826 * median_inplace(v))};
}

// Pixels of `img` to keep out of the ring evidence: within `grow` pixels of a cluster of pixels
// farther than `cut` from `level` (a knot's flanks are half as bright as its core, and the
// structure tensor spreads them), a cluster being more than kMaskShare of the box around a pixel
// (isolated noise pixels beyond the cut are no knot). 1 = masked.
constexpr float kMaskShare = 0.2f;
Grid outlier_mask(const Grid& img, float level, float cut, int grow) {
  Grid m(img.w, img.h);
  bool any = false;
  for (size_t k = 0; k < img.v.size(); ++k) {
    const bool out = !(std::abs(img.v[k] - level) <= cut);
    m.v[k] = out ? 1.f : 0.f;
    any = any || out;
  }
  if (!any || grow <= 0) return m;
  box_filter(m, grow);
  for (float& v : m.v) v = v > kMaskShare ? 1.f : 0.f;
  return m;
}

// The wood level and spread of a box's voters: median and MAD of the pixels `votes` admits
// (every `stride`-th) that lie in the wood window.
template <typename VotePred>
std::pair<float, float> box_level(const Grid& img, int x0, int y0, int stride, const WoodLevels& lv,
                                  VotePred votes) {
  std::vector<float> v;
  for (int j = 3; j + 3 < img.h; j += stride)
    for (int i = 3; i + 3 < img.w; i += stride)
      if (votes(x0 + i, y0 + j) && lv.contains(img.at(i, j))) v.push_back(img.at(i, j));
  return level_and_spread(v);
}

struct Extent {
  bool found = false;
  Vec2 centre_mm;        // centroid of the wood component
  double radius_mm = 0;  // equivalent radius
  // Coarse mask of the component (eroded once more), kCoarse blocks over the whole slice.
  int cw = 0, ch = 0;
  std::vector<std::uint8_t> inner;
  int bx0 = 0, by0 = 0, bx1 = 0, by1 = 0;  // bounding box, coarse cells, inclusive
};

Extent find_extent(const Slice& s, const VolumeGeometry& g, const WoodLevels& lv) {
  Extent e;
  const int cw = s.width / kCoarse, ch = s.height / kCoarse;
  if (cw < 3 || ch < 3) return e;
  const Grid m = block_mean(s, kCoarse, 0, 0, cw, ch);
  std::vector<std::uint8_t> wood(static_cast<size_t>(cw) * ch, 0), er(wood.size(), 0);
  for (size_t k = 0; k < wood.size(); ++k) wood[k] = lv.contains(m.v[k]);
  auto erode = [&](const std::vector<std::uint8_t>& in, std::vector<std::uint8_t>& out) {
    std::fill(out.begin(), out.end(), 0);
    for (int y = 1; y + 1 < ch; ++y)
      for (int x = 1; x + 1 < cw; ++x) {
        const size_t k = static_cast<size_t>(y) * cw + x;
        out[k] = in[k] && in[k - 1] && in[k + 1] && in[k - cw] && in[k + cw];
      }
  };
  erode(wood, er);
  // Largest 4-connected component.
  std::vector<int> label(wood.size(), -1);
  int best = -1;
  size_t best_n = 0;
  std::vector<int> stack;
  int next = 0;
  for (size_t k0 = 0; k0 < er.size(); ++k0) {
    if (!er[k0] || label[k0] >= 0) continue;
    size_t n = 0;
    stack.assign(1, static_cast<int>(k0));
    label[k0] = next;
    while (!stack.empty()) {
      const int k = stack.back();
      stack.pop_back();
      ++n;
      const int x = k % cw, y = k / cw;
      const int nb[4] = {x > 0 ? k - 1 : -1, x + 1 < cw ? k + 1 : -1, y > 0 ? k - cw : -1,
                         y + 1 < ch ? k + cw : -1};
      for (int q : nb)
        if (q >= 0 && er[q] && label[q] < 0) {
          label[q] = next;
          stack.push_back(q);
        }
    }
    if (n > best_n) best_n = n, best = next;
    ++next;
  }
  const double cell_x = kCoarse * g.spacing_x, cell_y = kCoarse * g.spacing_y;
  const double area = static_cast<double>(best_n) * cell_x * cell_y;
  const double radius = std::sqrt(area / kPi);
  if (best < 0 || radius < kMinRadiusMm) return e;
  std::vector<std::uint8_t> comp(wood.size(), 0);
  for (size_t k = 0; k < comp.size(); ++k) comp[k] = label[k] == best;
  e.inner.assign(wood.size(), 0);
  erode(comp, e.inner);
  double sx = 0, sy = 0;
  e.bx0 = cw, e.by0 = ch, e.bx1 = -1, e.by1 = -1;
  for (int y = 0; y < ch; ++y)
    for (int x = 0; x < cw; ++x)
      if (comp[static_cast<size_t>(y) * cw + x]) {
        sx += x, sy += y;
        e.bx0 = std::min(e.bx0, x), e.bx1 = std::max(e.bx1, x);
        e.by0 = std::min(e.by0, y), e.by1 = std::max(e.by1, y);
      }
  const double n = static_cast<double>(best_n);
  e.centre_mm = {(sx / n + 0.5) * cell_x - 0.5 * g.spacing_x,
                 (sy / n + 0.5) * cell_y - 0.5 * g.spacing_y};
  e.radius_mm = radius;
  e.cw = cw, e.ch = ch;
  e.found = true;
  return e;
}

// Votes of ring normals. The full-resolution box [x0, x0 + w) x [y0, y0 + h) gives the ring
// orientation (annual rings are 3-4 pixels wide: coarser images alias them into moire);
// `votes(x, y)` (full-resolution pixels) says who votes, every `stride` pixels. The accumulator
// has cells of `cell` pixels and covers the mm box [lo, hi]. Returns the peak (mm) and its
// sharpness (1 - mean / peak); `others`, when given, gets up to `n_others` further local peaks
// (cell centres, mm), strongest first, each at least `apart_mm` from the stronger ones.
// Pixels whose anisotropy is above `edge_factor` times the voters' median do not vote.
template <typename VotePred>
Vec2 vote(const Slice& s, const VolumeGeometry& g, const WoodLevels& lv, int x0, int y0, int w,
          int h, Vec2 lo, Vec2 hi, int cell, int stride, int tensor_radius, VotePred votes_in,
          double* sharpness, std::vector<Vec2>* others = nullptr, int n_others = 0,
          double apart_mm = 0, double edge_factor = kEdgeFactor) {
  const Grid img = block_mean(s, 1, x0, y0, w, h);
  const double sx = g.spacing_x, sy = g.spacing_y;
  const Orientation o = orientation_field(img, tensor_radius, sx, sy);
  // Knots (far above the box's wood level) and cracks (far below) never vote as rings.
  const auto [level, spread] = box_level(img, x0, y0, stride, lv, votes_in);
  const Grid mask = std::isnan(level)
                        ? Grid(w, h)
                        : outlier_mask(img, level, static_cast<float>(kVoteOutlierSigmas) * spread,
                                       tensor_radius + 1);
  auto votes = [&](int x, int y) { return mask.at(x - x0, y - y0) == 0.f && votes_in(x, y); };
  std::vector<float> an;
  an.reserve(o.aniso.v.size() / static_cast<size_t>(stride * stride) + 1);
  for (int j = 3; j + 3 < h; j += stride)
    for (int i = 3; i + 3 < w; i += stride)
      if (votes(x0 + i, y0 + j)) an.push_back(o.aniso.at(i, j));
  const float cap = static_cast<float>(edge_factor) * median_positive(an);
  const double cx_mm = cell * sx, cy_mm = cell * sy;
  const int aw = std::max(1, static_cast<int>(std::ceil((hi.x - lo.x) / cx_mm)) + 1);
  const int ah = std::max(1, static_cast<int>(std::ceil((hi.y - lo.y) / cy_mm)) + 1);
  Grid acc(aw, ah);
  for (int j = 3; j + 3 < h; j += stride)
    for (int i = 3; i + 3 < w; i += stride) {
      if (!votes(x0 + i, y0 + j)) continue;
      // Strong edges (knots, cracks, the heartwood border, the outline) do not vote at all:
      // annual rings are faint, so anything much above the typical anisotropy is not a ring.
      const float an_ij = o.aniso.at(i, j);
      if (!(an_ij > 0.f) || an_ij > cap) continue;
      const float wgt = weight_of(o.coh.at(i, j), an_ij);
      // Position and normal in accumulator cells, unit step along the major axis.
      const double px = ((x0 + i) * sx - lo.x) / cx_mm, py = ((y0 + j) * sy - lo.y) / cy_mm;
      double dx = o.nx.at(i, j) / cx_mm, dy = o.ny.at(i, j) / cy_mm;
      const double m = std::max(std::abs(dx), std::abs(dy));
      dx /= m, dy /= m;
      // Clip the line p + t d to the accumulator box (slab method).
      double tlo = -1e9, thi = 1e9;
      auto slab = [&](double p, double d, double a, double b) {
        if (std::abs(d) < 1e-12) {
          if (p < a || p > b) tlo = 1, thi = 0;
          return;
        }
        double t0 = (a - p) / d, t1 = (b - p) / d;
        if (t0 > t1) std::swap(t0, t1);
        tlo = std::max(tlo, t0), thi = std::min(thi, t1);
      };
      slab(px, dx, -0.49, aw - 0.51);
      slab(py, dy, -0.49, ah - 0.51);
      if (tlo > thi) continue;
      const int t0 = static_cast<int>(std::ceil(tlo)), t1 = static_cast<int>(std::floor(thi));
      for (int t = t0; t <= t1; ++t) {
        const int ax = static_cast<int>(std::lround(px + t * dx));
        const int ay = static_cast<int>(std::lround(py + t * dy));
        if (ax >= 0 && ax < aw && ay >= 0 && ay < ah) acc.at(ax, ay) += wgt;
      }
    }
  box_filter(acc, 1);
  int bi = 0;
  for (int k = 1; k < static_cast<int>(acc.v.size()); ++k)
    if (acc.v[k] > acc.v[bi]) bi = k;
  const int bx = bi % aw, by = bi / aw;
  // Sub-cell peak: parabola through the neighbours.
  auto para = [](double l, double c, double r) {
    const double den = l - 2 * c + r;
    return den < 0 ? std::clamp(0.5 * (l - r) / den, -0.5, 0.5) : 0.0;
  };
  double fx = bx, fy = by;
  if (bx > 0 && bx + 1 < aw) fx += para(acc.at(bx - 1, by), acc.at(bx, by), acc.at(bx + 1, by));
  if (by > 0 && by + 1 < ah) fy += para(acc.at(bx, by - 1), acc.at(bx, by), acc.at(bx, by + 1));
  double mean = 0;
  for (float v : acc.v) mean += v;
  mean /= static_cast<double>(acc.v.size());
  *sharpness = acc.v[bi] > 0 ? 1.0 - mean / acc.v[bi] : 0.0;
  const Vec2 peak{lo.x + fx * cx_mm, lo.y + fy * cy_mm};
  if (others) {
    // Greedy: the strongest cell not within apart_mm of a peak already taken.
    std::vector<Vec2> taken{peak};
    std::vector<int> order(acc.v.size());
    for (size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return acc.v[a] > acc.v[b]; });
    for (int k : order) {
      if (static_cast<int>(others->size()) >= n_others || !(acc.v[k] > 0.f)) break;
      const Vec2 c{lo.x + (k % aw) * cx_mm, lo.y + (k / aw) * cy_mm};
      bool near = false;
      for (const Vec2& t : taken) near = near || (c - t).norm() < apart_mm;
      if (near) continue;
      taken.push_back(c);
      others->push_back(c);
    }
  }
  return peak;
}

// Full-resolution refinement around `c` (mm). Returns the refined pith; *inlier is the weighted
// fraction of normals that point at it.
Vec2 refine(const Slice& s, const VolumeGeometry& g, const WoodLevels& lv, Vec2 c, double* inlier,
            double edge_factor = kEdgeFactor) {
  const double sx = g.spacing_x, sy = g.spacing_y;
  const int rx = static_cast<int>(std::ceil(kRefineRadiusMm / sx)) + 4;
  const int ry = static_cast<int>(std::ceil(kRefineRadiusMm / sy)) + 4;
  const int cx = static_cast<int>(std::lround(c.x / sx)),
            cy = static_cast<int>(std::lround(c.y / sy));
  const int x0 = std::max(0, cx - rx), y0 = std::max(0, cy - ry);
  const int x1 = std::min(s.width - 1, cx + rx), y1 = std::min(s.height - 1, cy + ry);
  *inlier = 0;
  if (x1 - x0 < 8 || y1 - y0 < 8) return c;
  Grid img(x1 - x0 + 1, y1 - y0 + 1);
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) img.at(x - x0, y - y0) = s.at(x, y);
  const Orientation o = orientation_field(img, kRefineTensorRadius, sx, sy);
  const auto [level, spread] = box_level(img, x0, y0, 1, lv, [](int, int) { return true; });
  const Grid mask = std::isnan(level)
                        ? Grid(img.w, img.h)
                        : outlier_mask(img, level, static_cast<float>(kVoteOutlierSigmas) * spread,
                                       kRefineTensorRadius + 1);
  struct Px {
    double x, y, nx, ny, aniso, w;
  };
  std::vector<Px> px;
  std::vector<float> an;
  px.reserve(img.v.size());
  for (int j = 3; j + 3 < img.h; ++j)
    for (int i = 3; i + 3 < img.w; ++i) {
      const float a = o.aniso.at(i, j);
      if (!(a > 0.f) || mask.at(i, j) != 0.f) continue;
      px.push_back({(x0 + i) * sx, (y0 + j) * sy, o.nx.at(i, j), o.ny.at(i, j), a,
                    weight_of(o.coh.at(i, j), a)});
      an.push_back(a);
    }
  const double cap = edge_factor * median_positive(an);
  for (Px& p : px) p.w = p.aniso > cap ? 0.0 : p.w;
  const double r2max = kRefineRadiusMm * kRefineRadiusMm;
  const double rmin = 4.0;
  for (int it = 0; it < 30; ++it) {
    double a11 = 0, a12 = 0, a22 = 0, b1 = 0, b2 = 0, wsum = 0, win = 0;
    for (const Px& p : px) {
      const double dx = c.x - p.x, dy = c.y - p.y;
      const double r2 = dx * dx + dy * dy;
      if (r2 > r2max) continue;
      const double w0 = p.w / std::max(std::sqrt(r2), rmin);
      // Sine of the angle between the normal and the direction to c.
      const double cross = p.nx * dy - p.ny * dx;
      const double sn = r2 > 1e-12 ? std::abs(cross) / std::sqrt(r2) : 0.0;
      const double u = sn / kTukeyAngle;
      wsum += w0;
      if (u >= 1.0) continue;
      const double tw = (1 - u * u) * (1 - u * u);
      const double wt = w0 * tw;
      win += wt;
      // (I - n n^T)
      const double m11 = 1 - p.nx * p.nx, m12 = -p.nx * p.ny, m22 = 1 - p.ny * p.ny;
      a11 += wt * m11, a12 += wt * m12, a22 += wt * m22;
      b1 += wt * (m11 * p.x + m12 * p.y);
      b2 += wt * (m12 * p.x + m22 * p.y);
    }
    const double det = a11 * a22 - a12 * a12;
    if (!(det > 1e-18 * (a11 + a22) * (a11 + a22)) || wsum <= 0) break;
    const Vec2 n{(a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det};
    *inlier = win / wsum;
    Vec2 step = n - c;
    // Keep a wild step (degenerate geometry) from leaving the window.
    const double len = step.norm();
    if (len > 0.5 * kRefineRadiusMm) step = (0.5 * kRefineRadiusMm / len) * step;
    c = c + step;
    if (step.norm() < 0.005) break;
  }
  return c;
}

// Fraction of half-resolution wood pixels in a disc (mm) of the slice.
double wood_fraction(const Slice& s, const VolumeGeometry& g, Vec2 c, double radius,
                     const WoodLevels& lv) {
  const int cx = static_cast<int>(std::lround(c.x / g.spacing_x));
  const int cy = static_cast<int>(std::lround(c.y / g.spacing_y));
  const int rx = static_cast<int>(radius / g.spacing_x),
            ry = static_cast<int>(radius / g.spacing_y);
  int n = 0, in = 0;
  for (int y = cy - ry; y <= cy + ry; y += 2)
    for (int x = cx - rx; x <= cx + rx; x += 2) {
      const double dx = (x - cx) * g.spacing_x, dy = (y - cy) * g.spacing_y;
      if (dx * dx + dy * dy > radius * radius) continue;
      ++n;
      if (x < 0 || y < 0 || x >= s.width || y >= s.height) continue;
      const float v = s.at(x, y);
      in += lv.contains(v);
    }
  return n ? static_cast<double>(in) / n : 0.0;
}

double confidence_from(double inlier, double sharpness) {
  // Pure noise gives an inlier fraction near 0.15; clean rings 0.6 and more.
  const double a = std::clamp((inlier - 0.15) / 0.45, 0.0, 1.0);
  return std::clamp(0.7 * a + 0.3 * sharpness, 0.0, 1.0);
}

PithResult detect_with_prior(const Slice& s, const VolumeGeometry& g, const PithOptions& opt,
                             Vec2 prior, double edge_factor = kEdgeFactor) {
  PithResult r;
  const double sr = opt.prior_radius_mm;
  const WoodLevels lv = wood_levels(s, opt);
  if (!lv.found || wood_fraction(s, g, prior, sr, lv) < 0.6) return r;
  // Voters: every other pixel within sr + 20 mm of the prior; accumulator: +- sr, 2-pixel cells.
  const double vr = sr + 20.0;
  const int x0 = std::max(0, static_cast<int>((prior.x - vr) / g.spacing_x));
  const int y0 = std::max(0, static_cast<int>((prior.y - vr) / g.spacing_y));
  const int x1 = std::min(s.width, static_cast<int>((prior.x + vr) / g.spacing_x) + 2);
  const int y1 = std::min(s.height, static_cast<int>((prior.y + vr) / g.spacing_y) + 2);
  if (x1 - x0 < 16 || y1 - y0 < 16) return r;
  const double vr2 = vr * vr;
  auto votes = [&](int x, int y) {
    const double dx = x * g.spacing_x - prior.x, dy = y * g.spacing_y - prior.y;
    return dx * dx + dy * dy <= vr2;
  };
  double sharp = 0;
  const Vec2 coarse =
      vote(s, g, lv, x0, y0, x1 - x0, y1 - y0, prior - Vec2{sr, sr}, prior + Vec2{sr, sr}, 2, 2,
           kPriorTensorRadius, votes, &sharp, nullptr, 0, 0.0, edge_factor);
  double inlier = 0;
  r.pith_mm = refine(s, g, lv, coarse, &inlier, edge_factor);
  r.confidence = confidence_from(inlier, sharp);
  r.found = true;
  return r;
}

std::vector<PithCandidate> candidates_without_prior(const Slice& s, const VolumeGeometry& g,
                                                    const PithOptions& opt) {
  std::vector<PithCandidate> out;
  const WoodLevels lv = wood_levels(s, opt);
  const Extent e = lv.found ? find_extent(s, g, lv) : Extent{};
  if (!e.found) return out;
  // The pith lies well inside the section: search +- 0.6 R around the centroid, with votes from
  // the inner 0.8 R (inner rings are rounder), every third pixel, into 4-pixel cells.
  const double R = e.radius_mm;
  const Vec2 c = e.centre_mm;
  const double vr = 0.8 * R, vr2 = vr * vr;
  const int x0 = std::max(0, static_cast<int>((c.x - vr) / g.spacing_x));
  const int y0 = std::max(0, static_cast<int>((c.y - vr) / g.spacing_y));
  const int x1 = std::min(s.width, static_cast<int>((c.x + vr) / g.spacing_x) + 2);
  const int y1 = std::min(s.height, static_cast<int>((c.y + vr) / g.spacing_y) + 2);
  auto votes = [&](int x, int y) {
    const double dx = x * g.spacing_x - c.x, dy = y * g.spacing_y - c.y;
    if (dx * dx + dy * dy > vr2) return false;
    const int cx = x / kCoarse, cy = y / kCoarse;
    return cx < e.cw && cy < e.ch && e.inner[static_cast<size_t>(cy) * e.cw + cx] != 0;
  };
  const int stride = R > 60 ? 3 : 2;
  double sharp = 0;
  std::vector<Vec2> others;
  const Vec2 coarse = vote(s, g, lv, x0, y0, x1 - x0, y1 - y0, c - Vec2{0.6 * R, 0.6 * R},
                           c + Vec2{0.6 * R, 0.6 * R}, 4, stride, kCoarseTensorRadius, votes,
                           &sharp, &others, kAcquireCandidates - 1, kAcquireApartMm);
  std::vector<Vec2> seeds{coarse};
  seeds.insert(seeds.end(), others.begin(), others.end());
  // The vote above keeps strong edges out (knot flanks, cracks, the heartwood border), taking
  // annual rings to be faint everywhere. Real rings are not: in a pine butt the heartwood's
  // rings stand 100-250 HU out and the wet sapwood's barely at all, so against the section's
  // median anisotropy the crisp rings around the pith are edges and do not vote (PIN1B of the
  // real slices: no candidate within 25 mm of the pith). A second vote lets every edge in; its
  // peaks join the candidates, and the rings lined up around each (wide_ring_score, and along z
  // in PithTracker::acquire) decide between them.
  double sharp_all = 0;
  std::vector<Vec2> others_all;
  const Vec2 coarse_all =
      vote(s, g, lv, x0, y0, x1 - x0, y1 - y0, c - Vec2{0.6 * R, 0.6 * R},
           c + Vec2{0.6 * R, 0.6 * R}, 4, stride, kCoarseTensorRadius, votes, &sharp_all,
           &others_all, kAcquireCandidates - 1, kAcquireApartMm, kUncappedEdgeFactor);
  const size_t capped = seeds.size();
  seeds.push_back(coarse_all);
  seeds.insert(seeds.end(), others_all.begin(), others_all.end());
  const size_t uncapped = seeds.size();
  seeds.push_back(c);
  PithOptions o2 = opt;
  o2.prior_radius_mm = 8.0;
  o2.wood_min_hu = lv.min_hu, o2.wood_max_hu = lv.max_hu;  // the whole slice's, once
  for (size_t k = 0; k < seeds.size(); ++k) {
    // The second vote's peaks are voted on again nearby as that vote was, every edge in.
    PithResult q = detect_with_prior(
        s, g, o2, seeds[k], k >= capped && k < uncapped ? kUncappedEdgeFactor : kEdgeFactor);
    if (!q.found) {
      if (k > 0) continue;
      double inlier = 0;
      q.pith_mm = refine(s, g, lv, seeds[k], &inlier);
      q.confidence = confidence_from(inlier, sharp);
      q.found = true;
    }
    bool seen = false;
    for (const PithCandidate& t : out) seen = seen || (t.vote - q.pith_mm).norm() < 1.0;
    if (seen) continue;
    const PithResult local = refine_pith_concentric(s, g, q.pith_mm, kAcquireRingSearchMm, nullptr);
    PithCandidate cand;
    cand.vote = q.pith_mm;
    cand.vote_confidence = q.confidence;
    cand.rings = local.found ? local.pith_mm : q.pith_mm;
    cand.score = wide_ring_score(s, g, cand.rings);
    out.push_back(cand);
  }
  return out;
}

PithResult detect_without_prior(const Slice& s, const VolumeGeometry& g, const PithOptions& opt) {
  // At high noise, and where knots or the scanner bed pull the votes, the strongest peak is not
  // always the pith: it stands unless another candidate lines the rings up clearly better. The
  // answer is the vote's (the caller refines it).
  const std::vector<PithCandidate> cands = candidates_without_prior(s, g, opt);
  PithResult r;
  if (cands.empty()) return r;
  size_t best = 0;
  for (size_t k = 1; k < cands.size(); ++k)
    if (cands[k].score > std::max(cands[best].score, cands[0].score + kAcquireMargin)) best = k;
  r.found = true;
  r.pith_mm = cands[best].vote;
  r.confidence = cands[best].vote_confidence;
  return r;
}

}  // namespace

WoodLevels wood_levels(const Slice& s, const PithOptions& options) {
  WoodLevels lv;
  if (!slice_holds_pixels(s)) return lv;
  const bool given = std::isfinite(options.wood_min_hu) && std::isfinite(options.wood_max_hu);
  if (given) {
    lv.found = options.wood_max_hu > options.wood_min_hu;
    lv.min_hu = options.wood_min_hu, lv.max_hu = options.wood_max_hu;
    lv.air_hu = lv.min_hu, lv.wood_hu = 0.5 * (lv.min_hu + lv.max_hu);
    return lv;
  }
  // Every sixth pixel each way (7000 of a 512 x 512 slice): plenty for two levels, and cheap on
  // the reading thread, which takes the levels of every slice.
  constexpr int kStep = 6;
  std::vector<float> v;
  v.reserve(static_cast<size_t>(s.width / kStep + 1) * static_cast<size_t>(s.height / kStep + 1));
  float lo = INFINITY, hi = -INFINITY;
  for (int y = kStep / 2; y < s.height; y += kStep)
    for (int x = kStep / 2; x < s.width; x += kStep) {
      const float q = s.at(x, y);
      if (!(q > kPaddingHu)) continue;
      v.push_back(q);
      lo = std::min(lo, q), hi = std::max(hi, q);
    }
  if (v.size() < 64 || !(hi > lo)) return lv;
  // Otsu's threshold on a 256-bin histogram.
  constexpr int kBins = 256;
  std::array<double, kBins> hist{};
  const double scale = (kBins - 1) / static_cast<double>(hi - lo);
  for (float q : v) hist[static_cast<size_t>((q - lo) * scale)] += 1.0;
  double total = 0, sum_all = 0;
  for (int b = 0; b < kBins; ++b) total += hist[b], sum_all += b * hist[b];
  double w0 = 0, s0 = 0, best = -1;
  int split = 0;
  for (int b = 0; b + 1 < kBins; ++b) {
    w0 += hist[b], s0 += b * hist[b];
    const double w1 = total - w0;
    if (w0 <= 0 || w1 <= 0) continue;
    const double m0 = s0 / w0, m1 = (sum_all - s0) / w1;
    const double between = w0 * w1 * (m0 - m1) * (m0 - m1);
    if (between > best) best = between, split = b;
  }
  const float t = lo + static_cast<float>((split + 1) / scale);
  std::vector<float> below, above;
  for (float q : v) (q < t ? below : above).push_back(q);
  if (below.empty() || above.empty()) return lv;
  const auto [air, air_spread] = level_and_spread(below);
  lv.air_hu = air;
  const auto [wood, spread] = level_and_spread(above);
  lv.wood_hu = wood;
  lv.sigma_hu = spread;
  const double step = lv.wood_hu - lv.air_hu;
  lv.min_hu =
      std::isfinite(options.wood_min_hu) ? options.wood_min_hu : lv.wood_hu - kWindowBelow * step;
  lv.max_hu = std::isfinite(options.wood_max_hu)
                  ? options.wood_max_hu
                  : lv.wood_hu + std::max(kWindowAbove * step, kWindowAboveSigmas * lv.sigma_hu);
  // Two classes of one noisy level (air only) lie a couple of spreads apart; air and wood are
  // hundreds of HU apart at any noise a log scan has.
  lv.found = step > kMinStepSpreads * air_spread && lv.max_hu > lv.min_hu;
  return lv;
}

PithResult refine_pith_concentric(const Slice& s, const VolumeGeometry& g, Vec2 start,
                                  double search_mm, const std::vector<double>* outline,
                                  double ring_max_mm, double ring_min_mm, double shape_share,
                                  Vec2 ring_drift, const RingDriftSearch* drift) {
  PithResult res;
  const double sx = g.spacing_x, sy = g.spacing_y;
  const double ring_min = std::max(ring_min_mm, kRingMinMm);
  const double ring_max = std::max(ring_max_mm, ring_min + 3 * kRingMinMm);
  const double reach = ring_profile_reach_mm(search_mm, ring_max);
  const int x0 = std::max(0, static_cast<int>((start.x - reach) / sx));
  const int y0 = std::max(0, static_cast<int>((start.y - reach) / sy));
  const int x1 = std::min(s.width - 1, static_cast<int>((start.x + reach) / sx) + 1);
  const int y1 = std::min(s.height - 1, static_cast<int>((start.y + reach) / sy) + 1);
  const int na = outline ? static_cast<int>(outline->size()) : 0;
  double rmean = 0;
  for (int k = 0; k < na; ++k) rmean += (*outline)[static_cast<size_t>(k)];
  if (na) rmean /= na;
  // Pixels relative to `start`, with their ring scale: homothetic rings put a pixel at distance
  // d in direction u on the ring of radius d * Rm / R(u), and a centre moved by delta changes
  // R(u) by -delta . u to first order.
  struct Px {
    float x, y, v, ux, uy, k, inv_r;
  };
  std::vector<Px> px;
  std::vector<float> vals;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double dx = x * sx - start.x, dy = y * sy - start.y;
      const double d2 = dx * dx + dy * dy;
      if (d2 > reach * reach) continue;
      const float v = s.at(x, y);
      if (!(v > kPaddingHu)) continue;  // padding; air (a crack) goes with the outliers below
      const double d = std::sqrt(d2);
      double k = 1.0, inv_r = 0.0;
      if (na) {
        const double w = azimuth_fast(dx, dy);
        const double R = (*outline)[static_cast<size_t>(std::lround(w / kTwoPi * na)) % na];
        if (!(R > 1.0)) continue;
        // The ring through this pixel follows shape_share of the outline's departure from its
        // mean radius: R_s = Rm + s (R - Rm); a centre moved by delta changes it by -s delta . u.
        const double Rs = rmean + shape_share * (R - rmean);
        k = rmean / Rs, inv_r = shape_share / Rs;
      }
      px.push_back({static_cast<float>(dx), static_cast<float>(dy), v,
                    d > 0 ? static_cast<float>(dx / d) : 0.f,
                    d > 0 ? static_cast<float>(dy / d) : 0.f, static_cast<float>(k),
                    static_cast<float>(inv_r)});
      vals.push_back(v);
    }
  if (px.size() < 100) return res;
  // Knots, the heartwood border and cracks are far from the wood level: leave them out. (Not
  // their blurred borders as well: growing the outliers by a pixel also takes the pixels around
  // the latewood peaks that pass the cut, and biased a phantom's ring pith by 4 mm.)
  const auto [level, spread] = level_and_spread(vals);
  const float cut = static_cast<float>(kRingOutlierSigmas) * spread;
  px.erase(std::remove_if(px.begin(), px.end(),
                          [&](const Px& p) { return !(std::abs(p.v - level) <= cut); }),
           px.end());
  if (px.size() < 100) return res;
  // A wide search screens its grid on the pixels near the start alone: those first.
  const bool screen = search_mm >= kScreenMinSearchMm && ring_max > kScreenRingMm + 4.0 &&
                      ring_min + 4.0 < kScreenRingMm;
  const float screen_reach = static_cast<float>(kScreenRingMm + search_mm);
  const size_t n_near =
      screen ? static_cast<size_t>(std::partition(px.begin(), px.end(),
                                                  [&](const Px& p) {
                                                    return std::sqrt(p.x * p.x + p.y * p.y) * p.k <=
                                                           screen_reach;
                                                  }) -
                                   px.begin())
             : px.size();
  // Structure of arrays, so the per-candidate radius loop vectorises.
  const size_t npx = px.size();
  std::vector<float> fx(npx), fy(npx), fv(npx), fux(npx), fuy(npx), fk(npx), fir(npx);
  for (size_t i = 0; i < npx; ++i) {
    fx[i] = px[i].x, fy[i] = px[i].y, fv[i] = px[i].v - level;
    fux[i] = px[i].ux, fuy[i] = px[i].uy, fk[i] = px[i].k, fir[i] = px[i].inv_r;
  }
  // Drifting rings: the ring of model radius rho is centred rho * d from the pith, so a pixel
  // at distance q in direction u lies on rho = q k / (1 + k d . u) (first order in d).
  std::vector<float> fk0;  // the scales without a drift (kept where a drift is taken or sought)
  if (drift || ring_drift.x != 0 || ring_drift.y != 0) fk0 = fk;
  auto set_drift = [&](Vec2 d) {
    const float dx = static_cast<float>(d.x), dy = static_cast<float>(d.y);
    for (size_t i = 0; i < npx; ++i) fk[i] = fk0[i] / (1.f + fk0[i] * (dx * fux[i] + dy * fuy[i]));
  };
  if (ring_drift.x != 0 || ring_drift.y != 0) set_drift(ring_drift);
  const int nb_all = static_cast<int>((ring_max - ring_min) / kRingBinMm) + 1;
  constexpr int lh = static_cast<int>(kRingSmoothMm / kRingBinMm);
  // Four interleaved histograms: consecutive pixels fall in the same bin, and one histogram
  // would make every add wait for the previous one. Bin 0 takes the pixels inside the first
  // ring radius, bin nb_all + 1 those beyond the last; 1..nb_all are the profile.
  // Each pixel adds its value and a count in one integer add: the value in 1/kQuantum HU
  // from bit 24 (kCountOne) up, the count below (exact; a bin holds far fewer than 2^24 pixels).
  constexpr int kLanes = 4;
  constexpr double kQuantum = 64.0;
  constexpr std::int64_t kCountOne = std::int64_t{1} << 24;
  std::array<std::vector<std::int64_t>, kLanes> hist;
  for (int l = 0; l < kLanes; ++l) hist[l].resize(nb_all + 2);
  std::vector<std::int64_t> packed(npx);
  // Rounded half away from zero, as std::lround would, inline: fv · 64 is a float's value times
  // a power of two, so adding one half is exact and truncating it rounds the same way.
  for (size_t i = 0; i < npx; ++i) {
    const double q = static_cast<double>(fv[i]) * kQuantum;
    packed[i] = static_cast<std::int64_t>(q >= 0 ? q + 0.5 : q - 0.5) * kCountOne + 1;
  }
  std::vector<double> m(nb_all), nbin(nb_all), sq(nb_all + 2);
  std::vector<std::int32_t> bins(npx);
  const float inv_bin = static_cast<float>(1.0 / kRingBinMm);
  const float rmin = static_cast<float>(ring_min);
  constexpr float kRingBinMmF = static_cast<float>(kRingBinMm);
  // Ring-profile energy around start + delta: the mean HU per ring-radius bin, minus its running
  // mean over about a ring width (knots and the density trend are smooth in radius, rings are
  // not), squared and summed. `noise` gets the profile's expected noise energy.
  // `use` pixels (a prefix) and `nbu` profile bins: the screening score of a wide search.
  auto score = [&](Vec2 delta, double* noise, size_t use = 0, int nbu = 0) {
    const size_t n_use = use ? use : npx;
    const int nb_use = nbu ? nbu : nb_all;
    const float ddx = static_cast<float>(delta.x), ddy = static_cast<float>(delta.y);
    const float top = static_cast<float>(nb_use + 1);
    const float lo = rmin - kRingBinMmF;  // bin 1 starts at rmin
    RingPixels rp{fx.data(), fy.data(), fux.data(), fuy.data(), fk.data(), fir.data()};
    ring_bins(rp, n_use, ddx, ddy, lo, inv_bin, top, bins.data());
    for (int l = 0; l < kLanes; ++l) std::fill(hist[l].begin(), hist[l].end(), 0);
    size_t i = 0;
    for (; i + kLanes <= n_use; i += kLanes)
      for (int l = 0; l < kLanes; ++l) hist[l][bins[i + l]] += packed[i + l];
    for (; i < n_use; ++i) hist[0][bins[i]] += packed[i];
    for (int b = 0; b < nb_use; ++b) {
      std::int64_t t = 0;
      for (int l = 0; l < kLanes; ++l) t += hist[l][b + 1];
      const std::int64_t n = t & (kCountOne - 1);
      nbin[b] = static_cast<double>(n);
      m[b] = n > 0 ? static_cast<double>((t - n) / kCountOne) / (kQuantum * nbin[b]) : 0.0;
    }
    double sc = 0;
    for (int b = 0; b < nb_use; ++b) {
      double a = 0;
      int n = 0;
      for (int j = std::max(0, b - lh); j <= std::min(nb_use - 1, b + lh); ++j) a += m[j], ++n;
      const double d = m[b] - a / n;
      sc += d * d;
    }
    if (noise) {
      std::fill(sq.begin(), sq.end(), 0.0);
      for (size_t q = 0; q < n_use; ++q) sq[bins[q]] += static_cast<double>(fv[q]) * fv[q];
      double nz = 0;
      for (int b = 0; b < nb_use; ++b)
        if (nbin[b] > 1) nz += (sq[b + 1] / nbin[b] - m[b] * m[b]) / nbin[b];
      *noise = nz;
    }
    return sc;
  };
  // A grid over the search disc, then hill climbing at finer steps.
  // A wide search screens the grid on the rings within kScreenRingMm of each grid point and
  // scores only the kScreenKeep best points on all rings.
  Vec2 best{0, 0};
  double bs = -1;
  // Rings are at least two pixels wide where they are resolved at all: a grid step of 0.6 pixel
  // keeps the main peak (about half a ring width across) from being stepped over on fine scans.
  const double grid_mm = std::min(kRingGridMm, 0.6 * std::max(sx, sy));
  const int ns = static_cast<int>(search_mm / grid_mm);
  const int nb_screen = std::max(1, static_cast<int>((kScreenRingMm - ring_min) / kRingBinMm) + 1);
  std::vector<std::pair<double, Vec2>> screened;
  for (int j = -ns; j <= ns; ++j)
    for (int i = -ns; i <= ns; ++i) {
      if (i * i + j * j > ns * ns) continue;
      const Vec2 c{i * grid_mm, j * grid_mm};
      if (screen) {
        screened.push_back({score(c, nullptr, std::max<size_t>(n_near, 1), nb_screen), c});
        continue;
      }
      const double v = score(c, nullptr);
      if (v > bs) bs = v, best = c;
    }
  if (screen) {
    const size_t keep = std::min<size_t>(kScreenKeep, screened.size());
    std::partial_sort(screened.begin(), screened.begin() + static_cast<std::ptrdiff_t>(keep),
                      screened.end(),
                      [](const auto& a, const auto& b) { return a.first > b.first; });
    for (size_t q = 0; q < keep; ++q) {
      const double v = score(screened[q].second, nullptr);
      if (v > bs) bs = v, best = screened[q].second;
    }
  }
  // Hill climbing on a 0.25 mm lattice until the best point is the centre of its 3 x 3
  // neighbourhood, then a parabola through that neighbourhood in x and in y.
  // Points are on the lattice exactly (multiples of 0.25 are exact in binary), and a step
  // revisits up to 5 of the last neighbourhood's points: their scores are remembered.
  constexpr double h = 0.25;
  std::array<double, 9> nbh{};
  struct Seen {
    int i, j;
    double v;
  };
  std::vector<Seen> seen;
  auto lattice_score = [&](Vec2 at) {
    const int li = static_cast<int>(std::lround(at.x / h)),
              lj = static_cast<int>(std::lround(at.y / h));
    for (const Seen& q : seen)
      if (q.i == li && q.j == lj) return q.v;
    const double v = score(at, nullptr);
    seen.push_back({li, lj, v});
    return v;
  };
  // From `at` (score `v`) to the best point of its 3 x 3 neighbourhood, within `limit` of the
  // start; `at` and `v` are updated, nbh holds the last neighbourhood.
  auto climb = [&](Vec2& at, double& v, double limit) {
    seen.clear();
    for (int it = 0; it < 40; ++it) {
      int arg = 4;
      nbh[4] = v;
      for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) {
          if (!i && !j) continue;
          const int q = (j + 1) * 3 + (i + 1);
          nbh[q] = lattice_score({at.x + i * h, at.y + j * h});
          if (nbh[q] > nbh[arg]) arg = q;
        }
      if (arg == 4) break;
      const Vec2 next{at.x + (arg % 3 - 1) * h, at.y + (arg / 3 - 1) * h};
      // Stay in the searched disc: a climb along a noisy ridge would reach the alignment one
      // ring off, outside the area the grid vouched for.
      if (next.norm() > limit) break;
      at = next;
      v = nbh[arg];
    }
  };
  climb(best, bs, search_mm + grid_mm);
  auto vertex = [](double l, double c, double r) {
    const double den = l - 2 * c + r;
    return den < 0 ? std::clamp(0.5 * (l - r) / den, -0.5, 0.5) : 0.0;
  };
  auto net_signal = [&](Vec2 at) {
    double nz = 0;
    const double v = score(at, &nz);
    return v - nz;
  };
  // The drift from the rings themselves, sector by sector: around the concentric answer each
  // sector's ring profile is the whole profile moved out by a + b r (a ring of radius r centred
  // at pith + drift r lies a + b r farther out in direction u: a = (pith - centre) . u, b =
  // drift . u). Each sector's a and b are where its profile matches the whole one best; their
  // first harmonics around the circle are the pith's offset and the drift (the rest is the
  // rings' shape, which a sector takes up on its own instead of biasing the two).
  if (drift) {
    const Vec2 c = best;
    const double base_signal = net_signal(best);
    constexpr double kBin = 0.2;
    const int nsec = drift->sectors;
    const int nb = static_cast<int>((ring_max - ring_min) / kBin) + 1;
    std::vector<double> sum(static_cast<size_t>(nsec) * nb, 0.0), cnt(sum.size(), 0.0);
    std::vector<double> gsum(static_cast<size_t>(nb), 0.0), gcnt(gsum.size(), 0.0);
    for (size_t i = 0; i < npx; ++i) {
      const double ex = fx[i] - c.x, ey = fy[i] - c.y;
      const double r =
          std::sqrt(ex * ex + ey * ey) * fk0[i] * (1.0 + (c.x * fux[i] + c.y * fuy[i]) * fir[i]);
      const int b = static_cast<int>((r - ring_min) / kBin);
      if (b < 0 || b >= nb) continue;
      const int j = std::min(nsec - 1, static_cast<int>(azimuth_fast(ex, ey) / kTwoPi * nsec));
      sum[static_cast<size_t>(j) * nb + b] += fv[i], cnt[static_cast<size_t>(j) * nb + b] += 1;
      gsum[static_cast<size_t>(b)] += fv[i], gcnt[static_cast<size_t>(b)] += 1;
    }
    // Profiles less their running mean over +-kRingSmoothMm (the rings alone).
    const int sm = static_cast<int>(kRingSmoothMm / kBin);
    auto detrend = [&](const double* s0, const double* c0, std::vector<double>& out,
                       std::vector<double>& w) {
      std::vector<double> mean(static_cast<size_t>(nb), 0.0);
      for (int b = 0; b < nb; ++b) mean[b] = c0[b] > 0 ? s0[b] / c0[b] : NAN;
      out.assign(static_cast<size_t>(nb), 0.0);
      w.assign(static_cast<size_t>(nb), 0.0);
      for (int b = 0; b < nb; ++b) {
        if (!std::isfinite(mean[b])) continue;
        double a = 0;
        int n = 0;
        for (int q = std::max(0, b - sm); q <= std::min(nb - 1, b + sm); ++q)
          if (std::isfinite(mean[q])) a += mean[q], ++n;
        out[b] = mean[b] - a / n;
        w[b] = c0[b];
      }
    };
    std::vector<double> whole, gw;
    detrend(gsum.data(), gcnt.data(), whole, gw);
    auto g_at = [&](double r) {
      const double t = (r - ring_min) / kBin - 0.5;
      const int b = static_cast<int>(std::floor(t));
      if (b < 0 || b + 1 >= nb) return 0.0;
      const double f = t - b;
      return (1 - f) * whole[b] + f * whole[b + 1];
    };
    // Least squares of a_j = e . u_j and b_j = d . u_j over the sectors with rings in them.
    double uxx = 0, uxy = 0, uyy = 0, sa_x = 0, sa_y = 0, sb_x = 0, sb_y = 0;
    std::vector<double> p, pw;
    std::vector<std::pair<double, double>> used;  // (radius, weight * value) of the filled bins
    const double amax = drift->offset_search_mm, bmax = drift->max_mm_per_mm;
    auto match = [&](double aq, double bq) {
      double v = 0;
      const double inv = 1.0 / (1 + bq);
      // The sector's ring at r is the whole profile's ring at (r - a) / (1 + b).
      for (const auto& [r, wv] : used) v += wv * g_at((r - aq) * inv);
      return v;
    };
    for (int j = 0; j < nsec; ++j) {
      detrend(&sum[static_cast<size_t>(j) * nb], &cnt[static_cast<size_t>(j) * nb], p, pw);
      used.clear();
      for (int b = 0; b < nb; ++b)
        if (pw[b] > 0) used.push_back({ring_min + (b + 0.5) * kBin, pw[b] * p[b]});
      if (static_cast<int>(used.size()) < nb / 2) continue;  // mostly outside the image or cut
      // A coarse grid (four times the steps), then twice a grid of half the last steps
      // around the best so far.
      double bestv = -1e300, ba = 0, bb = 0;
      double sa = 4 * drift->offset_step, sb = 4 * drift->drift_step;
      for (double bq = -bmax; bq <= bmax + 1e-9; bq += sb)
        for (double aq = -amax; aq <= amax + 1e-9; aq += sa) {
          const double v = match(aq, bq);
          if (v > bestv) bestv = v, ba = aq, bb = bq;
        }
      for (int finer = 0; finer < 2; ++finer) {
        sa *= 0.5, sb *= 0.5;
        const double ca = ba, cb = bb;
        for (int jb = -2; jb <= 2; ++jb)
          for (int ja = -2; ja <= 2; ++ja) {
            if (!ja && !jb) continue;
            const double aq = ca + ja * sa, bq = cb + jb * sb;
            if (std::abs(bq) > bmax + 1e-9 || std::abs(aq) > amax + 1e-9) continue;
            const double v = match(aq, bq);
            if (v > bestv) bestv = v, ba = aq, bb = bq;
          }
      }
      const double ux = std::cos((j + 0.5) * kTwoPi / nsec),
                   uy = std::sin((j + 0.5) * kTwoPi / nsec);
      uxx += ux * ux, uxy += ux * uy, uyy += uy * uy;
      sa_x += ba * ux, sa_y += ba * uy;
      sb_x += bb * ux, sb_y += bb * uy;
    }
    const double det = uxx * uyy - uxy * uxy;
    if (!(det > 0.1 * nsec * nsec / 4.0)) return res;  // too few sectors round the circle
    auto solve = [&](double bx, double by) {
      return Vec2{(uyy * bx - uxy * by) / det, (uxx * by - uxy * bx) / det};
    };
    const Vec2 e = solve(sa_x, sa_y);
    const Vec2 d = solve(sb_x, sb_y);
    res.ring_drift = d;
    // The pith: the concentric answer moved by the sectors' offset, then lined up again with
    // the drift.
    set_drift(d);
    const Vec2 guess{h * std::round((c.x + e.x) / h), h * std::round((c.y + e.y) / h)};
    const int ng = static_cast<int>(drift->offset_search_mm / grid_mm);
    bs = -1;
    for (int j = -ng; j <= ng; ++j)
      for (int i = -ng; i <= ng; ++i) {
        if (i * i + j * j > ng * ng) continue;
        const Vec2 q{guess.x + i * grid_mm, guess.y + j * grid_mm};
        const double v = score(q, nullptr);
        if (v > bs) bs = v, best = q;
      }
    climb(best, bs, 1e9);
    res.drift_gain = base_signal > 0 ? net_signal(best) / base_signal - 1.0 : 0.0;
  }
  best = {best.x + h * vertex(nbh[3], nbh[4], nbh[5]), best.y + h * vertex(nbh[1], nbh[4], nbh[7])};
  double noise = 0;
  bs = score(best, &noise);
  // Ring period: twice the profile's length over its sign changes (the slow trend removed).
  {
    int crossings = 0;
    double prev = 0;
    for (int b = 0; b < nb_all; ++b) {
      double a = 0;
      int n = 0;
      for (int j = std::max(0, b - lh); j <= std::min(nb_all - 1, b + lh); ++j) a += m[j], ++n;
      const double d = m[b] - a / n;
      if (d != 0 && prev != 0 && (d > 0) != (prev > 0)) ++crossings;
      if (d != 0) prev = d;
    }
    res.ring_period_mm = crossings > 0 ? 2.0 * nb_all * kRingBinMm / crossings : 0.0;
  }
  res.found = true;
  res.pith_mm = start + best;
  // Signal share of the profile energy: near 0 for noise, near 1 for clear rings.
  res.confidence = bs > 0 ? std::clamp((bs - noise) / bs, 0.0, 1.0) : 0.0;
  return res;
}

bool log_section(const Slice& slice, const VolumeGeometry& geometry, const PithOptions& options,
                 Vec2* centre_mm, double* radius_mm) {
  if (!slice_holds_pixels(slice)) return false;
  const WoodLevels lv = wood_levels(slice, options);
  if (!lv.found) return false;
  const Extent e = find_extent(slice, geometry, lv);
  if (!e.found) return false;
  *centre_mm = e.centre_mm;
  *radius_mm = e.radius_mm;
  return true;
}

std::vector<PithCandidate> pith_candidates(const Slice& slice, const VolumeGeometry& geometry,
                                           const PithOptions& options) {
  if (!slice_holds_pixels(slice)) return {};
  return candidates_without_prior(slice, geometry, options);
}

double wide_ring_score(const Slice& slice, const VolumeGeometry& geometry, Vec2 centre) {
  const ContourResult outline = detect_contour(slice, geometry, centre, {});
  std::vector<double> radius = outline.radius;
  if (!fill_circular(radius, outline.valid)) return 0.0;
  double mean = 0;
  for (double r : radius) mean += r;
  mean /= static_cast<double>(radius.size());
  const double wide = std::clamp(0.5 * mean, kRingMaxMm, kAcquireRingMaxMm);
  // The median over bands of radius: the pith's rings line up at every radius, a knot's only
  // out to its own radius, and a single strong step (a knot's rim, the heartwood border) lifts
  // one band, where over the whole range its energy could outweigh the rings'.
  const int bands = std::max(2, static_cast<int>(std::ceil((wide - kRingMinMm) / kWideBandMm)));
  const double width = (wide - kRingMinMm) / bands;
  std::vector<double> share;
  for (int b = 0; b < bands; ++b) {
    const PithResult rings =
        refine_pith_concentric(slice, geometry, centre, 0.0, &radius, kRingMinMm + (b + 1) * width,
                               kRingMinMm + b * width);
    share.push_back(rings.found ? rings.confidence : 0.0);
  }
  return median(share);
}

PithResult detect_pith(const Slice& slice, const VolumeGeometry& geometry,
                       const PithOptions& options, const Vec2* prior_mm) {
  if (!slice_holds_pixels(slice)) return {};
  if (prior_mm) {
    PithResult r = detect_with_prior(slice, geometry, options, *prior_mm);
    if (r.found || !options.fall_back_to_whole_slice) return r;
  }
  return detect_without_prior(slice, geometry, options);
}

}  // namespace sawyer::ct
