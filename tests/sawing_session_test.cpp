// The viewer's sawing mode without a window, now in libs/sawing (sawing_session.h): heat and
// grade colours, position parsing, sawing, valuing, placing and saving, and bad choices named.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "sawyer/model/log_json.h"
#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/sawing_session.h"
#include "sawyer/sawing/setup.h"
#include "sawyer/test/test_util.h"

namespace sawyer::sawing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

double luminance(const std::array<unsigned char, 3>& c) {
  return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

TEST(ViewerSawing, HeatColoursGetLighterWithTheValueAndClampOutside) {
  double last = -1;
  for (int i = 0; i <= 100; ++i) {
    const double l = luminance(heat_colour(i / 100.0));
    EXPECT_GT(l, last) << "t " << i / 100.0;
    last = l;
  }
  EXPECT_EQ(heat_colour(-3.0), heat_colour(0.0));
  EXPECT_EQ(heat_colour(7.0), heat_colour(1.0));
  EXPECT_EQ(heat_colour(std::nan("")), (std::array<unsigned char, 3>{128, 128, 128}));
}

TEST(ViewerSawing, GradeColoursRunFromGreenToOrangeAndRejectIsRed) {
  const auto best = grade_colour(0, 7), last = grade_colour(6, 7), reject = grade_colour(7, 7);
  EXPECT_GT(best[1], best[0]);  // green
  EXPECT_GT(last[0], last[1]);  // orange
  EXPECT_GT(reject[0], 200);    // red
  EXPECT_LT(reject[1], 100);
  EXPECT_NE(grade_colour(3, 7), best);
  EXPECT_EQ(grade_colour(-1, 7), reject);
}

TEST(ViewerSawing, PositionParsesLikeTheSawCommand) {
  Result<sawing::LogPosition> p = sawing::parse_position("20,4,-2");
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p.value().rotation_deg, 20);
  EXPECT_EQ(p.value().offset_x_mm, 4);
  EXPECT_EQ(p.value().offset_y_mm, -2);
  EXPECT_TRUE(sawing::parse_position("15").ok());
  for (const char* bad : {"", "a", "1,2,3,4", "1,,2", "1;2"})
    EXPECT_FALSE(sawing::parse_position(bad).ok()) << bad;
}

TEST(ViewerSawing, SessionSawsValuesPlacesAndSavesThePosition) {
  Result<LogModel> log = read_log_json(test::sample_log("gran1_spruce") / "log.json");
  ASSERT_TRUE(log.ok()) << log.error().message();
  Result<std::unique_ptr<SawingSession>> made =
      SawingSession::create(log.value(), {"2ex", "nordic", ""});
  ASSERT_TRUE(made.ok()) << made.error().message();
  SawingSession& s = *made.value();
  EXPECT_GT(s.horns_down_value(), 0);
  EXPECT_NEAR(s.value().value, s.horns_down_value(), 1e-9);  // starts at horns-down
  EXPECT_NEAR(s.gain_over_horns_down(), 0.0, 1e-12);

  const sawing::LogPosition pos{20.0, 4.0, -2.0};
  s.set_position(pos);
  ASSERT_FALSE(s.sawn().boards.empty());
  ASSERT_EQ(s.value().boards.size(), s.sawn().boards.size());
  double sum = 0;
  for (const sawing::BoardValue& b : s.value().boards) sum += b.value;
  EXPECT_NEAR(s.value().value, sum, 1e-9);
  EXPECT_NEAR(s.gain_over_horns_down(), s.value().value / s.horns_down_value() - 1.0, 1e-12);

  // Each board in the scanner frame: its centre is the centre of its outline at mid-height, and
  // its width and thickness run along the outline's sides.
  for (size_t i = 0; i < s.sawn().boards.size(); ++i) {
    const sawing::Board& b = s.sawn().boards[i];
    const bool along_u = b.thickness_axis == sawing::ThicknessAxis::kU;
    const double zm = 0.5 * (b.z_begin + b.z_end);
    const std::array<Vec2, 4> c =
        s.rect_in_scanner(b.u_mm, b.v_mm, along_u ? b.thickness_mm : b.width_mm,
                          along_u ? b.width_mm : b.thickness_mm, zm);
    const BoardBox rb = s.board_in_scanner(i);
    EXPECT_NEAR(0.25 * (c[0].x + c[1].x + c[2].x + c[3].x), rb.cx, 1e-6);
    EXPECT_NEAR(0.25 * (c[0].y + c[1].y + c[2].y + c[3].y), rb.cy, 1e-6);
    EXPECT_EQ(rb.width, b.width_mm);
    EXPECT_EQ(rb.thickness, b.thickness_mm);
    // The side from corner 0 to 1 runs along pattern u: the board's u when the thickness is
    // along v, its v when the thickness is along u.
    const Vec3 dir = along_u ? rb.v() : rb.u();
    const double len = std::hypot(c[1].x - c[0].x, c[1].y - c[0].y);
    EXPECT_NEAR(std::abs((c[1].x - c[0].x) * dir.x + (c[1].y - c[0].y) * dir.y), len, 1e-6);
  }
  // A drag on the section: the offset change it gives moves the pattern's outline by the drag.
  const sawing::BoardSpec& spec = s.pattern().boards.front();
  const std::array<Vec2, 4> before = s.rect_in_scanner(spec.u_mm, spec.v_mm, 50, 100, 2000);
  const Vec2 d = s.scanner_to_pattern_delta(3.0, 4.0);
  EXPECT_NEAR(std::hypot(d.x, d.y), 5.0, 1e-9);
  s.set_position({pos.rotation_deg, pos.offset_x_mm + d.x, pos.offset_y_mm + d.y});
  const std::array<Vec2, 4> after = s.rect_in_scanner(spec.u_mm, spec.v_mm, 50, 100, 2000);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(after[i].x - before[i].x, 3.0, 1e-9);
    EXPECT_NEAR(after[i].y - before[i].y, 4.0, 1e-9);
  }
  s.set_position(pos);

  test::TempDir dir;
  const fs::path out = dir / "position.json";
  ASSERT_TRUE(s.save(out, log.value().id).ok());
  Result<sawing::LogPosition> back = read_saw_position(out);
  ASSERT_TRUE(back.ok()) << back.error().message();
  EXPECT_EQ(back.value().rotation_deg, pos.rotation_deg);
  EXPECT_EQ(back.value().offset_x_mm, pos.offset_x_mm);
  EXPECT_EQ(back.value().offset_y_mm, pos.offset_y_mm);
  std::ifstream in(out);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(text, HasSubstr("\"format\": \"sawyer-sawing/1\""));
  EXPECT_THAT(text, HasSubstr("\"given_position\""));
  EXPECT_THAT(text, HasSubstr("\"limited_by\""));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1)
      << "no temporary file left";

  EXPECT_FALSE(read_saw_position(dir / "missing.json").ok());
  {
    std::ofstream bad(dir / "bad.json");
    bad << "{\"format\": \"sawyer-sawing/1\", \"horns_down\": {\"rotation_deg\": 0, "
           "\"offset_x_mm\": 0, \"offset_y_mm\": 0, \"value\": 1}, "
           "\"given_position\": {\"rotation_deg\": 1}}";
  }
  Result<sawing::LogPosition> bad = read_saw_position(dir / "bad.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.error().message(), HasSubstr("offset_x_mm"));
  // The one sawing-file reader (sawyer/sawing/sawing_file.h) wants the format tag.
  {
    std::ofstream untagged(dir / "untagged.json");
    untagged << "{\"given_position\": {\"rotation_deg\": 1, \"offset_x_mm\": 0, "
                "\"offset_y_mm\": 0, \"value\": 1}}";
  }
  Result<sawing::LogPosition> untagged = read_saw_position(dir / "untagged.json");
  ASSERT_FALSE(untagged.ok());
  EXPECT_THAT(untagged.error().message(), HasSubstr("untagged.json: format"));
}

TEST(ViewerSawing, UnknownPatternOrGradingIsAnErrorNamingIt) {
  Result<LogModel> log = read_log_json(test::sample_log("gran1_spruce") / "log.json");
  ASSERT_TRUE(log.ok());
  Result<std::unique_ptr<SawingSession>> p =
      SawingSession::create(log.value(), {"no_such.pattern.json", "nordic", ""});
  ASSERT_FALSE(p.ok());
  EXPECT_THAT(p.error().message(), HasSubstr("no_such.pattern.json"));
  Result<std::unique_ptr<SawingSession>> g =
      SawingSession::create(log.value(), {"2ex", "no_such_grading.json", ""});
  ASSERT_FALSE(g.ok());
  EXPECT_THAT(g.error().message(), HasSubstr("no_such_grading.json"));
}
}  // namespace
}  // namespace sawyer::sawing
