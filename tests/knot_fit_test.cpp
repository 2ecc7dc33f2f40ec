// Knot-formula fit tests (issue 5): round trips from known knots, with noise and with a
// neighbour's blob mixed in, the sound/dead decision, errors and speed.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "sawyer/core/vec.h"
#include "sawyer/ct/knots/knot_fit.h"

namespace sawyer::ct {
namespace {

constexpr double kRadToDeg = 180.0 / kPi;

// Tolerances of the round trip (issue 5): at r = 50 mm for the axis.
constexpr double kHeightTol = 1.0;    // mm
constexpr double kAzimuthTol = 1.0;   // degrees
constexpr double kDiameterTol = 1.5;  // mm
constexpr double kRDeadTol = 5.0;     // mm
constexpr double kREndTol = 2.0;      // mm
constexpr double kProbeR = 50.0;      // mm

Knot make_knot(double z0, double a, double b, double omega0, double twist, double r_dead,
               double r_end, double d_dead, double exponent) {
  Knot k;
  k.z0 = z0;
  k.a = a;
  k.b = b;
  k.omega0 = omega0;
  k.twist = twist;
  k.r_dead = r_dead;
  k.r_end = r_end;
  k.diameter.d_dead = d_dead;
  k.diameter.exponent = exponent;
  return k;
}

struct Case {
  std::string name;
  Knot knot;
};

// Sound, dead, strongly twisted, two that cross ω = 0 / 2π (rising and falling, the second
// small and short), and a small sound one.
std::vector<Case> cases() {
  return {
      {"sound", make_knot(1000, 3.0, 0.3, 1.0, 0.02, 120, 120, 22, 0.8)},
      {"dead", make_knot(500, 6.0, 0.1, 3.5, -0.03, 60, 110, 18, 1.0)},
      {"twisted", make_knot(200, -2.0, 1.0, 4.0, 0.09, 80, 140, 25, 0.5)},
      {"wrap_up", make_knot(1500, 10.0, -0.2, 6.25, 0.05, 45, 70, 10, 1.2)},
      {"wrap_down", make_knot(800, 4.0, 0.5, 0.1, -0.05, 25, 40, 6, 1.0)},
      {"sound_sm", make_knot(300, 2.0, 0.6, 2.5, 0.0, 45, 45, 8, 0.6)},
  };
}

struct Noise {
  double z_mm = 0.5;
  double arc_mm = 0.5;
  double d_mm = 0.7;
};

// Shells every 1 mm from r = 5 to r_end on the knot formula, with Gaussian noise. Dead shells
// get a dark ring when asked.
KnotTrace make_trace(const Knot& k, unsigned seed, Noise noise = {}, bool dark_rings = false) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  KnotTrace t;
  for (double r = 5.0; r <= k.r_end + 1e-9; r += 1.0) {
    KnotShell s;
    s.r = r;
    s.z = k.height_at(r) + noise.z_mm * gauss(rng);
    s.omega = wrap_angle(k.azimuth_at(r) + noise.arc_mm * gauss(rng) / r);
    s.diameter = k.diameter_at(r) + noise.d_mm * gauss(rng);
    s.voxels = 100;
    s.contrast = 200;
    s.ring_hu = (dark_rings && k.dead_at(r)) ? -150 : 0;
    t.shells.push_back(s);
  }
  t.r_last_seen = k.r_end;
  return t;
}

// A neighbour's blob: `share` of the shells, picked at random, have their centre pulled by
// 8–15 mm towards the neighbour (45° between the height and the arc direction), and their
// diameter grows by wider_mm (the merged blob).
void add_blobs(KnotTrace& t, unsigned seed, double share, double wider_mm = 0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0), shift(8.0, 15.0);
  const int n = static_cast<int>(t.shells.size());
  std::vector<int> idx(n);
  for (int i = 0; i < n; ++i) idx[i] = i;
  std::shuffle(idx.begin(), idx.end(), rng);
  for (int j = 0; j < static_cast<int>(std::lround(share * n)); ++j) {
    KnotShell& s = t.shells[idx[j]];
    const double d = shift(rng);
    s.z += d * std::sqrt(0.5);
    s.omega = wrap_angle(s.omega + d * std::sqrt(0.5) / s.r);
    s.diameter += wider_mm;
  }
}

struct Errors {
  double height = 0;    // mm at kProbeR
  double azimuth = 0;   // degrees at kProbeR
  double diameter = 0;  // largest diameter, mm
  double r_dead = 0;    // mm (sound knots: how far short of r_end the fit put r_dead, if at all)
  double r_end = 0;     // mm
  bool ok() const {
    return height <= kHeightTol && azimuth <= kAzimuthTol && diameter <= kDiameterTol &&
           r_dead <= kRDeadTol && r_end <= kREndTol;
  }
};

// The axis is compared at r = 50 mm, or at the end of a shorter knot (not extrapolated).
Errors compare(const Knot& truth, const Knot& fit) {
  Errors e;
  const double r = std::min(kProbeR, truth.r_end);
  e.height = std::abs(fit.height_at(r) - truth.height_at(r));
  e.azimuth = std::abs(angle_diff(fit.azimuth_at(r), truth.azimuth_at(r))) * kRadToDeg;
  e.diameter = std::abs(fit.max_diameter() - truth.max_diameter());
  e.r_dead = truth.has_dead_part() ? std::abs(fit.r_dead - truth.r_dead)
                                   : std::max(0.0, truth.r_end - fit.r_dead);
  e.r_end = std::abs(fit.r_end - truth.r_end);
  return e;
}

void print(const char* what, const std::string& name, const Errors& e, const KnotFitReport& r) {
  std::printf(
      "%-8s %-10s height %.2f mm  azimuth %.2f deg  d %.2f mm  r_dead %.2f mm  r_end %.2f "
      "mm  (axis rms %.2f, diam rms %.2f, iters %d)\n",
      what, name.c_str(), e.height, e.azimuth, e.diameter, e.r_dead, e.r_end, r.axis_rms_mm,
      r.diameter_rms_mm, r.iterations);
}

TEST(KnotFit, RoundTripWithNoise) {
  for (const Case& c : cases()) {
    for (unsigned seed : {1u, 2u, 3u}) {
      SCOPED_TRACE(c.name + " seed " + std::to_string(seed));
      Result<KnotFitReport> fit = fit_knot(make_trace(c.knot, seed));
      ASSERT_TRUE(fit) << fit.error().message();
      const Errors e = compare(c.knot, fit.value().knot);
      if (seed == 1) print("noise", c.name, e, fit.value());
      EXPECT_LE(e.height, kHeightTol);
      EXPECT_LE(e.azimuth, kAzimuthTol);
      EXPECT_LE(e.diameter, kDiameterTol);
      EXPECT_LE(e.r_dead, kRDeadTol);
      EXPECT_LE(e.r_end, kREndTol);
      EXPECT_EQ(fit.value().dead, c.knot.has_dead_part());
      const Knot& k = fit.value().knot;
      EXPECT_GE(k.omega0, 0.0);
      EXPECT_LT(k.omega0, kTwoPi);
      EXPECT_EQ(k.support, static_cast<int>(make_trace(c.knot, seed).shells.size()));
      EXPECT_NEAR(k.fit_rms_mm, 0.5, 0.15);  // the noise put in
    }
  }
}

TEST(KnotFit, NoiselessIsNearExact) {
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    Result<KnotFitReport> fit = fit_knot(make_trace(c.knot, 1, Noise{0, 0, 0}));
    ASSERT_TRUE(fit) << fit.error().message();
    const Errors e = compare(c.knot, fit.value().knot);
    EXPECT_LT(e.height, 0.05);
    EXPECT_LT(e.azimuth, 0.05);
    EXPECT_LT(e.diameter, 0.1);
    EXPECT_LE(e.r_dead, 1.0);
    EXPECT_LT(fit.value().axis_rms_mm, 0.01);
  }
}

TEST(KnotFit, RobustToANeighboursBlobWherePlainLeastSquaresIsNot) {
  KnotFitOptions plain;
  plain.huber_mm = 0;
  plain.diameter_huber_mm = 0;
  KnotFitOptions huber;  // shown for comparison, not asserted
  huber.loss = RobustLoss::kHuber;
  for (const Case& c : cases()) {
    SCOPED_TRACE(c.name);
    KnotTrace t = make_trace(c.knot, 7);
    add_blobs(t, 11, 0.15);
    Result<KnotFitReport> robust = fit_knot(t);
    Result<KnotFitReport> ls = fit_knot(t, plain);
    Result<KnotFitReport> hub = fit_knot(t, huber);
    ASSERT_TRUE(robust) << robust.error().message();
    ASSERT_TRUE(ls) << ls.error().message();
    ASSERT_TRUE(hub) << hub.error().message();
    const Errors er = compare(c.knot, robust.value().knot);
    const Errors el = compare(c.knot, ls.value().knot);
    print("cauchy", c.name, er, robust.value());
    print("huber", c.name, compare(c.knot, hub.value().knot), hub.value());
    print("plain", c.name, el, ls.value());
    EXPECT_TRUE(er.ok());
    EXPECT_FALSE(el.ok());  // the blob drags plain least squares out of the bounds
  }
}

// Over many noise draws: how often each case is within all the round-trip bounds, and the worst
// error of each kind. Prints the figures of the issue; asserts a high pass rate.
TEST(KnotFit, PassRateOverManySeeds) {
  constexpr int kSeeds = 50;
  struct Variant {
    const char* name;
    double blob_share;
    double wider_mm;
  };
  for (const Variant& v :
       {Variant{"noise", 0, 0}, Variant{"blobs", 0.15, 0}, Variant{"blobs+d", 0.15, 4.0}}) {
    for (const Case& c : cases()) {
      int pass = 0;
      Errors worst;
      for (int seed = 1; seed <= kSeeds; ++seed) {
        KnotTrace t = make_trace(c.knot, 1000 + seed);
        if (v.blob_share > 0) add_blobs(t, 2000 + seed, v.blob_share, v.wider_mm);
        Result<KnotFitReport> fit = fit_knot(t);
        ASSERT_TRUE(fit) << fit.error().message();
        const Errors e = compare(c.knot, fit.value().knot);
        pass += e.ok() ? 1 : 0;
        // KNOT_FIT_VERBOSE=1 names the failing draws.
        if (!e.ok() && std::getenv("KNOT_FIT_VERBOSE"))
          print(("seed " + std::to_string(seed)).c_str(), c.name, e, fit.value());
        worst.height = std::max(worst.height, e.height);
        worst.azimuth = std::max(worst.azimuth, e.azimuth);
        worst.diameter = std::max(worst.diameter, e.diameter);
        worst.r_dead = std::max(worst.r_dead, e.r_dead);
        worst.r_end = std::max(worst.r_end, e.r_end);
      }
      std::printf(
          "%-8s %-10s pass %2d/%d  worst: height %.2f mm  azimuth %.2f deg  d %.2f mm  "
          "r_dead %.2f mm  r_end %.2f mm\n",
          v.name, c.name.c_str(), pass, kSeeds, worst.height, worst.azimuth, worst.diameter,
          worst.r_dead, worst.r_end);
      // The small, short dead knot (6 mm, kink at 25 of 40 mm) with blobs that also widen the
      // diameter by 4 mm is past what its diameters can tell: printed, not asserted.
      const bool edge = std::string(v.name) == "blobs+d" && c.name == "wrap_down";
      if (!edge) {
        EXPECT_GE(pass, kSeeds * 9 / 10) << v.name << " " << c.name;
      }
    }
  }
}

TEST(KnotFit, SoundKnotHasNoDeadPart) {
  const Knot k = cases()[0].knot;
  ASSERT_FALSE(k.has_dead_part());
  for (unsigned seed = 1; seed <= 10; ++seed) {
    Result<KnotFitReport> fit = fit_knot(make_trace(k, seed));
    ASSERT_TRUE(fit) << fit.error().message();
    EXPECT_GE(fit.value().knot.r_dead, k.r_end - 3.0) << "seed " << seed;
  }
}

TEST(KnotFit, DarkRingsPlaceRDeadWhereTheDiameterCannot) {
  // A dead knot whose growth has nearly stopped before r_dead (small exponent): the diameter
  // kink is within the noise, the encased-bark ring is not.
  const Knot k = make_knot(600, 5.0, 0.2, 2.0, 0.0, 70, 120, 20, 0.1);
  constexpr int kSeeds = 20;
  int with_ok = 0, without_ok = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    Result<KnotFitReport> with = fit_knot(make_trace(k, seed, Noise{}, true));
    Result<KnotFitReport> without = fit_knot(make_trace(k, seed, Noise{}, false));
    ASSERT_TRUE(with && without);
    EXPECT_GT(with.value().dark_ring_shells, 40);
    with_ok += std::abs(with.value().knot.r_dead - k.r_dead) <= kRDeadTol ? 1 : 0;
    without_ok += std::abs(without.value().knot.r_dead - k.r_dead) <= kRDeadTol ? 1 : 0;
  }
  std::printf("r_dead within %.0f mm: %d/%d with dark rings, %d/%d from the diameters alone\n",
              kRDeadTol, with_ok, kSeeds, without_ok, kSeeds);
  EXPECT_GE(with_ok, kSeeds - 1);
  EXPECT_GT(with_ok, without_ok);
}

// r_dead from the core's density (KnotShell::core_hu), where the diameters cannot tell (the
// knot's growth has nearly stopped, exponent 0.1): green wood, the dead part 180 HU lighter and
// the last two shells reaching the bark's HU level higher again; dried wood, the dead part only
// 40 HU lighter but far above the core HU's scatter (5 HU); and sound knots whose core HU only
// scatters (green, σ 25 HU) or drifts by 20 HU along the knot (dried, σ 5 HU).
TEST(KnotFit, CoreDensityStepPlacesRDead) {
  const Knot dead = make_knot(600, 5.0, 0.2, 2.0, 0.0, 70, 120, 20, 0.1);
  const Knot sound = make_knot(600, 5.0, 0.2, 2.0, 0.0, 120, 120, 20, 0.1);
  struct Core {
    const char* name;
    const Knot* knot;
    double sound_hu, dead_hu, sigma_hu, drift_hu, last_two_hu;
  };
  const Core cores[] = {
      {"green dead, bark at the end", &dead, 0, -180, 25, 0, 60},
      {"dried dead, 40 HU step", &dead, -280, -320, 5, 0, -280},
      {"green sound", &sound, 0, 0, 25, 0, 0},
      {"dried sound, drifting", &sound, -280, -280, 5, -20, -280},
  };
  constexpr int kSeeds = 10;
  for (const Core& c : cores) {
    int right = 0;
    double worst = 0;
    for (int seed = 1; seed <= kSeeds; ++seed) {
      KnotTrace t = make_trace(*c.knot, seed);
      std::mt19937 rng(1000 + seed);
      std::normal_distribution<double> gauss(0.0, c.sigma_hu);
      const int n = static_cast<int>(t.shells.size());
      for (int i = 0; i < n; ++i) {
        KnotShell& s = t.shells[i];
        const double along = s.r / c.knot->r_end;
        s.core_hu =
            (c.knot->dead_at(s.r) ? c.dead_hu : c.sound_hu) + c.drift_hu * along + gauss(rng);
        if (i >= n - 2) s.core_hu = c.last_two_hu + gauss(rng);
      }
      Result<KnotFitReport> fit = fit_knot(t);
      ASSERT_TRUE(fit) << fit.error().message();
      const double err = std::abs(fit.value().knot.r_dead - c.knot->r_dead);
      worst = std::max(worst, err);
      right += err <= 3.0 ? 1 : 0;
    }
    std::printf("%-28s r_dead within 3 mm on %d/%d, worst %.1f mm\n", c.name, right, kSeeds, worst);
    EXPECT_EQ(right, kSeeds) << c.name;
  }
}

TEST(KnotFit, SurfaceKnotEndsAtItsLastShell) {
  const Knot k = cases()[1].knot;
  KnotTrace t = make_trace(k, 3);
  t.reaches_surface = true;
  t.r_last_seen = k.r_end + 20;  // evidence in the bark beyond: not knot
  Result<KnotFitReport> fit = fit_knot(t);
  ASSERT_TRUE(fit) << fit.error().message();
  EXPECT_DOUBLE_EQ(fit.value().knot.r_end, t.shells.back().r);

  t.reaches_surface = false;
  t.r_last_seen = 0;  // unset: never before the last shell
  fit = fit_knot(t);
  ASSERT_TRUE(fit) << fit.error().message();
  EXPECT_DOUBLE_EQ(fit.value().knot.r_end, t.shells.back().r);
}

TEST(KnotFit, PredictedShellsWeighLess) {
  // The outer third followed by prediction, and that prediction drifted 6 mm up: down-weighted,
  // it moves the fit less than the same shells at full weight.
  const Knot k = cases()[1].knot;
  KnotTrace t = make_trace(k, 4);
  const size_t from = 2 * t.shells.size() / 3;
  for (size_t i = from; i < t.shells.size(); ++i) t.shells[i].z += 6.0;
  KnotFitOptions o;
  o.huber_mm = 0;  // plain least squares, so that only the weights differ
  Result<KnotFitReport> full = fit_knot(t, o);
  for (size_t i = from; i < t.shells.size(); ++i) t.shells[i].predicted = true;
  Result<KnotFitReport> weak = fit_knot(t, o);
  ASSERT_TRUE(full && weak);
  const double r = k.r_end;
  EXPECT_LT(std::abs(weak.value().knot.height_at(r) - k.height_at(r)),
            std::abs(full.value().knot.height_at(r) - k.height_at(r)));
}

TEST(KnotFit, TooFewShellsIsAnError) {
  KnotTrace t = make_trace(cases()[0].knot, 1);
  t.shells.resize(3);
  Result<KnotFitReport> fit = fit_knot(t);
  ASSERT_FALSE(fit);
  EXPECT_NE(fit.error().message().find("too few shells"), std::string::npos)
      << fit.error().message();
}

TEST(KnotFit, NonFiniteShellIsAnError) {
  KnotTrace t = make_trace(cases()[0].knot, 1);
  t.shells[10].z = std::nan("");
  Result<KnotFitReport> fit = fit_knot(t);
  ASSERT_FALSE(fit);
  EXPECT_NE(fit.error().message().find("shell 10"), std::string::npos) << fit.error().message();
}

// A hundred knots with outliers all fit (the time is printed for reference; bench/knot_bench
// measures speed, a test does not assert it).
TEST(KnotFit, HundredKnotsWithOutliersAllFit) {
  std::vector<KnotTrace> traces;
  const std::vector<Case> cs = cases();
  for (unsigned i = 0; i < 100; ++i) {
    traces.push_back(make_trace(cs[i % cs.size()].knot, 100 + i));
    add_blobs(traces.back(), 200 + i, 0.1);
  }
  const auto t0 = std::chrono::steady_clock::now();
  int failed = 0;
  for (const KnotTrace& t : traces) failed += fit_knot(t) ? 0 : 1;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("100 knots (%zu..%zu shells each): %.1f ms total, %.2f ms per knot\n",
              traces[4].shells.size(), traces[2].shells.size(), 1e3 * s, 10.0 * s);
  EXPECT_EQ(failed, 0);
}

}  // namespace
}  // namespace sawyer::ct
