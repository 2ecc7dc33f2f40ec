// Board grading from rule tables and board value from price tables, on synthetic logs whose
// knots cross the board sides at known places and sizes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>

#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/value.h"
#include "sawyer/test/sawing_fixtures.h"
#include "sawyer/test/test_util.h"

using namespace sawyer;
using namespace sawyer::sawing;

namespace {

using test::cylinder_log;

// Straight horizontal knot along +x at height z0: d(r) = d_dead·r/r_dead up to r_dead, then
// d_dead (dead).
Knot knot_along_x(int id, double z0, double r_dead, double d_dead) {
  return test::straight_knot(id, z0, 0.0, r_dead, d_dead);
}

// One board centred on the pith, thickness along u: a knot along +x crosses face+ at r = t/2.
Pattern centred_board(double thickness, double width) {
  return test::single_board_pattern(0, 0, thickness, width);
}

GradingRules rules_from(const std::string& json) {
  Result<GradingRules> r = grading_from_json(json);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message());
  return r.ok() ? r.value() : GradingRules{};
}

// A: sound ≤ `sound_a`, dead ≤ 10 on faces; B: sound ≤ 40, dead ≤ 30; C: anything.
std::string three_grades(double sound_a, double per_width_a = 0.0) {
  return R"({"format": "sawyer-grading/1", "name": "t", "grades": [
    {"name": "A", "face": {"sound_knot": {"mm": )" +
         std::to_string(sound_a) + R"(, "per_width": )" + std::to_string(per_width_a) +
         R"(}, "dead_knot": {"mm": 10}}},
    {"name": "B", "face": {"sound_knot": {"mm": 40}, "dead_knot": {"mm": 30}}},
    {"name": "C"}]})";
}

Board one_board(const LogModel& log, const Pattern& p) {
  const SawLog saw_log(log);
  const SawResult r = saw(saw_log, p, {});
  EXPECT_EQ(r.boards.size(), 1u);
  return r.boards.empty() ? Board{} : r.boards[0];
}

}  // namespace

TEST(Grading, KnotOnAFaceAtALimitGradesOnBothSidesOfIt) {
  LogModel log = cylinder_log(200.0);
  log.knots.push_back(knot_along_x(3, 1500.0, 60.0, 60.0));  // d(20) = 20 mm, sound
  const Board b = one_board(log, centred_board(40.0, 150.0));
  ASSERT_EQ(b.knots.size(), 1u);
  EXPECT_EQ(b.knots[0].side, Side::kFacePlus);
  EXPECT_NEAR(b.knots[0].width_mm, 20.0, 1e-6);
  EXPECT_FALSE(b.knots[0].dead);

  const GradingRules above = rules_from(three_grades(20.01));
  const BoardGrade ga = grade_board(b, above);
  EXPECT_EQ(above.grade_name(ga.grade), "A");
  EXPECT_EQ(ga.limit.kind, LimitKind::kNone);
  EXPECT_EQ(describe(ga.limit, above), "none");

  const GradingRules below = rules_from(three_grades(19.99));
  const BoardGrade gb = grade_board(b, below);
  EXPECT_EQ(below.grade_name(gb.grade), "B");
  EXPECT_EQ(gb.limit.kind, LimitKind::kSoundKnot);
  EXPECT_EQ(gb.limit.side, Side::kFacePlus);
  EXPECT_NEAR(gb.limit.measured, 20.0, 1e-6);
  EXPECT_NEAR(gb.limit.along_mm, 1500.0 - b.z_begin, 1e-6);
  char along[16];
  std::snprintf(along, sizeof along, "%.2f", (1500.0 - b.z_begin) * 1e-3);
  EXPECT_EQ(describe(gb.limit, below),
            "sound knot 20.0 mm on face+ at " + std::string(along) + " m > 20.0 mm allowed in A");
}

TEST(Grading, LimitsScaleWithBoardWidth) {
  LogModel log = cylinder_log(200.0);
  log.knots.push_back(knot_along_x(3, 1500.0, 60.0, 60.0));       // 20 mm on face+
  const GradingRules rules = rules_from(three_grades(0.0, 0.2));  // A: sound ≤ 0.2 × width
  // Width 150: 30 mm allowed; width 75: 15 mm.
  EXPECT_EQ(grade_board(one_board(log, centred_board(40.0, 150.0)), rules).grade, 0);
  const BoardGrade narrow = grade_board(one_board(log, centred_board(40.0, 75.0)), rules);
  EXPECT_EQ(narrow.grade, 1);
  EXPECT_NEAR(narrow.limit.allowed, 15.0, 1e-9);
}

TEST(Grading, DeadAndSoundKnotsOfTheSameSizeGradeDifferently) {
  const GradingRules rules = rules_from(three_grades(25.0));  // A: sound ≤ 25, dead ≤ 10
  LogModel sound = cylinder_log(200.0);
  sound.knots.push_back(knot_along_x(1, 1500.0, 60.0, 60.0));  // 20 mm sound at r = 20
  LogModel dead = cylinder_log(200.0);
  dead.knots.push_back(knot_along_x(1, 1500.0, 10.0, 20.0));  // 20 mm dead (r > r_dead = 10)
  const Board bs = one_board(sound, centred_board(40.0, 150.0));
  const Board bd = one_board(dead, centred_board(40.0, 150.0));
  ASSERT_EQ(bd.knots.size(), 1u);
  EXPECT_TRUE(bd.knots[0].dead);
  EXPECT_NEAR(bd.knots[0].width_mm, bs.knots[0].width_mm, 1e-6);
  EXPECT_EQ(grade_board(bs, rules).grade, 0);
  const BoardGrade gd = grade_board(bd, rules);
  EXPECT_EQ(gd.grade, 1);
  EXPECT_EQ(gd.limit.kind, LimitKind::kDeadKnot);
  EXPECT_NE(describe(gd.limit, rules).find("dead knot 20.0 mm on face+"), std::string::npos);
}

TEST(Grading, KnotCountsPerMetre) {
  LogModel log = cylinder_log(200.0);
  for (int i = 0; i < 4; ++i) log.knots.push_back(knot_along_x(i, 400.0 + 700.0 * i, 60, 10));
  const Board b = one_board(log, centred_board(40.0, 150.0));
  ASSERT_EQ(b.knots.size(), 4u);
  // 1 knot per metre on a 3 m board allows 3: one too many.
  const GradingRules rules = rules_from(R"({"format": "sawyer-grading/1", "grades": [
      {"name": "A", "face": {"knots_per_m": 1}}, {"name": "B"}]})");
  const BoardGrade g = grade_board(b, rules);
  EXPECT_EQ(g.grade, 1);
  EXPECT_EQ(g.limit.kind, LimitKind::kKnotCount);
  EXPECT_EQ(describe(g.limit, rules), "4 knots on face+ > 3 allowed in A");
}

TEST(Grading, ClearLogGradesBestOnEveryBoard) {
  for (const char* file :
       {"data/grading/nordic_appearance.json", "data/grading/gost_8486_like.json"}) {
    SCOPED_TRACE(file);
    Result<GradingRules> rules = read_grading_file(test::source_dir() / file);
    ASSERT_TRUE(rules.ok()) << rules.error().message();
    const LogModel log = cylinder_log(200.0);
    const SawResult r = saw(SawLog(log), two_ex_pattern({}), {});
    ASSERT_EQ(r.boards.size(), 4u);
    for (const Board& b : r.boards) EXPECT_EQ(grade_board(b, rules.value()).grade, 0) << b.name;
  }
}

TEST(Grading, BundledFilesReadAndPricesCoverTheirGrades) {
  Result<PriceTable> prices =
      read_price_file(test::source_dir() / "data/prices/example_prices.json");
  ASSERT_TRUE(prices.ok()) << prices.error().message();
  for (const char* file :
       {"data/grading/nordic_appearance.json", "data/grading/gost_8486_like.json"}) {
    Result<GradingRules> rules = read_grading_file(test::source_dir() / file);
    ASSERT_TRUE(rules.ok()) << rules.error().message();
    EXPECT_TRUE(prices.value().check_covers(rules.value()).ok()) << file;
  }
  EXPECT_EQ(read_grading_file(test::source_dir() / "data/grading/nordic_appearance.json")
                .value()
                .grades.size(),
            7u);
}

TEST(Grading, BadRuleFilesNameTheKey) {
  auto msg = [](const std::string& json) {
    Result<GradingRules> r = grading_from_json(json);
    return r.ok() ? std::string("ok") : r.error().message();
  };
  EXPECT_EQ(msg(R"({"grades": []})").rfind("format", 0), 0u);
  EXPECT_EQ(msg(R"({"format": "sawyer-grading/1", "grades": []})"), "grades: no grade given");
  EXPECT_EQ(
      msg(R"({"format": "sawyer-grading/1", "grades": [{"name": "A", "face": {"sound_knot": {"mm": -1}}}]})"),
      "grades[0].face.sound_knot.mm: expected a finite number ≥ 0");
  EXPECT_EQ(
      msg(R"({"format": "sawyer-grading/1", "grades": [{"name": "A", "face": {"knot": 1}}]})"),
      "grades[0].face.knot: unknown key");
  EXPECT_EQ(msg(R"({"format": "sawyer-grading/1", "grades": [{"name": "A"}, {"name": "A"}]})"),
            "grades[1].name: 'A' twice");
  Result<PriceTable> p =
      prices_from_json(R"({"format": "sawyer-prices/1", "default": {"A": "x"}})");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().message(), "default.A: expected a price ≥ 0");
}

TEST(Value, BoardValueIsVolumeTimesPriceForItsGradeAndSize) {
  LogModel log = cylinder_log(200.0);
  log.knots.push_back(knot_along_x(3, 1500.0, 60.0, 60.0));
  const SawResult r = saw(SawLog(log), centred_board(40.0, 150.0), {});
  const GradingRules rules = rules_from(three_grades(19.0));  // the 20 mm knot: B
  Result<PriceTable> prices = prices_from_json(R"({"format": "sawyer-prices/1",
      "default": {"A": 500, "B": 300, "C": 100},
      "dimensions": [{"thickness_mm": 150, "width_mm": 40, "prices": {"B": 320}}]})");
  ASSERT_TRUE(prices.ok()) << prices.error().message();
  const LogValue v = value_of(r, rules, prices.value());
  ASSERT_EQ(v.boards.size(), 1u);
  EXPECT_EQ(v.boards[0].grade.grade, 1);
  EXPECT_DOUBLE_EQ(v.boards[0].price_per_m3, 320.0);  // dimension matched in either order
  EXPECT_NEAR(v.value, r.boards[0].volume_m3 * 320.0, 1e-9);
  EXPECT_FALSE(prices.value()
                   .check_covers(rules_from(R"({"format": "sawyer-grading/1",
      "grades": [{"name": "X"}]})"))
                   .ok());
}

// The readers of outside files answer every damaged file with a value or an Error, never a crash:
// each bundled file cut short at every byte, and with every byte replaced by a few others.
TEST(Grading, DamagedFilesGiveAnErrorNotACrash) {
  for (const char* file : {"data/grading/nordic_appearance.json",
                           "data/grading/gost_8486_like.json", "data/prices/example_prices.json"}) {
    std::ifstream in(test::source_dir() / file);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_FALSE(text.empty()) << file;
    const bool prices = std::string(file).find("prices") != std::string::npos;
    auto parse = [&](const std::string& t) {
      if (prices) return prices_from_json(t).ok();
      return grading_from_json(t).ok();
    };
    EXPECT_TRUE(parse(text)) << file;
    for (size_t n = 0; n < text.size(); n += 7) EXPECT_FALSE(parse(text.substr(0, n))) << n;
    for (size_t i = 0; i < text.size(); i += 3)
      for (char c : {'-', '9', '"', '{', 'x'}) {
        std::string t = text;
        t[i] = c;
        (void)parse(t);
      }
  }
  // A number too large for a double (found by the fuzz target fuzz_sawing_files: the parser's
  // out-of-range exception was not caught) is an error naming the problem, in all three readers.
  const std::string huge = R"({"format": "sawyer-prices/1", "default": {"A": 1e99999}})";
  auto message = [](const auto& result) {
    return result.ok() ? std::string() : result.error().message();
  };
  for (const std::string& m :
       {message(prices_from_json(huge)), message(grading_from_json("[1e99999]")),
        message(pattern_from_json("[1e99999]"))})
    EXPECT_NE(m.find("out of range"), std::string::npos) << m;
}

// Cross-cutting to value (issue 21, item 5): a dead knot 400 mm from one end of a 3 m board
// keeps it in B; cut 600 mm shorter (two 300 mm steps) the piece is A and, at A's price, worth
// more. Without length steps in the price list the board is sold as sawn.
TEST(Value, ABoardWithADeadKnotNearOneEndIsCrossCutAndWorthMore) {
  const GradingRules rules = rules_from(three_grades(25.0));  // A: dead ≤ 10; B: dead ≤ 30
  LogModel log = cylinder_log(200.0, 3000.0);
  log.knots.push_back(knot_along_x(1, 400.0, 10.0, 20.0));  // 20 mm dead on face+
  const SawLog saw_log(log);
  const Pattern p = centred_board(40.0, 150.0);
  const std::string json =
      R"({"format": "sawyer-prices/1", "default": {"A": 500, "B": 300, "C": 100},
      "lengths": {"step_mm": 300, "min_mm": 1800}})";
  Result<PriceTable> prices = prices_from_json(json);
  ASSERT_TRUE(prices.ok()) << prices.error().message();
  EXPECT_EQ(prices.value().length_step_mm, 300.0);
  EXPECT_EQ(prices.value().min_length_mm, 1800.0);

  const SawResult sawn = saw(saw_log, p, {});
  ASSERT_EQ(sawn.boards.size(), 1u);
  ASSERT_EQ(sawn.boards[0].knots.size(), 1u);
  const LogValue before = value_of(sawn, rules, prices.value());
  EXPECT_EQ(rules.grade_name(before.boards[0].grade.grade), "B");

  SawResult cut = sawn;
  trim_to_value(cut, rules, prices.value());
  const Board& b = cut.boards[0];
  ASSERT_TRUE(b.trimmed());
  EXPECT_TRUE(b.knots.empty());
  EXPECT_NEAR(b.z_begin - b.sawn_begin, 600.0, 1e-9);  // past the knot at 400 mm, in two steps
  EXPECT_NEAR(b.sawn_end, b.z_end, 1e-9);
  EXPECT_NEAR(b.volume_m3, sawn.boards[0].volume_m3 * b.length_mm() / sawn.boards[0].length_mm(),
              1e-9);  // a cylinder wide enough for no wane: volume goes with length
  EXPECT_NEAR(cut.volume_m3, b.volume_m3, 1e-12);
  const LogValue after = value_of(cut, rules, prices.value());
  EXPECT_EQ(rules.grade_name(after.boards[0].grade.grade), "A");
  EXPECT_GT(after.value, before.value);
  EXPECT_NEAR(after.value, b.volume_m3 * 500.0, 1e-9);

  // The same knot in the middle: any piece without it is under the minimum length; no cut.
  LogModel mid = cylinder_log(200.0, 3000.0);
  mid.knots.push_back(knot_along_x(1, 1500.0, 10.0, 20.0));
  const SawLog mid_log(mid);
  SawResult m = saw(mid_log, p, {});
  trim_to_value(m, rules, prices.value());
  ASSERT_EQ(m.boards.size(), 1u);
  EXPECT_FALSE(m.boards[0].trimmed());

  // A cheap A: the shorter A piece is worth less than the whole B board; no cut.
  Result<PriceTable> flat = prices_from_json(R"({"format": "sawyer-prices/1",
      "default": {"A": 320, "B": 300, "C": 100}, "lengths": {"step_mm": 300}})");
  ASSERT_TRUE(flat.ok());
  SawResult f = sawn;
  trim_to_value(f, rules, flat.value());
  EXPECT_FALSE(f.boards[0].trimmed());

  // No length steps: sold as sawn.
  Result<PriceTable> none = prices_from_json(R"({"format": "sawyer-prices/1",
      "default": {"A": 500, "B": 300, "C": 100}})");
  ASSERT_TRUE(none.ok());
  SawResult n = sawn;
  trim_to_value(n, rules, none.value());
  EXPECT_FALSE(n.boards[0].trimmed());

  // A bad length is refused, naming the key.
  Result<PriceTable> bad = prices_from_json(R"({"format": "sawyer-prices/1",
      "default": {"A": 500}, "lengths": {"step_mm": -300}})");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message().find("lengths.step_mm"), std::string::npos)
      << bad.error().message();
  // So is a step so short that every board would be millions of candidate pieces.
  Result<PriceTable> tiny = prices_from_json(R"({"format": "sawyer-prices/1",
      "default": {"A": 500}, "lengths": {"step_mm": 0.5}})");
  ASSERT_FALSE(tiny.ok());
  EXPECT_NE(tiny.error().message().find("lengths.step_mm: a step of 0.5"), std::string::npos)
      << tiny.error().message();
}

namespace {

KnotOnSide knot_on(int id, Side side, double along_mm, double width_mm, bool dead) {
  KnotOnSide k;
  k.knot = id;
  k.knot_id = id;
  k.side = side;
  k.along_mm = along_mm;
  k.z_mm = 1000.0 + along_mm;
  k.across_mm = 12.0;
  k.diameter_mm = k.minor_mm = k.major_mm = k.width_mm = width_mm;
  k.dead = dead;
  return k;
}

}  // namespace

// A hand-built 40 × 150 board, 3 m long, and rules whose limits the knots sit on either side of.
TEST(Grading, LimitingKnotsAreTheKnotsThatBreakTheGradeAbove) {
  const GradingRules rules = rules_from(R"({"format": "sawyer-grading/1", "min_knot_mm": 5,
    "grades": [
      {"name": "A", "face": {"sound_knot": {"mm": 25}, "dead_knot": {"mm": 10}},
                    "edge": {"dead_knot": {"mm": 2}}},
      {"name": "B", "face": {"sound_knot": {"mm": 40}, "dead_knot": {"mm": 30}}},
      {"name": "C"}]})");
  Board b;
  b.name = "centre 1";
  b.thickness_mm = 40;
  b.width_mm = 150;
  b.z_begin = 1000;
  b.z_end = 4000;
  b.knots = {knot_on(5, Side::kFacePlus, 500, 30, false),   // over A's 25 mm sound
             knot_on(7, Side::kFaceMinus, 2410, 20, true),  // over A's 10 mm dead
             knot_on(9, Side::kFacePlus, 1200, 12, false),  // within A
             knot_on(11, Side::kEdgeMinus, 800, 4, true),   // under min_knot_mm: not graded
             knot_on(13, Side::kEdgePlus, 1900, 6, true)};  // over A's 2 mm dead on edges
  const BoardGrade g = grade_board(b, rules);
  ASSERT_EQ(rules.grade_name(g.grade), "B");

  const std::vector<LimitingKnot> lim = limiting_knots(b, rules, g.grade);
  ASSERT_EQ(lim.size(), 3u);
  // Largest excess first: 20 − 10, 30 − 25, 6 − 2.
  EXPECT_EQ(lim[0].knot_id, 7);
  EXPECT_EQ(lim[1].knot_id, 5);
  EXPECT_EQ(lim[2].knot_id, 13);
  EXPECT_EQ(lim[0].index, 1);
  EXPECT_TRUE(lim[0].dead);
  EXPECT_EQ(lim[0].rule, LimitKind::kDeadKnot);
  EXPECT_EQ(lim[0].side, Side::kFaceMinus);
  EXPECT_NEAR(lim[0].along_mm, 2410, 1e-9);
  EXPECT_NEAR(lim[0].across_mm, 12, 1e-9);
  EXPECT_NEAR(lim[0].allowed_mm, 10, 1e-9);
  EXPECT_EQ(lim[1].rule, LimitKind::kSoundKnot);
  EXPECT_NEAR(lim[1].allowed_mm, 25, 1e-9);
  EXPECT_EQ(rules.grade_name(lim[0].grade), "A");
  EXPECT_EQ(describe(lim[0], rules),
            "knot 7, dead, 20 mm on face- at 2.41 m: over 10 mm allowed in A");
  EXPECT_EQ(describe(lim[1], rules),
            "knot 5, sound, 30 mm on face+ at 0.50 m: over 25 mm allowed in A");

  // Without them the board makes the grade above; with any one of them back it does not.
  Board clear = b;
  clear.knots.clear();
  for (size_t i = 0; i < b.knots.size(); ++i)
    if (std::none_of(lim.begin(), lim.end(),
                     [&](const LimitingKnot& l) { return l.index == int(i); }))
      clear.knots.push_back(b.knots[i]);
  EXPECT_EQ(rules.grade_name(grade_board(clear, rules).grade), "A");
  for (const LimitingKnot& l : lim) {
    Board one = clear;
    one.knots.push_back(b.knots[l.index]);
    EXPECT_EQ(rules.grade_name(grade_board(one, rules).grade), "B") << describe(l, rules);
  }
  // The best grade has nothing above it; a size that prints equal to its limit keeps a decimal.
  EXPECT_TRUE(limiting_knots(clear, rules, 0).empty());
  Board close = b;
  close.knots = {knot_on(21, Side::kFacePlus, 100, 25.3, false)};
  const std::vector<LimitingKnot> l2 =
      limiting_knots(close, rules, grade_board(close, rules).grade);
  ASSERT_EQ(l2.size(), 1u);
  EXPECT_EQ(describe(l2[0], rules),
            "knot 21, sound, 25.3 mm on face+ at 0.10 m: over 25.0 mm allowed in A");
}
