// make_uniform_z(): pass-through of even grids, snapping of tiny jitter, resampling of missing
// slices and uneven gaps, rejection messages, and streaming (each source slice read once, at most
// two held). Uses a tiny in-memory SliceSource whose HU are linear in z, so linear interpolation
// along z must reproduce them exactly.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct {
namespace {

using ::testing::HasSubstr;

constexpr int kW = 4;
constexpr int kH = 3;

// HU at (col, row) of the slice at absolute position z: linear in z, different per pixel.
float truth(double z, int col, int row) {
  return static_cast<float>(2.0 * z + 10.0 * col - 100.0 * row);
}

class FakeSource final : public SliceSource {
 public:
  explicit FakeSource(std::vector<double> z) {
    geometry_.width = kW;
    geometry_.height = kH;
    geometry_.spacing_x = 0.5;
    geometry_.spacing_y = 0.7;
    geometry_.z = std::move(z);
    geometry_.origin = {1, 2, 3};
  }
  Format format() const override { return Format::kTiffStack; }
  const VolumeGeometry& geometry() const override { return geometry_; }
  std::string description() const override { return "fake series"; }
  const std::vector<std::string>& notes() const override { return notes_; }
  Status read(int i, Slice& out) override {
    ++reads;
    if (i == fail_at) return Error("fake.tif", "cannot read slice " + std::to_string(i));
    out.index = i;
    out.z = geometry_.z[static_cast<size_t>(i)];
    out.width = kW;
    out.height = kH;
    out.hu.resize(kW * kH);
    for (int r = 0; r < kH; ++r)
      for (int c = 0; c < kW; ++c) out.hu[static_cast<size_t>(r * kW + c)] = truth(out.z, c, r);
    return Status::Ok();
  }

  int reads = 0;
  int fail_at = -1;
  std::vector<std::string> notes_{"from the fake reader"};

 private:
  VolumeGeometry geometry_;
};

std::vector<double> even(int n, double dz, double z0 = 0.0) {
  std::vector<double> z;
  for (int i = 0; i < n; ++i) z.push_back(z0 + i * dz);
  return z;
}

// 0, 5, ..., 120, then 140, 145, ...: three slices (125, 130, 135) missing.
std::vector<double> with_gap() {
  std::vector<double> z;
  for (int i = 0; i <= 24; ++i) z.push_back(i * 5.0);
  for (int i = 28; i <= 40; ++i) z.push_back(i * 5.0);
  return z;
}

OpenOptions policy(ZPolicy p, double tolerance = 1.5) {
  OpenOptions o;
  o.z_policy = p;
  o.gap_tolerance = tolerance;
  return o;
}

void expect_slice_matches_truth(SliceSource& s, int i, double z_abs) {
  Slice out;
  ASSERT_TRUE(s.read(i, out)) << i;
  ASSERT_EQ(out.width, kW);
  ASSERT_EQ(out.height, kH);
  ASSERT_EQ(out.hu.size(), static_cast<size_t>(kW * kH));
  EXPECT_EQ(out.index, i);
  for (int r = 0; r < kH; ++r)
    for (int c = 0; c < kW; ++c)
      EXPECT_NEAR(out.at(c, r), truth(z_abs, c, r), 1e-3) << "slice " << i << " z " << z_abs;
}

TEST(UniformZ, EvenGridPassesThroughUnchanged) {
  auto fake = std::make_unique<FakeSource>(even(10, 2.5));
  SliceSource* raw = fake.get();
  auto r = make_uniform_z(std::move(fake), {});
  ASSERT_TRUE(r) << r.error().message();
  EXPECT_EQ(r.value().get(), raw);  // the very same object: no wrapper, no copy
}

TEST(UniformZ, SingleSlicePassesThrough) {
  auto fake = std::make_unique<FakeSource>(std::vector<double>{0.0});
  SliceSource* raw = fake.get();
  auto r = make_uniform_z(std::move(fake), {});
  ASSERT_TRUE(r);
  EXPECT_EQ(r.value().get(), raw);
}

TEST(UniformZ, JitterWithinOnePercentIsSnappedNotResampled) {
  std::vector<double> z = even(20, 5.0, 12.0);
  for (size_t i = 0; i < z.size(); ++i) z[i] += (i % 2 ? 0.01 : -0.01);  // gaps 4.98, 5.02
  auto fake = std::make_unique<FakeSource>(z);
  FakeSource* f = fake.get();
  auto r = make_uniform_z(std::move(fake), policy(ZPolicy::kReject));
  ASSERT_TRUE(r) << r.error().message();
  const VolumeGeometry& g = r.value()->geometry();
  ASSERT_EQ(g.slice_count(), 20);
  const double spacing = (z.back() - z.front()) / 19.0;
  for (int i = 0; i < 20; ++i) EXPECT_DOUBLE_EQ(g.z[static_cast<size_t>(i)], i * spacing);
  // Slices are the source's own, relabelled: slice 3 holds the data of source position z[3].
  Slice out;
  ASSERT_TRUE(r.value()->read(3, out));
  EXPECT_DOUBLE_EQ(out.z, 3 * spacing);
  EXPECT_FLOAT_EQ(out.at(1, 1), truth(z[3], 1, 1));
  EXPECT_EQ(f->reads, 1);
  EXPECT_EQ(r.value()->notes(), std::vector<std::string>{"from the fake reader"});
}

TEST(UniformZ, DuplicatePositionIsAnErrorForBothPolicies) {
  std::vector<double> z = even(10, 5.0);
  z[6] = z[5] + 0.0004;
  for (ZPolicy p : {ZPolicy::kResample, ZPolicy::kReject}) {
    auto r = make_uniform_z(std::make_unique<FakeSource>(z), policy(p));
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().message(),
              "fake series: duplicate slice positions: slices 5 and 6 both at z=25.000 mm");
  }
}

TEST(UniformZ, BackwardsPositionIsAnError) {
  auto r = make_uniform_z(std::make_unique<FakeSource>(std::vector<double>{0, 5, 10, 7, 20}), {});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr("slice positions go backwards: slice 3 at z=7.000"));
}

TEST(UniformZ, MissingSlicesAreResampledWithANote) {
  const std::vector<double> z = with_gap();
  auto fake = std::make_unique<FakeSource>(z);
  FakeSource* f = fake.get();
  auto r = make_uniform_z(std::move(fake), policy(ZPolicy::kResample));
  ASSERT_TRUE(r) << r.error().message();
  SliceSource& s = *r.value();
  const VolumeGeometry& g = s.geometry();
  ASSERT_EQ(g.slice_count(), 41);  // 0..200 mm at 5 mm
  for (int k = 0; k < 41; ++k) EXPECT_DOUBLE_EQ(g.z[static_cast<size_t>(k)], 5.0 * k);
  EXPECT_DOUBLE_EQ(g.slice_spacing(), 5.0);
  EXPECT_EQ(g.spacing_x, 0.5);
  EXPECT_EQ(g.origin, (Vec3{1, 2, 3}));
  EXPECT_THAT(s.notes(), ::testing::ElementsAre(
                             "from the fake reader",
                             "resampled along z: 3 missing slices between z=120.0 and z=140.0 mm"));
  for (int k = 0; k < 41; ++k) expect_slice_matches_truth(s, k, 5.0 * k);
  // Streaming: ascending reads touch every source slice exactly once.
  EXPECT_EQ(f->reads, static_cast<int>(z.size()));
}

TEST(UniformZ, RejectListsTheGap) {
  auto r = make_uniform_z(std::make_unique<FakeSource>(with_gap()), policy(ZPolicy::kReject));
  ASSERT_FALSE(r);
  EXPECT_EQ(
      r.error().message(),
      "fake series: uneven slice spacing: gaps at z=120.0..140.0 mm (20.0 mm, median 5.0 mm)");
}

TEST(UniformZ, RejectListsSeveralGaps) {
  std::vector<double> z = even(30, 2.0);
  z.erase(z.begin() + 20);                // 38 -> 42 missing 40
  z.erase(z.begin() + 5, z.begin() + 7);  // 8 -> 14 missing 10, 12
  auto r = make_uniform_z(std::make_unique<FakeSource>(z), policy(ZPolicy::kReject));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().message(),
            "fake series: uneven slice spacing: gaps at z=8.0..14.0 mm (6.0 mm), "
            "z=38.0..42.0 mm (4.0 mm); median 2.0 mm");
}

TEST(UniformZ, UnevenGapsBelowTheToleranceAreResampledAsJitter) {
  // 10 mm grid; one slice 3 mm late: gaps 13 and 7 (not missing slices, but 30% off).
  std::vector<double> z = even(12, 10.0);
  z[5] += 3.0;
  auto r = make_uniform_z(std::make_unique<FakeSource>(z), policy(ZPolicy::kResample));
  ASSERT_TRUE(r) << r.error().message();
  SliceSource& s = *r.value();
  ASSERT_EQ(s.geometry().slice_count(), 12);
  ASSERT_EQ(s.notes().size(), 2u);
  EXPECT_EQ(s.notes()[1],
            "resampled along z: 2 uneven gaps (up to 3.000 mm off the median 10.0 mm) "
            "interpolated onto an even grid");
  for (int k = 0; k < 12; ++k) expect_slice_matches_truth(s, k, 10.0 * k);
}

TEST(UniformZ, GapToleranceDecidesWhatCountsAsMissing) {
  // One gap of 1.4 median spacings.
  std::vector<double> z = even(10, 5.0);
  for (size_t i = 5; i < z.size(); ++i) z[i] += 2.0;
  auto loose = make_uniform_z(std::make_unique<FakeSource>(z), policy(ZPolicy::kResample, 1.5));
  ASSERT_TRUE(loose);
  EXPECT_THAT(loose.value()->notes().back(), HasSubstr("1 uneven gap"));
  auto strict = make_uniform_z(std::make_unique<FakeSource>(z), policy(ZPolicy::kResample, 1.2));
  ASSERT_TRUE(strict);
  EXPECT_EQ(strict.value()->notes().back(),
            "resampled along z: 1 missing slice between z=20.0 and z=27.0 mm");
  auto bad = make_uniform_z(std::make_unique<FakeSource>(z), policy(ZPolicy::kResample, 0.5));
  ASSERT_FALSE(bad);
  EXPECT_THAT(bad.error().message(), HasSubstr("gap tolerance must be more than 1"));
}

TEST(UniformZ, AbsurdGridIsRefused) {
  std::vector<double> z = even(10, 0.5);
  z.push_back(1e6);  // one slice a kilometre away
  auto r = make_uniform_z(std::make_unique<FakeSource>(z), {});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(),
              HasSubstr("resampling 11 slices would need 2000001 output slices"));
  auto inf = make_uniform_z(std::make_unique<FakeSource>(std::vector<double>{0, 1, HUGE_VAL}), {});
  ASSERT_FALSE(inf);
  EXPECT_THAT(inf.error().message(), HasSubstr("slice positions are not usable numbers"));
}

TEST(UniformZ, OutputStartsAtZeroWhenTheSourceDoesNot) {
  std::vector<double> z = with_gap();
  for (double& v : z) v += 1000.0;
  auto r = make_uniform_z(std::make_unique<FakeSource>(z), {});
  ASSERT_TRUE(r);
  EXPECT_EQ(r.value()->geometry().z.front(), 0.0);
  EXPECT_THAT(r.value()->notes().back(), HasSubstr("between z=120.0 and z=140.0 mm"));
  expect_slice_matches_truth(*r.value(), 26, 1000.0 + 130.0);
}

TEST(UniformZ, RandomAccessStillInterpolatesCorrectly) {
  auto r = make_uniform_z(std::make_unique<FakeSource>(with_gap()), {});
  ASSERT_TRUE(r);
  for (int k : {40, 0, 26, 25, 27, 3, 39}) expect_slice_matches_truth(*r.value(), k, 5.0 * k);
}

TEST(UniformZ, SourceReadErrorsPropagate) {
  auto fake = std::make_unique<FakeSource>(with_gap());
  fake->fail_at = 25;  // the slice at 140 mm, needed for 125..140
  auto r = make_uniform_z(std::move(fake), {});
  ASSERT_TRUE(r);
  Slice out;
  ASSERT_TRUE(r.value()->read(24, out));
  const Status st = r.value()->read(25, out);
  ASSERT_FALSE(st);
  EXPECT_EQ(st.error().message(), "fake.tif: cannot read slice 25");
}

}  // namespace
}  // namespace sawyer::ct
