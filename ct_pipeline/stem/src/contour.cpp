// Outer contour under bark and heartwood border of one CT slice, by rays cast from the pith
// (issue 4). See stem_detect.h for the contract.
//
// Contour, per ray (n_angles rays, bilinear samples every pixel from the pith outwards, the ray
// stopped after 10 mm of air):
//   1. candidates are falling edges going outwards through the wood/bark level (midway between
//      wet sapwood and inner bark); the outermost candidate whose inside (1-4 mm) looks like
//      wood (median within the wood range, no bright sample) is the surface. So the bed's belt
//      (+200 HU) and rails (+2200 HU) are never taken for wood, bark gaps (wood next to air) are
//      found the same way, and rings of encased bark around dead knots lie inside the surface;
//   2. sub-pixel: the crossing, at 0.1 mm steps, of the level midway between the wood inside and
//      the bark (or air) 1 mm outside;
//   3. bark: from the surface to the first crossing into air, where there is one before anything
//      bright (the belt touching the bark hides it).
// Each ray's walk starts 12 mm inside the previous ray's surface (from the pith when there is
// none, or when that start is not in the wood); rays that found nothing from the pith (rot or a
// heart check at the centre reads as air and stops the walk) are tried again, going round once
// more, from the surface the ray before them found.
// The levels (the wood/bark level, the wood range, air) are options: fixed HU for a green log at
// the nominal calibration by default, from the scan's own levels in the stem pass
// (scan_levels.h), with the bark measured on the slice (bark_level).
// Rays whose surface is grossly off a robust Fourier fit of the outline (a second log touching,
// the belt) take their next candidate near the fit, or are dropped.
// Then a robust angular cleanup: angles off a running median by more than 1.5 mm are dropped
// (knots reaching the surface at a grazing angle, the belt), gaps are filled by interpolation
// and the result is smoothed with a 5-tap binomial.
//
// Heartwood, per ray: walking inwards from 3 mm under the surface, the first point where the
// (lightly smoothed) profile falls below the level midway between sapwood and heartwood, the
// slice's levels taken as medians near the surface and near the pith, and stays below it for
// 5 mm (so the 1 mm bark rings of dead knots are passed over). Knots crossing the heartwood look
// like sapwood and pull single rays inwards; a robust (Tukey) Fourier fit of order 4 rejects
// them, and rays off the fit by more than 3 mm take the fit's value.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

#include "sawyer/core/stats.h"
#include "sawyer/ct/stem/stem_detect.h"

namespace sawyer::ct {
namespace {

// Ray stops after this much air beyond the log.
constexpr double kAirStopMm = 10.0;
// A ray's walk starts this far inside the previous ray's edge (from the pith when that fails).
constexpr double kHintMm = 12.0;
// Inside a surface candidate: the window checked for wood, mm under the edge.
constexpr double kInsideNearMm = 0.8, kInsideFarMm = 4.0;
// The wood range for the inside median and the brightest sample allowed there are options
// (ContourOptions::wood_min_hu ...), from the scan's levels in the stem pass.
// Bark level: measured on every kBarkStride-th ray, from kBarkNearMm to kBarkFarMm inside the
// log's edge with air (the outer bark; the inner bark is denser, so the level midway between
// wood and it is crossed at or just outside the inner bark's edge).
constexpr int kBarkStride = 8;
constexpr double kBarkNearMm = 0.5, kBarkFarMm = 2.0;
// The bark's edge with air is where a ray falls through the level kBarkAirShare of the way from
// air to the densest wood mode, or kBarkAirSigmas noise sigmas above air where that is higher
// (dry bark reads -650 to -800 HU, air -1000).
constexpr double kBarkAirShare = 0.25, kBarkAirSigmas = 6.0;
// Bark is read where at least this share of the bark rays show it (the rest: bark missing, the
// bed), at least this share of the wood-air step under the densest wood.
constexpr double kBarkRayShare = 0.2, kBarkStepShare = 0.1;
// Sub-pixel refinement: outside level taken this far beyond the edge; search half-width; step.
constexpr double kOutsideMm = 1.0, kFineHalfMm = 1.2, kFineStepMm = 0.1;
// Bark: search this far beyond the surface for air.
constexpr double kMaxBarkMm = 30.0;
// Contour cleanup: running median half-window (angles at 360), outlier tolerance, largest gap
// filled (fraction of the circle), least fraction of angles found for the slice to count.
constexpr int kMedianHalf = 7;
constexpr double kOutlierMm = 1.5;
constexpr double kMaxGapFraction = 0.125;
constexpr double kMinFoundFraction = 0.2;
// Gross outliers: surface candidates kept per ray; Fourier order of the robust outline fit; a
// ray off it by more than kGrossMm or kGrossShare of the median radius (whichever is larger) takes
// its candidate nearest the fit within that, or is dropped when off by kGrossDropFactor times it
// (a lobed outline's misfit stays well inside that; a second log's far side does not).
constexpr int kMaxCandidates = 4, kGrossStride = 4;
constexpr int kGrossOrder = 4;
constexpr double kGrossMm = 8.0, kGrossShare = 0.08, kGrossDropFactor = 3.0;
// Heartwood.
constexpr double kHeartStartMm = 3.0;    // start the inward walk this far under the surface
constexpr double kHeartPersistMm = 5.0;  // the dry core must stay dry this long inwards
constexpr double kHeartOutlierMm = 3.0;  // rays off the robust fit by more take the fit
constexpr int kHeartOrder = 4;           // Fourier order of the robust fit
constexpr double kTukeyMm = 6.0;         // Tukey biweight constant of the fit
constexpr int kLevelStride = 4;          // rays used for the slice's HU levels
constexpr double kHeartStepPx = 2.0;     // step along the rays, pixels

class Sampler {
 public:
  Sampler(const Slice& s, const VolumeGeometry& g, float air_hu = -1000.0f)
      : air_(air_hu),
        d_(s.hu.data()),
        w_(s.width),
        h_(s.height),
        isx_(1.0 / g.spacing_x),
        isy_(1.0 / g.spacing_y) {}

  // Bilinear HU at scanner (x, y) mm; air outside the image.
  float at(double x, double y) const {
    const double c = x * isx_, r = y * isy_;
    if (!(c >= 0.0 && r >= 0.0 && c <= w_ - 1 && r <= h_ - 1)) return air_;
    int c0 = static_cast<int>(c), r0 = static_cast<int>(r);
    c0 = std::min(c0, w_ - 2);
    r0 = std::min(r0, h_ - 2);
    const float fc = static_cast<float>(c - c0), fr = static_cast<float>(r - r0);
    const float* p = d_ + static_cast<size_t>(r0) * w_ + c0;
    const float a = p[0] + fc * (p[1] - p[0]);
    const float b = p[w_] + fc * (p[w_ + 1] - p[w_]);
    return a + fr * (b - a);
  }

 private:
  float air_;
  const float* d_;
  int w_, h_;
  double isx_, isy_;
};

bool slice_ok(const Slice& s, const VolumeGeometry& g) {
  return s.width >= 2 && s.height >= 2 && s.hu.size() == static_cast<size_t>(s.width) * s.height &&
         g.spacing_x > 0 && g.spacing_y > 0;
}

// Farthest distance from p to the image's corners (mm).
double max_reach(const Slice& s, const VolumeGeometry& g, const Vec2& p) {
  const double X = (s.width - 1) * g.spacing_x, Y = (s.height - 1) * g.spacing_y;
  const double dx = std::max(std::abs(p.x), std::abs(X - p.x));
  const double dy = std::max(std::abs(p.y), std::abs(Y - p.y));
  return std::hypot(dx, dy);
}

// Drops angles off the circular running median by more than `tol`, fills gaps up to `max_gap`
// angles by linear interpolation (circularly); longer gaps stay invalid.
void clean_angles(std::vector<double>& r, std::vector<bool>& valid, int half, double tol,
                  int max_gap) {
  const int n = static_cast<int>(r.size());
  std::vector<float> win;
  std::vector<bool> keep(valid);
  for (int k = 0; k < n; ++k) {
    if (!valid[k]) continue;
    win.clear();
    for (int d = -half; d <= half; ++d) {
      const int j = ((k + d) % n + n) % n;
      if (valid[j]) win.push_back(static_cast<float>(r[j]));
    }
    if (win.size() < 3) {
      keep[k] = false;
      continue;
    }
    if (std::abs(r[k] - median_inplace(win)) > tol) keep[k] = false;
  }
  valid = keep;
  // Fill gaps between kept angles.
  int first = -1;
  for (int k = 0; k < n; ++k)
    if (valid[k]) {
      first = k;
      break;
    }
  if (first < 0) return;
  int prev = first;
  for (int step = 1; step <= n; ++step) {
    const int k = (first + step) % n;
    if (!valid[k]) continue;
    const int gap = ((k - prev) % n + n) % n;  // n when only one angle is valid
    if (gap > 1 && gap - 1 <= max_gap) {
      for (int g = 1; g < gap; ++g) {
        const int j = (prev + g) % n;
        const double t = static_cast<double>(g) / gap;
        r[j] = (1 - t) * r[prev] + t * r[k];
        valid[j] = true;
      }
    }
    prev = k;
  }
}

// Circular binomial smoothing [1 4 6 4 1] / 16 over runs of valid angles.
void smooth_angles(std::vector<double>& r, const std::vector<bool>& valid, int passes) {
  const int n = static_cast<int>(r.size());
  static constexpr double kW[5] = {1, 4, 6, 4, 1};
  std::vector<double> out(r);
  for (int p = 0; p < passes; ++p) {
    for (int k = 0; k < n; ++k) {
      if (!valid[k]) continue;
      double s = 0, w = 0;
      for (int d = -2; d <= 2; ++d) {
        const int j = ((k + d) % n + n) % n;
        if (!valid[j]) continue;
        s += kW[d + 2] * r[j];
        w += kW[d + 2];
      }
      out[k] = s / w;
    }
    r = out;
  }
}

// Robust Fourier fit of order `order` to the valid radii (Tukey biweight, IRLS, the order raised
// step by step from a constant). Returns false when too few angles are valid.
bool robust_fourier(const std::vector<double>& r, const std::vector<bool>& valid, int order,
                    std::vector<double>* fit) {
  const int n = static_cast<int>(r.size());
  const int m = 2 * order + 1;
  int count = 0;
  for (int k = 0; k < n; ++k) count += valid[k] ? 1 : 0;
  if (count < 2 * m) return false;
  std::vector<double> basis(static_cast<size_t>(n) * m);
  for (int k = 0; k < n; ++k) {
    const double w = kTwoPi * k / n;
    const double c1 = std::cos(w), s1 = std::sin(w);
    double* b = &basis[static_cast<size_t>(k) * m];
    b[0] = 1;
    // cos(o w), sin(o w) by the angle-addition recurrence (order is small: no drift to speak of).
    double co = 1, so = 0;
    for (int o = 1; o <= order; ++o) {
      const double cn = co * c1 - so * s1;
      so = so * c1 + co * s1;
      co = cn;
      b[2 * o - 1] = co;
      b[2 * o] = so;
    }
  }
  std::vector<float> vals;
  for (int k = 0; k < n; ++k)
    if (valid[k]) vals.push_back(static_cast<float>(r[k]));
  std::vector<double> coef(m, 0.0);
  coef[0] = median_inplace(vals);
  std::vector<double> A(static_cast<size_t>(m) * m), rhs(m);
  for (int o = 1; o <= order; ++o) {
    const int mm = 2 * o + 1;
    for (int it = 0; it < 4; ++it) {
      std::fill(A.begin(), A.end(), 0.0);
      std::fill(rhs.begin(), rhs.end(), 0.0);
      for (int k = 0; k < n; ++k) {
        if (!valid[k]) continue;
        const double* b = &basis[static_cast<size_t>(k) * m];
        double f = 0;
        for (int q = 0; q < mm; ++q) f += coef[q] * b[q];
        const double u = (r[k] - f) / kTukeyMm;
        if (std::abs(u) >= 1) continue;
        const double w = (1 - u * u) * (1 - u * u);
        for (int q = 0; q < mm; ++q) {
          rhs[q] += w * b[q] * r[k];
          for (int s = 0; s <= q; ++s) A[q * m + s] += w * b[q] * b[s];
        }
      }
      // Cholesky solve of the mm x mm system (lower triangle filled).
      std::vector<double> L(static_cast<size_t>(mm) * mm, 0.0);
      bool ok = true;
      for (int q = 0; q < mm && ok; ++q) {
        for (int s = 0; s <= q; ++s) {
          double v = A[q * m + s];
          for (int t = 0; t < s; ++t) v -= L[q * mm + t] * L[s * mm + t];
          if (q == s) {
            if (v <= 1e-9) {
              ok = false;
              break;
            }
            L[q * mm + q] = std::sqrt(v);
          } else {
            L[q * mm + s] = v / L[s * mm + s];
          }
        }
      }
      if (!ok) break;
      std::vector<double> y(mm);
      for (int q = 0; q < mm; ++q) {
        double v = rhs[q];
        for (int t = 0; t < q; ++t) v -= L[q * mm + t] * y[t];
        y[q] = v / L[q * mm + q];
      }
      for (int q = mm - 1; q >= 0; --q) {
        double v = y[q];
        for (int t = q + 1; t < mm; ++t) v -= L[t * mm + q] * coef[t];
        coef[q] = v / L[q * mm + q];
      }
    }
  }
  fit->assign(n, 0.0);
  for (int k = 0; k < n; ++k) {
    const double* b = &basis[static_cast<size_t>(k) * m];
    double f = 0;
    for (int q = 0; q < m; ++q) f += coef[q] * b[q];
    (*fit)[k] = f;
  }
  return true;
}

// The slice's bark level: on every kBarkStride-th ray from the pith, the median of the profile
// kBarkNearMm to kBarkFarMm (at least a pixel and a pixel and a half) inside the outermost fall
// through `air_edge` (the log's edge with air); over the rays, the median of those that read
// bark (below the wood, above air), or of all where too few do. NaN when no ray reached air. Each
// ray's walk starts kHintMm inside the previous one's edge when that is in the log (the pith
// otherwise), as the contour's rays do.
double bark_level(const Sampler& img, const Vec2& pith, double reach, double h,
                  const ContourOptions& o, double air_edge, int* rays) {
  const int air_stop = static_cast<int>(std::ceil(kAirStopMm / h));
  const int hint_back = static_cast<int>(std::ceil(2 * kHintMm / h));
  const double near = std::max(kBarkNearMm, h),
               far = near + std::max(kBarkFarMm - kBarkNearMm, 1.5 * h);
  std::vector<float> prof, win, per_ray;
  int hint = 0;
  for (int k = 0; k < o.n_angles; k += kBarkStride) {
    const double w = kTwoPi * k / o.n_angles;
    const double c = std::cos(w), s = std::sin(w);
    int j0 = std::max(0, hint - hint_back), e = -1;
    for (;;) {
      prof.clear();
      int air_run = 0;
      bool seen = false;
      for (int j = j0; j * h <= reach; ++j) {
        const float v = img.at(pith.x + j * h * c, pith.y + j * h * s);
        prof.push_back(v);
        if (v < air_edge) {
          if (seen && ++air_run >= air_stop) break;
        } else {
          seen = true;
          air_run = 0;
        }
      }
      e = -1;
      for (int j = static_cast<int>(prof.size()) - 2; j >= 0; --j)
        if (prof[j] >= air_edge && prof[j + 1] < air_edge) {
          e = j;
          break;
        }
      if (j0 > 0 && (e < 0 || prof[0] < air_edge)) {  // the hint was not in the log
        j0 = 0;
        continue;
      }
      break;
    }
    if (e < 0) continue;
    e += j0;
    hint = e;
    const double re =
        e * h + h * (prof[e - j0] - air_edge) / std::max(1e-6f, prof[e - j0] - prof[e - j0 + 1]);
    if (re - far < 0.5 * re) continue;  // a small object: not the log's edge
    win.clear();
    for (double r = re - far; r <= re - near + 1e-9; r += 0.25)
      win.push_back(img.at(pith.x + r * c, pith.y + r * s));
    per_ray.push_back(static_cast<float>(median_inplace(win)));
  }
  *rays = static_cast<int>(per_ray.size());
  if (per_ray.size() < 3) return NAN;
  // The rays read bark, wood where the bark is missing, or the bed's belt where the log lies on
  // it: bark is what lies clearly under the wood (a tenth of the wood-air step, two standard
  // errors of a ray's median) and above the edge with air. Where at least kBarkRayShare of the
  // rays see such bark, its median is the level; else the median of all (the wood: no bark).
  if (std::isfinite(o.outer_wood_hu)) {
    const double window = (far - near) / 0.25 + 1;
    const double below = o.outer_wood_hu - std::max(kBarkStepShare * (o.outer_wood_hu - o.air_hu),
                                                    2.0 * o.noise_hu / std::sqrt(window));
    std::vector<float> bark;
    for (float v : per_ray)
      if (v < below && v > air_edge) bark.push_back(v);
    if (bark.size() >= 3 && bark.size() >= kBarkRayShare * per_ray.size()) {
      *rays = static_cast<int>(bark.size());
      return median_inplace(bark);
    }
  }
  return median_inplace(per_ray);
}

// Dried wood (issue 41): the bark is barely lighter than the wood (50-120 HU, less than a noisy
// pixel's spread and less than the rings' own swing), so no level separates them on one ray, and
// the wood's level from the histogram (its mode: the earlywood, with strong rings) may even lie
// under the bark's. The bark is found instead as what it is: a layer under the log's edge with
// air whose CT numbers differ from the wood's in level and in texture (no rings).
//   1. The edge with air per ray, walking outwards from well inside the log: the first fall into
//      air that stays there for kWeakAirMm (a check's gap is narrower; the gap under loose bark
//      or before the bed's belt is wider). Edges far off a robust outline through them (the far
//      side of the belt the bark lies on) are dropped; those rays are filled from their
//      neighbours.
//   2. The profile inwards from it (kMaxBarkMm of bark and kWeakWoodMm of wood at most) is split
//      in two, bark above and wood below, where it is best explained as two stretches each of
//      its own mean and spread (a change point: t log var(bark) + (n - t) log var(wood), spreads
//      floored at half the scan's noise); the costs of the rays kWeakPoolDeg either side are
//      summed (the bark's thickness changes slowly round the log) and the split kept where it
//      beats no split by a BIC margin with the lighter stretch outside.
//   3. All rays' splits are then chosen together, as the least-cost path round the log (each
//      sample the split moves between neighbouring rays costs kWeakStepCost), with the slice's
//      typical bark barring splits deeper than twice the median first split and kWeakSpreadMm,
//      and those whose outer stretch is nearer the wood's median level than the bark's (a knot
//      under the surface, 300 HU denser than dry wood, otherwise draws its rays' splits down to
//      it with wood taken for bark).
//   4. To a fraction of a sample: the crossing nearest the split of the level midway between the
//      bark and the kWeakLevelMm of wood under it, on the profile averaged over the pooled rays
//      (the change point puts samples that mix bark and wood on the side with the larger spread).
// At coarser pixels a 2-4 mm bark is a sample or two, too few to tell its level and spread from
// the wood's, and a whorl's knots under the surface draw the splits down to them (the sweep's 29
// coarse dried scans with it: median 1.53 -> 1.16 mm RMS, but 6 worse, #46 2.35 -> 5.98 mm): the
// level's edge stays there.
constexpr double kWeakMaxPixelMm = 1.0;
constexpr double kWeakAirMm = 2.0;
constexpr double kWeakAirOffMm = 4.0, kWeakAirOffShare = 0.04;  // or this share of the radius
constexpr double kWeakWoodMm = 8.0;
constexpr double kWeakPoolDeg = 3.0;
constexpr double kWeakSpreadMm = 4.0;
constexpr double kWeakLevelMm = 2.0;
constexpr double kWeakStepCost = 10.0;
constexpr double kWeakBarkShare = 0.1;

void refine_weak_bark(const Sampler& img, const Vec2& pith, double h, const ContourOptions& o,
                      double air_edge, std::vector<double>& edge_r, std::vector<bool>& valid,
                      std::vector<double>& bark_mm) {
  const int n = static_cast<int>(edge_r.size());
  std::vector<double> r_air(n, NAN);
  std::vector<float> rv;
  for (int k = 0; k < n; ++k) {
    if (!valid[k]) continue;
    const double w = kTwoPi * k / n;
    const double c = std::cos(w), s = std::sin(w);
    // The edge with air: walking outwards from well inside the log (a quarter of the surface's
    // radius under it, deeper than any bark), the first fall through air_edge that stays in air
    // for kWeakAirMm: not a check's narrow gap, but the gap under loose bark (its wood is the
    // surface) and the gap before the bed's belt (which the surface may have been put on).
    // Unless something brighter than any wood comes first (rails, steel).
    const double step = 0.5 * h;
    const int persist = std::max(2, static_cast<int>(std::ceil(kWeakAirMm / step)));
    double r = std::max(h, 0.75 * edge_r[k]), cross = NAN;
    float prev = img.at(pith.x + r * c, pith.y + r * s);
    int run = 0;
    for (r += step; r <= edge_r[k] + kMaxBarkMm + kWeakAirMm; r += step) {
      const float v = img.at(pith.x + r * c, pith.y + r * s);
      if (v > o.wood_peak_hu) break;
      if (v < air_edge) {
        if (prev >= air_edge)
          cross = r - step + step * (prev - air_edge) / std::max(1e-6f, prev - v), run = 0;
        if (++run >= persist) {
          r_air[k] = cross;
          break;
        }
      } else {
        run = 0;
      }
      prev = v;
    }
    if (std::isfinite(r_air[k])) rv.push_back(static_cast<float>(r_air[k]));
  }
  if (rv.size() < 8) return;
  const double r_med = median_inplace(rv);
  // Edges with air far off a robust outline through them are not the log's (the far side of the
  // bed's belt where the bark lies on it, a gap too narrow to count): those rays are dropped
  // and filled from their neighbours.
  {
    std::vector<bool> has(n);
    for (int k = 0; k < n; ++k) has[k] = std::isfinite(r_air[k]);
    std::vector<double> fit, ra(r_air);
    for (double& v : ra)
      if (!std::isfinite(v)) v = 0;
    if (robust_fourier(ra, has, kGrossOrder, &fit)) {
      const double tol = std::max(kWeakAirOffMm, kWeakAirOffShare * r_med);
      for (int k = 0; k < n; ++k)
        if (has[k] && std::abs(r_air[k] - fit[k]) > tol) r_air[k] = NAN;
    }
  }
  const int nd = static_cast<int>(std::floor(std::min(kMaxBarkMm + kWeakWoodMm, 0.5 * r_med) / h));
  const int min_wood = static_cast<int>(std::ceil(std::min(kWeakWoodMm, 0.25 * nd * h) / h));
  const int t_max = nd - min_wood;
  if (t_max < 2) return;
  const double floor_var = std::max(1.0, 0.25 * o.noise_hu * o.noise_hu);
  // cost[k * (t_max + 1) + t]: ray k's profile split after t bark samples (at depths (i + 1) h),
  // twice the negative log-likelihood less constants; t = 0: one stretch.
  std::vector<double> cost(static_cast<size_t>(n) * (t_max + 1), 0.0);
  std::vector<double> s1(static_cast<size_t>(n) * (nd + 1)), s2(s1.size());
  std::vector<bool> usable(n, false);
  auto var = [&](int k, int a, int b) {  // spread of samples [a, b) of ray k
    const double* p1 = &s1[static_cast<size_t>(k) * (nd + 1)];
    const double* p2 = &s2[static_cast<size_t>(k) * (nd + 1)];
    const double m = (p1[b] - p1[a]) / (b - a);
    return std::max(floor_var, (p2[b] - p2[a]) / (b - a) - m * m);
  };
  for (int k = 0; k < n; ++k) {
    if (!std::isfinite(r_air[k]) || r_air[k] - nd * h < 0.25 * r_air[k]) continue;
    usable[k] = true;
    const double w = kTwoPi * k / n;
    const double c = std::cos(w), s = std::sin(w);
    double* p1 = &s1[static_cast<size_t>(k) * (nd + 1)];
    double* p2 = &s2[static_cast<size_t>(k) * (nd + 1)];
    p1[0] = p2[0] = 0;
    for (int i = 0; i < nd; ++i) {
      const double r = r_air[k] - (i + 1) * h;
      const double v = img.at(pith.x + r * c, pith.y + r * s);
      p1[i + 1] = p1[i] + v;
      p2[i + 1] = p2[i] + v * v;
    }
    double* ck = &cost[static_cast<size_t>(k) * (t_max + 1)];
    ck[0] = nd * std::log(var(k, 0, nd));
    for (int t = 1; t <= t_max; ++t)
      ck[t] = t * std::log(var(k, 0, t)) + (nd - t) * std::log(var(k, t, nd));
  }
  const int half = std::max(1, static_cast<int>(std::lround(kWeakPoolDeg * n / 360.0)));
  const double penalty = 3.0 * std::log(static_cast<double>(nd));  // per ray: mean, spread, split
  // The pooled costs and the pooled means outside and inside each split of one ray.
  std::vector<double> pooled(t_max + 1), p_out(t_max + 1), p_in(t_max + 1);
  // Calls f(j) on the usable rays j pooled with ray k; returns how many.
  auto each_pooled = [&](int k, auto&& f) {
    int rays = 0;
    for (int d = -half; d <= half; ++d) {
      const int j = ((k + d) % n + n) % n;
      if (usable[j]) ++rays, f(j);
    }
    return rays;
  };
  auto pool = [&](int k, int lim) {  // fills pooled, p_out, p_in for t <= lim; the rays pooled
    std::fill(pooled.begin(), pooled.begin() + lim + 1, 0.0);
    std::fill(p_out.begin(), p_out.begin() + lim + 1, 0.0);
    std::fill(p_in.begin(), p_in.begin() + lim + 1, 0.0);
    const int rays = each_pooled(k, [&](int j) {
      const double* cj = &cost[static_cast<size_t>(j) * (t_max + 1)];
      const double* p1 = &s1[static_cast<size_t>(j) * (nd + 1)];
      pooled[0] += cj[0];
      for (int t = 1; t <= lim; ++t) {
        pooled[t] += cj[t];
        p_out[t] += p1[t] / t;
        p_in[t] += (p1[nd] - p1[t]) / (nd - t);
      }
    });
    for (int t = 1; t <= lim; ++t) p_out[t] /= rays, p_in[t] /= rays;
    return rays;
  };
  auto choose = [&](int k, int lim, double* m_out, double* m_in) {
    const int rays = pool(k, lim);
    // The best split whose outer stretch is the lighter (else it is no bark), kept where it beats
    // no split by the penalty.
    int best = 0;
    for (int t = 1; t <= lim; ++t)
      if (p_out[t] < p_in[t] && (best == 0 || pooled[t] < pooled[best])) best = t;
    if (best == 0 || pooled[best] + penalty * rays >= pooled[0]) return 0;
    *m_out = p_out[best];
    *m_in = p_in[best];
    return best;
  };
  // The split to a fraction of a sample: the change-point puts samples that mix bark and wood
  // (the scanner's blur) on the side with the larger spread, the bark's when the edge with air is
  // in it. Instead, the crossing nearest the split of the level midway between the bark and the
  // wood just under it, on the profile averaged over the pooled rays.
  std::vector<double> mean_prof(nd);
  auto subsample = [&](int k, int t) {
    std::fill(mean_prof.begin(), mean_prof.end(), 0.0);
    const int rays = each_pooled(k, [&](int j) {
      const double* p1 = &s1[static_cast<size_t>(j) * (nd + 1)];
      for (int i = 0; i < nd; ++i) mean_prof[i] += p1[i + 1] - p1[i];
    });
    for (double& v : mean_prof) v /= rays;
    const int b0 = t >= 3 ? 1 : 0;  // the first sample may hold air
    const int w1 = std::min(nd, t + std::max(3, static_cast<int>(std::ceil(kWeakLevelMm / h))));
    double mb = 0, mw = 0;
    for (int i = b0; i < t; ++i) mb += mean_prof[i] / (t - b0);
    for (int i = t; i < w1; ++i) mw += mean_prof[i] / (w1 - t);
    const double level = 0.5 * (mb + mw);
    double depth = (t + 0.5) * h, off = 1e9;
    for (int i = std::max(1, t - 2); i <= std::min(nd - 1, t + 2); ++i) {
      const double a = mean_prof[i - 1], b = mean_prof[i];  // depths i h and (i + 1) h
      if (!(a < level && b >= level)) continue;
      const double d = i * h + h * (level - a) / std::max(1e-6, b - a);
      if (std::abs(d - (t + 0.5) * h) < off) off = std::abs(d - (t + 0.5) * h), depth = d;
    }
    return depth;
  };
  // The slice's typical bark, from each ray's own best split as deep as kMaxBarkMm: its depth
  // and level, and the wood's level under it.
  std::vector<float> depths, outs, ins;
  for (int k = 0; k < n; ++k) {
    double m_out = 0, m_in = 0;
    const int t = usable[k] ? choose(k, t_max, &m_out, &m_in) : 0;
    if (t == 0) continue;
    depths.push_back(static_cast<float>(t));
    outs.push_back(static_cast<float>(m_out));
    ins.push_back(static_cast<float>(m_in));
  }
  if (depths.size() < 8) return;
  const int lim = std::min(
      t_max, static_cast<int>(std::ceil(2.0 * median_inplace(depths) + kWeakSpreadMm / h)));
  const double bark_like = 0.5 * (median_inplace(outs) + median_inplace(ins));
  // The splits of all rays together: the path round the log through (ray, split) that costs
  // least, each ray's pooled cost (with the penalty for a split; splits deeper than `lim` or
  // whose outer stretch is not bark-like barred) plus kWeakStepCost per sample the split moves
  // from one ray to the next (the bark's thickness is continuous round the log, so a run of
  // rays whose best split jumps a ring deeper must be worth more than the jump). Two laps round
  // the circle, the second's path kept (the first settles where it starts).
  const int m = lim + 1;
  std::vector<double> data(static_cast<size_t>(n) * m, 0.0);
  for (int k = 0; k < n; ++k) {
    if (!usable[k]) continue;
    const int rays = pool(k, lim);
    double* dk = &data[static_cast<size_t>(k) * m];
    dk[0] = pooled[0];
    for (int t = 1; t <= lim; ++t)
      dk[t] = p_out[t] < p_in[t] && p_out[t] < bark_like ? pooled[t] + penalty * rays : 1e30;
    const double lo = *std::min_element(dk, dk + m);
    for (int t = 0; t <= lim; ++t) dk[t] -= lo;
  }
  const int laps = 2 * n;
  std::vector<double> acc(m), next(m);
  std::vector<int> from(static_cast<size_t>(laps) * m), arg(m);
  for (int t = 0; t < m; ++t) acc[t] = data[t];
  for (int q = 1; q < laps; ++q) {
    // L1 distance transform of acc: next[t] = min over u of acc[u] + kWeakStepCost |t - u|.
    for (int t = 0; t < m; ++t) next[t] = acc[t], arg[t] = t;
    for (int t = 1; t < m; ++t)
      if (next[t - 1] + kWeakStepCost < next[t])
        next[t] = next[t - 1] + kWeakStepCost, arg[t] = arg[t - 1];
    for (int t = m - 2; t >= 0; --t)
      if (next[t + 1] + kWeakStepCost < next[t])
        next[t] = next[t + 1] + kWeakStepCost, arg[t] = arg[t + 1];
    const double* dk = &data[static_cast<size_t>(q % n) * m];
    for (int t = 0; t < m; ++t) {
      acc[t] = next[t] + dk[t];
      from[static_cast<size_t>(q) * m + t] = arg[t];
    }
  }
  std::vector<int> split(n, 0);
  int t = static_cast<int>(std::min_element(acc.begin(), acc.end()) - acc.begin());
  for (int q = laps - 1; q >= n; --q) {
    split[q % n] = t;
    t = from[static_cast<size_t>(q) * m + t];
  }
  // A bare log (a debarked or dried disc: bark on fewer than kWeakBarkShare of the rays) keeps
  // the level's edges, which are the wood's own edge with air there. Else rays with bark take
  // the split, rays without keep the level's edge (the wood's edge where the bark is missing;
  // where it was missed, some depth in it, which is nearer than the edge with air), and rays
  // whose edge with air was not the log's are filled from their neighbours.
  int rays = 0, with_bark = 0;
  for (int k = 0; k < n; ++k) rays += usable[k], with_bark += usable[k] && split[k] > 0;
  if (with_bark < kWeakBarkShare * rays) return;
  for (int k = 0; k < n; ++k) {
    if (valid[k] && !std::isfinite(r_air[k])) valid[k] = false;
    if (!usable[k] || split[k] == 0) continue;
    const double depth = subsample(k, split[k]);
    edge_r[k] = r_air[k] - depth;
    bark_mm[k] = depth;
  }
}

}  // namespace

ContourResult detect_contour(const Slice& slice, const VolumeGeometry& geometry,
                             const Vec2& pith_mm, const ContourOptions& options) {
  assert(options.n_angles > 0);
  const int n = options.n_angles;
  ContourResult out;
  out.radius.assign(n, 0.0);
  out.valid.assign(n, false);
  out.bark_mm.assign(n, 0.0);
  if (!slice_ok(slice, geometry)) return out;

  const Sampler img(slice, geometry, static_cast<float>(options.air_hu));
  const double h = std::min(geometry.spacing_x, geometry.spacing_y);  // coarse step, mm
  const double reach = max_reach(slice, geometry, pith_mm);
  const int air_stop = static_cast<int>(std::ceil(kAirStopMm / h));
  const int in_near = std::max(1, static_cast<int>(std::floor(kInsideNearMm / h)));
  const int in_far = std::max(in_near + 2, static_cast<int>(std::ceil(kInsideFarMm / h)));
  const int fine_n = static_cast<int>(std::lround(2 * kFineHalfMm / kFineStepMm)) + 1;
  const double air_level = 0.5 * (options.wood_hu + options.air_hu);  // bark → air crossing
  // Wood → bark level: midway between the outer wood (wet sapwood) and the bark, which also
  // lies between wood and air, so bark gaps are found the same way. From the scan's levels and
  // this slice's bark when given, else the options' fixed level. The inside of a surface must be
  // at least as dense as the level (bark is not; wood is).
  double edge_level = options.under_bark_hu, wood_min = options.wood_min_hu;
  // The log's edge with air, where rays stop after kAirStopMm below it: near air, below any bark
  // or wood, from the scan's levels; else the options' air/log threshold. (The log threshold, 60 %
  // of the way from air to the lightest wood mode, lies above a green log's outer bark when the
  // log has no dry core, and above a dry core when the bark is the lightest mode: the bark was
  // read as air and the wood under it as bark, or rays stopped in the heartwood.)
  const double air_edge =
      std::isfinite(options.outer_wood_hu)
          ? std::min(
                options.wood_hu,
                options.air_hu + std::max(kBarkAirShare * (options.outer_wood_hu - options.air_hu),
                                          kBarkAirSigmas * options.noise_hu))
          : options.wood_hu;
  if (std::isfinite(options.outer_wood_hu)) {
    int rays = 0;
    out.bark_hu = bark_level(img, pith_mm, reach, h, options, air_edge, &rays);
    // The bark level is a median over many rays: lighter than the wood by a few of its standard
    // errors is bark (a dried log's bark is only 50-120 HU lighter than its wood, under 2 pixel
    // sigmas of a noisy scan). Where the bark is missing the outermost fall through any level
    // between wood and air is the surface all the same.
    const double se = options.noise_hu / std::sqrt(std::max(1, rays));
    out.bark_seen = std::isfinite(out.bark_hu) &&
                    options.outer_wood_hu - out.bark_hu >= options.bark_sigmas * se;
    const double outside = out.bark_seen ? out.bark_hu : options.air_hu;
    edge_level = 0.5 * (options.outer_wood_hu + outside);
    // The inside of a surface: nearer the wood than the bark (a fall within noisy bark has bark
    // inside); not the edge level itself, which a wood level a little under the histogram's mode
    // (moisture, drift along the log) would fail.
    wood_min = edge_level - 0.25 * (options.outer_wood_hu - outside);
  }
  out.under_bark_hu = edge_level;

  std::vector<float> prof, inside, fine(fine_n);
  std::vector<double> edge_r(n, 0.0);
  // Every ray's surface candidates (coarse index from the pith, inside median), outermost
  // first: the outermost is taken; another where the outermost is a gross outlier (below).
  struct Candidate {
    int j;
    float med;
  };
  std::vector<Candidate> cands(static_cast<size_t>(n) * kMaxCandidates);
  std::vector<int> n_cands(n, 0);
  // Sub-pixel: the crossing of the level midway between inside and outside nearest to the
  // coarse crossing rc, at kFineStepMm steps.
  auto subpixel = [&](double c, double s, double rc, double in_level) {
    const double out_v = std::max<double>(
        options.air_hu,
        img.at(pith_mm.x + (rc + kOutsideMm) * c, pith_mm.y + (rc + kOutsideMm) * s));
    const double level = 0.5 * (in_level + out_v);
    const double r0 = rc - kFineHalfMm;
    for (int q = 0; q < fine_n; ++q) {
      const double r = r0 + q * kFineStepMm;
      fine[q] = img.at(pith_mm.x + r * c, pith_mm.y + r * s);
    }
    double best = rc, best_d = 1e9;
    for (int q = 0; q + 1 < fine_n; ++q) {
      if (!(fine[q] >= level && fine[q + 1] < level)) continue;
      const double r =
          r0 + kFineStepMm * (q + (fine[q] - level) / std::max(1e-6f, fine[q] - fine[q + 1]));
      if (std::abs(r - rc) < best_d) {
        best_d = std::abs(r - rc);
        best = r;
      }
    }
    return best;
  };
  int found = 0;
  int hint = 0;  // the previous ray's edge (coarse index): the walk starts kHintMm inside it
  const int hint_back = static_cast<int>(std::ceil(kHintMm / h));
  // One ray: its surface candidates, the surface (edge_r, valid), its bark; `hint` updated.
  std::vector<int> coarse_edge(n, -1);
  auto ray = [&](int k) {
    const double w = kTwoPi * k / n;
    const double c = std::cos(w), s = std::sin(w);
    int j0 = std::max(0, hint - hint_back);
    int edge = -1, np = 0;
    double in_level = 0;
    for (;;) {
      // Coarse profile outwards from j0 (prof[q] is at r = (j0 + q) h), stopped in air.
      prof.clear();
      int air_run = 0;
      bool seen = false;
      for (int j = j0; j * h <= reach; ++j) {
        const double r = j * h;
        const float v = img.at(pith_mm.x + r * c, pith_mm.y + r * s);
        prof.push_back(v);
        if (v < air_edge) {
          if (seen && ++air_run >= air_stop) break;
        } else {
          seen = true;
          air_run = 0;
        }
      }
      // Outermost falling edge with wood inside (and the next few inwards).
      np = static_cast<int>(prof.size());
      n_cands[k] = 0;
      for (int j = np - 2; j >= 1 && n_cands[k] < kMaxCandidates; --j) {
        if (!(prof[j] >= edge_level && prof[j + 1] < edge_level)) continue;
        inside.clear();
        float peak = -1e9f;
        for (int q = std::max(0, j - in_far); q <= j - in_near; ++q) {
          inside.push_back(prof[q]);
          peak = std::max(peak, prof[q]);
        }
        if (inside.empty()) continue;
        const double med = median_inplace(inside);
        if (med < wood_min || med > options.wood_max_hu || peak > options.wood_peak_hu) continue;
        if (edge < 0) {
          edge = j;
          in_level = med;
        }
        cands[static_cast<size_t>(k) * kMaxCandidates + n_cands[k]++] = {j + j0,
                                                                         static_cast<float>(med)};
        j -= in_near;  // the next candidate lies inside this one's window
      }
      // Started from a hint: trust it only with wood well inside the start; else from the pith.
      if (j0 > 0 && (edge < 0 || edge < in_far + 2 || prof[0] < edge_level)) {
        j0 = 0;
        edge = -1;
        n_cands[k] = 0;
        continue;
      }
      break;
    }
    if (edge < 0) return;
    // From here on indices are from the pith.
    prof.insert(prof.begin(), j0, 0.0f);
    edge += j0;
    np += j0;
    hint = edge;
    coarse_edge[k] = edge;
    // Sub-pixel: crossing of the level midway between inside and outside.
    const double rc =
        edge * h + h * (prof[edge] - edge_level) / std::max(1e-6f, prof[edge] - prof[edge + 1]);
    const double best = subpixel(c, s, rc, in_level);
    edge_r[k] = best;
    out.valid[k] = true;
    ++found;
    // Bark: the first crossing into air beyond the surface, unless something bright (the
    // belt, clutter) comes first.
    const int jmax = std::min(np - 1, edge + static_cast<int>(std::ceil(kMaxBarkMm / h)));
    for (int j = edge + 1; j < jmax; ++j) {
      if (prof[j + 1] >= edge_level) break;
      if (prof[j] >= air_level && prof[j + 1] < air_level) {
        const double ro =
            j * h + h * (prof[j] - air_level) / std::max(1e-6f, prof[j] - prof[j + 1]);
        out.bark_mm[k] = std::max(0.0, ro - best);
        break;
      }
    }
  };
  for (int k = 0; k < n; ++k) ray(k);
  // Rays that found no surface while the walk started from the pith (the first rays, or those
  // after a failed run: rot or a crack at the centre reads as air and stops the walk) are tried
  // again from the nearest surface found before them, going round once more.
  if (found > 0 && found < n) {
    int first = 0;
    while (coarse_edge[first] < 0) ++first;
    hint = coarse_edge[first];
    for (int t = 1; t < n; ++t) {
      const int k = (first + t) % n;
      if (coarse_edge[k] >= 0)
        hint = coarse_edge[k];
      else
        ray(k);
    }
  }
  if (found < kMinFoundFraction * n) {
    std::fill(out.valid.begin(), out.valid.end(), false);
    std::fill(out.bark_mm.begin(), out.bark_mm.end(), 0.0);
    return out;
  }
  // Gross outliers (a second log touching this one, the belt, clutter: the outermost surface
  // with wood inside is theirs) off a robust Fourier fit of the outline: the ray's candidate
  // nearest the fit instead when it is near it, dropped when far off and none is.
  // The fit on every kGrossStride-th ray (an order-4 outline is smooth at that spacing; the fit
  // costs a fraction of the slice's time), interpolated linearly between them.
  std::vector<double> fit, sub_r, sub_fit;
  std::vector<bool> sub_valid;
  const int gs = n % kGrossStride == 0 && n >= 90 * kGrossStride ? kGrossStride : 1;
  for (int k = 0; k < n; k += gs) {
    sub_r.push_back(edge_r[k]);
    sub_valid.push_back(out.valid[k]);
  }
  if (robust_fourier(sub_r, sub_valid, kGrossOrder, &sub_fit)) {
    const int m = static_cast<int>(sub_fit.size());
    fit.resize(n);
    for (int k = 0; k < n; ++k) {
      const int a = k / gs, b = (a + 1) % m;
      const double t = static_cast<double>(k % gs) / gs;
      fit[k] = (1 - t) * sub_fit[a] + t * sub_fit[b];
    }
    std::vector<float> rv;
    for (int k = 0; k < n; ++k)
      if (out.valid[k]) rv.push_back(static_cast<float>(edge_r[k]));
    const double tol = std::max(kGrossMm, kGrossShare * median_inplace(rv));
    for (int k = 0; k < n; ++k) {
      if (!out.valid[k] || std::abs(edge_r[k] - fit[k]) <= tol) continue;
      const Candidate* pick = nullptr;
      for (int i = 1; i < n_cands[k]; ++i) {
        const Candidate& q = cands[static_cast<size_t>(k) * kMaxCandidates + i];
        if (std::abs(q.j * h - fit[k]) <= tol &&
            (!pick || std::abs(q.j * h - fit[k]) < std::abs(pick->j * h - fit[k])))
          pick = &q;
      }
      if (pick) {
        const double w = kTwoPi * k / n;
        const double c = std::cos(w), s = std::sin(w);
        const double a = img.at(pith_mm.x + pick->j * h * c, pith_mm.y + pick->j * h * s);
        const double b =
            img.at(pith_mm.x + (pick->j + 1) * h * c, pith_mm.y + (pick->j + 1) * h * s);
        const double rc = pick->j * h + h * (a - edge_level) / std::max(1e-6, a - b);
        edge_r[k] = subpixel(c, s, rc, pick->med);
        out.bark_mm[k] = 0.0;
      } else if (std::abs(edge_r[k] - fit[k]) > kGrossDropFactor * tol) {
        out.valid[k] = false;
      }
    }
  }
  // Dried wood: the bark found by its level and texture under the edge with air instead.
  if (options.dried && std::isfinite(options.outer_wood_hu) && h <= kWeakMaxPixelMm)
    refine_weak_bark(img, pith_mm, h, options, air_edge, edge_r, out.valid, out.bark_mm);
  const std::vector<bool> measured = out.valid;
  const int half = std::max(2, static_cast<int>(std::lround(kMedianHalf * n / 360.0)));
  clean_angles(edge_r, out.valid, half, kOutlierMm,
               static_cast<int>(std::lround(kMaxGapFraction * n)));
  smooth_angles(edge_r, out.valid, 1);
  for (int k = 0; k < n; ++k) {
    out.radius[k] = out.valid[k] ? edge_r[k] : 0.0;
    if (!out.valid[k] || !measured[k]) out.bark_mm[k] = 0.0;
  }
  return out;
}

HeartwoodResult detect_heartwood(const Slice& slice, const VolumeGeometry& geometry,
                                 const Vec2& pith_mm, const ContourResult& contour,
                                 const HeartwoodOptions& options) {
  assert(options.n_angles > 0);
  const int n = options.n_angles;
  HeartwoodResult out;
  out.radius.assign(n, 0.0);
  out.valid.assign(n, false);
  if (!slice_ok(slice, geometry) || contour.radius.empty()) return out;
  const int nc = static_cast<int>(contour.radius.size());

  // Outer radius at this ray's azimuth, from the contour's (possibly different) angular grid.
  auto outer_at = [&](int k, double* R) {
    const double u = static_cast<double>(k) * nc / n;
    const int a = static_cast<int>(std::floor(u)) % nc, b = (a + 1) % nc;
    const double t = u - std::floor(u);
    if (!contour.valid[a] || !contour.valid[b]) return false;
    *R = (1 - t) * contour.radius[a] + t * contour.radius[b];
    return true;
  };

  const Sampler img(slice, geometry);
  // Step along the rays: two pixels (the transition is 4 mm wide; rays are smoothed in angle).
  const double h = kHeartStepPx * std::min(geometry.spacing_x, geometry.spacing_y);
  // Slice levels from every kLevelStride-th ray: sapwood just under the surface, heartwood
  // around the pith (away from the pith's own knots).
  std::vector<float> sap, heart;
  int rays = 0;
  for (int k = 0; k < n; ++k) {
    double R;
    if (!outer_at(k, &R) || R - kHeartStartMm < 8 * h) continue;
    ++rays;
    if (k % kLevelStride != 0) continue;
    const double w = kTwoPi * k / n;
    const double c = std::cos(w), s = std::sin(w);
    for (double q = R - 8.0; q <= R - kHeartStartMm; q += h)
      sap.push_back(img.at(pith_mm.x + q * c, pith_mm.y + q * s));
    for (double q = 0.15 * R; q <= 0.35 * R; q += h)
      heart.push_back(img.at(pith_mm.x + q * c, pith_mm.y + q * s));
  }
  if (rays < kMinFoundFraction * n || sap.empty() || heart.empty()) return out;
  const double sap_level = median_inplace(sap), heart_level = median_inplace(heart);
  if (sap_level - heart_level < options.min_contrast_hu) return out;
  out.present = true;
  const double level = 0.5 * (sap_level + heart_level);
  const int persist = std::max(2, static_cast<int>(std::ceil(kHeartPersistMm / h)));

  // Per ray, inwards from kHeartStartMm under the surface: raw[m] is at r = (J - m) h, sampled
  // as far as the walk needs; p(m) the [1 2 1]-smoothed profile.
  std::vector<double> r(n, 0.0);
  std::vector<bool> valid(n, false);
  std::vector<float> raw, win;
  for (int k = 0; k < n; ++k) {
    double R;
    if (!outer_at(k, &R)) continue;
    const int J = static_cast<int>(std::floor((R - kHeartStartMm) / h));
    if (J < 8) continue;
    const double w = kTwoPi * k / n;
    const double c = std::cos(w), s = std::sin(w);
    raw.clear();
    auto need = [&](int m) {  // raw[0..m] sampled (clamped at the pith)
      m = std::min(m, J);
      while (static_cast<int>(raw.size()) <= m) {
        const double q = (J - static_cast<int>(raw.size())) * h;
        raw.push_back(img.at(pith_mm.x + q * c, pith_mm.y + q * s));
      }
    };
    auto p = [&](int m) {
      need(m + 1);
      if (m <= 0 || m >= J) return raw[m];
      return 0.25f * (raw[m - 1] + 2 * raw[m] + raw[m + 1]);
    };
    float prev = p(1);
    if (prev < level) continue;  // no sapwood under the surface
    for (int m = 2; m <= J; ++m) {
      const float pm = p(m), before = prev;
      prev = pm;
      if (!(pm < level && before >= level)) continue;
      win.clear();
      for (int q = m; q <= std::min(J, m + persist); ++q) win.push_back(p(q));
      if (median_inplace(win) >= level) continue;  // a thin dark ring, not the dry core
      r[k] = h * ((J - m) + (level - pm) / std::max(1e-6f, before - pm));
      valid[k] = true;
      break;
    }
  }
  std::vector<double> fit;
  if (!robust_fourier(r, valid, kHeartOrder, &fit)) {
    out.present = false;
    return out;
  }
  // Rays near the fit keep their own value (smoothed); the rest, and rays without a border,
  // take the fit.
  std::vector<bool> near(n, false);
  for (int k = 0; k < n; ++k) near[k] = valid[k] && std::abs(r[k] - fit[k]) <= kHeartOutlierMm;
  for (int k = 0; k < n; ++k)
    if (!near[k]) r[k] = fit[k];
  std::vector<bool> all(n, true);
  smooth_angles(r, all, 2);
  for (int k = 0; k < n; ++k) {
    double R;
    const bool has_outer = outer_at(k, &R);
    out.valid[k] = has_outer && r[k] > 0 && r[k] < R;
    out.radius[k] = out.valid[k] ? r[k] : 0.0;
  }
  return out;
}

bool fill_circular(std::vector<double>& row, const std::vector<bool>& valid) {
  const int n = static_cast<int>(row.size());
  int first = -1;
  for (int k = 0; k < n; ++k)
    if (valid[k]) {
      first = k;
      break;
    }
  if (first < 0) return false;
  int prev = first;
  for (int step = 1; step <= n; ++step) {
    const int k = (first + step) % n;
    if (!valid[k]) continue;
    const int gap = (k - prev + n) % n;
    for (int j = 1; j < gap; ++j) {
      const double t = static_cast<double>(j) / gap;
      row[(prev + j) % n] = (1 - t) * row[prev] + t * row[k];
    }
    prev = k;
  }
  return true;
}

}  // namespace sawyer::ct
