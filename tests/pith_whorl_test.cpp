// The whorl cue (pith_whorl.h) on drawn slices with an exact answer: knot streaks radiating from a
// known pith at the noise and ring spread of real heartwood, with distractors that are not knots
// (a tangential resin pocket, a metal streak), and the cases that must give no answer (one
// streak, parallel streaks, a slice of rings only).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "sawyer/ct/stem/pith_whorl.h"

namespace sawyer::ct {
namespace {

constexpr double kPixel = 0.8;
constexpr int kSize = 160;  // 128 mm square crop at the origin

struct Drawn {
  SliceCrop crop;
  VolumeGeometry g;
};

// Heartwood at -500 HU with rings (`ring_hu` peak to peak, 2 mm) around `pith` and Gaussian noise.
Drawn wood(Vec2 pith, double ring_hu, double noise_hu, unsigned seed) {
  Drawn d;
  d.g.width = d.g.height = kSize;
  d.g.spacing_x = d.g.spacing_y = kPixel;
  d.g.z = {0.0};
  d.crop.width = d.crop.height = kSize;
  d.crop.wood_min_hu = -800;
  d.crop.wood_max_hu = -200;
  d.crop.hu.assign(static_cast<size_t>(kSize) * kSize, 0.f);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_hu);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const double r = std::hypot(x * kPixel - pith.x, y * kPixel - pith.y);
      d.crop.hu[static_cast<size_t>(y) * kSize + x] =
          static_cast<float>(-500 + 0.5 * ring_hu * std::sin(2 * kPi * r / 2.0) + noise(rng));
    }
  return d;
}

// A bright bar (a knot's section: `hu` above the wood) from `from` in direction `angle`.
void bar(Drawn& d, Vec2 from, double angle, double length_mm, double width_mm, double hu) {
  const Vec2 u{std::cos(angle), std::sin(angle)};
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const Vec2 q = Vec2{x * kPixel, y * kPixel} - from;
      const double along = q.x * u.x + q.y * u.y, across = std::abs(q.x * u.y - q.y * u.x);
      if (along >= 0 && along <= length_mm && across <= 0.5 * width_mm)
        d.crop.hu[static_cast<size_t>(y) * kSize + x] += static_cast<float>(hu);
    }
}

// Knots leaving the pith at `angles`, starting `start_mm` out (a knot is thin at the pith and,
// blurred, stays under the threshold there; knots that join at the pith into one star are one
// component and not split: see docs/scan.md).
void whorl(Drawn& d, Vec2 pith, const std::vector<double>& angles, double start_mm = 8.0) {
  for (double a : angles)
    bar(d, pith + start_mm * Vec2{std::cos(a), std::sin(a)}, a, 35.0, 7.0, 450.0);
}

const Vec2 kPith{61.3, 66.9};
const Vec2 kRegion{64.0, 64.0};

TEST(PithWhorl, FourKnotsMeetAtThePith) {
  Drawn d = wood(kPith, 150, 40, 1);
  whorl(d, kPith, {0.3, 1.9, 3.4, 4.9});
  const WhorlPith w = whorl_pith(d.crop, d.g, kRegion, 55.0, 40.0);
  ASSERT_TRUE(w.found);
  EXPECT_LT((w.pith_mm - kPith).norm(), 1.5) << w.pith_mm.x << "," << w.pith_mm.y;
  EXPECT_EQ(w.knots, 4);
  EXPECT_GT(w.expected_error_mm, 0.0);
  EXPECT_LT(w.expected_error_mm, 3.0);
}

TEST(PithWhorl, TwoKnotsAreEnough) {
  Drawn d = wood(kPith, 100, 30, 2);
  whorl(d, kPith, {0.5, 2.2});
  const WhorlPith w = whorl_pith(d.crop, d.g, kRegion, 55.0, 30.0);
  ASSERT_TRUE(w.found);
  EXPECT_LT((w.pith_mm - kPith).norm(), 2.0);
}

// A resin pocket (tangential lens) and a metal streak across the section and one of the knots
// are not knots' lines: the three knots' meeting point stands.
TEST(PithWhorl, DistractorsAreWeightedOut) {
  Drawn d = wood(kPith, 150, 40, 3);
  whorl(d, kPith, {0.2, 2.3, 4.4});
  bar(d, kPith + Vec2{-20, 30}, 0.05, 22.0, 4.0, 500.0);  // tangential, well off the pith
  bar(d, Vec2{5, 110}, -0.35, 120.0, 2.5, 2500.0);  // a metal streak across the slice and a knot
  const WhorlPith w = whorl_pith(d.crop, d.g, kRegion, 60.0, 40.0);
  ASSERT_TRUE(w.found);
  EXPECT_LT((w.pith_mm - kPith).norm(), 2.0) << w.pith_mm.x << "," << w.pith_mm.y;
  EXPECT_EQ(w.knots, 3);
}

TEST(PithWhorl, NoAnswerWithoutAMeeting) {
  {  // rings only, strong latewood: nothing stands out as a knot
    Drawn d = wood(kPith, 250, 40, 4);
    const WhorlPith w = whorl_pith(d.crop, d.g, kRegion, 55.0, 40.0);
    EXPECT_FALSE(w.found);
    EXPECT_TRUE(w.streaks.empty()) << w.streaks.size() << " streaks in rings";
  }
  {  // one knot: a line, not a point
    Drawn d = wood(kPith, 100, 30, 5);
    whorl(d, kPith, {1.0});
    const WhorlPith w = whorl_pith(d.crop, d.g, kRegion, 55.0, 30.0);
    EXPECT_FALSE(w.found);
    EXPECT_EQ(w.streaks.size(), 1u);
  }
  {  // two parallel streaks never meet
    Drawn d = wood(kPith, 100, 30, 6);
    bar(d, Vec2{30, 40}, 0.4, 30.0, 6.0, 450.0);
    bar(d, Vec2{40, 75}, 0.4, 30.0, 6.0, 450.0);
    const WhorlPith w = whorl_pith(d.crop, d.g, kRegion, 55.0, 30.0);
    EXPECT_FALSE(w.found);
  }
}

// Pooled streaks of several slices, shifted along z: meet_streaks with weights gives the same
// point, and a streak from another slice far off the point does not move it.
TEST(PithWhorl, PooledStreaksMeet) {
  std::vector<WhorlStreak> pool;
  std::vector<double> weight;
  const Vec2 p{3.0, -2.0};
  for (double a : {0.1, 1.4, 2.9, 4.2}) {
    WhorlStreak s;
    s.direction = {std::cos(a), std::sin(a)};
    s.centre_mm = p + 20.0 * s.direction;
    s.length_mm = 25.0;
    s.width_mm = 7.0;
    pool.push_back(s);
    weight.push_back(a < 2 ? 1.0 : 0.5);
  }
  WhorlStreak off;
  off.direction = {1.0, 0.0};
  off.centre_mm = {0.0, 25.0};
  off.length_mm = 30.0;
  off.width_mm = 6.0;
  pool.push_back(off);
  weight.push_back(1.0);
  const WhorlPith w = meet_streaks(pool, weight, {0, 0}, 50.0, kPixel);
  ASSERT_TRUE(w.found);
  EXPECT_LT((w.pith_mm - p).norm(), 0.05);
  EXPECT_EQ(w.knots, 4);
  EXPECT_EQ(w.distinct, 4);
}

}  // namespace
}  // namespace sawyer::ct
