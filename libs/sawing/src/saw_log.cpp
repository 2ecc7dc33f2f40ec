#include <algorithm>
#include <atomic>
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
  static std::atomic<std::uint64_t> next_serial{1};
  serial_ = next_serial.fetch_add(1);
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

  // Bounds over runs of 2^l sectors (cyclic) for segment_surely_inside / _outside: the bound
  // over any run of sectors is the min (max) over two overlapping power-of-two runs, the same
  // number as a loop over the run gives, in two look-ups.
  run_min_.assign(static_cast<size_t>(n) * kLevels * kSectors, 0.0);
  run_max_.assign(static_cast<size_t>(n) * kLevels * kSectors, 0.0);
  for (int i = 0; i < n; ++i) {
    double* mn = &run_min_[static_cast<size_t>(i) * kLevels * kSectors];
    double* mx = &run_max_[static_cast<size_t>(i) * kLevels * kSectors];
    for (int j = 0; j < kSectors; ++j) {
      mn[j] = smin_[static_cast<size_t>(i) * kSectors + j];
      mx[j] = smax_[static_cast<size_t>(i) * kSectors + j];
    }
    for (int l = 1; l < kLevels; ++l) {
      const int half = 1 << (l - 1);
      for (int j = 0; j < kSectors; ++j) {
        const int k = (j + half) & (kSectors - 1);
        mn[l * kSectors + j] = std::min(mn[(l - 1) * kSectors + j], mn[(l - 1) * kSectors + k]);
        mx[l * kSectors + j] = std::max(mx[(l - 1) * kSectors + j], mx[(l - 1) * kSectors + k]);
      }
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

}  // namespace sawyer::sawing
