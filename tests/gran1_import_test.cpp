// Import of the real spruce log Gran_1 (Luleå stem-bank JSON) into the model.
#include "sawyer/model/gran1_import.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "sawyer/test/test_util.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const LogModel& gran1() {
  static const LogModel log = [] {
    Result<LogModel> r = import_gran1(test::gran1_source_dir());
    EXPECT_TRUE(r) << r.error().message();
    return r ? r.value() : LogModel{};
  }();
  return log;
}

TEST(Gran1Import, Has108KnotsAnd400SlicesOf10mm) {
  const LogModel& log = gran1();
  EXPECT_EQ(log.knots.size(), 108u);
  EXPECT_EQ(log.stem.slice_count(), 400);
  EXPECT_DOUBLE_EQ(log.stem.dz_mm, 10.0);
  EXPECT_DOUBLE_EQ(log.stem.z0_mm, 0.0);
  EXPECT_EQ(log.stem.n_angles, 360);
  EXPECT_DOUBLE_EQ(log.stem.length_mm(), 4000.0);
  EXPECT_EQ(log.species, "spruce");
}

TEST(Gran1Import, RadiiSpan104To143mm) {
  double lo = 1e9, hi = 0;
  for (const auto& row : gran1().stem.radius)
    for (double r : row) lo = std::min(lo, r), hi = std::max(hi, r);
  EXPECT_DOUBLE_EQ(lo, 104.06);
  EXPECT_DOUBLE_EQ(hi, 143.375);
}

TEST(Gran1Import, StemAzimuthFollowsThePublishedRenderer) {
  // Row 0 of Gran_1_radii.json: value j is at the renderer's azimuth j degrees from +y towards
  // +x, which is our ω = 90° − j: file value 0 (124.207) at ω = 90°, value 90 (117.965) at ω = 0,
  // value 180 (132.729) at ω = 270°, value 270 (124.956) at ω = 180°.
  const Stem& s = gran1().stem;
  EXPECT_DOUBLE_EQ(s.radius[0][90], 124.207);
  EXPECT_DOUBLE_EQ(s.radius[0][0], 117.965);
  EXPECT_DOUBLE_EQ(s.radius[0][270], 132.729);
  EXPECT_DOUBLE_EQ(s.radius[0][180], 124.956);
  EXPECT_DOUBLE_EQ(s.pith[0].x, 184.201146323);
  EXPECT_DOUBLE_EQ(s.pith[123].y, 167.635627211);
}

TEST(Gran1Import, KnotColumnsMapToTheKnotFormula) {
  // Row 7: [A..I] = [0.553483, -0.14481, 350.565, 0.133432, -0.262179, 2.05488, 0.0302885,
  // 138.0, 87.4148]. Heights and twist take the signs the published renderer draws.
  const Knot& k = gran1().knots[7];
  EXPECT_EQ(k.id, 7);
  EXPECT_DOUBLE_EQ(k.z0, 350.565);
  EXPECT_DOUBLE_EQ(k.a, -0.133432);
  EXPECT_DOUBLE_EQ(k.b, 0.262179);
  EXPECT_DOUBLE_EQ(k.omega0, 2.05488);
  EXPECT_DOUBLE_EQ(k.twist, -0.0302885);
  EXPECT_DOUBLE_EQ(k.r_end, 138.0);
  EXPECT_DOUBLE_EQ(k.r_dead, 87.4148);
  // Branches rise from the pith: at r = 100 mm the axis is 24.9 mm above its start.
  EXPECT_NEAR(k.height_at(100.0) - k.z0, -0.133432 * 10.0 + 0.262179 * 100.0, 1e-9);
}

TEST(Gran1Import, MostKnotsRiseAndDiametersAreRealistic) {
  int rising = 0;
  for (const Knot& k : gran1().knots) {
    if (k.height_at(std::min(60.0, k.r_end)) > k.z0) ++rising;
    EXPECT_GT(k.max_diameter(), 3.0) << "knot " << k.id;
    EXPECT_LT(k.max_diameter(), 40.0) << "knot " << k.id;
    EXPECT_GT(k.diameter.exponent, 0.5);
    EXPECT_LT(k.diameter.exponent, 2.0);
  }
  EXPECT_GT(rising, 90);
}

TEST(Gran1Import, DiameterFollowsThePaperGrowthRule) {
  // The power law stays within 10 % of the rule it was fitted to over the knot's sound part.
  const double rmin = 104.06, R = 125.0;
  for (double r_dead : {35.0, 60.0, 90.0, 130.0}) {
    const KnotDiameter d = fit_paper_diameter(r_dead, R, rmin);
    EXPECT_NEAR(d.d_dead, 2 * paper_knot_radius(r_dead, R, rmin), 1e-12);
    for (double f : {0.3, 0.6, 0.9}) {
      const double r = f * r_dead;
      const double fit = d.d_dead * std::pow(f, d.exponent);
      EXPECT_NEAR(fit, 2 * paper_knot_radius(r, R, rmin), 0.10 * fit) << r_dead << " " << r;
    }
  }
  // Hand value: r = 60, R = 125, rmin = 104.06: (20.812 − 0.1·√6243.6)·60/125 = 6.197 mm.
  EXPECT_NEAR(paper_knot_radius(60.0, 125.0, 104.06), 6.1970, 1e-3);
}

TEST(Gran1Import, BadInputsNameTheFileAndTheProblem) {
  test::TempDir dir;
  const fs::path src = test::gran1_source_dir();
  for (const char* f : {"Gran_1_pith.json", "Gran_1_radii.json", "Gran_1_knots.json"})
    fs::copy_file(src / f, dir / f);
  // Missing file.
  fs::remove(dir / "Gran_1_knots.json");
  Result<LogModel> r = import_gran1(dir.path());
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr("Gran_1_knots.json: no such file"));
  // A knot row with 8 values.
  test::write_file(dir / "Gran_1_knots.json", "[[1,2,3,4,5,6,7,8,9],[1,2,3,4,5,6,7,8]]");
  r = import_gran1(dir.path());
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr("Gran_1_knots.json: knot 1: expected 9 numbers"));
  // Not JSON.
  test::write_file(dir / "Gran_1_knots.json", "[[1,2,3");
  r = import_gran1(dir.path());
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr("Gran_1_knots.json: malformed JSON"));
  // Radii rows do not match pith rows.
  test::write_file(dir / "Gran_1_knots.json", "[]");
  test::write_file(dir / "Gran_1_radii.json", "[[1,2]]");
  r = import_gran1(dir.path());
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr("Gran_1_radii.json: expected 400 rows"));
  // Pith heights not uniformly spaced.
  test::write_file(dir / "Gran_1_pith.json", "[[0,0,0],[0,0,10],[0,0,25]]");
  r = import_gran1(dir.path());
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr("row 2: z is not uniformly spaced"));
}

}  // namespace
}  // namespace sawyer
