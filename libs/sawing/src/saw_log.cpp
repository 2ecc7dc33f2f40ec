#include <algorithm>
#include <atomic>
#include <cmath>

#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/sawing.h"

namespace sawyer::sawing {
namespace {

// The usable diameter is the median over the stem samples this close to the top end (mm).
constexpr double kTopEndMm = 20.0;

// v in single precision, rounded down / up: a bound stays a bound.
float float_below(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) > v ? std::nextafter(f, -HUGE_VALF) : f;
}
float float_above(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) < v ? std::nextafter(f, HUGE_VALF) : f;
}

// The azimuth (rad) of diamond angle d in [0, 4) (detail::diamond's inverse): quadrant
// floor(d), fraction f within it at atan2(f, 1 − f).
double diamond_azimuth(double d) {
  const double q = std::floor(d), f = d - q;
  return q * 0.5 * kPi + std::atan2(f, 1 - f);
}

}  // namespace

Vec2 outline_centre(const Stem& stem, int i) {
  const Vec2 pith = stem.pith[i];
  const std::vector<double>& rad = stem.radius[i];
  const int na = static_cast<int>(rad.size());
  if (na < 3) return pith;
  // Fan of triangles (pith, p_k, p_k+1): area ½ r_k r_k+1 sin Δ, centroid (p_k + p_k+1) / 3.
  const double d = kTwoPi / na, sd = std::sin(d);
  double area = 0, cx = 0, cy = 0;
  for (int k = 0; k < na; ++k) {
    const double r0 = rad[k], r1 = rad[(k + 1) % na];
    const double w0 = k * d, w1 = w0 + d;
    const double a = 0.5 * r0 * r1 * sd;
    area += a;
    cx += a * (r0 * std::cos(w0) + r1 * std::cos(w1)) / 3.0;
    cy += a * (r0 * std::sin(w0) + r1 * std::sin(w1)) / 3.0;
  }
  if (!(area > 0)) return pith;
  return {pith.x + cx / area, pith.y + cy / area};
}

BowInfo detect_bow(const Stem& stem, double min_bow_mm) {
  BowInfo out;
  const int n = stem.slice_count();
  if (n < 3) return out;
  std::vector<Vec2> c(n);
  for (int i = 0; i < n; ++i) c[i] = outline_centre(stem, i);
  // Mills' sweep: the centre line's largest distance from the chord between its end centres.
  for (int i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / (n - 1);
    out.chord_mm = std::max(out.chord_mm, (c[i] - (c.front() + t * (c.back() - c.front()))).norm());
  }
  // Parabola c(t) = a + b t + q t², t = −1 at the first sample's slab start, +1 at the last one's
  // end: least squares in x and y (normal equations on t's centred powers). Its sagitta over
  // [−1, 1] is |q|, and the ends lie on the side q points to: the horns.
  const double zm = 0.5 * (stem.z_begin() + stem.z_end()), h = 0.5 * stem.length_mm();
  double s[5] = {0, 0, 0, 0, 0};
  Vec2 r[3] = {{0, 0}, {0, 0}, {0, 0}};
  for (int i = 0; i < n; ++i) {
    const double t = (stem.z_at(i) - zm) / h;
    double tk = 1;
    for (int k = 0; k < 5; ++k, tk *= t) {
      s[k] += tk;
      if (k < 3) r[k] = r[k] + tk * c[i];
    }
  }
  // Solve [s0 s1 s2; s1 s2 s3; s2 s3 s4] [a b q] = r for q (Cramer's rule on the last column).
  auto det3 = [](double a, double b, double cc, double d, double e, double f, double g, double hh,
                 double k) {
    return a * (e * k - f * hh) - b * (d * k - f * g) + cc * (d * hh - e * g);
  };
  const double det = det3(s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4]);
  if (!(std::abs(det) > 1e-12)) return out;
  const Vec2 q{det3(s[0], s[1], r[0].x, s[1], s[2], r[1].x, s[2], s[3], r[2].x) / det,
               det3(s[0], s[1], r[0].y, s[1], s[2], r[1].y, s[2], s[3], r[2].y) / det};
  out.height_mm = q.norm();
  if (!(out.height_mm >= min_bow_mm)) return out;
  out.straight = false;
  out.horns_direction = (1.0 / out.height_mm) * q;
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
  turn0_ = 1.5 * kPi - bow_.horns_azimuth;
  build(knot_samples);
}

SawLog::SawLog(const LogModel& model, const ScannerPosition& at, int knot_samples)
    : model_(&model) {
  // The line's height and slope in the model's z (scanner z = z0 ± z).
  const bool flipped = model.scanner_frame && model.scanner_frame->z_dir < 0;
  line_z_ = from_scanner_z(model, at.centre_z);
  line_p_ = at.centre;
  line_s_ = (flipped ? -1.0 : 1.0) * at.slope;
  bow_ = detect_bow(model.stem);
  turn0_ = at.turn_deg * kPi / 180.0;
  build(knot_samples);
}

void SawLog::release_tables() {
  for (auto* v : {&rmin2_, &rmax2_}) std::vector<double>().swap(*v);
  for (auto* v : {&smin2_, &smax2_, &run_min_, &run_max_}) std::vector<float>().swap(*v);
  std::vector<Vec2>().swap(line_at_slice_);
  std::vector<KnotPolyline>().swap(knots_);
  std::vector<Vec2>().swap(dir_);
  std::vector<int>().swap(bin_entry_);
  na_ = 0;
}

void SawLog::build(int knot_samples) {
  static std::atomic<std::uint64_t> next_serial{1};
  serial_ = next_serial.fetch_add(1);
  const LogModel& model = *model_;
  const Stem& stem = model.stem;
  const int n = stem.slice_count();

  rmin2_.resize(n);
  rmax2_.resize(n);
  for (int i = 0; i < n; ++i) {
    const std::vector<double>& rad = stem.radius[i];
    const double lo = rad.empty() ? 0.0 : *std::min_element(rad.begin(), rad.end());
    const double hi = rad.empty() ? 0.0 : *std::max_element(rad.begin(), rad.end());
    rmin2_[i] = lo * lo;
    rmax2_[i] = hi * hi;
  }
  // The exact look-up's directions and diamond-angle bins (radius_towards), where every sample
  // has the same number of angles.
  na_ = n > 0 ? static_cast<int>(stem.radius[0].size()) : 0;
  for (int i = 1; i < n && na_ > 0; ++i)
    if (static_cast<int>(stem.radius[i].size()) != na_) na_ = 0;
  if (na_ < kMinSeriesAngles) na_ = 0;
  dir_.clear();
  bin_entry_.clear();
  if (na_ > 0) {
    for (int k = 0; k <= na_; ++k) {
      const double w = kTwoPi * (k % na_) / na_;
      dir_.push_back({std::cos(w), std::sin(w)});
    }
    for (int b = 0; b < kDiamondBins; ++b) {
      const double w = diamond_azimuth(4.0 * b / kDiamondBins);
      bin_entry_.push_back(std::min(static_cast<int>(w * na_ / kTwoPi), na_ - 1));
    }
  }
  line_at_slice_.resize(n);
  for (int i = 0; i < n; ++i) line_at_slice_[i] = line_at(stem.z_at(i));

  // Sector bounds for inside(). Sector j covers diamond angles [4j/K, 4(j+1)/K) (quadrant q =
  // floor(d), fraction f: azimuth q·π/2 + atan2(f, 1 − f)). The exact test interpolates between
  // table entries i0 = floor(ω·na/2π) and i0 + 1, so a sector's bounds are the min / max of the
  // entries from floor(ω_begin) to floor(ω_end) + 1, the azimuths widened by 1e-6 rad for
  // rounding, and the squared bounds by a relative 1e-9.
  smin2_.assign(static_cast<size_t>(n) * kSectors, 0.0f);
  smax2_.assign(static_cast<size_t>(n) * kSectors, 0.0f);
  run_min_.assign(static_cast<size_t>(n) * kLevels * kSectors, 0.0f);
  run_max_.assign(static_cast<size_t>(n) * kLevels * kSectors, 0.0f);
  for (int i = 0; i < n; ++i) {
    const std::vector<double>& rad = stem.radius[i];
    const int na = static_cast<int>(rad.size());
    if (na == 0) continue;
    for (int j = 0; j < kSectors; ++j) {
      const double w0 = diamond_azimuth(4.0 * j / kSectors) - 1e-6;
      const double w1 = diamond_azimuth(4.0 * (j + 1) / kSectors) + 1e-6;
      const long k0 = static_cast<long>(std::floor(w0 * na / kTwoPi));
      const long k1 = static_cast<long>(std::floor(w1 * na / kTwoPi)) + 1;
      double lo = 1e300, hi = 0;
      for (long k = k0; k <= k1; ++k) {
        const double r = rad[static_cast<size_t>(((k % na) + na) % na)];
        lo = std::min(lo, r);
        hi = std::max(hi, r);
      }
      smin2_[static_cast<size_t>(i) * kSectors + j] = float_below(lo * lo * (1 - 1e-9));
      smax2_[static_cast<size_t>(i) * kSectors + j] = float_above(hi * hi * (1 + 1e-9));
      run_min_[static_cast<size_t>(i) * kLevels * kSectors + j] = float_below(lo * (1 - 1e-9));
      run_max_[static_cast<size_t>(i) * kLevels * kSectors + j] = float_above(hi * (1 + 1e-9));
    }
  }

  // Bounds over runs of 2^l sectors (cyclic) for segment_surely_inside / _outside: the bound
  // over any run of sectors is the min (max) over two overlapping power-of-two runs, the same
  // number as a loop over the run gives, in two look-ups.
  // (Level 0 is the sectors' own bounds, filled above.)
  for (int i = 0; i < n; ++i) {
    float* mn = &run_min_[static_cast<size_t>(i) * kLevels * kSectors];
    float* mx = &run_max_[static_cast<size_t>(i) * kLevels * kSectors];
    for (int l = 1; l < kLevels; ++l) {
      const int half = 1 << (l - 1);
      for (int j = 0; j < kSectors; ++j) {
        const int k = (j + half) & (kSectors - 1);
        mn[l * kSectors + j] = std::min(mn[(l - 1) * kSectors + j], mn[(l - 1) * kSectors + k]);
        mx[l * kSectors + j] = std::max(mx[(l - 1) * kSectors + j], mx[(l - 1) * kSectors + k]);
      }
    }
  }

  // Usable diameter: circle about the mean pith line inscribed in the top end's outline, the
  // median over the samples within kTopEndMm of the top end. A log's top diameter changes by a
  // fraction of a millimetre over its last centimetres (taper about 1 cm per metre), but a scan's
  // end slice is its least certain (a half-covered end, one-sided windows): on a generated pine
  // it put the diameter 9 mm low, and a pattern set then chose from a smaller class.
  if (n > 0) {
    const bool top_last = stem.mean_radius(n - 1) <= stem.mean_radius(0);
    const int top = top_last ? n - 1 : 0;
    std::vector<double> per;
    for (int k = 0; k < n; ++k) {
      const int i = top_last ? n - 1 - k : k;
      if (k > 0 && std::abs(stem.z_at(i) - stem.z_at(top)) > kTopEndMm) break;
      const std::vector<double>& rad = stem.radius[i];
      const double rmin = rad.empty() ? 0.0 : *std::min_element(rad.begin(), rad.end());
      const double off = (stem.pith[i] - line_at_slice_[i]).norm();
      per.push_back(2.0 * (rmin - off));
    }
    std::sort(per.begin(), per.end());
    const size_t m = per.size() / 2;
    const double mid = per.size() % 2 ? per[m] : 0.5 * (per[m - 1] + per[m]);
    usable_diameter_mm_ = std::max(0.0, mid);
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
