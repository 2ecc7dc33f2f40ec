#include "sawyer/field/wood_field.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "glsl_shim.h"

namespace sawyer {
namespace glsl {
#include "wood_field.glsl"
}  // namespace glsl

namespace {

constexpr float kFar = 1e30f;
// Knot tracks in a Slice: axis sampled every kTrackStep mm of pith distance.
constexpr double kTrackStep = 0.5;
constexpr int kTrackStride = 4;  // x, y, z, azimuth
// Azimuth samples of the outer radius in a Slice (linear interpolation between them).
constexpr int kSliceAngles = 1440;

// Pith distance beyond which knot i has no effect: its end plus the closing of its stub.
double influence_end(const Knot& k) { return k.r_end + 2.0 * 0.5 * k.max_diameter() + 5.0 + 1.0; }

}  // namespace

WoodField::WoodField(const LogModel& log, const WoodFieldParams& params)
    : log_(&log), params_(params) {
  const Stem& s = log.stem;
  assert(s.slice_count() > 0);
  r_ref_ = params.reference_radius_mm;
  if (!(r_ref_ > 0)) {
    double acc = 0;
    for (int i = 0; i < s.slice_count(); ++i) acc += s.mean_radius(i);
    r_ref_ = acc / s.slice_count();
  }
  // Each knot's reach in z: its axis over its length, widened by the range of influence.
  info_.resize(log.knots.size());
  double lo = s.z_begin(), hi = s.z_end();
  for (size_t i = 0; i < log.knots.size(); ++i) {
    const Knot& k = log.knots[i];
    const double r_lim = influence_end(k);
    double zmin = 1e300, zmax = -1e300;
    constexpr int kSteps = 64;
    for (int j = 0; j <= kSteps; ++j) {
      const double r = r_lim * j / kSteps;
      const double z = k.height_at(r);
      const double reach = glsl::wf_range_outer(static_cast<float>(r), static_cast<float>(r_ref_));
      zmin = std::min(zmin, z - reach);
      zmax = std::max(zmax, z + reach);
    }
    info_[i].zmin = zmin;
    info_[i].zmax = zmax;
    info_[i].seed = static_cast<std::uint32_t>(k.id) * 7919u + 17u;
    lo = std::min(lo, zmin);
    hi = std::max(hi, zmax);
  }
  bucket_z0_ = lo;
  const int n = std::max(1, static_cast<int>(std::ceil((hi - lo) / bucket_mm_)) + 1);
  buckets_.assign(n, {});
  for (size_t i = 0; i < info_.size(); ++i) {
    const int a =
        std::clamp(static_cast<int>(std::floor((info_[i].zmin - lo) / bucket_mm_)), 0, n - 1);
    const int b =
        std::clamp(static_cast<int>(std::floor((info_[i].zmax - lo) / bucket_mm_)), 0, n - 1);
    for (int j = a; j <= b; ++j) buckets_[j].push_back(static_cast<int>(i));
  }
}

const std::vector<int>& WoodField::knots_near(double z) const {
  const int n = static_cast<int>(buckets_.size());
  const int j = std::clamp(static_cast<int>(std::floor((z - bucket_z0_) / bucket_mm_)), 0, n - 1);
  return buckets_[j];
}

WoodField::KnotEval WoodField::eval_knot(int i, float r, float t_s, float R, const Vec3& p,
                                         const Vec3& axis, float axis_omega) const {
  const Knot& k = log_->knots[i];
  KnotEval e{kFar, 0.0f, kFar, false, false};
  const Vec3 v = p - axis;
  const float dist = static_cast<float>(v.norm());
  const float fade_range = glsl::wf_range_fade(dist, r, static_cast<float>(r_ref_));
  if (fade_range <= 0.0f) return e;
  // Angle around the axis: 0 at the knot's horizontal side, +-pi/2 above and below it.
  const double side = -std::sin(axis_omega) * v.x + std::cos(axis_omega) * v.y;
  const float beta = glsl::atan(static_cast<float>(v.z), static_cast<float>(side));
  const float r_dead = static_cast<float>(k.r_dead);
  const float r_live = std::min(r, r_dead);
  const float rho0 = static_cast<float>(0.5 * k.diameter_at(r_live));
  const float rho =
      glsl::wf_knot_rho(rho0, dist, beta, r, info_[i].seed, static_cast<float>(params_.knot_noise));
  const float t_c = r_live / R;
  const float t_since_death = std::max(r - r_dead, 0.0f) / R;
  const float t_b = glsl::wf_knot_time(dist, rho, t_c, t_since_death);
  const float fade = fade_range * glsl::wf_end_fade(r, static_cast<float>(k.r_end),
                                                    static_cast<float>(0.5 * k.max_diameter()));
  e.delta = glsl::wf_knot_delta(t_s, t_b, t_since_death, beta, fade);
  if (r <= static_cast<float>(k.r_end)) {
    e.t_b = t_b;
    e.depth = dist / std::max(rho, 1e-3f);
    e.inside = dist < rho;
    e.dead = t_since_death > 0.0f;
  }
  return e;
}

FieldSample WoodField::combine(FieldSample s, const KnotEval* evals, const int* ids, int n) const {
  float t_min = kFar, delta_sum = 0.0f, best_depth = kFar;
  for (int j = 0; j < n; ++j) {
    const KnotEval& e = evals[j];
    t_min = std::min(t_min, e.t_b);
    delta_sum += e.delta;
    if (e.inside && e.depth < best_depth) {
      best_depth = e.depth;
      s.knot = ids[j];
      s.dead = e.dead;
      s.knot_depth = e.depth;
    }
  }
  s.t_knot = t_min;
  s.t = glsl::wf_union(s.t_stem, t_min, delta_sum);
  return s;
}

FieldSample WoodField::sample(const Vec3& p) const {
  const Stem& st = log_->stem;
  FieldSample s;
  double r, w;
  st.polar(p, &r, &w);
  s.r = static_cast<float>(r);
  s.omega = static_cast<float>(w);
  s.radius = static_cast<float>(st.radius_at(w, p.z));
  s.t_stem = s.r / s.radius;
  const std::vector<int>& near = knots_near(p.z);
  std::vector<KnotEval> evals;
  std::vector<int> ids;
  evals.reserve(near.size());
  ids.reserve(near.size());
  for (int i : near) {
    const Knot& k = log_->knots[i];
    if (r > influence_end(k)) continue;
    const double z_axis = k.height_at(r);
    if (std::abs(p.z - z_axis) > glsl::wf_range_outer(s.r, static_cast<float>(r_ref_))) continue;
    evals.push_back(eval_knot(i, s.r, s.t_stem, s.radius, p, k.axis_point(r, st),
                              static_cast<float>(k.azimuth_at(r))));
    ids.push_back(i);
  }
  return combine(s, evals.data(), ids.data(), static_cast<int>(evals.size()));
}

WoodField::Slice WoodField::slice(double z) const {
  const Stem& st = log_->stem;
  Slice sl;
  sl.field_ = this;
  sl.z_ = z;
  sl.pith_ = st.pith_at(z);
  sl.radius_.resize(kSliceAngles + 1);
  for (int k = 0; k < kSliceAngles; ++k) {
    const double R = st.radius_at(kTwoPi * k / kSliceAngles, z);
    sl.radius_[k] = static_cast<float>(R);
    sl.max_radius_ = std::max(sl.max_radius_, R);
  }
  sl.radius_[kSliceAngles] = sl.radius_[0];
  for (int i : knots_near(z)) {
    if (z < info_[i].zmin || z > info_[i].zmax) continue;
    const Knot& k = log_->knots[i];
    const int n = static_cast<int>(std::ceil(influence_end(k) / kTrackStep)) + 2;
    sl.knots_.push_back(i);
    sl.track_offset_.push_back(static_cast<int>(sl.tracks_.size()));
    for (int j = 0; j < n; ++j) {
      const double r = j * kTrackStep;
      const Vec3 a = k.axis_point(r, st);
      sl.tracks_.push_back(static_cast<float>(a.x));
      sl.tracks_.push_back(static_cast<float>(a.y));
      sl.tracks_.push_back(static_cast<float>(a.z));
      sl.tracks_.push_back(static_cast<float>(k.azimuth_at(r)));
    }
  }
  sl.track_offset_.push_back(static_cast<int>(sl.tracks_.size()));
  return sl;
}

FieldSample WoodField::Slice::sample(double x, double y) const {
  const WoodField& f = *field_;
  FieldSample s;
  const double dx = x - pith_.x, dy = y - pith_.y;
  const double r = std::hypot(dx, dy);
  const double w = wrap_angle(std::atan2(dy, dx));
  s.r = static_cast<float>(r);
  s.omega = static_cast<float>(w);
  const double u = w / kTwoPi * kSliceAngles;
  const int k0 = std::min(static_cast<int>(u), kSliceAngles - 1);
  const float fu = static_cast<float>(u - k0);
  s.radius = radius_[k0] + (radius_[k0 + 1] - radius_[k0]) * fu;
  s.t_stem = s.r / s.radius;
  constexpr int kMaxNear = 64;
  KnotEval evals[kMaxNear];
  int ids[kMaxNear];
  int n = 0;
  const Vec3 p{x, y, z_};
  const float reach = glsl::wf_range_outer(s.r, static_cast<float>(f.r_ref_));
  for (size_t c = 0; c < knots_.size() && n < kMaxNear; ++c) {
    const int i = knots_[c];
    const float* tr = tracks_.data() + track_offset_[c];
    const int count = (track_offset_[c + 1] - track_offset_[c]) / kTrackStride;
    const double jf = r / kTrackStep;
    if (jf >= count - 1) continue;  // beyond the knot's influence
    const int j = static_cast<int>(jf);
    const float a = static_cast<float>(jf - j);
    const float* p0 = tr + j * kTrackStride;
    const float* p1 = p0 + kTrackStride;
    const float az = p0[2] + (p1[2] - p0[2]) * a;
    if (std::abs(static_cast<float>(z_) - az) > reach) continue;
    const Vec3 axis{p0[0] + (p1[0] - p0[0]) * a, p0[1] + (p1[1] - p0[1]) * a, az};
    // Azimuths may wrap between samples; the twist per half millimetre is tiny.
    float d_om = p1[3] - p0[3];
    if (d_om > kPi) d_om -= static_cast<float>(kTwoPi);
    if (d_om < -kPi) d_om += static_cast<float>(kTwoPi);
    evals[n] = f.eval_knot(i, s.r, s.t_stem, s.radius, p, axis, p0[3] + d_om * a);
    ids[n] = i;
    ++n;
  }
  return f.combine(s, evals, ids, n);
}

}  // namespace sawyer
