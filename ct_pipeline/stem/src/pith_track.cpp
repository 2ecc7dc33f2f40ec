// Pith tracking along z and its robust smoothing (see pith_track.h).
#include "sawyer/ct/pith_track.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace sawyer::ct {

namespace {
constexpr double kMaxStepMm = 4.0;  // largest accepted pith move between tracked slices
}  // namespace

PithTracker::PithTracker(const VolumeGeometry& geometry, const PithOptions& options,
                         double min_confidence)
    : geometry_(geometry), options_(options), min_confidence_(min_confidence) {}

PithResult PithTracker::next(const Slice& slice) {
  PithResult r = detect_pith(slice, geometry_, options_, last_ ? &*last_ : nullptr);
  if (last_ && r.found && r.confidence < min_confidence_) {
    // Weak near the prior: search the whole slice and keep the better answer.
    PithResult q = detect_pith(slice, geometry_, options_, nullptr);
    if (q.found && q.confidence > r.confidence) r = q;
  }
  // A pith moves little from slice to slice: a jump is not trusted as the next prior.
  const bool jump = last_ && r.found && (r.pith_mm - *last_).norm() > kMaxStepMm;
  if (r.found && r.confidence >= min_confidence_ && !jump) last_ = r.pith_mm;
  return r;
}

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Weighted local linear fit of (z, x), (z, y) at z0; false if the weights are degenerate.
bool local_linear(const std::vector<double>& z, const std::vector<Vec2>& p,
                  const std::vector<double>& w, double z0, double h, Vec2* out) {
  double s0 = 0, s1 = 0, s2 = 0, tx = 0, ty = 0, ux = 0, uy = 0;
  for (size_t i = 0; i < z.size(); ++i) {
    if (w[i] <= 0) continue;
    const double d = (z[i] - z0) / h;
    if (std::abs(d) >= 1) continue;
    const double k = std::pow(1 - std::pow(std::abs(d), 3), 3) * w[i];
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
                                    const PithTrackOptions& options) {
  assert(z.size() == raw.size());
  const size_t n = z.size();
  std::vector<Vec2> p(n);
  std::vector<double> prior_w(n, 0.0);
  bool any = false;
  for (size_t i = 0; i < n; ++i) {
    p[i] = raw[i].pith_mm;
    if (raw[i].found) prior_w[i] = std::max(0.05, raw[i].confidence), any = true;
  }
  if (!any) return {};
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
      for (size_t j = 0; j < n; ++j)
        if (prior_w[j] > 0 && std::abs(z[j] - z[i]) <= options.window_mm)
          xs.push_back(p[j].x), ys.push_back(p[j].y);
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
  return fit;
}

}  // namespace sawyer::ct
