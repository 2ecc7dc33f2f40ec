// The pith where a whorl's knot streaks meet (see pith_whorl.h).
#include "sawyer/ct/stem/pith_whorl.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace sawyer::ct {

namespace {

double median_in_place(std::vector<float>& v) {
  if (v.empty()) return 0;
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(m), v.end());
  return v[m];
}

// Distance of the line (c, d) from p, and p's position along it from c.
double line_distance(const WhorlStreak& s, Vec2 p) {
  const Vec2 q = p - s.centre_mm;
  return std::abs(q.x * s.direction.y - q.y * s.direction.x);
}
double along(const WhorlStreak& s, Vec2 p) {
  const Vec2 q = p - s.centre_mm;
  return q.x * s.direction.x + q.y * s.direction.y;
}

// The angle (radians, 0..pi/2) between two undirected lines.
double line_angle(const WhorlStreak& a, const WhorlStreak& b) {
  const double c = std::abs(a.direction.x * b.direction.x + a.direction.y * b.direction.y);
  return std::acos(std::min(1.0, c));
}

// The point nearest (weighted least squares) to the lines `which` marks; false when they are
// (nearly) parallel.
bool meet(const std::vector<WhorlStreak>& s, const std::vector<double>& w, Vec2* p) {
  double a = 0, b = 0, c = 0, bx = 0, by = 0;
  for (size_t k = 0; k < s.size(); ++k) {
    if (w[k] <= 0) continue;
    // Projection onto the line's normal: I - d d^T.
    const Vec2 d = s[k].direction;
    const double m00 = 1 - d.x * d.x, m01 = -d.x * d.y, m11 = 1 - d.y * d.y;
    a += w[k] * m00, b += w[k] * m01, c += w[k] * m11;
    bx += w[k] * (m00 * s[k].centre_mm.x + m01 * s[k].centre_mm.y);
    by += w[k] * (m01 * s[k].centre_mm.x + m11 * s[k].centre_mm.y);
  }
  const double det = a * c - b * b;
  const double tr = a + c;
  if (tr <= 0 || det <= 1e-3 * tr * tr) return false;
  *p = {(c * bx - b * by) / det, (a * by - b * bx) / det};
  return true;
}

}  // namespace

std::vector<WhorlStreak> knot_streaks(const SliceCrop& crop, const VolumeGeometry& g,
                                      Vec2 region_centre, double region_radius_mm, double noise_hu,
                                      const WhorlPithOptions& o) {
  std::vector<WhorlStreak> streaks;
  const int w = crop.width, h = crop.height;
  if (w < 5 || h < 5 || region_radius_mm <= 0 || crop.hu.size() != static_cast<size_t>(w) * h)
    return streaks;
  const double sx = g.spacing_x, sy = g.spacing_y;
  const double pixel = std::max(sx, sy);
  // A 3 x 3 mean: a third of the noise, knots (several pixels wide) keep their level.
  std::vector<float> sm(static_cast<size_t>(w) * h, 0.f);
  for (int y = 1; y + 1 < h; ++y)
    for (int x = 1; x + 1 < w; ++x) {
      float sum = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) sum += crop.hu[static_cast<size_t>(y + dy) * w + x + dx];
      sm[static_cast<size_t>(y) * w + x] = sum / 9.f;
    }
  // The region's pixels (inside the disc, off the crop's border) and its wood level and spread.
  std::vector<char> inside(static_cast<size_t>(w) * h, 0);
  std::vector<float> wood;
  const double r2 = region_radius_mm * region_radius_mm;
  for (int y = 1; y + 1 < h; ++y)
    for (int x = 1; x + 1 < w; ++x) {
      const double px = (crop.x0 + x) * sx - region_centre.x,
                   py = (crop.y0 + y) * sy - region_centre.y;
      if (px * px + py * py > r2) continue;
      const size_t k = static_cast<size_t>(y) * w + x;
      inside[k] = 1;
      const float v = crop.hu[k];
      if (v >= crop.wood_min_hu && v <= crop.wood_max_hu) wood.push_back(sm[k]);
    }
  if (wood.size() < 50) return streaks;
  const double level = median_in_place(wood);
  for (float& v : wood) v = static_cast<float>(std::abs(v - level));
  const double spread = 1.4826 * median_in_place(wood);
  const double threshold =
      level + std::max(o.noise_sigmas * noise_hu / 3.0, o.spread_sigmas * spread);
  // Nothing wooden stands more than about 1000 HU above the wood around it (a resin-soaked knot
  // in dry heartwood: 1.2 against 0.45 g/cm3); brighter pixels are metal or its streaks, and are
  // left out so that a streak across a knot does not join it.
  const double ceiling = level + o.max_step_hu;
  const auto bright = [&](size_t k) { return sm[k] > threshold && sm[k] < ceiling; };
  // Bright connected regions (4-connected), their moments in mm.
  std::vector<int> label(static_cast<size_t>(w) * h, 0);
  std::vector<int> stack;
  const double min_area_mm2 = std::max(6.0 * sx * sy, 4.0);
  int next = 0;
  for (int y0 = 1; y0 + 1 < h; ++y0)
    for (int x0 = 1; x0 + 1 < w; ++x0) {
      const size_t k0 = static_cast<size_t>(y0) * w + x0;
      if (!inside[k0] || label[k0] || !bright(k0)) continue;
      label[k0] = ++next;
      stack.assign(1, static_cast<int>(k0));
      double n = 0, mx = 0, my = 0, mxx = 0, myy = 0, mxy = 0;
      while (!stack.empty()) {
        const int k = stack.back();
        stack.pop_back();
        const int x = k % w, y = k / w;
        const double px = (crop.x0 + x) * sx, py = (crop.y0 + y) * sy;
        n += 1, mx += px, my += py, mxx += px * px, myy += py * py, mxy += px * py;
        const int nb[4] = {k - 1, k + 1, k - w, k + w};
        for (int j : nb) {
          const size_t u = static_cast<size_t>(j);
          if (inside[u] && !label[u] && bright(u)) {
            label[u] = next;
            stack.push_back(j);
          }
        }
      }
      if (n * sx * sy < min_area_mm2) continue;
      mx /= n, my /= n;
      const double cxx = mxx / n - mx * mx, cyy = myy / n - my * my, cxy = mxy / n - mx * my;
      const double tr = cxx + cyy, det = cxx * cyy - cxy * cxy;
      const double disc = std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
      const double l1 = 0.5 * tr + disc, l2 = std::max(0.5 * tr - disc, 1e-12);
      WhorlStreak s;
      s.centre_mm = {mx, my};
      // A uniform bar of length L has variance L^2 / 12 along it; a pixel-wide one, a pixel's.
      s.length_mm = std::sqrt(12.0 * l1);
      s.width_mm = std::max(std::sqrt(12.0 * l2), pixel);
      const double angle = 0.5 * std::atan2(2 * cxy, cxx - cyy);
      s.direction = {std::cos(angle), std::sin(angle)};
      if (s.length_mm >= o.min_length_mm && s.length_mm >= o.min_elongation * s.width_mm)
        streaks.push_back(s);
    }
  std::sort(streaks.begin(), streaks.end(),
            [](const WhorlStreak& a, const WhorlStreak& b) { return a.length_mm > b.length_mm; });
  if (static_cast<int>(streaks.size()) > o.max_streaks)
    streaks.resize(static_cast<size_t>(o.max_streaks));
  return streaks;
}

WhorlPith meet_streaks(std::vector<WhorlStreak> streaks, std::vector<double> weight,
                       Vec2 region_centre, double region_radius_mm, double pixel,
                       const WhorlPithOptions& o) {
  WhorlPith out;
  if (weight.size() != streaks.size()) weight.assign(streaks.size(), 1.0);
  // The heaviest (weight times length) first; at most max_streaks of them.
  std::vector<size_t> order(streaks.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return weight[a] * streaks[a].length_mm > weight[b] * streaks[b].length_mm;
  });
  if (static_cast<int>(order.size()) > o.max_streaks)
    order.resize(static_cast<size_t>(o.max_streaks));
  {
    std::vector<WhorlStreak> s2;
    std::vector<double> w2;
    for (size_t k : order) s2.push_back(streaks[k]), w2.push_back(weight[k]);
    streaks.swap(s2), weight.swap(w2);
  }
  out.streaks = streaks;
  const size_t m = streaks.size();
  if (m < 2) return out;
  const double tol = o.max_residual_mm + 0.5 * pixel;
  const double min_angle = o.min_angle_deg * kPi / 180.0;
  // A streak fits a meeting point p when its line passes close to p and p lies beyond its
  // inner part (along the line, not within the middle of the streak), inside the region.
  auto fits = [&](const WhorlStreak& s, Vec2 p) {
    return line_distance(s, p) <= tol && std::abs(along(s, p)) >= 0.3 * s.length_mm;
  };
  auto inliers_of = [&](Vec2 p, std::vector<double>* wts) {
    int count = 0;
    wts->assign(m, 0.0);
    for (size_t k = 0; k < m; ++k)
      if (fits(streaks[k], p)) (*wts)[k] = weight[k] * streaks[k].length_mm, ++count;
    return count;
  };
  // Every pair far enough apart in angle proposes its crossing; the one most streaks fit
  // (then the smallest spread) is refined on its inliers.
  int best_count = 0;
  double best_cost = 0;
  Vec2 best;
  std::vector<double> wts, pair(m, 0.0);
  for (size_t a = 0; a < m; ++a)
    for (size_t b = a + 1; b < m; ++b) {
      if (line_angle(streaks[a], streaks[b]) < min_angle) continue;
      pair[a] = pair[b] = 1.0;
      Vec2 p;
      const bool met = meet(streaks, pair, &p);
      pair[a] = pair[b] = 0.0;
      if (!met) continue;
      if ((p - region_centre).norm() > region_radius_mm) continue;
      if (!fits(streaks[a], p) || !fits(streaks[b], p)) continue;
      const int count = inliers_of(p, &wts);
      double cost = 0;
      for (size_t k = 0; k < m; ++k)
        if (wts[k] > 0) cost += line_distance(streaks[k], p);
      if (count > best_count || (count == best_count && cost < best_cost))
        best_count = count, best_cost = cost, best = p;
    }
  if (best_count < 2) return out;
  Vec2 p = best;
  for (int iter = 0; iter < 3; ++iter) {
    if (inliers_of(p, &wts) < 2) return out;
    Vec2 q;
    if (!meet(streaks, wts, &q)) return out;
    p = q;
  }
  const int count = inliers_of(p, &wts);
  if (count < 2 || (p - region_centre).norm() > region_radius_mm) return out;
  double widest = 0, ss = 0;
  for (size_t a = 0; a < m; ++a) {
    if (wts[a] <= 0) continue;
    out.streaks[a].inlier = true;
    ss += line_distance(streaks[a], p) * line_distance(streaks[a], p);
    for (size_t b = a + 1; b < m; ++b)
      if (wts[b] > 0) widest = std::max(widest, line_angle(streaks[a], streaks[b]));
  }
  if (widest < min_angle) return out;
  out.found = true;
  out.pith_mm = p;
  out.knots = count;
  out.residual_mm = std::sqrt(ss / count);
  // Two lines always meet: their error is a line's (a knot's axis misses the pith by a pixel or
  // by its curvature and twist, line_error_mm); more lines show theirs. The narrower the widest
  // angle, the farther along the lines an error moves the point.
  // Streaks of one knot in neighbouring slices (pooled ones) lie along one line and count once:
  // distinct directions, 10 degrees apart.
  std::vector<Vec2> dirs;
  for (size_t a = 0; a < m; ++a) {
    if (wts[a] <= 0) continue;
    bool seen = false;
    for (const Vec2& d : dirs)
      seen = seen || std::abs(d.x * streaks[a].direction.x + d.y * streaks[a].direction.y) >
                         std::cos(10.0 * kPi / 180.0);
    if (!seen) dirs.push_back(streaks[a].direction);
  }
  out.distinct = static_cast<int>(dirs.size());
  const double line_error =
      std::max({pixel, o.line_error_mm, out.distinct > 2 ? out.residual_mm : 0.0});
  out.expected_error_mm =
      std::max(0.5 * pixel, line_error / std::sqrt(std::max(1, out.distinct - 1)) /
                                std::max(std::sin(widest), 0.4));
  return out;
}

WhorlPith whorl_pith(const SliceCrop& crop, const VolumeGeometry& g, Vec2 region_centre,
                     double region_radius_mm, double noise_hu, const WhorlPithOptions& o) {
  return meet_streaks(knot_streaks(crop, g, region_centre, region_radius_mm, noise_hu, o), {},
                      region_centre, region_radius_mm, std::max(g.spacing_x, g.spacing_y), o);
}

}  // namespace sawyer::ct
