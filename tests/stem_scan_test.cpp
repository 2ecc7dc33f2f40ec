// The stem pass's own arithmetic: the robust pith track flags jumps and keeps a straight or
// bowed pith, and re-centring a contour on another point is exact for a circle.
#include "sawyer/ct/scan/stem_scan.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace sawyer::ct {
namespace {

TEST(SmoothPithTrack, KeepsALinearTrackAndFlagsJumps) {
  std::vector<PithResult> raw(60);
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int i = 0; i < 60; ++i) {
    raw[i].found = true;
    raw[i].pith_mm = {100.0 + 0.2 * i + noise(rng), 80.0 - 0.1 * i + noise(rng)};
  }
  // A whorl pulls two slices 6 mm off; one slice has no log found.
  raw[20].pith_mm.x += 6.0;
  raw[41].pith_mm.y -= 6.0;
  raw[30].found = false;
  std::vector<double> z(60);
  for (int i = 0; i < 60; ++i) z[i] = 5.0 * i;
  std::vector<bool> outlier;
  const std::vector<Vec2> s = smooth_pith_track(z, raw, {}, &outlier);
  ASSERT_EQ(s.size(), raw.size());
  EXPECT_TRUE(outlier[20]);
  EXPECT_TRUE(outlier[41]);
  EXPECT_FALSE(outlier[10]);
  double worst = 0;
  for (int i = 0; i < 60; ++i) {
    const Vec2 want{100.0 + 0.2 * i, 80.0 - 0.1 * i};
    worst = std::max(worst, (s[i] - want).norm());
  }
  EXPECT_LT(worst, 0.25);
}

TEST(RecentreContour, IsExactForACircle) {
  const int n = 360;
  const double R = 120.0;
  const Vec2 from{200, 210}, to{203.5, 207.0};
  // A circle of radius R around (201, 209): its radius per angle around `from`.
  const Vec2 c{201, 209};
  auto radius_around = [&](const Vec2& p, double w) {
    // Ray p + t (cos w, sin w) meets |x - c| = R at the positive root.
    const double dx = p.x - c.x, dy = p.y - c.y;
    const double b = dx * std::cos(w) + dy * std::sin(w);
    const double cc = dx * dx + dy * dy - R * R;
    return -b + std::sqrt(b * b - cc);
  };
  std::vector<double> r(n);
  std::vector<bool> valid(n, true);
  for (int k = 0; k < n; ++k) r[k] = radius_around(from, kTwoPi * k / n);
  recentre_contour(from, to, r, valid);
  double worst = 0;
  for (int k = 0; k < n; ++k) {
    ASSERT_TRUE(valid[k]) << k;
    worst = std::max(worst, std::abs(r[k] - radius_around(to, kTwoPi * k / n)));
  }
  // Linear interpolation between contour points 2 mm apart on a 120 mm circle.
  EXPECT_LT(worst, 0.01);
}

TEST(RecentreContour, KeepsAGapInvalid) {
  const int n = 360;
  std::vector<double> r(n, 100.0);
  std::vector<bool> valid(n, true);
  for (int k = 90; k < 120; ++k) valid[k] = false;  // the bed hid 30 degrees
  recentre_contour({0, 0}, {1.0, 0.5}, r, valid);
  int invalid = 0;
  for (int k = 0; k < n; ++k) invalid += !valid[k];
  EXPECT_GE(invalid, 25);
  EXPECT_LE(invalid, 35);
}

// A scan with no log in it is refused, naming the scan.
class AirSource final : public SliceSource {
 public:
  AirSource() {
    g_.width = g_.height = 128;
    g_.spacing_x = g_.spacing_y = 0.8;
    for (int i = 0; i < 12; ++i) g_.z.push_back(5.0 * i);
  }
  Format format() const override { return Format::kDicom; }
  const VolumeGeometry& geometry() const override { return g_; }
  std::string description() const override { return "air-only scan"; }
  const std::vector<std::string>& notes() const override { return notes_; }
  Status read(int i, Slice& out) override {
    out.index = i;
    out.z = g_.z[static_cast<size_t>(i)];
    out.width = out.height = 128;
    out.hu.assign(128 * 128, -1000.f);
    return Status::Ok();
  }

 private:
  VolumeGeometry g_;
  std::vector<std::string> notes_;
};

TEST(ScanStem, NoLogIsRefusedNamingTheScan) {
  AirSource src;
  auto r = scan_stem(src, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message().find("air-only scan"), std::string::npos) << r.error().message();
  EXPECT_NE(r.error().message().find("no log"), std::string::npos) << r.error().message();
}

}  // namespace
}  // namespace sawyer::ct
