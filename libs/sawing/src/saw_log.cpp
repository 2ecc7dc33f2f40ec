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
  i0 %= na;
  return r - ((1 - t) * rad[i0] + t * rad[(i0 + 1) % na]);
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
  double w = std::atan2(dy, dx);
  if (w < 0) w += kTwoPi;
  const double f = w * na / kTwoPi;
  int i0 = static_cast<int>(f);
  const double t = f - i0;
  i0 %= na;
  const double R = (1 - t) * rad[i0] + t * rad[(i0 + 1) % na];
  return r2 <= R * R;
}

}  // namespace sawyer::sawing
