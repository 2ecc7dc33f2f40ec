#include "published_renderer_port.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <sstream>

namespace sawyer::test {
namespace {

namespace fs = std::filesystem;

// Power smooth minimum with an adaptive k (paper 4.2.1): sharp (kKnot) where the knot's time is
// below the stem's, soft (kStem) outside. The paper gives no formula for the transition; the
// port moves k along d / (kSpread + |d|), d = t_s − t_b, with the values that
// shaders/wood_field.glsl records as the published shader's (1.5, 5, 0.3).
constexpr double kStem = 1.5;
constexpr double kKnot = 5.0;
constexpr double kSpread = 0.3;
// Dead knots (paper 4.2.2): δ scaled by f, from 1 at death towards kDeadEnd (rings dip towards
// the knot) at rate kDeadRate per unit of time since death; β is not used (no butterfly).
constexpr double kDeadEnd = -0.5;
constexpr double kDeadRate = 8.0;
// The published renderer counts a knot at a point within 0.2 + r (rmin units) of its axis point,
// and at most 20 of them. Its range fade (full effect within 0.1 + 0.8 r, none at 0.2 + r) is
// meant for the knot's δ but lands on the next slot (docs/render.md), so δ is not faded.
constexpr double kRangeRmin = 0.2;
constexpr double kRangeInnerRmin = 0.1;
constexpr int kMaxKnots = 20;
// Knot axis tables: every 0.1 mm of pith distance, out to 1.5 rmax.
constexpr double kTableStep = 0.1;
constexpr double kTableMaxR = 1.5;

std::uint32_t le32(const unsigned char* p) {
  return p[0] | (p[1] << 8) | (p[2] << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

double smin_power(double a, double b, double k) {
  const double lo = std::min(a, b), hi = std::max(a, b);
  if (hi <= 0) return 0;
  return lo * std::pow(1.0 + std::pow(lo / hi, k), -1.0 / k);
}

double adaptive_k(double t_s, double t_b) {
  const double d = t_s - t_b;
  const double s = 0.5 + 0.5 * d / (kSpread + std::abs(d));  // 0 far outside, 1 deep inside
  return kStem + (kKnot - kStem) * s;
}

// Knot growth speed at pith distance r, in rmin per unit of time (formats.md, without noise).
double knot_speed(double r, double rmin) { return 0.2 - 0.1 * std::sqrt(std::max(r, 0.0) / rmin); }

// Uniform cubic B-spline weights at fraction f.
void bspline_weights(double f, double w[4]) {
  const double f2 = f * f, f3 = f2 * f;
  w[0] = (1 - f) * (1 - f) * (1 - f) / 6.0;
  w[1] = (3 * f3 - 6 * f2 + 4) / 6.0;
  w[2] = (-3 * f3 + 3 * f2 + 3 * f + 1) / 6.0;
  w[3] = f3 / 6.0;
}

}  // namespace

Result<PublishedRendererPort::Map> PublishedRendererPort::read_bmp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error(path.string(), "cannot open");
  const std::vector<unsigned char> b((std::istreambuf_iterator<char>(in)),
                                     std::istreambuf_iterator<char>());
  if (b.size() < 54 || b[0] != 'B' || b[1] != 'M') return Error(path.string(), "not a BMP file");
  const std::uint32_t offset = le32(&b[10]);
  const auto w = static_cast<std::int32_t>(le32(&b[18]));
  const auto h = static_cast<std::int32_t>(le32(&b[22]));
  const int bpp = b[28] | (b[29] << 8);
  if (bpp != 24 || le32(&b[30]) != 0 || w <= 0 || h == 0)
    return Error(path.string(), "expected an uncompressed 24-bit BMP");
  const int rows = std::abs(h);
  const size_t stride = (static_cast<size_t>(w) * 3 + 3) & ~size_t{3};
  if (b.size() < offset + stride * rows) return Error(path.string(), "truncated");
  Map m;
  m.w = w, m.h = rows;
  m.rgb.resize(static_cast<size_t>(w) * rows * 3);
  for (int r = 0; r < rows; ++r) {
    // Rows are stored bottom-up unless the height is negative; row 0 here is the top row.
    const int stored = h > 0 ? rows - 1 - r : r;
    const unsigned char* p = &b[offset + stride * stored];
    for (int c = 0; c < w; ++c)
      for (int ch = 0; ch < 3; ++ch)  // BMP keeps B, G, R
        m.rgb[(static_cast<size_t>(r) * w + c) * 3 + ch] = p[c * 3 + (2 - ch)] / 255.0f;
  }
  return m;
}

Result<PublishedRendererPort> PublishedRendererPort::load(const fs::path& dir,
                                                          const PublishedRules& rules) {
  PublishedRendererPort p;
  p.rules_ = rules;
  {
    const fs::path f = dir / "map_params.json";
    std::ifstream in(f);
    if (!in) return Error(f.string(), "cannot open");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (char& c : text)
      if (c == '[' || c == ']' || c == ',') c = ' ';
    std::istringstream ss(text);
    double n = 0;
    if (!(ss >> p.rmin_ >> p.rmax_ >> p.hmax_ >> n)) return Error(f.string(), "expected 4 numbers");
    p.n_ = static_cast<int>(n);
  }
  const std::pair<const char*, Map*> maps[] = {{"pith_and_radius_map.bmp", &p.stem_},
                                               {"knot_height_map.bmp", &p.height_},
                                               {"knot_orientation_map.bmp", &p.orient_},
                                               {"knot_state_map.bmp", &p.state_}};
  for (const auto& [name, dst] : maps) {
    Result<Map> m = read_bmp(dir / name);
    if (!m) return m.error();
    *dst = std::move(m).value();
  }
  if (p.n_ > 0 && p.height_.h % p.n_ != 0)
    return Error((dir / "knot_height_map.bmp").string(), "rows do not match the knot count");
  if (!rules.start_azimuth_override.empty() &&
      static_cast<int>(rules.start_azimuth_override.size()) != p.n_)
    return Error("PublishedRules", "start_azimuth_override needs one azimuth per knot");
  const int steps = static_cast<int>(std::ceil(kTableMaxR * p.rmax_ / kTableStep)) + 1;
  p.tables_.resize(p.n_);
  for (int i = 0; i < p.n_; ++i) {
    KnotTable& t = p.tables_[i];
    t.h.resize(steps);
    t.w.resize(steps);
    t.h_lo = 1e300, t.h_hi = -1e300;
    for (int j = 0; j < steps; ++j) {
      p.knot_axis(i, j * kTableStep, &t.h[j], &t.w[j]);
      t.h_lo = std::min(t.h_lo, t.h[j]);
      t.h_hi = std::max(t.h_hi, t.h[j]);
    }
    t.r_death = p.death_r(i);
  }
  return p;
}

std::array<double, 3> PublishedRendererPort::filtered(const Map& m, double u, double v,
                                                      bool wrap_u) {
  const double x = u * m.w - 0.5, y = v * m.h - 0.5;
  const int i = static_cast<int>(std::floor(x)), j = static_cast<int>(std::floor(y));
  double wx[4], wy[4];
  bspline_weights(x - i, wx);
  bspline_weights(y - j, wy);
  std::array<double, 3> out{0, 0, 0};
  for (int b = 0; b < 4; ++b) {
    const int row = std::clamp(j - 1 + b, 0, m.h - 1);
    for (int a = 0; a < 4; ++a) {
      int col = i - 1 + a;
      col = wrap_u ? ((col % m.w) + m.w) % m.w : std::clamp(col, 0, m.w - 1);
      const double w = wx[a] * wy[b];
      for (int ch = 0; ch < 3; ++ch) out[ch] += w * m.at(col, row, ch);
    }
  }
  return out;
}

Vec2 PublishedRendererPort::pith(double h) const {
  const std::array<double, 3> c = filtered(stem_, 0.5, h / hmax_, true);
  return {(c[0] - 0.5) * rmin_, (c[1] - 0.5) * rmin_};
}

double PublishedRendererPort::radius(double h, double phi) const {
  const std::array<double, 3> c = filtered(stem_, wrap_angle(phi) / kTwoPi, h / hmax_, true);
  return rmin_ + c[2] * (rmax_ - rmin_);
}

void PublishedRendererPort::knot_axis(int i, double r, double* h, double* omega) const {
  const PublishedRules& rules = rules_;
  const double u = std::clamp(r / (rules.knot_axis_over_rmin ? rmin_ : rmax_), 0.0, 1.0);
  const double v = (i + 0.5) / n_;
  const std::array<double, 3> hc = filtered(height_, u, v, false);
  const std::array<double, 3> oc = filtered(orient_, u, v, false);
  const double rise = (rules.height_green_negative ? hc[2] - hc[1] : hc[1] - hc[2]) * rmin_;
  const double turn = (rules.twist_green_negative ? oc[2] - oc[1] : oc[1] - oc[2]) * 0.5 * kPi;
  const double start =
      rules.start_azimuth_override.empty() ? kTwoPi * oc[0] : rules.start_azimuth_override[i];
  *h = hc[0] * hmax_ + rise;
  *omega = start + turn;
}

double PublishedRendererPort::death_r(int i) const {
  const std::array<double, 3> sc = filtered(state_, 0.5, (i + 0.5) / n_, false);
  return sc[1] * (rules_.death_over_rmin ? rmin_ : rmax_);
}

PublishedSample PublishedRendererPort::sample(const Vec3& p) const {
  const PublishedRules& rules = rules_;
  PublishedSample s;
  const Vec2 c = pith(p.z);
  const double dx = p.x - c.x, dy = p.y - c.y;
  s.r = std::hypot(dx, dy);
  const double phi = rules.stem_azimuth_from_y ? std::atan2(dx, dy) : std::atan2(dy, dx);
  s.radius = radius(p.z, phi);
  s.t_stem = s.r / s.radius;

  double delta_sum = 0;
  int counted = 0;
  const double reach = kRangeRmin * rmin_ + s.r;
  const double last = tables_.empty() ? 0.0 : static_cast<double>(tables_[0].h.size() - 2);
  const double jf = std::min(s.r / kTableStep, last);
  const int j = static_cast<int>(jf);
  const double f = jf - j;
  for (int i = 0; i < n_ && counted < kMaxKnots; ++i) {
    const KnotTable& kt = tables_[i];
    if (p.z < kt.h_lo - reach || p.z > kt.h_hi + reach) continue;
    const double h = kt.h[j] + f * (kt.h[j + 1] - kt.h[j]);
    const double w = kt.w[j] + f * (kt.w[j + 1] - kt.w[j]);
    const Vec3 a{c.x + s.r * std::cos(w), c.y + s.r * std::sin(w), h};
    const double dist = (p - a).norm();
    if (dist >= reach) continue;
    ++counted;
    const double r_d = kt.r_death;
    const bool dead = s.r > r_d;
    // Time: distance over the knot's growth speed; once dead the knot keeps the thickness it had
    // at death and its time runs on with the stem's.
    double t_b;
    if (!dead) {
      t_b = dist / (rmin_ * knot_speed(s.r, rmin_));
    } else {
      t_b = dist / (rmin_ * knot_speed(r_d, rmin_)) + (s.r - r_d) / s.radius;
    }
    const double since_death = dead ? (s.r - r_d) / s.radius : 0.0;
    const double k = adaptive_k(s.t_stem, t_b);
    double delta = smin_power(s.t_stem, t_b, k) - std::min(s.t_stem, t_b);
    if (dead) {
      const double q = kDeadRate * since_death;
      delta *= 1.0 + (kDeadEnd - 1.0) * q / (1.0 + q);
    }
    if (!rules.range_fade_slip) {
      const double inner = kRangeInnerRmin * rmin_ + 0.8 * s.r;
      delta *= 1.0 - std::clamp((dist - inner) / (reach - inner), 0.0, 1.0);
    }
    delta_sum += delta;
    if (t_b < s.t_knot) {
      s.t_knot = t_b;
      if (t_b < s.t_stem) {
        s.knot = i;
        s.dead = dead;
      }
    }
  }
  if (s.t_knot >= s.t_stem) s.knot = -1, s.dead = false;
  s.t = std::min(s.t_stem, s.t_knot) + delta_sum;
  return s;
}

}  // namespace sawyer::test
