// The figures of `sawyer info` against logs of known geometry.
#include "sawyer/model/log_summary.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

namespace sawyer {
namespace {

// A frustum: radius r_butt at z = 0 down to r_top at the last sample, pith on a line, plus an
// optional sideways bump of the pith of height `bump` in the middle.
LogModel frustum(double r_butt, double r_top, int n, double dz, Vec2 tilt, double bump = 0) {
  LogModel log;
  log.id = "frustum";
  Stem& s = log.stem;
  s.dz_mm = dz;
  s.n_angles = 720;
  for (int i = 0; i < n; ++i) {
    const double f = n > 1 ? double(i) / (n - 1) : 0;
    const double z = s.z_at(i);
    const double b = (i == n / 2) ? bump : 0.0;
    s.pith.push_back({tilt.x * z + b, tilt.y * z});
    s.radius.push_back(std::vector<double>(720, r_butt + f * (r_top - r_butt)));
  }
  return log;
}

TEST(LogSummary, CylinderVolumeAndDiameters) {
  const LogModel log = frustum(150, 150, 400, 10, {0, 0});
  const LogSummary s = summarize(log);
  EXPECT_DOUBLE_EQ(s.length_mm, 4000);
  // π·150²·4000 mm³ = 0.28274 m³ (the 720-gon is 0.0013 % smaller than the circle).
  EXPECT_NEAR(s.volume_m3, kPi * 150 * 150 * 4000 * 1e-9, 1e-4 * s.volume_m3);
  EXPECT_NEAR(s.butt_diameter_mm, 300, 0.01);
  EXPECT_NEAR(s.top_diameter_mm, 300, 0.01);
  EXPECT_NEAR(s.mean_diameter_mm, 300, 0.01);
  EXPECT_NEAR(s.taper_mm_per_m, 0, 1e-9);
  EXPECT_NEAR(s.ovality, 0, 1e-12);
  EXPECT_EQ(s.knot_count, 0);
  EXPECT_EQ(s.largest_knot, -1);
}

TEST(LogSummary, ConeTaperAndEndDiameters) {
  // 4 m from r = 160 to r = 120: taper = 80 mm over 3.99 m between the first and last samples.
  const LogModel log = frustum(160, 120, 400, 10, {0, 0});
  const LogSummary s = summarize(log);
  // End diameters average the samples within 100 mm of each end (11 samples: 0..100 mm).
  const double step = 80.0 / 399;  // diameter change per sample
  EXPECT_NEAR(s.butt_diameter_mm, 320 - 5 * step, 0.02);
  EXPECT_NEAR(s.top_diameter_mm, 240 + 5 * step, 0.02);
  EXPECT_NEAR(s.taper_mm_per_m, (80 - 10 * step) / 4.0, 0.02);
  // Volume of a frustum: π·L/3·(R² + Rr + r²) over the sampled length ≈ Σ areas·dz.
  double v = 0;
  for (int i = 0; i < 400; ++i) {
    const double r = 160 - 40.0 * i / 399;
    v += kPi * r * r * 10;
  }
  EXPECT_NEAR(s.volume_m3, v * 1e-9, 1e-4 * s.volume_m3);
}

TEST(LogSummary, PithTiltIsNotWanderButABumpIs) {
  LogModel log = frustum(150, 150, 300, 10, {0.003, -0.004});
  LogSummary s = summarize(log);
  EXPECT_NEAR(s.pith_tilt_mm_per_m, 5.0, 1e-9);  // √(3² + 4²) mm/m
  EXPECT_NEAR(s.pith_wander_mm, 0.0, 1e-9);
  log = frustum(150, 150, 301, 10, {0, 0}, 7.0);
  s = summarize(log);
  // One sample 7 mm off: the fitted line barely moves, so the wander is close to 7 mm.
  EXPECT_NEAR(s.pith_wander_mm, 7.0, 0.1);
}

TEST(LogSummary, OvalityOfAnEllipse) {
  LogModel log = frustum(150, 150, 10, 10, {0, 0});
  for (auto& row : log.stem.radius)
    for (int k = 0; k < 720; ++k) {
      // Ellipse with semi-axes 160 and 140, centred on the pith.
      const double w = kTwoPi * k / 720;
      row[k] = 1.0 / std::sqrt(std::pow(std::cos(w) / 160, 2) + std::pow(std::sin(w) / 140, 2));
    }
  const LogSummary s = summarize(log);
  EXPECT_NEAR(s.ovality, 1.0 - 280.0 / 320.0, 1e-6);
  // Equal-area diameter of the ellipse: 2·√(160·140).
  EXPECT_NEAR(s.mean_diameter_mm, 2 * std::sqrt(160.0 * 140.0), 0.01);
}

TEST(LogSummary, KnotCountsAndLargestKnot) {
  LogModel log = frustum(150, 150, 100, 10, {0, 0});
  for (int i = 0; i < 5; ++i) {
    Knot k;
    k.id = 100 + i;
    k.z0 = 100.0 * i;
    k.r_end = 120;
    k.r_dead = i < 2 ? 200 : 60;  // two sound knots, three with a dead part
    k.diameter = {10.0 + 3 * i, 1.0};
    log.knots.push_back(k);
  }
  log.knots[1].diameter.d_dead = 100;  // sound to r_end: largest diameter 100·120/200 = 60
  const LogSummary s = summarize(log);
  EXPECT_EQ(s.knot_count, 5);
  EXPECT_EQ(s.sound_knots, 2);
  EXPECT_EQ(s.dead_knots, 3);
  EXPECT_EQ(s.largest_knot, 1);
  EXPECT_NEAR(s.largest_knot_diameter_mm, 60.0, 1e-9);
  std::ostringstream os;
  print_summary(os, log, s);
  EXPECT_NE(os.str().find("id 101: 60.0 mm"), std::string::npos) << os.str();
  EXPECT_NE(os.str().find("knots                   5  (sound 2, with a dead part 3)"),
            std::string::npos)
      << os.str();
}

}  // namespace
}  // namespace sawyer
