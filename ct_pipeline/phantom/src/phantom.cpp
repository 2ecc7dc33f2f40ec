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
// Thickness of the bark ring encased around dead knots.
constexpr double kKnotBarkMm = 1.0;
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
// through the earlywood, rising steeply into the latewood, dropping back at the ring border
// (the drop is spread over the last 10 % of the ring to keep point sampling from aliasing).
// Range 0..1; kRingProfileMean is its mean, so the modulation averages to zero over a ring.
double ring_profile(double phase) {
  if (phase < 0.9) {
    const double u = phase / 0.9;
    return u * u * u;
  }
  return (1.0 - phase) / 0.1;
}
constexpr double kRingProfileMean = 0.9 / 4 + 0.05;

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
  }
  return "?";
}

Status PhantomOptions::validate() const {
  auto bad = [](const char* opt, const std::string& what) { return Status(Error(opt, what)); };
  if (image_size < 16 || image_size > 8192)
    return bad("--size", "image size must be 16-8192 pixels, got " + std::to_string(image_size));
  if (!(pixel_mm > 0.01 && pixel_mm <= 20))
    return bad("--pixel-mm", "pixel size must be in (0.01, 20] mm, got " + fmt(pixel_mm));
  if (!(slice_spacing_mm > 0.01 && slice_spacing_mm <= 100))
    return bad("--spacing-mm",
               "slice spacing must be in (0.01, 100] mm, got " + fmt(slice_spacing_mm));
  if (!(slice_thickness_mm >= 0 && slice_thickness_mm <= 100))
    return bad("--thickness-mm", "slice thickness must be in (0, 100] mm (0: the spacing), got " +
                                     fmt(slice_thickness_mm));
  if (sub_slices < 0 || sub_slices > 64)
    return bad("--sub-slices", "must be 0 (auto) to 64, got " + std::to_string(sub_slices));
  if (from_mm && !std::isfinite(*from_mm)) return bad("--from-mm", "not a number");
  if (to_mm && !std::isfinite(*to_mm)) return bad("--to-mm", "not a number");
  if (from_mm && to_mm && *from_mm > *to_mm)
    return bad("--from-mm", "the range start " + fmt(*from_mm, 1) + " mm is past its end " +
                                fmt(*to_mm, 1) + " mm");
  const Placement& p = placement;
  if (!std::isfinite(p.offset_x_mm) || !std::isfinite(p.offset_y_mm) ||
      std::abs(p.offset_x_mm) > 1e4 || std::abs(p.offset_y_mm) > 1e4)
    return bad("--offset-x-mm/--offset-y-mm", "offset must be a finite number of mm");
  if (!(std::abs(p.tilt_x_deg) <= 10))
    return bad("--tilt-x-deg", "tilt must be within ±10°, got " + fmt(p.tilt_x_deg, 2));
  if (!(std::abs(p.tilt_y_deg) <= 10))
    return bad("--tilt-y-deg", "tilt must be within ±10°, got " + fmt(p.tilt_y_deg, 2));
  if (!std::isfinite(p.roll_deg)) return bad("--roll-deg", "not a number");
  if (!(noise_hu >= 0 && noise_hu <= 1000))
    return bad("--noise-hu", "noise σ must be 0-1000 HU, got " + fmt(noise_hu, 1));
  if (!(blur_px >= 0 && blur_px <= 10))
    return bad("--blur-px", "PSF σ must be 0-10 pixels, got " + fmt(blur_px, 2));
  if (!(bed_gap_mm >= 0 && bed_gap_mm <= 100))
    return bad("--bed-gap-mm", "must be 0-100 mm, got " + fmt(bed_gap_mm, 2));
  if (!(ring_width_mm >= 0.3 && ring_width_mm <= 30))
    return bad("--ring-width-mm", "ring width must be 0.3-30 mm, got " + fmt(ring_width_mm, 2));
  if (!(ring_amplitude >= 0 && ring_amplitude <= 1))
    return bad("--ring-amplitude", "must be 0-1, got " + fmt(ring_amplitude, 3));
  if (!(knot_noise >= 0 && knot_noise <= 0.5))
    return bad("--knot-noise", "must be 0-0.5, got " + fmt(knot_noise, 3));
  if (drop_slices < 0) return bad("--drop-slices", "must not be negative");
  if (threads < 0 || threads > 256) return bad("--threads", "must be 0 (auto) to 256");
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
  return base * std::max(v, 0.3);
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
    return Error("--from-mm/--to-mm", "the scanned range [" + fmt(from_, 1) + ", " + fmt(to_, 1) +
                                          "] mm must lie within the log's extent [" + fmt(zb, 1) +
                                          ", " + fmt(ze, 1) + "] mm");
  const double nf = std::floor((to_ - from_) / sp + 1e-6) + 1;
  if (nf > kMaxSlices)
    return Error("--spacing-mm", "the scan would have " + fmt(nf, 0) + " slices (at most " +
                                     std::to_string(kMaxSlices) + ")");
  const int n = static_cast<int>(nf);
  if (o.drop_slices > std::max(0, n - 2))
    return Error("--drop-slices", "cannot drop " + std::to_string(o.drop_slices) + " of " +
                                      std::to_string(n) +
                                      " slices (the first and last are always kept)");

  WoodFieldParams fp;
  fp.knot_noise = o.knot_noise;
  field_ = std::make_unique<WoodField>(log_, fp);
  ring_count_ = field_->reference_radius() / o.ring_width_mm;
  sub_slices_ = o.sub_slices > 0
                    ? o.sub_slices
                    : std::clamp(static_cast<int>(std::ceil(th / kSubSliceMm - 1e-9)), 1, 16);

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
  if (need > half) {
    const double px_min = std::ceil(need / (0.5 * W) * 1000.0) / 1000.0;
    return Error("log does not fit the field of view: it reaches " + fmt(need, 1) +
                 " mm from the image centre, a " + std::to_string(W) + " x " + fmt(px, 3) +
                 " mm image only " + fmt(half, 1) + " mm; the smallest pixel size that fits is " +
                 fmt(px_min, 3) + " mm (--pixel-mm), or use a larger --size");
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
  geometry_.origin = {0, 0, 0};
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

namespace {

// The CT number of the log at a point, from its field sample and the heartwood radius and bark
// thickness there. Shared by rendering (layers) and sample_point (exact heights).
float material_hu(const LogModel& log, const PhantomOptions& o, double ring_count,
                  const FieldSample& fs, float H, float B, Region* region) {
  const HuTable& hu = o.hu;
  const float r = fs.r, R = fs.radius;
  if (r > R) {
    if (r > R + B) {
      *region = Region::kAir;
      return static_cast<float>(hu.air);
    }
    *region = Region::kBark;
    const double s = (r - R) / std::max(B, 1e-3f);
    return static_cast<float>(hu.bark_inner + (hu.bark_outer - hu.bark_inner) * s);
  }
  double v;
  if (fs.knot >= 0) {
    const Knot& k = log.knots[fs.knot];
    if (fs.dead) {
      const double rho0 = 0.5 * k.diameter_at(std::min<double>(r, k.r_dead));
      // Encased bark: the outer kKnotBarkMm of the dead knot's outline (the field's, with its
      // outline noise, since knot_depth is measured against it).
      if (fs.knot_depth >= 1.0 - kKnotBarkMm / std::max(rho0, 2 * kKnotBarkMm)) {
        *region = Region::kKnotBark;
        return static_cast<float>(hu.knot_bark);
      }
      *region = Region::kDeadKnot;
      v = hu.dead_knot;
    } else {
      *region = Region::kSoundKnot;
      v = hu.sound_knot;
    }
  } else {
    const double s = smoothstep(H - 0.5 * kHeartTransitionMm, H + 0.5 * kHeartTransitionMm, r);
    *region = s < 0.5 ? Region::kHeartwood : Region::kSapwood;
    v = hu.heartwood + (hu.sapwood - hu.heartwood) * s;
  }
  // Annual rings: the dry wood substance is denser in the latewood. The phase follows the
  // field's t, so the rings bend around knots exactly as in the renderer.
  const double t = std::max(0.0f, fs.t) * ring_count;
  v +=
      o.ring_amplitude * hu.dry_wood_density * (ring_profile(t - std::floor(t)) - kRingProfileMean);
  return static_cast<float>(v);
}

}  // namespace

float Phantom::log_hu(const Layer& layer, double x, double y, Region* region) const {
  const FieldSample fs = layer.field.sample(x, y);
  return material_hu(log_, options_, ring_count_, fs, table_at(layer.heart, fs.omega),
                     table_at(layer.bark, fs.omega), region);
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
  out.hu = static_cast<float>(options_.hu.air);
  float ohu;
  if (clutter_hu(s, &ohu)) {
    out.hu = ohu;
    out.region = Region::kClutter;
    return out;
  }
  if (bed_hu(s.x, s.y, &ohu)) {
    out.hu = ohu;
    out.region = Region::kBed;
    return out;
  }
  const Vec3& p = out.log_point;
  const Stem& st = log_.stem;
  if (p.z < st.z_begin() || p.z > st.z_end()) return out;
  const FieldSample fs = field_->sample(p);
  out.field = fs;
  out.heartwood_radius = static_cast<float>(heartwood_radius(fs.omega, p.z, fs.radius));
  out.bark_mm = static_cast<float>(bark_thickness(fs.omega, p.z, fs.radius));
  out.hu =
      material_hu(log_, options_, ring_count_, fs, out.heartwood_radius, out.bark_mm, &out.region);
  return out;
}

// ---- rendering -------------------------------------------------------------------------------

// Field layers by log-frame height for tilted logs: a bank kTiltLayerStep apart, kept between
// the slices one thread renders (neighbouring slices share most of their heights).
struct Phantom::Renderer::Cache {
  std::map<long long, std::unique_ptr<Layer>> bank;
  std::vector<float> acc, tmp;
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
      }
    }
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
  const float top = static_cast<float>(o.hu.max_hu);
  for (float& v : c.acc) v = std::min(v, top);

  out.index = i;
  out.z = ph.nominal_z_[i];
  out.width = W;
  out.height = W;
  out.hu.swap(c.acc);
}

}  // namespace sawyer::ct
