#include <algorithm>
#include <cmath>

#include "sawyer/sawing/sawing.h"

namespace sawyer::sawing {

BowInfo detect_bow(const Stem& stem) {
  BowInfo out;
  const int n = stem.slice_count();
  if (n < 3) return out;
  const Vec2 a = stem.pith.front(), b = stem.pith.back();
  // Deviation of every pith sample from the chord between the end piths; its mean points to the
  // bulge (the convex side), the horns point the other way.
  Vec2 mean{0, 0};
  std::vector<Vec2> dev(n);
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / (n - 1);
    dev[i] = stem.pith[i] - (a + t * (b - a));
    mean = mean + (1.0 / n) * dev[i];
  }
  const double m = mean.norm();
  if (m < 1e-9) return out;
  const Vec2 bulge = (1.0 / m) * mean;
  double h = 0;
  for (const Vec2& d : dev) h = std::max(h, d.x * bulge.x + d.y * bulge.y);
  out.height_mm = h;
  out.horns_direction = {-bulge.x, -bulge.y};
  out.horns_azimuth = wrap_angle(std::atan2(out.horns_direction.y, out.horns_direction.x));
  return out;
}

SawLog::SawLog(const LogModel& model, int knot_samples) : model_(&model) {
  const Stem& stem = model.stem;
  const int n = stem.slice_count();
  // Least-squares line through the pith samples: pith ≈ line_p_ + line_s_·(z − line_z_).
  double zs = 0;
  Vec2 ps{0, 0};
  for (int i = 0; i < n; ++i) {
    zs += stem.z_at(i);
    ps = ps + stem.pith[i];
  }
  line_z_ = n > 0 ? zs / n : 0;
  line_p_ = n > 0 ? (1.0 / n) * ps : Vec2{};
  double szz = 0;
  Vec2 szp{0, 0};
  for (int i = 0; i < n; ++i) {
    const double dz = stem.z_at(i) - line_z_;
    szz += dz * dz;
    szp = szp + dz * (stem.pith[i] - line_p_);
  }
  line_s_ = szz > 0 ? (1.0 / szz) * szp : Vec2{};
  bow_ = detect_bow(stem);

  rmin2_.resize(n);
  rmax2_.resize(n);
  for (int i = 0; i < n; ++i) {
    const std::vector<double>& rad = stem.radius[i];
    const double lo = rad.empty() ? 0.0 : *std::min_element(rad.begin(), rad.end());
    const double hi = rad.empty() ? 0.0 : *std::max_element(rad.begin(), rad.end());
    rmin2_[i] = lo * lo;
    rmax2_[i] = hi * hi;
  }
  line_at_slice_.resize(n);
  for (int i = 0; i < n; ++i) line_at_slice_[i] = line_at(stem.z_at(i));

  // Sector bounds for inside(). Sector j covers diamond angles [4j/K, 4(j+1)/K) (quadrant q =
  // floor(d), fraction f: azimuth q·π/2 + atan2(f, 1 − f)). The exact test interpolates between
  // table entries i0 = floor(ω·na/2π) and i0 + 1, so a sector's bounds are the min / max of the
  // entries from floor(ω_begin) to floor(ω_end) + 1, the azimuths widened by 1e-6 rad for
  // rounding, and the squared bounds by a relative 1e-9.
  smin2_.assign(static_cast<size_t>(n) * kSectors, 0.0);
  smax2_.assign(static_cast<size_t>(n) * kSectors, 0.0);
  smin_.assign(static_cast<size_t>(n) * kSectors, 0.0);
  smax_.assign(static_cast<size_t>(n) * kSectors, 0.0);
  for (int i = 0; i < n; ++i) {
    const std::vector<double>& rad = stem.radius[i];
    const int na = static_cast<int>(rad.size());
    if (na == 0) continue;
    for (int j = 0; j < kSectors; ++j) {
      auto azimuth = [](double d) {
        const double q = std::floor(d), f = d - q;
        return q * 0.5 * kPi + std::atan2(f, 1 - f);
      };
      const double w0 = azimuth(4.0 * j / kSectors) - 1e-6;
      const double w1 = azimuth(4.0 * (j + 1) / kSectors) + 1e-6;
      const long k0 = static_cast<long>(std::floor(w0 * na / kTwoPi));
      const long k1 = static_cast<long>(std::floor(w1 * na / kTwoPi)) + 1;
      double lo = 1e300, hi = 0;
      for (long k = k0; k <= k1; ++k) {
        const double r = rad[static_cast<size_t>(((k % na) + na) % na)];
        lo = std::min(lo, r);
        hi = std::max(hi, r);
      }
      smin2_[static_cast<size_t>(i) * kSectors + j] = lo * lo * (1 - 1e-9);
      smax2_[static_cast<size_t>(i) * kSectors + j] = hi * hi * (1 + 1e-9);
      smin_[static_cast<size_t>(i) * kSectors + j] = lo * (1 - 1e-9);
      smax_[static_cast<size_t>(i) * kSectors + j] = hi * (1 + 1e-9);
    }
  }

  // Usable diameter: circle about the mean pith line inscribed in the top end's outline.
  if (n > 0) {
    const int top = stem.mean_radius(n - 1) <= stem.mean_radius(0) ? n - 1 : 0;
    const std::vector<double>& rad = stem.radius[top];
    const double rmin = rad.empty() ? 0.0 : *std::min_element(rad.begin(), rad.end());
    const double off = (stem.pith[top] - line_at(stem.z_at(top))).norm();
    usable_diameter_mm_ = std::max(0.0, 2.0 * (rmin - off));
  }

  // Knot axis polylines, denser near the pith where z(r) = z0 + a√r + b·r bends most.
  const int ns = std::max(knot_samples, 2);
  knots_.reserve(model.knots.size());
  for (size_t k = 0; k < model.knots.size(); ++k) {
    const Knot& knot = model.knots[k];
    if (!(knot.r_end > 0)) continue;
    KnotPolyline pl;
    pl.index = static_cast<int>(k);
    pl.half_dmax = 0.5 * knot.max_diameter();
    double reach = 0, zmin = 1e300, zmax = -1e300;
    for (int i = 0; i <= ns; ++i) {
      const double t = static_cast<double>(i) / ns;
      const double r = knot.r_end * t * t;
      const Vec3 p = knot.axis_point(r, stem);
      const Vec2 c = line_at(p.z);
      const Vec3 q{p.x - c.x, p.y - c.y, p.z};
      pl.q.push_back(q);
      pl.r.push_back(r);
      reach = std::max(reach, std::hypot(q.x, q.y));
      zmin = std::min(zmin, q.z);
      zmax = std::max(zmax, q.z);
    }
    pl.reach_mm = reach + pl.half_dmax;
    pl.zmin = zmin - pl.half_dmax;
    pl.zmax = zmax + pl.half_dmax;
    knots_.push_back(std::move(pl));
  }
}

namespace {

// Diamond angle of (x, y) ≠ 0 in [0, 4): same quadrant and order as the azimuth.
inline double diamond(double x, double y) {
  const double ax = std::abs(x), ay = std::abs(y);
  if (y >= 0) return x >= 0 ? ay / (ax + ay) : 1 + ax / (ax + ay);
  return x < 0 ? 2 + ay / (ax + ay) : 3 + ax / (ax + ay);
}

}  // namespace

bool SawLog::sector_span(double ax, double ay, double bx, double by, int* first, int* count) {
  const double cr = ax * by - ay * bx;  // > 0: A → B counter-clockwise
  const double la2 = ax * ax + ay * ay, lb2 = bx * bx + by * by;
  const double dot = ax * bx + ay * by;
  // The sweep of a segment not through the pith is below π; refuse near-π sweeps (sin < 1e-3
  // with the ends on opposite sides) and ends at the pith.
  if (!(la2 > 1e-12 && lb2 > 1e-12)) return false;
  if (dot < 0 && cr * cr < 1e-6 * la2 * lb2) return false;
  const int q = kSectors / 4;
  int ja = std::min(static_cast<int>(diamond(ax, ay) * q), kSectors - 1);
  int jb = std::min(static_cast<int>(diamond(bx, by) * q), kSectors - 1);
  if (cr < 0) std::swap(ja, jb);
  *first = ja;
  *count = (jb - ja + kSectors) % kSectors + 1;
  return true;
}

bool SawLog::segment_surely_inside(int slice, Vec2 a, Vec2 b, double margin) const {
  const Vec2 c = model_->stem.pith[slice];
  const double ax = a.x - c.x, ay = a.y - c.y, bx = b.x - c.x, by = b.y - c.y;
  // The farthest point of a segment from the pith is an end.
  const double r = std::sqrt(std::max(ax * ax + ay * ay, bx * bx + by * by)) + margin;
  if (r * r <= rmin2_[slice] * (1 - 1e-9)) return true;
  if (r * r > rmax2_[slice]) return false;
  int j0, cnt;
  if (!sector_span(ax, ay, bx, by, &j0, &cnt)) return false;
  const double* lo = &smin_[static_cast<size_t>(slice) * kSectors];
  for (int k = 0, j = j0; k < cnt; ++k, j = j + 1 == kSectors ? 0 : j + 1)
    if (r > lo[j]) return false;
  return true;
}

bool SawLog::segment_surely_outside(int slice, Vec2 a, Vec2 b, double margin) const {
  const Vec2 c = model_->stem.pith[slice];
  const double ax = a.x - c.x, ay = a.y - c.y, bx = b.x - c.x, by = b.y - c.y;
  // Nearest point of the segment to the pith.
  const double ex = bx - ax, ey = by - ay, ee = ex * ex + ey * ey;
  const double t = ee > 0 ? std::clamp(-(ax * ex + ay * ey) / ee, 0.0, 1.0) : 0.0;
  const double nx = ax + t * ex, ny = ay + t * ey;
  const double r = std::sqrt(nx * nx + ny * ny) - margin;
  if (r * r > rmax2_[slice] * (1 + 1e-9) && r > 0) return true;
  if (!(r > 0) || r * r <= rmin2_[slice]) return false;
  int j0, cnt;
  if (!sector_span(ax, ay, bx, by, &j0, &cnt)) return false;
  const double* hi = &smax_[static_cast<size_t>(slice) * kSectors];
  for (int k = 0, j = j0; k < cnt; ++k, j = j + 1 == kSectors ? 0 : j + 1)
    if (r <= hi[j]) return false;
  return true;
}

double SawLog::outside_by(int slice, double x, double y) const {
  const Stem& stem = model_->stem;
  const Vec2 c = stem.pith[slice];
  const double dx = x - c.x, dy = y - c.y;
  const std::vector<double>& rad = stem.radius[slice];
  const int na = static_cast<int>(rad.size());
  const double r = std::sqrt(dx * dx + dy * dy);
  if (na == 0) return r;
  double w = std::atan2(dy, dx);
  if (w < 0) w += kTwoPi;
  const double f = w * na / kTwoPi;
  int i0 = static_cast<int>(f);
  const double t = f - i0;
  if (i0 >= na) i0 -= na;  // w rounded up to 2π
  const int i1 = i0 + 1 == na ? 0 : i0 + 1;
  return r - ((1 - t) * rad[i0] + t * rad[i1]);
}

bool SawLog::inside(int slice, double x, double y) const {
  const Stem& stem = model_->stem;
  const Vec2 c = stem.pith[slice];
  const double dx = x - c.x, dy = y - c.y;
  const double r2 = dx * dx + dy * dy;
  // Fast answers from the slice's radius range before the angle lookup.
  if (r2 <= rmin2_[slice]) return true;
  if (r2 > rmax2_[slice]) return false;
  const std::vector<double>& rad = stem.radius[slice];
  const int na = static_cast<int>(rad.size());
  if (na == 0) return false;
  if (r2 > 0) {
    const int j = std::min(static_cast<int>(diamond(dx, dy) * (kSectors / 4)), kSectors - 1);
    const size_t at = static_cast<size_t>(slice) * kSectors + j;
    if (r2 <= smin2_[at]) return true;
    if (r2 > smax2_[at]) return false;
  }
  double w = std::atan2(dy, dx);
  if (w < 0) w += kTwoPi;
  const double f = w * na / kTwoPi;
  int i0 = static_cast<int>(f);
  const double t = f - i0;
  if (i0 >= na) i0 -= na;
  const int i1 = i0 + 1 == na ? 0 : i0 + 1;
  const double R = (1 - t) * rad[i0] + t * rad[i1];
  return r2 <= R * R;
}

}  // namespace sawyer::sawing
