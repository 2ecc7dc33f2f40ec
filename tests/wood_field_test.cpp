// The wood time field on the real spruce log: the fast per-height Slice agrees with the generic
// sample(), the knot material agrees with LogModel::material_at, the stem time is r / R, knots
// bend the rings only near them, and the field has no jumps.
#include "sawyer/field/wood_field.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sawyer/model/log_json.h"
#include "sawyer/test/test_util.h"

namespace sawyer {
namespace {

const LogModel& spruce() {
  static const LogModel log = [] {
    auto r = read_log_json(test::sample_log("gran1_spruce") / "log.json");
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message());
    return r.ok() ? r.value() : LogModel{};
  }();
  return log;
}

// A point in the stem at pith distance frac * R, azimuth w, height z.
Vec3 stem_point(const LogModel& log, double z, double w, double frac) {
  const Vec2 c = log.stem.pith_at(z);
  const double R = log.stem.radius_at(w, z);
  return {c.x + frac * R * std::cos(w), c.y + frac * R * std::sin(w), z};
}

// A point near knot k: on its axis at pith distance r, moved by `off` mm perpendicular to it.
Vec3 knot_point(const LogModel& log, const Knot& k, double r, double off_up, double off_side) {
  const Vec3 a = k.axis_point(r, log.stem);
  const double w = k.azimuth_at(r);
  return {a.x - std::sin(w) * off_side, a.y + std::cos(w) * off_side, a.z + off_up};
}

TEST(WoodField, SliceAgreesWithGenericSample) {
  const LogModel& log = spruce();
  ASSERT_FALSE(log.knots.empty());
  WoodField field(log);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  int compared = 0, knot_agree = 0, in_knots = 0;
  double worst = 0;
  // Heights at the knots (where the two paths differ most) and at random.
  for (int n = 0; n < 60; ++n) {
    const Knot& k = log.knots[(n * 7) % log.knots.size()];
    const double z = (n % 2 == 0) ? k.height_at(0.5 * k.r_end) + (u(rng) - 0.5) * 10.0
                                  : log.stem.z_begin() + u(rng) * log.stem.length_mm();
    const WoodField::Slice sl = field.slice(z);
    for (int m = 0; m < 200; ++m) {
      const Vec3 p = stem_point(log, z, u(rng) * kTwoPi, 1.05 * std::sqrt(u(rng)));
      const FieldSample a = field.sample(p);
      const FieldSample b = sl.sample(p.x, p.y);
      ++compared;
      worst = std::max(worst, static_cast<double>(std::abs(a.t - b.t)));
      EXPECT_NEAR(a.t_stem, b.t_stem, 2e-3) << "z " << z;
      if (a.knot >= 0 || b.knot >= 0) {
        ++in_knots;
        knot_agree += (a.knot == b.knot);
      }
    }
  }
  // The Slice interpolates the outer radius and the knot axes (every 0.5 mm of pith distance).
  EXPECT_LT(worst, 5e-3) << "worst |t_slice - t_generic| over " << compared << " points";
  ASSERT_GT(in_knots, 50);
  EXPECT_GE(knot_agree, in_knots * 97 / 100) << knot_agree << " of " << in_knots;
}

TEST(WoodField, KnotMaterialAgreesWithTheModel) {
  const LogModel& log = spruce();
  WoodFieldParams params;
  params.knot_noise = 0.0;
  WoodField field(log, params);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  int checked = 0, agree = 0, sound = 0, dead = 0;
  for (const Knot& k : log.knots) {
    for (int m = 0; m < 40; ++m) {
      // Points in and around the knot: up to 1.5 knot radii from the axis.
      const double r = u(rng) * k.r_end * 1.1;
      const double rho = 0.5 * k.diameter_at(std::min(r, k.r_end));
      const Vec3 p = knot_point(log, k, r, (u(rng) - 0.5) * 3 * rho, (u(rng) - 0.5) * 3 * rho);
      const MaterialSample want = log.material_at(p);
      // Beyond the bark the model says air; the field is the wood's and leaves that to callers.
      if (want.material == Material::kAir) continue;
      const FieldSample got = field.sample(p);
      ASSERT_TRUE(got.inside());
      ++checked;
      const bool want_knot =
          want.material == Material::kSoundKnot || want.material == Material::kDeadKnot;
      if (want_knot != (got.knot >= 0) ||
          (want_knot &&
           (want.knot != got.knot || (want.material == Material::kDeadKnot) != got.dead))) {
        continue;
      }
      if (want_knot) {
        (got.dead ? dead : sound)++;
      }
      ++agree;
    }
  }
  // Float arithmetic on boundaries is the only allowed difference.
  EXPECT_GE(agree, checked * 995 / 1000) << agree << " of " << checked;
  EXPECT_GT(sound, 200);
  EXPECT_GT(dead, 200);
}

// True when p is within a knot's range of influence (docs/architecture.md 5: 0.2 r_ref + r around
// the axis, up to the end of its overgrown stub), by the model's knot formula directly.
bool within_reach_of_a_knot(const LogModel& log, const WoodField& field, const Vec3& p) {
  double r, w;
  log.stem.polar(p, &r, &w);
  for (const Knot& k : log.knots) {
    if (r > k.r_end + k.max_diameter() + 6.0) continue;
    const Vec3 a = k.axis_point(r, log.stem);
    if ((p - a).norm() <= 0.2 * field.reference_radius() + r + 1e-3) return true;
  }
  return false;
}

TEST(WoodField, StemTimeIsPithDistanceOverRadiusAwayFromKnots) {
  const LogModel& log = spruce();
  WoodField field(log);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  int far = 0;
  for (int n = 0; n < 3000; ++n) {
    const double z = log.stem.z_begin() + u(rng) * log.stem.length_mm();
    const double frac = u(rng);
    const Vec3 p = stem_point(log, z, u(rng) * kTwoPi, frac);
    const FieldSample s = field.sample(p);
    EXPECT_NEAR(s.t_stem, frac, 1e-4);
    if (!within_reach_of_a_knot(log, field, p)) {
      ++far;
      EXPECT_NEAR(s.t, s.t_stem, 1e-6) << "z " << z;
      EXPECT_EQ(s.knot, -1);
    }
  }
  EXPECT_GT(far, 300);
}

TEST(WoodField, KnotsBendTheRingsNearThemOnly) {
  const LogModel& log = spruce();
  WoodField field(log);
  int bent = 0, n = 0;
  for (const Knot& k : log.knots) {
    const double r = 0.5 * std::min(k.r_dead, k.r_end);
    const double rho = 0.5 * k.diameter_at(r);
    if (rho < 2.0) continue;
    ++n;
    // Just above the knot's outline the rings bulge: the time there is earlier than the
    // stem's (knot wood grows faster than the stem around it).
    const FieldSample near = field.sample(knot_point(log, k, r, 1.3 * rho, 0));
    if (near.t < near.t_stem - 1e-3) ++bent;
    // Inside the knot, the knot's own time wins.
    const FieldSample in = field.sample(knot_point(log, k, r, 0, 0));
    EXPECT_EQ(in.knot, static_cast<int>(&k - log.knots.data()));
    EXPECT_LE(in.t, in.t_stem);
  }
  ASSERT_GT(n, 50);
  EXPECT_GE(bent, n * 9 / 10) << bent << " of " << n;
}

TEST(WoodField, HasNoJumpsAlongALine) {
  const LogModel& log = spruce();
  WoodField field(log);
  // Walk from the pith to the bark through the middle of several knots in 0.05 mm steps: the
  // field is continuous, so neighbouring samples differ by at most its steepest gradient times
  // the step (knots are steep but never discontinuous).
  int checked = 0;
  for (size_t i = 0; i < log.knots.size(); i += 9) {
    const Knot& k = log.knots[i];
    const double z = k.height_at(0.6 * k.r_end);
    const double w = k.azimuth_at(0.6 * k.r_end);
    FieldSample prev;
    prev.t = -1;
    for (double f = 0.02; f < 0.98; f += 0.05 / 120.0) {
      const FieldSample s = field.sample(stem_point(log, z, w, f));
      // The one real discontinuity: the end of a knot, where the stub's early wood meets stem
      // wood grown over it later.
      const bool knot_end =
          prev.knot >= 0 && s.knot != prev.knot && std::abs(s.r - log.knots[prev.knot].r_end) < 0.2;
      if (prev.t >= 0 && !knot_end) {
        EXPECT_LT(std::abs(s.t - prev.t), 0.01) << "knot " << k.id << " at t_stem " << s.t_stem;
        ++checked;
      }
      prev = s;
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(WoodField, KnotsNearListsEveryKnotWhoseWoodIsAtThatHeight) {
  const LogModel& log = spruce();
  WoodField field(log);
  for (size_t i = 0; i < log.knots.size(); ++i) {
    const Knot& k = log.knots[i];
    for (double f : {0.0, 0.3, 0.7, 1.0}) {
      const double z = k.height_at(f * k.r_end);
      const auto& near = field.knots_near(z);
      EXPECT_NE(std::find(near.begin(), near.end(), static_cast<int>(i)), near.end())
          << "knot " << k.id << " at z " << z;
    }
  }
}

}  // namespace
}  // namespace sawyer
