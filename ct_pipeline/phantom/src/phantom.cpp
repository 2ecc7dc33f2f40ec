// The phantom: placement of the log in the scanner, the log's anatomy (bark, heartwood, knots,
// rings) as CT numbers from the shared wood field, the bed and clutter, and the rendering of one
// slice (slab averaging, PSF, noise). Truth files: phantom_truth.cpp; writing: phantom_write.cpp.
#include <algorithm>
#include <cassert>
#include <cctype>
#include <cmath>
#include <map>
#include <sstream>

#include "phantom_internal.h"
#include "sawyer/model/log_json.h"

namespace sawyer::ct {

using phantom_detail::Rng;
using phantom_detail::stream_seed;

namespace {

constexpr double kDeg = kPi / 180.0;
// Height step of the field layers for tilted logs: a pixel uses the layer nearest its log-frame
// height, so its height is off by at most half this (0.125 mm, well under a pixel).
constexpr double kTiltLayerStep = 0.25;
// Width of the heartwood/sapwood transition (the moisture gradient of the intermediate zone).
constexpr double kHeartTransitionMm = 4.0;
// Compression wood at full strength: this much denser on its side, and rings this much wider.
constexpr double kCompressionHu = 150.0;
constexpr double kCompressionWidth = 0.6;
// Default bark thickness when the model has none: a share of the radius (Nordic softwood logs
// carry 1.5-3 % of the radius as bark).
constexpr double kDefaultBarkShare = 0.02;
// Default heartwood when the model has none: pine, a share of the radius (Scots pine heartwood
// is 45-65 % of the radius in butt logs); other species (spruce: the dry core), the radius less
// a wet sapwood band of about 30 mm (20-40 mm in Norway spruce).
constexpr double kPineHeartShare = 0.55;
constexpr double kSapwoodBandMm = 30.0;
// Auto sub-slices: one field evaluation every ~1.25 mm of slice thickness.
constexpr double kSubSliceMm = 1.25;
constexpr int kMaxSlices = 100000;

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Density within one annual ring, phase 0 at the ring's start (earlywood) to 1 at its end: low
// through the earlywood, rising gradually (cubic) into the latewood, which with a latewood share
// `lw` stays dense for that share of the ring, dropping back sharply at the ring border (the
// drop is spread over the last 10 % of the ring to keep point sampling from aliasing). Range
// 0..1; kRingProfileMean is its mean for lw = 0 (the original profile), so the modulation
// averages to zero over a ring.
constexpr double kRingProfileMean = 0.9 / 4 + 0.05;
double ring_profile_lw(double phase, double lw) {
  const double u_l = 0.9 - lw;
  if (phase < u_l) {
    const double u = phase / u_l;
    return u * u * u;
  }
  if (phase < 0.9) return 1.0;
  return (1.0 - phase) / 0.1;
}

// Mean and standard deviation of a ring profile over one ring (fine quadrature).
void ring_profile_stats(double lw, double* mean, double* sd) {
  constexpr int kN = 20000;
  double a = 0, b = 0;
  for (int i = 0; i < kN; ++i) {
    const double v = ring_profile_lw((i + 0.5) / kN, lw);
    a += v;
    b += v * v;
  }
  *mean = a / kN;
  *sd = std::sqrt(std::max(0.0, b / kN - *mean * *mean));
}

// Weight of the compression-wood side at azimuth offset d from its centre: 1 on the centre line,
// 0.5 at ±45°, none on the far half.
double side_weight(double d) {
  const double c = std::cos(d);
  return c > 0 ? c * c : 0.0;
}

// Shortest form of a number for messages: 600, 0.3, -1e+300.
std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string fmt(double v, int digits = 3) {
  std::ostringstream s;
  s.precision(digits);
  s << std::fixed << v;
  return s.str();
}

// Linear interpolation in a wrapped angular table of kLayerAngles + 1 entries.
inline float table_at(const std::vector<float>& t, double omega) {
  const double u = omega / kTwoPi * kLayerAngles;
  const int k = std::clamp(static_cast<int>(u), 0, kLayerAngles - 1);
  const float f = static_cast<float>(u - k);
  return t[k] + (t[k + 1] - t[k]) * f;
}

}  // namespace

const char* region_name(Region r) {
  switch (r) {
    case Region::kAir:
      return "air";
    case Region::kBark:
      return "bark";
    case Region::kHeartwood:
      return "heartwood";
    case Region::kSapwood:
      return "sapwood";
    case Region::kSoundKnot:
      return "sound knot";
    case Region::kDeadKnot:
      return "dead knot";
    case Region::kKnotBark:
      return "dead-knot bark";
    case Region::kBed:
      return "bed";
    case Region::kClutter:
      return "clutter";
    case Region::kWetPocket:
      return "wet pocket";
    case Region::kCrack:
      return "crack";
    case Region::kResinPocket:
      return "resin pocket";
    case Region::kRot:
      return "rot";
  }
  return "?";
}

const char* moisture_name(Moisture m) { return m == Moisture::kDried ? "dried" : "green"; }

HuTable dried_hu_table(const HuTable& green) {
  // Dried wood at about 12 % moisture: heartwood and sapwood alike at ≈ 400 kg/m³; dry
  // knotwood 650-800 kg/m³; dry bark 250-350 kg/m³.
  HuTable h = green;
  h.heartwood = -600;
  h.sapwood = -600;
  h.sound_knot = -280;
  h.dead_knot = -320;
  h.knot_bark = -680;
  h.bark_inner = -650;
  h.bark_outer = -720;
  return h;
}

Status PhantomOptions::validate() const {
  auto bad = [](const char* opt, const std::string& what) { return Status(Error(opt, what)); };
  if (image_size < 16 || image_size > 8192)
    return bad("PhantomOptions::image_size",
               "image size must be 16-8192 pixels, got " + std::to_string(image_size));
  if (!(pixel_mm > 0.01 && pixel_mm <= 20))
    return bad("PhantomOptions::pixel_mm",
               "pixel size must be in (0.01, 20] mm, got " + fmt(pixel_mm));
  if (!(slice_spacing_mm > 0.01 && slice_spacing_mm <= 100))
    return bad("PhantomOptions::slice_spacing_mm",
               "slice spacing must be in (0.01, 100] mm, got " + fmt(slice_spacing_mm));
  if (!(slice_thickness_mm >= 0 && slice_thickness_mm <= 100))
    return bad(
        "PhantomOptions::slice_thickness_mm",
        "slice thickness must be in (0, 100] mm (0: the spacing), got " + fmt(slice_thickness_mm));
  if (sub_slices < 0 || sub_slices > 64)
    return bad("PhantomOptions::sub_slices",
               "must be 0 (auto) to 64, got " + std::to_string(sub_slices));
  if (from_mm && !std::isfinite(*from_mm)) return bad("PhantomOptions::from_mm", "not a number");
  if (to_mm && !std::isfinite(*to_mm)) return bad("PhantomOptions::to_mm", "not a number");
  if (from_mm && to_mm && *from_mm > *to_mm)
    return bad("PhantomOptions::from_mm", "the range start " + fmt(*from_mm, 1) +
                                              " mm is past its end " + fmt(*to_mm, 1) + " mm");
  const Placement& p = placement;
  if (!std::isfinite(p.offset_x_mm) || !std::isfinite(p.offset_y_mm) ||
      std::abs(p.offset_x_mm) > 1e4 || std::abs(p.offset_y_mm) > 1e4)
    return bad("Placement::offset_x_mm/Placement::offset_y_mm",
               "offset must be a finite number of mm");
  if (!(std::abs(p.tilt_x_deg) <= 10))
    return bad("Placement::tilt_x_deg", "tilt must be within ±10°, got " + fmt(p.tilt_x_deg, 2));
  if (!(std::abs(p.tilt_y_deg) <= 10))
    return bad("Placement::tilt_y_deg", "tilt must be within ±10°, got " + fmt(p.tilt_y_deg, 2));
  if (!std::isfinite(p.roll_deg)) return bad("Placement::roll_deg", "not a number");
  if (!(noise_hu >= 0 && noise_hu <= 1000))
    return bad("PhantomOptions::noise_hu", "noise σ must be 0-1000 HU, got " + fmt(noise_hu, 1));
  if (!(blur_px >= 0 && blur_px <= 10))
    return bad("PhantomOptions::blur_px", "PSF σ must be 0-10 pixels, got " + fmt(blur_px, 2));
  if (!(bed_gap_mm >= 0 && bed_gap_mm <= 100))
    return bad("PhantomOptions::bed_gap_mm", "must be 0-100 mm, got " + fmt(bed_gap_mm, 2));
  if (!(ring_width_mm >= 0.3 && ring_width_mm <= 30))
    return bad("PhantomOptions::ring_width_mm",
               "ring width must be 0.3-30 mm, got " + fmt(ring_width_mm, 2));
  if (!(ring_amplitude >= 0 && ring_amplitude <= 1))
    return bad("PhantomOptions::ring_amplitude", "must be 0-1, got " + fmt(ring_amplitude, 3));
  if (!(knot_noise >= 0 && knot_noise <= 0.5))
    return bad("PhantomOptions::knot_noise", "must be 0-0.5, got " + fmt(knot_noise, 3));
  if (drop_slices < 0) return bad("PhantomOptions::drop_slices", "must not be negative");
  if (threads < 0 || threads > 256)
    return bad("PhantomOptions::threads", "must be 0 (auto) to 256");
  return validate_conditions();
}

// The condition space's options: each range covers the realistic one of docs/phantom.md with
// room to spare, and refuses what cannot be drawn.
Status PhantomOptions::validate_conditions() const {
  auto range = [](const char* opt, double v, double lo, double hi, const char* unit = "") {
    if (v >= lo && v <= hi) return Status::Ok();
    return Status(Error(opt, num(v) + unit + " is outside " + num(lo) + " to " + num(hi) + unit));
  };
  auto count = [](const char* opt, int v, int hi) {
    if (v >= 0 && v <= hi) return Status::Ok();
    return Status(Error(opt, std::to_string(v) + " is outside 0-" + std::to_string(hi)));
  };
  const Status checks[] = {
      juvenile_ring_width_mm == 0
          ? Status::Ok()
          : range("PhantomOptions::juvenile_ring_width_mm", juvenile_ring_width_mm, 0.3, 30, " mm"),
      range("PhantomOptions::juvenile_radius_mm", juvenile_radius_mm, 1, 1000, " mm"),
      range("PhantomOptions::ring_contrast_hu", ring_contrast_hu, 0, 500, " HU"),
      range("PhantomOptions::latewood_fraction", latewood_fraction, 0, 0.8),
      range("PhantomOptions::density_drift_hu_per_m", density_drift_hu_per_m, -200, 200, " HU/m"),
      count("PhantomOptions::wet_pockets", wet_pockets, 50),
      range("PhantomOptions::hu_offset", hu_offset, -500, 500, " HU"),
      range("PhantomOptions::hu_slope", hu_slope, 0.5, 2),
      range("PhantomOptions::cupping_hu", cupping_hu, 0, 500, " HU"),
      range("PhantomOptions::metal_streak_hu", metal_streak_hu, 0, 2000, " HU"),
      metal_streak_hu > 0 && !clutter
          ? Status(Error("PhantomOptions::metal_streak_hu",
                         "needs PhantomOptions::clutter (the streaks come from its steel)"))
          : Status::Ok(),
      range("PhantomOptions::window_centre_hu", window_centre_hu, -1024, 3071, " HU"),
      window_width_hu == 0
          ? Status::Ok()
          : range("PhantomOptions::window_width_hu", window_width_hu, 10, 5000, " HU"),
      count("PhantomOptions::cracks", cracks, 50),
      range("PhantomOptions::crack_width_mm", crack_width_mm, 0.1, 20, " mm"),
      count("PhantomOptions::resin_pockets", resin_pockets, 200),
      count("PhantomOptions::rot_pockets", rot_pockets, 20),
      range("PhantomOptions::compression_wood", compression_wood, 0, 1),
      count("PhantomOptions::bark_missing", bark_missing, 50),
      count("PhantomOptions::bark_loose", bark_loose, 50),
      range("PhantomOptions::knot_bark_mm", knot_bark_mm, 0, 5, " mm"),
      range("PhantomOptions::resin_knots", resin_knots, 0, 1),
  };
  for (const Status& st : checks)
    if (!st) return st;
  return Status::Ok();
}

// ---- construction ----------------------------------------------------------------------------

Phantom::Phantom(const LogModel& log, const PhantomOptions& options)
    : log_(log), options_(options) {}

Phantom::~Phantom() = default;

Result<std::unique_ptr<Phantom>> Phantom::create(const LogModel& log,
                                                 const PhantomOptions& options) {
  if (Status st = options.validate(); !st) return st.error();
  if (Status st = sawyer::validate(log); !st) return st.error().with_context("log model");
  std::unique_ptr<Phantom> ph(new Phantom(log, options));
  if (Status st = ph->prepare(); !st) return st.error();
  return ph;
}

Vec3 Phantom::to_scanner(const Vec3& p) const {
  const double d[3] = {p.x - A_.x, p.y - A_.y, p.z - A_.z};
  return {T_.x + M_[0][0] * d[0] + M_[0][1] * d[1] + M_[0][2] * d[2],
          T_.y + M_[1][0] * d[0] + M_[1][1] * d[1] + M_[1][2] * d[2],
          T_.z + M_[2][0] * d[0] + M_[2][1] * d[1] + M_[2][2] * d[2]};
}

Vec3 Phantom::to_log(const Vec3& s) const {
  const double d[3] = {s.x - T_.x, s.y - T_.y, s.z - T_.z};
  return {A_.x + M_[0][0] * d[0] + M_[1][0] * d[1] + M_[2][0] * d[2],
          A_.y + M_[0][1] * d[0] + M_[1][1] * d[1] + M_[2][1] * d[2],
          A_.z + M_[0][2] * d[0] + M_[1][2] * d[1] + M_[2][2] * d[2]};
}

void Phantom::solve_pith(double zs, double* z_log, Vec2* xy) const {
  const Stem& st = log_.stem;
  double z = A_.z + (zs - T_.z) / M_[2][2];
  Vec3 s;
  for (int it = 0; it < 30; ++it) {
    const Vec2 p = st.pith_at(z);
    s = to_scanner({p.x, p.y, z});
    const double dz = (zs - s.z) / M_[2][2];
    z += dz;
    if (std::abs(dz) < 1e-10) break;
  }
  const Vec2 p = st.pith_at(z);
  s = to_scanner({p.x, p.y, z});
  *z_log = z;
  *xy = {s.x, s.y};
}

double Phantom::heartwood_radius(double omega, double z, double R) const {
  const Stem& st = log_.stem;
  if (st.has_heartwood()) return st.heartwood_at(omega, z);
  // A smooth wobble in azimuth and height, fixed (not seeded) so that the anatomy does not
  // change with the noise seed.
  std::string sp = log_.species;
  std::transform(sp.begin(), sp.end(), sp.begin(), [](unsigned char c) { return std::tolower(c); });
  if (sp.find("pine") != std::string::npos) {
    const double w = 1 + 0.04 * std::sin(2 * omega + 1.3 + z / 1700.0) +
                     0.025 * std::sin(3 * omega + 0.4 - z / 1100.0);
    return kPineHeartShare * R * w;
  }
  const double band = kSapwoodBandMm * (1 + 0.2 * std::sin(2 * omega + 1.3 + z / 1700.0) +
                                        0.12 * std::sin(3 * omega + 0.4 - z / 1100.0));
  return std::max(0.0, R - band);
}

double Phantom::bark_thickness(double omega, double z, double R) const {
  const Stem& st = log_.stem;
  double base;
  if (st.bark_mm.empty()) {
    base = kDefaultBarkShare * R;
  } else {
    const int n = static_cast<int>(st.bark_mm.size());
    const double u = std::clamp((z - st.z0_mm) / st.dz_mm, 0.0, static_cast<double>(n - 1));
    const int j = std::min(static_cast<int>(u), std::max(n - 2, 0));
    const double f = n > 1 ? u - j : 0.0;
    base = n > 1 ? st.bark_mm[j] * (1 - f) + st.bark_mm[j + 1] * f : st.bark_mm[0];
  }
  // Uneven bark: two broad lobes and ridges (plates and fissures) that wander along the log.
  // The mean over azimuth of this factor is 1, so the truth's bark_mm is the mean thickness.
  const double v = 1 + 0.15 * std::sin(2 * omega + 0.7 + z / 900.0) +
                   0.08 * std::sin(5 * omega + 2.3 - z / 500.0) +
                   0.10 * std::sin(19 * omega + 3.0 * std::sin(z / 37.0));
  double b = base * std::max(v, 0.3);
  for (const Defect& d : defects_) {
    if (d.kind != "bark_missing" && d.kind != "bark_loose") continue;
    if (z < d.z_min || z > d.z_max || std::abs(angle_diff(omega, d.omega)) > d.half_angle) continue;
    b = d.kind == "bark_missing" ? 0.0 : b + d.width_mm;
  }
  return b;
}

double Phantom::bark_gap(double omega, double z) const {
  for (const Defect& d : defects_) {
    if (d.kind == "bark_loose" && z >= d.z_min && z <= d.z_max &&
        std::abs(angle_diff(omega, d.omega)) <= d.half_angle)
      return d.width_mm;
  }
  return 0;
}

double Phantom::rings_at(double t, double omega) const {
  const PhantomOptions& o = options_;
  if (o.juvenile_ring_width_mm == 0 && o.compression_wood == 0) return t * ring_count_;
  // Rings up to nominal radius rho = t · R_ref with the width rising linearly from w_j at the
  // pith to w_m at r_j: the integral of 1 / w.
  const double rho = t * field_->reference_radius();
  const double w_m = o.ring_width_mm;
  double n;
  if (o.juvenile_ring_width_mm == 0) {
    n = rho / w_m;
  } else {
    const double w_j = o.juvenile_ring_width_mm, r_j = o.juvenile_radius_mm;
    const double b = (w_m - w_j) / r_j;
    auto ramp = [&](double x) {
      return std::abs(b) < 1e-12 ? x / w_j : std::log1p(b * x / w_j) / b;
    };
    n = rho <= r_j ? ramp(rho) : ramp(r_j) + (rho - r_j) / w_m;
  }
  if (o.compression_wood > 0) {
    for (const Defect& d : defects_)
      if (d.kind == "compression_wood")
        n /= 1 + kCompressionWidth * o.compression_wood * side_weight(angle_diff(omega, d.omega));
  }
  return n;
}

double Phantom::max_outer_radius(double z_lo, double z_hi) const {
  const Stem& st = log_.stem;
  const int n = st.slice_count();
  const int a =
      std::clamp(static_cast<int>(std::floor((z_lo - st.z0_mm) / st.dz_mm)) - 1, 0, n - 1);
  const int b = std::clamp(static_cast<int>(std::ceil((z_hi - st.z0_mm) / st.dz_mm)) + 1, 0, n - 1);
  double m = 0;
  for (int i = a; i <= b; ++i) m = std::max(m, outer_per_sample_[i]);
  return m;
}

std::unique_ptr<Phantom::Layer> Phantom::make_layer(double z) const {
  auto L = std::make_unique<Layer>();
  L->field = field_->slice(z);
  L->z = z;
  L->heart.resize(kLayerAngles + 1);
  L->bark.resize(kLayerAngles + 1);
  float mo = 0;
  for (int k = 0; k < kLayerAngles; ++k) {
    const double w = kTwoPi * k / kLayerAngles;
    const double R = log_.stem.radius_at(w, z);
    L->heart[k] = static_cast<float>(heartwood_radius(w, z, R));
    L->bark[k] = static_cast<float>(bark_thickness(w, z, R));
    mo = std::max(mo, static_cast<float>(R) + L->bark[k]);
  }
  L->heart[kLayerAngles] = L->heart[0];
  L->bark[kLayerAngles] = L->bark[0];
  L->max_outer = std::max(mo, static_cast<float>(L->field.max_radius()));
  return L;
}

Status Phantom::prepare() {
  const PhantomOptions& o = options_;
  const Stem& st = log_.stem;
  const double th = o.thickness();
  const double sp = o.slice_spacing_mm;
  const double zb = st.z_begin(), ze = st.z_end();

  // Scanned range: slice centres from_..to_ in the log frame.
  from_ = o.from_mm.value_or(zb + 0.5 * th);
  to_ = o.to_mm.value_or(ze - 0.5 * th);
  if (!o.from_mm && !o.to_mm && to_ < from_)
    from_ = to_ = 0.5 * (zb + ze);  // log shorter than a slab
  const double eps = 1e-6;
  if (from_ < zb - eps || to_ > ze + eps || from_ > to_)
    return Error("PhantomOptions::from_mm/PhantomOptions::to_mm",
                 "the scanned range [" + fmt(from_, 1) + ", " + fmt(to_, 1) +
                     "] mm must lie within the log's extent [" + fmt(zb, 1) + ", " + fmt(ze, 1) +
                     "] mm");
  const double nf = std::floor((to_ - from_) / sp + 1e-6) + 1;
  if (nf > kMaxSlices)
    return Error("PhantomOptions::slice_spacing_mm", "the scan would have " + fmt(nf, 0) +
                                                         " slices (at most " +
                                                         std::to_string(kMaxSlices) + ")");
  const int n = static_cast<int>(nf);
  if (o.drop_slices > std::max(0, n - 2))
    return Error("PhantomOptions::drop_slices", "cannot drop " + std::to_string(o.drop_slices) +
                                                    " of " + std::to_string(n) +
                                                    " slices (the first and last are always kept)");

  WoodFieldParams fp;
  fp.knot_noise = o.knot_noise;
  field_ = std::make_unique<WoodField>(log_, fp);
  ring_count_ = field_->reference_radius() / o.ring_width_mm;
  if (o.juvenile_ring_width_mm > 0) ring_count_ = rings_at(1.0, 0.0);
  sub_slices_ = o.sub_slices > 0
                    ? o.sub_slices
                    : std::clamp(static_cast<int>(std::ceil(th / kSubSliceMm - 1e-9)), 1, 16);
  hu_ = o.moisture == Moisture::kDried ? dried_hu_table(o.hu) : o.hu;
  if (o.ring_contrast_hu > 0) {
    double sd;
    ring_profile_stats(o.latewood_fraction, &ring_mean_, &sd);
    ring_amp_hu_ = o.ring_contrast_hu / sd;
  } else {
    ring_amp_hu_ = o.ring_amplitude * hu_.dry_wood_density;
    if (o.latewood_fraction > 0) {
      double sd;
      ring_profile_stats(o.latewood_fraction, &ring_mean_, &sd);
    }
  }
  if (o.latewood_fraction == 0) ring_mean_ = kRingProfileMean;
  // Defects before anything that asks for the bark thickness (the field of view, the bed).
  draw_defects();

  // Placement: M = Ry(tilt_y) · Rx(tilt_x) · Rz(roll).
  const Placement& pl = o.placement;
  const double ax = pl.tilt_x_deg * kDeg, ay = pl.tilt_y_deg * kDeg, ar = pl.roll_deg * kDeg;
  const double Rz[3][3] = {
      {std::cos(ar), -std::sin(ar), 0}, {std::sin(ar), std::cos(ar), 0}, {0, 0, 1}};
  const double Rx[3][3] = {
      {1, 0, 0}, {0, std::cos(ax), -std::sin(ax)}, {0, std::sin(ax), std::cos(ax)}};
  const double Ry[3][3] = {
      {std::cos(ay), 0, std::sin(ay)}, {0, 1, 0}, {-std::sin(ay), 0, std::cos(ay)}};
  double XR[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      XR[i][j] = 0;
      for (int k = 0; k < 3; ++k) XR[i][j] += Rx[i][k] * Rz[k][j];
    }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      M_[i][j] = 0;
      for (int k = 0; k < 3; ++k) M_[i][j] += Ry[i][k] * XR[k][j];
    }
  const double zc = from_ + 0.5 * (n - 1) * sp;
  const Vec2 pc = st.pith_at(zc);
  A_ = {pc.x, pc.y, zc};
  const int W = o.image_size;
  const double px = o.pixel_mm;
  const double centre = 0.5 * (W - 1) * px;
  T_ = {centre + pl.offset_x_mm, centre + pl.offset_y_mm, 0.5 * (n - 1) * sp};

  nominal_z_.resize(n);
  pith_.resize(n);
  pith_log_z_.resize(n);
  for (int i = 0; i < n; ++i) {
    nominal_z_[i] = i * sp;
    solve_pith(nominal_z_[i], &pith_log_z_[i], &pith_[i]);
  }

  // Largest outer radius (R + bark) per stem sample, with a margin for the interpolation's
  // overshoot between samples.
  outer_per_sample_.resize(st.slice_count());
  for (int i = 0; i < st.slice_count(); ++i) {
    const double z = st.z_at(i);
    double m = 0;
    for (int k = 0; k < 360; ++k) {
      const double w = kTwoPi * k / 360;
      const double R = st.radius_at(w, z);
      m = std::max(m, R + bark_thickness(w, z, R));
    }
    outer_per_sample_[i] = 1.01 * m + 0.5;
  }
  max_outer_ = *std::max_element(outer_per_sample_.begin(), outer_per_sample_.end());

  // Field of view: every slice's cross-section (bark included) must lie inside the image.
  const double tilt = std::acos(std::clamp(M_[2][2], -1.0, 1.0));
  const double reach_z = max_outer_ * std::sin(tilt) + 0.5 * th;
  double need = 0;
  for (int i = 0; i < n; ++i) {
    const double ext =
        max_outer_radius(pith_log_z_[i] - reach_z, pith_log_z_[i] + reach_z) / std::cos(tilt) +
        0.5 * th * std::tan(tilt);
    need = std::max(need,
                    std::max(std::abs(pith_[i].x - centre), std::abs(pith_[i].y - centre)) + ext);
  }
  const double half = 0.5 * W * px;
  if (need > half && !o.allow_clipped) {
    const double px_min = std::ceil(need / (0.5 * W) * 1000.0) / 1000.0;
    return Error("log does not fit the field of view: it reaches " + fmt(need, 1) +
                 " mm from the image centre, a " + std::to_string(W) + " x " + fmt(px, 3) +
                 " mm image only " + fmt(half, 1) + " mm; the smallest pixel size that fits is " +
                 fmt(px_min, 3) +
                 " mm (PhantomOptions::pixel_mm), or use a larger PhantomOptions::image_size");
  }

  // Missing slices: drawn from the seed, never the first (z = 0) or the last.
  if (o.drop_slices > 0) {
    std::vector<int> pool;
    for (int i = 1; i < n - 1; ++i) pool.push_back(i);
    Rng rng(stream_seed(o.seed, phantom_detail::kDropStream, 0));
    for (int k = 0; k < o.drop_slices; ++k) {
      const int j = k + static_cast<int>(rng.next() % (pool.size() - k));
      std::swap(pool[k], pool[j]);
      dropped_.push_back(pool[k]);
    }
    std::sort(dropped_.begin(), dropped_.end());
  }
  geometry_ = VolumeGeometry{};
  geometry_.width = geometry_.height = W;
  geometry_.spacing_x = geometry_.spacing_y = px;
  // Where a scanner puts its image: centred on the isocentre (0, 0), the table at 1 m. Non-zero
  // so that every consumer must honour the origin; truth/log.json is in the same frame.
  geometry_.origin = {-0.5 * (W - 1) * px, -0.5 * (W - 1) * px, 1000.0};
  geometry_.bits_stored = 16;
  geometry_.pixel_signed = true;
  for (int i = 0, d = 0; i < n; ++i) {
    if (d < static_cast<int>(dropped_.size()) && dropped_[d] == i) {
      ++d;
      continue;
    }
    kept_.push_back(i);
    geometry_.z.push_back(nominal_z_[i]);
  }

  // The bed: a curved rubber belt (a cradle) the log lies on, on two aluminium rails. Fixed in
  // the scanner; its lowest inner point touches the log's lowest point over the whole scan.
  if (o.bed) {
    double y_low = -1e300, x_low = centre;
    for (int i = 0; i < n; ++i) {
      for (int k = -12; k <= 12; ++k) {
        const double ws = 0.5 * kPi + k * 0.05;  // scanner azimuth near straight down (+y)
        const double wl = wrap_angle(ws - ar);
        const double R = st.radius_at(wl, pith_log_z_[i]);
        const double r = R + bark_thickness(wl, pith_log_z_[i], R);
        const double y = pith_[i].y + r * std::sin(ws);
        if (y > y_low) {
          y_low = y;
          x_low = pith_[i].x + r * std::cos(ws);
        }
      }
    }
    has_bed_ = true;
    bed_radius_ = 1.35 * max_outer_;
    bed_half_angle_ = 40 * kDeg;
    const double gap = o.bed_gap_mm;
    bed_centre_ = {x_low, y_low + gap - bed_radius_};
    for (int s = 0; s < 2; ++s) {
      const double sg = s == 0 ? -1 : 1;
      const Vec2 u{sg * std::sin(bed_half_angle_), std::cos(bed_half_angle_)};
      rail_centre_[s] = bed_centre_ + (bed_radius_ + bed_thickness_ + rail_half_) * u;
    }
  }

  // Clutter: steel support bars across the scan under the belt, and a short chain lying on the
  // log; positions drawn from the seed.
  if (o.clutter) {
    Rng rng(stream_seed(o.seed, phantom_detail::kClutterStream, 0));
    const double z_len = (n - 1) * sp;
    const double bed_y =
        has_bed_ ? bed_centre_.y + bed_radius_ + bed_thickness_ : pith_[n / 2].y + max_outer_;
    const int bars = std::max(1, static_cast<int>(std::lround(z_len / 1000.0)));
    for (int b = 0; b < bars; ++b) {
      ClutterShape s;
      s.kind = ClutterShape::Kind::kBar;
      const double zc_bar = rng.uniform(0, z_len);
      const double xc = has_bed_ ? bed_centre_.x : pith_[n / 2].x;
      // Under the belt, moved up into the image if the belt sits at its bottom edge.
      const double y_hi = std::min(bed_y + 22, (W - 3) * px);
      s.lo = {xc - 0.9 * max_outer_ * 1.35, y_hi - 20, zc_bar - 6};
      s.hi = {xc + 0.9 * max_outer_ * 1.35, y_hi, zc_bar + 6};
      s.z_min = s.lo.z;
      s.z_max = s.hi.z;
      shapes_.push_back(s);
      clutter_.push_back({"bar", 0.5 * (s.lo + s.hi), s.z_min, s.z_max});
    }
    // A chain of links along the log's top; links alternate between the vertical and the
    // horizontal plane, as a chain lies.
    constexpr int kLinks = 5;
    constexpr double kLinkLength = 50, kLinkWidth = 26, kWire = 4, kPitch = 42;
    const double z0 = rng.uniform(0, std::max(0.0, z_len - kLinks * kPitch));
    for (int l = 0; l < kLinks; ++l) {
      ClutterShape s;
      s.kind = ClutterShape::Kind::kLink;
      const double zl = z0 + (l + 0.5) * kPitch;
      const int i = std::clamp(static_cast<int>(std::lround(zl / sp)), 0, n - 1);
      // Top of the log (smallest y) at that slice.
      const double wl = wrap_angle(1.5 * kPi - ar);
      const double R = st.radius_at(wl, pith_log_z_[i]);
      const double top = pith_[i].y - (R + bark_thickness(wl, pith_log_z_[i], R));
      const bool vertical = l % 2 == 0;
      s.a = kWire;
      s.rho = 0.5 * kLinkWidth - kWire;
      s.h = 0.5 * kLinkLength - 0.5 * kLinkWidth;
      s.e_u = {0, 0, 1};
      s.e_v = vertical ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
      s.e_w = vertical ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
      s.c = {pith_[i].x, top - (vertical ? 0.5 * kLinkWidth : kWire) - 0.5, zl};
      s.z_min = zl - 0.5 * kLinkLength;
      s.z_max = zl + 0.5 * kLinkLength;
      shapes_.push_back(s);
      clutter_.push_back({"chain_link", s.c, s.z_min, s.z_max});
    }
  }

  if (o.second_log) place_second_log();

  // Metal streaks: six lines through each steel object, 30° apart with a jitter, from the seed.
  if (o.metal_streak_hu > 0) {
    Rng rng(stream_seed(o.seed, phantom_detail::kDefectStream, 8));
    for (const ClutterObject& c : clutter_) {
      MetalStreaks m;
      m.centre = {c.centre.x, c.centre.y};
      m.z_min = c.z_min;
      m.z_max = c.z_max;
      m.amplitude_hu = o.metal_streak_hu;
      const double base = rng.uniform(0, kPi);
      for (int k = 0; k < 6; ++k) m.angles.push_back(base + k * kPi / 6 + rng.uniform(-0.1, 0.1));
      streaks_.push_back(std::move(m));
    }
  }

  // The scene without the log: air, and the bed, which is the same in every slice.
  base_.assign(static_cast<size_t>(W) * W, static_cast<float>(o.hu.air));
  if (has_bed_) {
    for (int y = 0; y < W; ++y)
      for (int x = 0; x < W; ++x) {
        float v;
        if (bed_hu(x * px, y * px, &v)) base_[static_cast<size_t>(y) * W + x] = v;
      }
  }
  return Status::Ok();
}

// Places the defects of the condition space from the seed, inside the scanned range so that a
// short scan sees them. Each kind draws from its own stream.
void Phantom::draw_defects() {
  const PhantomOptions& o = options_;
  const Stem& st = log_.stem;
  auto rng_for = [&](int kind) {
    return Rng(
        stream_seed(o.seed, phantom_detail::kDefectStream, static_cast<std::uint64_t>(kind)));
  };
  // An ellipsoidal pocket at a share of the heartwood radius (heart = true) or of the radius.
  auto pocket = [&](Rng& rng, const char* kind, bool heart, double share_lo, double share_hi,
                    double rad_lo, double rad_hi, double tan_lo, double tan_hi, double len_lo,
                    double len_hi) {
    Defect d;
    d.kind = kind;
    d.omega = rng.uniform(0, kTwoPi);
    d.z_mm = rng.uniform(from_, to_);
    const double R = st.radius_at(d.omega, d.z_mm);
    const double outer = heart ? heartwood_radius(d.omega, d.z_mm, R) : R;
    d.r_mm = rng.uniform(share_lo, share_hi) * outer;
    d.radial_mm = std::min(rng.uniform(rad_lo, rad_hi), std::max(1.0, 0.5 * outer));
    d.tangential_mm = rng.uniform(tan_lo, tan_hi);
    const double len = rng.uniform(len_lo, len_hi);
    d.z_min = d.z_mm - len;
    d.z_max = d.z_mm + len;
    defects_.push_back(d);
  };
  {
    // Wet patches of spruce heartwood: 10-30 mm across, 10-50 cm long.
    Rng rng = rng_for(0);
    for (int i = 0; i < o.wet_pockets; ++i)
      pocket(rng, "wet_pocket", true, 0.3, 0.75, 5, 15, 8, 20, 50, 250);
  }
  {
    // Rot: decayed columns in the heartwood near the pith (butt rot), 2-6 cm across.
    Rng rng = rng_for(1);
    for (int i = 0; i < o.rot_pockets; ++i)
      pocket(rng, "rot", true, 0.0, 0.4, 10, 30, 10, 30, 100, 400);
  }
  {
    // Resin pockets: lenses between rings, 2-5 mm thick, 1-3 cm wide, 2-8 cm long.
    Rng rng = rng_for(2);
    for (int i = 0; i < o.resin_pockets; ++i)
      pocket(rng, "resin_pocket", false, 0.15, 0.9, 1, 2.5, 5, 15, 10, 40);
  }
  {
    // Cracks, alternately heart checks (from the pith) and checks (from the bark).
    Rng rng = rng_for(3);
    for (int i = 0; i < o.cracks; ++i) {
      Defect d;
      d.kind = "crack";
      d.omega = rng.uniform(0, kTwoPi);
      d.z_mm = rng.uniform(from_, to_);
      const double R = st.radius_at(d.omega, d.z_mm);
      d.from_bark = i % 2 == 1;
      if (d.from_bark) {
        d.r_max = R + 1;  // open at the surface (the bark over it is cracked too)
        d.r_min = R * (1 - rng.uniform(0.15, 0.35));
      } else {
        d.r_min = 0;
        d.r_max = R * rng.uniform(0.25, 0.6);
      }
      d.r_mm = 0.5 * (d.r_min + d.r_max);
      d.width_mm = o.crack_width_mm;
      const double len = rng.uniform(100, 600);
      d.z_min = d.z_mm - len;
      d.z_max = d.z_mm + len;
      defects_.push_back(d);
    }
  }
  if (o.compression_wood > 0) {
    // The lower side of a leaning stem: one side over the whole log.
    Rng rng = rng_for(4);
    Defect d;
    d.kind = "compression_wood";
    d.omega = rng.uniform(0, kTwoPi);
    d.half_angle = 0.25 * kPi;  // where the side weight is 0.5
    d.z_min = st.z_begin();
    d.z_max = st.z_end();
    d.z_mm = 0.5 * (d.z_min + d.z_max);
    d.width_mm = kCompressionHu * o.compression_wood;  // the extra HU on the centre line
    defects_.push_back(d);
  }
  for (int kind = 5; kind <= 6; ++kind) {
    // Bark patches: missing (stripped in handling) or loose (standing off on an air gap).
    Rng rng = rng_for(kind);
    const int n = kind == 5 ? o.bark_missing : o.bark_loose;
    for (int i = 0; i < n; ++i) {
      Defect d;
      d.kind = kind == 5 ? "bark_missing" : "bark_loose";
      d.omega = rng.uniform(0, kTwoPi);
      d.half_angle = rng.uniform(10, 35) * kDeg;
      d.z_mm = rng.uniform(from_, to_);
      const double len = rng.uniform(50, 300);
      d.z_min = d.z_mm - len;
      d.z_max = d.z_mm + len;
      d.r_mm = st.radius_at(d.omega, d.z_mm);
      if (kind == 6) d.width_mm = rng.uniform(1, 4);
      defects_.push_back(d);
    }
  }
  resin_knot_.assign(log_.knots.size(), 0);
  if (o.resin_knots > 0) {
    Rng rng = rng_for(7);
    for (size_t i = 0; i < log_.knots.size(); ++i) {
      const Knot& k = log_.knots[i];
      if (rng.uniform() >= o.resin_knots || k.r_dead >= k.r_end) continue;
      resin_knot_[i] = 1;
      Defect d;
      d.kind = "resin_knot";
      d.knot_id = k.id;
      d.omega = k.omega0;
      d.z_mm = k.z0;
      d.r_min = k.r_dead;
      d.r_max = k.r_end;
      d.r_mm = 0.5 * (k.r_dead + k.r_end);
      defects_.push_back(d);
    }
  }
}

bool Phantom::in_crack(double r, double omega, double z) const {
  for (const Defect& d : defects_) {
    if (d.kind != "crack" || z <= d.z_min || z >= d.z_max || r < d.r_min || r > d.r_max) continue;
    const double dw = angle_diff(omega, d.omega);
    if (std::cos(dw) <= 0) continue;
    const double open_r = d.from_bark ? d.r_max : d.r_min;
    const double dz = (z - d.z_mm) / (0.5 * (d.z_max - d.z_min));
    const double half = 0.5 * d.width_mm * (1 - std::abs(r - open_r) / (d.r_max - d.r_min)) *
                        std::sqrt(std::max(0.0, 1 - dz * dz));
    if (std::abs(r * std::sin(dw)) <= half) return true;
  }
  return false;
}

void Phantom::apply_pockets(double r, double omega, double z, double sap, double* v,
                            Region* region) const {
  for (size_t i = 0; i < defects_.size(); ++i) {
    const Defect& d = defects_[i];
    const bool wet = d.kind == "wet_pocket";
    if (!wet && d.kind != "rot" && d.kind != "resin_pocket") continue;
    if (z <= d.z_min || z >= d.z_max) continue;
    const double dw = angle_diff(omega, d.omega);
    const double u = (r * std::cos(dw) - d.r_mm) / d.radial_mm;
    const double w = r * std::sin(dw) / d.tangential_mm;
    const double h = (z - d.z_mm) / (0.5 * (d.z_max - d.z_min));
    const double q = u * u + w * w + h * h;
    if (q >= 1) continue;
    if (wet) {
      // An irregular outline: the radius wanders by ±25 % around the pocket and along it.
      const double lobe = 1 + 0.25 * std::sin(3 * std::atan2(w, u) + 1.7 * i + z / 45.0);
      if (q >= lobe * lobe) continue;
      *v += (hu_.sapwood - hu_.heartwood) * (1 - sap);
      *region = Region::kWetPocket;
    } else if (d.kind == "rot") {
      *v = hu_.rot;
      *region = Region::kRot;
    } else {
      *v = hu_.resin;
      *region = Region::kResinPocket;
    }
  }
}

Vec3 Phantom::second_to_log(const Vec3& s) const {
  return {A_.x - (s.x - second_c_.x), A_.y - (s.y - second_c_.y), A_.z - (s.z - T_.z)};
}

Vec2 Phantom::second_pith(int i) const {
  const double z2 = A_.z - (nominal_z_[i] - T_.z);
  const Vec2 p = log_.stem.pith_at(z2);
  return {second_c_.x - (p.x - A_.x), second_c_.y - (p.y - A_.y)};
}

// The second log beside the first on +x, at the height of A: as close as the two outlines
// allow in every slice, so that they touch where they are closest (the first log's placement
// without its tilt, which moves it by a few mm at most).
void Phantom::place_second_log() {
  const Stem& st = log_.stem;
  const double roll = options_.placement.roll_deg * kDeg;
  // How far a section reaches along scanner +x when the log frame is turned by `turn`: the
  // largest (R + bark) · cos(omega + turn).
  auto reach_x = [&](double z, double turn) {
    double m = 0;
    for (int k = 0; k < kLayerAngles; ++k) {
      const double w = kTwoPi * k / kLayerAngles;
      const double R = st.radius_at(w, z);
      m = std::max(m, (R + bark_thickness(w, z, R)) * std::cos(w + turn));
    }
    return m;
  };
  double need = -1e300;
  for (int i = 0; i < nominal_count(); ++i) {
    const double z2 = A_.z - (nominal_z_[i] - T_.z);
    if (z2 < st.z_begin() || z2 > st.z_end()) continue;
    const double right1 = pith_[i].x + reach_x(pith_log_z_[i], roll);
    // The second log's leftmost point, relative to C2, is where its log-frame x is largest (it
    // is turned by π).
    const double left2 = -(st.pith_at(z2).x - A_.x) - reach_x(z2, 0);
    if (right1 - left2 > need) {
      need = right1 - left2;
      second_touch_ = i;
    }
  }
  has_second_ = second_touch_ >= 0;
  second_c_ = {need, T_.y};
}

float Phantom::calibrated(float v) const {
  const PhantomOptions& o = options_;
  if (o.hu_offset == 0 && o.hu_slope == 1) return v;
  return static_cast<float>(o.hu_offset + o.hu_slope * v);
}

bool Phantom::ClutterShape::contains(const Vec3& p) const {
  if (p.z < z_min || p.z > z_max) return false;
  if (kind == Kind::kBar)
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  const Vec3 d = p - c;
  const double u = std::abs(dot(d, e_u)), v = dot(d, e_v), w = dot(d, e_w);
  const double in_plane =
      u <= h ? std::abs(std::abs(v) - rho) : std::abs(std::hypot(u - h, v) - rho);
  return in_plane * in_plane + w * w <= a * a;
}

// ---- CT numbers ------------------------------------------------------------------------------

// The CT number of the log at a point, from its field sample and the heartwood radius and bark
// thickness there. Shared by rendering (layers) and sample_point (exact heights).
float Phantom::material_hu(const FieldSample& fs, double z, float H, float B,
                           Region* region) const {
  const HuTable& hu = hu_;
  const PhantomOptions& o = options_;
  const float r = fs.r, R = fs.radius;
  if (r > R) {
    if (r > R + B) {
      *region = Region::kAir;
      return static_cast<float>(hu.air);
    }
    const double gap = o.bark_loose > 0 ? bark_gap(fs.omega, z) : 0.0;
    if (r - R < gap) {  // under loose bark
      *region = Region::kAir;
      return static_cast<float>(hu.air);
    }
    *region = Region::kBark;
    const double s =
        gap == 0 ? (r - R) / std::max(B, 1e-3f) : (r - R - gap) / std::max(B - gap, 1e-3);
    return static_cast<float>(hu.bark_inner + (hu.bark_outer - hu.bark_inner) * s);
  }
  if (o.cracks > 0 && in_crack(r, fs.omega, z)) {
    *region = Region::kCrack;
    return static_cast<float>(hu.air);
  }
  double v;
  double sap = 0;
  const bool knot = fs.knot >= 0;
  if (knot) {
    const Knot& k = log_.knots[fs.knot];
    if (fs.dead) {
      const double rho0 = 0.5 * k.diameter_at(std::min<double>(r, k.r_dead));
      // Encased bark: the outer knot_bark_mm of the dead knot's outline (the field's, with its
      // outline noise, since knot_depth is measured against it).
      const double kb = o.knot_bark_mm;
      if (kb > 0 && fs.knot_depth >= 1.0 - kb / std::max(rho0, 2 * kb)) {
        *region = Region::kKnotBark;
        return static_cast<float>(hu.knot_bark);
      }
      *region = Region::kDeadKnot;
      v = resin_knot_[fs.knot] ? hu.resin_knot : hu.dead_knot;
    } else {
      *region = Region::kSoundKnot;
      v = hu.sound_knot;
    }
  } else {
    sap = smoothstep(H - 0.5 * kHeartTransitionMm, H + 0.5 * kHeartTransitionMm, r);
    *region = sap < 0.5 ? Region::kHeartwood : Region::kSapwood;
    v = hu.heartwood + (hu.sapwood - hu.heartwood) * sap;
    if (o.compression_wood > 0) {
      for (const Defect& d : defects_)
        if (d.kind == "compression_wood")
          v += d.width_mm * side_weight(angle_diff(fs.omega, d.omega));
    }
  }
  if (o.density_drift_hu_per_m != 0)
    v += o.density_drift_hu_per_m * (z - 0.5 * (log_.stem.z_begin() + log_.stem.z_end())) / 1000;
  // Annual rings: the dry wood substance is denser in the latewood. The phase follows the
  // field's t, so the rings bend around knots exactly as in the renderer.
  const double t = rings_at(std::max(0.0f, fs.t), fs.omega);
  v += ring_amp_hu_ * (ring_profile_lw(t - std::floor(t), o.latewood_fraction) - ring_mean_);
  if (!knot && (o.wet_pockets > 0 || o.rot_pockets > 0 || o.resin_pockets > 0))
    apply_pockets(r, fs.omega, z, sap, &v, region);
  // Beam hardening: the centre of the section reads lower than its rim.
  if (o.cupping_hu > 0) v -= o.cupping_hu * std::max(0.0, 1.0 - (r / R) * (r / R));
  return static_cast<float>(v);
}

float Phantom::log_hu(const Layer& layer, double x, double y, Region* region) const {
  const FieldSample fs = layer.field.sample(x, y);
  return material_hu(fs, layer.z, table_at(layer.heart, fs.omega), table_at(layer.bark, fs.omega),
                     region);
}

bool Phantom::clutter_hu(const Vec3& s, float* hu) const {
  for (const ClutterShape& c : shapes_) {
    if (c.contains(s)) {
      *hu = static_cast<float>(options_.hu.steel);
      return true;
    }
  }
  return false;
}

bool Phantom::bed_hu(double x, double y, float* hu) const {
  if (!has_bed_) return false;
  const double dx = x - bed_centre_.x, dy = y - bed_centre_.y;
  const double d = std::hypot(dx, dy);
  if (d >= bed_radius_ && d <= bed_radius_ + bed_thickness_ && dy > 0 &&
      std::abs(std::atan2(dx, dy)) <= bed_half_angle_) {
    *hu = static_cast<float>(options_.hu.bed_belt);
    return true;
  }
  for (const Vec2& rc : rail_centre_) {
    const double ux = std::abs(x - rc.x), uy = std::abs(y - rc.y);
    if (ux <= rail_half_ && uy <= rail_half_ &&
        (ux > rail_half_ - rail_wall_ || uy > rail_half_ - rail_wall_)) {
      *hu = static_cast<float>(options_.hu.bed_rail);
      return true;
    }
  }
  return false;
}

PhantomPoint Phantom::sample_point(const Vec3& s) const {
  PhantomPoint out;
  out.log_point = to_log(s);
  out.hu = calibrated(static_cast<float>(options_.hu.air));
  float ohu;
  if (clutter_hu(s, &ohu)) {
    out.hu = calibrated(ohu);
    out.region = Region::kClutter;
    return out;
  }
  if (bed_hu(s.x, s.y, &ohu)) {
    out.hu = calibrated(ohu);
    out.region = Region::kBed;
    return out;
  }
  const Stem& st = log_.stem;
  auto log_at = [&](const Vec3& p) {
    if (p.z < st.z_begin() || p.z > st.z_end()) return;
    const FieldSample fs = field_->sample(p);
    out.field = fs;
    out.heartwood_radius = static_cast<float>(heartwood_radius(fs.omega, p.z, fs.radius));
    out.bark_mm = static_cast<float>(bark_thickness(fs.omega, p.z, fs.radius));
    out.hu = calibrated(material_hu(fs, p.z, out.heartwood_radius, out.bark_mm, &out.region));
  };
  log_at(out.log_point);
  if (out.region == Region::kAir && has_second_) {
    const PhantomPoint first = out;
    out.log_point = second_to_log(s);
    out.second_log = true;
    log_at(out.log_point);
    if (out.region == Region::kAir) out = first;
  }
  return out;
}

// ---- rendering -------------------------------------------------------------------------------

// Field layers by log-frame height for tilted logs: a bank kTiltLayerStep apart, kept between
// the slices one thread renders (neighbouring slices share most of their heights).
struct Phantom::Renderer::Cache {
  std::map<long long, std::unique_ptr<Layer>> bank;
  std::vector<float> acc, tmp;
  std::vector<char> first;  // second log: pixels the first log holds in this sub-slice
};

Phantom::Renderer::Renderer(const Phantom& phantom)
    : ph_(phantom), cache_(std::make_unique<Cache>()) {}
Phantom::Renderer::~Renderer() = default;

Slice Phantom::render_slice(int i) const {
  Renderer r(*this);
  Slice s;
  r.render(i, s);
  return s;
}

namespace {

// Separable Gaussian blur with clamped edges, in place (`tmp` is scratch).
void gaussian_blur(std::vector<float>& img, std::vector<float>& tmp, int W, int H, double sigma) {
  if (sigma <= 0) return;
  const int rad = std::max(1, static_cast<int>(std::ceil(3 * sigma)));
  std::vector<float> k(2 * rad + 1);
  double sum = 0;
  for (int i = -rad; i <= rad; ++i) {
    k[i + rad] = static_cast<float>(std::exp(-0.5 * i * i / (sigma * sigma)));
    sum += k[i + rad];
  }
  for (float& v : k) v = static_cast<float>(v / sum);
  tmp.resize(img.size());
  for (int y = 0; y < H; ++y) {
    const float* row = img.data() + static_cast<size_t>(y) * W;
    float* out = tmp.data() + static_cast<size_t>(y) * W;
    for (int x = 0; x < W; ++x) {
      float a = 0;
      for (int d = -rad; d <= rad; ++d) a += k[d + rad] * row[std::clamp(x + d, 0, W - 1)];
      out[x] = a;
    }
  }
  for (int y = 0; y < H; ++y) {
    float* out = img.data() + static_cast<size_t>(y) * W;
    std::fill(out, out + W, 0.0f);
    for (int d = -rad; d <= rad; ++d) {
      const float* src = tmp.data() + static_cast<size_t>(std::clamp(y + d, 0, H - 1)) * W;
      const float w = k[d + rad];
      for (int x = 0; x < W; ++x) out[x] += w * src[x];
    }
  }
}

}  // namespace

// Reconstruction streaks of the steel crossing slice height z, added to the W x W image.
void Phantom::add_streaks(const Phantom& ph, double z, std::vector<float>& img) {
  const int W = ph.options_.image_size;
  const double px = ph.options_.pixel_mm;
  for (const MetalStreaks& m : ph.streaks_) {
    if (z < m.z_min || z > m.z_max) continue;
    const double reach = 4 * m.sigma_mm;
    for (size_t k = 0; k < m.angles.size(); ++k) {
      const double ux = std::cos(m.angles[k]), uy = std::sin(m.angles[k]);
      const double a = (k % 2 == 0 ? -1.0 : 1.0) * m.amplitude_hu;
      for (int y = 0; y < W; ++y)
        for (int x = 0; x < W; ++x) {
          const double dx = x * px - m.centre.x, dy = y * px - m.centre.y;
          const double d = std::abs(dx * uy - dy * ux);
          if (d > reach) continue;
          const double L = std::abs(dx * ux + dy * uy);
          img[static_cast<size_t>(y) * W + x] += static_cast<float>(
              a * std::exp(-0.5 * d * d / (m.sigma_mm * m.sigma_mm) - L / m.decay_mm));
        }
    }
  }
}

// The second log in one sub-slice at scanner height zs, where the first log (which the caller
// drew in the box x0..x1, y0..y1) left air or the bed.
void Phantom::Renderer::render_second_log(double zs, int x0, int x1, int y0, int y1) {
  const Phantom& ph = ph_;
  const int W = ph.options_.image_size;
  const double px = ph.options_.pixel_mm;
  const Stem& st = ph.log_.stem;
  const double z2 = ph.A_.z - (zs - ph.T_.z);
  if (z2 < st.z_begin() || z2 > st.z_end()) return;
  const std::unique_ptr<Layer> L = ph.make_layer(z2);
  const Vec2 lp = L->field.pith();
  const Vec2 c{ph.second_c_.x - (lp.x - ph.A_.x), ph.second_c_.y - (lp.y - ph.A_.y)};
  const double ext = L->max_outer + 2 * px;
  const int a0 = std::clamp(static_cast<int>(std::floor((c.x - ext) / px)), 0, W - 1);
  const int a1 = std::clamp(static_cast<int>(std::ceil((c.x + ext) / px)), 0, W - 1);
  const int b0 = std::clamp(static_cast<int>(std::floor((c.y - ext) / px)), 0, W - 1);
  const int b1 = std::clamp(static_cast<int>(std::ceil((c.y + ext) / px)), 0, W - 1);
  Cache& cc = *cache_;
  for (int y = b0; y <= b1; ++y)
    for (int x = a0; x <= a1; ++x) {
      const size_t p = static_cast<size_t>(y) * W + x;
      // Where the first log is, it stays (the two touch at most).
      if (x >= x0 && x <= x1 && y >= y0 && y <= y1 && cc.first[p]) continue;
      const Vec3 P = ph.second_to_log({x * px, y * px, zs});
      const double dx = P.x - lp.x, dy = P.y - lp.y;
      const double lim = L->max_outer + 1.0;
      if (dx * dx + dy * dy > lim * lim) continue;
      Region reg;
      const float v = ph.log_hu(*L, P.x, P.y, &reg);
      if (reg == Region::kAir) continue;
      cc.acc[p] += v - ph.base_[p];
    }
}

void Phantom::Renderer::render(int i, Slice& out) {
  const Phantom& ph = ph_;
  const PhantomOptions& o = ph.options_;
  assert(i >= 0 && i < ph.nominal_count());
  const int W = o.image_size;
  const double px = o.pixel_mm;
  const size_t npix = static_cast<size_t>(W) * W;
  const int n_sub = ph.sub_slices_;
  const double th = o.thickness();
  const bool tilted = o.placement.tilted();
  const Stem& st = ph.log_.stem;
  const double zb = st.z_begin(), ze = st.z_end();
  Cache& c = *cache_;

  // Sum of the sub-slices; each starts as the scene without the log (air and bed), and the
  // log and clutter add their difference from it where they are.
  c.acc.resize(npix);
  for (size_t p = 0; p < npix; ++p) c.acc[p] = n_sub * ph.base_[p];
  auto sub_z = [&](int k) { return ph.nominal_z_[i] - 0.5 * th + (k + 0.5) * th / n_sub; };

  const double tilt = std::acos(std::clamp(ph.M_[2][2], -1.0, 1.0));
  const double reach = ph.max_outer_ * std::sin(tilt) + 1.0;

  // Tilted logs: the bank of layers must cover every height this slice's pixels reach.
  long long k_lo = 0, k_hi = -1;
  std::vector<Layer*> lut;
  if (tilted) {
    double zmin = 1e300, zmax = -1e300;
    for (int k : {0, n_sub - 1}) {
      double zl;
      Vec2 pc;
      ph.solve_pith(sub_z(k), &zl, &pc);
      zmin = std::min(zmin, zl - reach);
      zmax = std::max(zmax, zl + reach);
    }
    k_lo = static_cast<long long>(std::floor(zmin / kTiltLayerStep)) - 1;
    k_hi = static_cast<long long>(std::ceil(zmax / kTiltLayerStep)) + 1;
    for (auto it = c.bank.begin(); it != c.bank.end();) {
      if (it->first < k_lo || it->first > k_hi)
        it = c.bank.erase(it);
      else
        ++it;
    }
    lut.assign(static_cast<size_t>(k_hi - k_lo + 1), nullptr);
    for (auto& [key, layer] : c.bank) lut[static_cast<size_t>(key - k_lo)] = layer.get();
  }

  for (int k = 0; k < n_sub; ++k) {
    const double zs = sub_z(k);
    double zl_pith;
    Vec2 pc;
    ph.solve_pith(zs, &zl_pith, &pc);
    const double ext =
        ph.max_outer_radius(zl_pith - reach, zl_pith + reach) / std::cos(tilt) + 2 * px;
    const int x0 = std::clamp(static_cast<int>(std::floor((pc.x - ext) / px)), 0, W - 1);
    const int x1 = std::clamp(static_cast<int>(std::ceil((pc.x + ext) / px)), 0, W - 1);
    const int y0 = std::clamp(static_cast<int>(std::floor((pc.y - ext) / px)), 0, W - 1);
    const int y1 = std::clamp(static_cast<int>(std::ceil((pc.y + ext) / px)), 0, W - 1);

    if (ph.has_second_) c.first.assign(npix, 0);
    std::unique_ptr<Layer> flat;
    if (!tilted) {
      if (zl_pith < zb || zl_pith > ze) continue;  // beyond the log's end face: air
      flat = ph.make_layer(zl_pith);               // untilted: one exact height per sub-slice
    }

    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Vec3 P = ph.to_log({x * px, y * px, zs});
        const Layer* L = flat.get();
        if (tilted) {
          if (P.z < zb || P.z > ze) continue;  // beyond the log's end faces
          const long long key = std::clamp(std::llround(P.z / kTiltLayerStep), k_lo, k_hi);
          Layer*& slot = lut[static_cast<size_t>(key - k_lo)];
          if (!slot) {
            auto made = ph.make_layer(key * kTiltLayerStep);
            slot = made.get();
            c.bank[key] = std::move(made);
          }
          L = slot;
        }
        const Vec2 lp = L->field.pith();
        const double dx = P.x - lp.x, dy = P.y - lp.y;
        const double lim = L->max_outer + 1.0;
        if (dx * dx + dy * dy > lim * lim) continue;
        Region reg;
        const float v = ph.log_hu(*L, P.x, P.y, &reg);
        if (reg == Region::kAir) continue;
        const size_t p = static_cast<size_t>(y) * W + x;
        c.acc[p] += v - ph.base_[p];
        if (ph.has_second_) c.first[p] = 1;
      }
    }
    if (ph.has_second_) render_second_log(zs, x0, x1, y0, y1);
    // Clutter: steel objects crossing this sub-slice.
    for (const ClutterShape& s : ph.shapes_) {
      if (zs < s.z_min || zs > s.z_max) continue;
      double bx0, bx1, by0, by1;
      if (s.kind == ClutterShape::Kind::kBar) {
        bx0 = s.lo.x, bx1 = s.hi.x, by0 = s.lo.y, by1 = s.hi.y;
      } else {
        const double e = s.h + s.rho + s.a;
        bx0 = s.c.x - e, bx1 = s.c.x + e, by0 = s.c.y - e, by1 = s.c.y + e;
      }
      const int cx0 = std::clamp(static_cast<int>(std::floor(bx0 / px)), 0, W - 1);
      const int cx1 = std::clamp(static_cast<int>(std::ceil(bx1 / px)), 0, W - 1);
      const int cy0 = std::clamp(static_cast<int>(std::floor(by0 / px)), 0, W - 1);
      const int cy1 = std::clamp(static_cast<int>(std::ceil(by1 / px)), 0, W - 1);
      for (int y = cy0; y <= cy1; ++y)
        for (int x = cx0; x <= cx1; ++x)
          if (s.contains({x * px, y * px, zs})) {
            const size_t p = static_cast<size_t>(y) * W + x;
            c.acc[p] += static_cast<float>(o.hu.steel) - ph.base_[p];
          }
    }
  }

  const float inv = 1.0f / static_cast<float>(n_sub);
  for (float& v : c.acc) v *= inv;
  gaussian_blur(c.acc, c.tmp, W, W, o.blur_px);
  add_streaks(ph, ph.nominal_z_[i], c.acc);
  if (o.noise_hu > 0) {
    // Noise from (seed, slice) only: the same whichever thread renders the slice.
    Rng rng(stream_seed(o.seed, phantom_detail::kNoiseStream, static_cast<std::uint64_t>(i)));
    const double sg = o.noise_hu;
    for (size_t p = 0; p < npix; p += 2) {
      double a, b;
      rng.normal2(&a, &b);
      c.acc[p] += static_cast<float>(sg * a);
      if (p + 1 < npix) c.acc[p + 1] += static_cast<float>(sg * b);
    }
  }
  // The scanner's calibration applies to what it measured, noise included.
  if (o.hu_offset != 0 || o.hu_slope != 1)
    for (float& v : c.acc) v = ph.calibrated(v);
  const float top = static_cast<float>(o.hu.max_hu);
  for (float& v : c.acc) v = std::min(v, top);

  out.index = i;
  out.z = ph.nominal_z_[i];
  out.width = W;
  out.height = W;
  out.hu.swap(c.acc);
}

}  // namespace sawyer::ct
