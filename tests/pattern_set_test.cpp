// Pattern sets (sawyer/sawing/pattern_set.h): the sawyer-pattern-set/1 file through its reader and
// writer, bad files refused with one line naming the problem, the log's class and its
// candidates, and the choice of the pattern per log (saw_log_model with a set): a thin log gets
// a smaller pattern than a thick one, the chosen one is worth the most of every candidate that
// fits, and a log that no pattern fits is refused naming the set.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "sawyer/model/log_generator.h"
#include "sawyer/sawing/pattern_set.h"
#include "sawyer/sawing/sawing_file.h"
#include "sawyer/sawing/sawing_job.h"
#include "sawyer/sawing/setup.h"
#include "sawyer/test/sawing_fixtures.h"
#include "sawyer/test/test_util.h"

using namespace sawyer;
using namespace sawyer::sawing;

namespace {

bool has(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

// A coarse grid: the choice between patterns matters here, not the last euro of each.
OptimiseOptions coarse() {
  OptimiseOptions o;
  o.rot_step_deg = 15;
  o.offset_x_max_mm = 4;
  o.offset_x_step_mm = 4;
  return o;
}

SawSetup set_setup(const std::string& set, const std::string& position = "") {
  SawNames n;
  n.pattern_set = set;
  n.position = position;
  Result<SawSetup> s = load_saw_setup(n, coarse());
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message());
  return s.value();
}

LogModel generated(double top_diameter_mm, std::uint64_t seed) {
  GeneratorOptions g;
  g.seed = seed;
  g.length_mm = 4000;
  g.top_diameter_mm = top_diameter_mm;
  g.dz_mm = 20;
  Result<LogModel> log = generate_log(g);
  EXPECT_TRUE(log.ok()) << (log.ok() ? "" : log.error().message());
  return log.value();
}

// A set of two classes with inline and preset patterns, for the round trip.
const char* kSmallSet = R"({"format": "sawyer-pattern-set/1", "name": "mill 7",
  "description": "two classes", "neighbour_classes": 0,
  "classes": [
    {"name": "small", "min_diameter_mm": 120, "max_diameter_mm": 180, "patterns": [
      {"preset": "tt", "board_count": 5, "thickness_mm": 25, "max_width_mm": 150},
      {"name": "2ex short", "kerf_mm": 2.5, "wane": {"min_length_mm": 600, "length_step_mm": 100},
       "standard_widths_mm": [75, 100, 125],
       "boards": [
         {"name": "centre 1", "u_mm": -26.25, "v_mm": 0, "thickness_mm": 50, "width_mm": 100},
         {"name": "centre 2", "u_mm": 26.25, "v_mm": 0, "thickness_mm": 50, "width_mm": 100},
         {"name": "side 1", "u_mm": 65, "v_mm": 0, "thickness_mm": 22, "width_mm": 100,
          "edged": true, "thickness_axis": "u"}]}]},
    {"min_diameter_mm": 180, "max_diameter_mm": 260, "patterns": [
      {"preset": "4ex", "name": "my 4ex", "centre_thickness_mm": 50, "side_boards_per_side": 2,
       "side_thickness_mm": 19, "wane": {"max_face_fraction": 0.2}}]}]})";

}  // namespace

TEST(PatternSet, FileRoundTrip) {
  test::TempDir dir;
  test::write_file(dir / "set.json", kSmallSet);
  const Result<PatternSet> a = read_pattern_set_file(dir / "set.json");
  ASSERT_TRUE(a.ok()) << a.error().message();
  const PatternSet& s = a.value();
  EXPECT_EQ(s.name, "mill 7");
  EXPECT_EQ(s.description, "two classes");
  EXPECT_EQ(s.neighbour_classes, 0);
  ASSERT_EQ(s.classes.size(), 2u);
  EXPECT_EQ(s.classes[0].label(), "small");
  EXPECT_EQ(s.classes[1].label(), "180-260 mm");
  // The presets are the bundled patterns' functions with the parameters given.
  const Pattern tt = through_and_through_pattern(5, 25, 150, 3);
  EXPECT_EQ(pattern_to_json(s.classes[0].patterns[0]), pattern_to_json(tt));
  CantOptions c = four_ex_options();
  c.centre_thickness_mm = 50;
  c.side_boards_per_side = 2;
  c.side_thickness_mm = 19;
  Pattern four = four_ex_pattern(c);
  four.name = "my 4ex";
  four.wane.max_face_fraction = 0.2;
  EXPECT_EQ(pattern_to_json(s.classes[1].patterns[0]), pattern_to_json(four));
  EXPECT_EQ(s.classes[0].patterns[1].kerf_mm, 2.5);
  EXPECT_EQ(s.classes[0].patterns[1].wane.min_length_mm, 600);
  EXPECT_EQ(s.classes[0].patterns[1].boards.size(), 3u);

  // Written out (every pattern whole) and read back: the same set.
  ASSERT_TRUE(write_pattern_set_file(dir / "again.json", s).ok());
  const Result<PatternSet> b = read_pattern_set_file(dir / "again.json");
  ASSERT_TRUE(b.ok()) << b.error().message();
  EXPECT_EQ(pattern_set_to_json(b.value()), pattern_set_to_json(s));
  ASSERT_EQ(b.value().classes.size(), s.classes.size());
  for (size_t i = 0; i < s.classes.size(); ++i) {
    EXPECT_EQ(b.value().classes[i].min_diameter_mm, s.classes[i].min_diameter_mm);
    EXPECT_EQ(b.value().classes[i].max_diameter_mm, s.classes[i].max_diameter_mm);
    ASSERT_EQ(b.value().classes[i].patterns.size(), s.classes[i].patterns.size());
    for (size_t k = 0; k < s.classes[i].patterns.size(); ++k)
      EXPECT_EQ(pattern_to_json(b.value().classes[i].patterns[k]),
                pattern_to_json(s.classes[i].patterns[k]));
  }
}

// The bundled set: found by name, and every class has a pattern that a log at the class's
// smallest diameter can be sawn with (a log of the class is never refused).
TEST(PatternSet, BundledNordicSetFitsEveryClassFromItsStart) {
  const Result<PatternSet> set = pattern_set_by_name("nordic");
  ASSERT_TRUE(set.ok()) << set.error().message();
  const PatternSet& s = set.value();
  EXPECT_EQ(s.name, "nordic");
  ASSERT_GE(s.classes.size(), 5u);
  bool has_4ex = false, has_2ex = false, has_tt = false;
  for (const DiameterClass& c : s.classes) {
    double smallest = 1e9;
    for (const Pattern& p : c.patterns) {
      smallest = std::min(smallest, p.required_diameter_mm());
      has_2ex = has_2ex || p.name.rfind("2ex", 0) == 0;
      has_4ex = has_4ex || p.name.rfind("4ex", 0) == 0;
      has_tt = has_tt || p.name.rfind("through-and-through", 0) == 0;
    }
    EXPECT_LE(smallest, c.min_diameter_mm) << c.label();
  }
  EXPECT_TRUE(has_2ex && has_4ex && has_tt);
  // 2ex for the small classes, 4ex only from the middle up.
  for (const Pattern& p : s.classes.front().patterns) EXPECT_NE(p.name.rfind("4ex", 0), 0u);
  EXPECT_TRUE(set_setup("nordic").pattern_set.has_value());
}

TEST(PatternSet, ClassAndCandidates) {
  const Result<PatternSet> r = pattern_set_from_json(kSmallSet);
  ASSERT_TRUE(r.ok()) << r.error().message();
  PatternSet s = r.value();
  EXPECT_EQ(s.class_of(119.9), -1);  // below the set: not a log it saws
  EXPECT_EQ(s.class_of(120), 0);
  EXPECT_EQ(s.class_of(179.9), 0);
  EXPECT_EQ(s.class_of(180), 1);
  EXPECT_EQ(s.class_of(900), 1);  // above the set: its largest class
  EXPECT_TRUE(s.candidates(100).empty());
  ASSERT_EQ(s.candidates(150).size(), 2u);  // no neighbours
  EXPECT_TRUE(s.candidates(150)[0].own_class);
  s.neighbour_classes = 1;
  const std::vector<PatternCandidate> c = s.candidates(150);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c[2].pattern->name, "my 4ex");
  EXPECT_EQ(c[2].class_index, 1);
  EXPECT_FALSE(c[2].own_class);
  // A pattern listed in two classes is one candidate.
  s.classes[1].patterns.push_back(s.classes[0].patterns[0]);
  ASSERT_TRUE(s.validate().ok()) << s.validate().error().message();
  EXPECT_EQ(s.candidates(200).size(), 3u);
  EXPECT_EQ(s.patterns().size(), 3u);
}

TEST(PatternSet, BadFilesGiveOneClearError) {
  test::TempDir dir;
  const std::string file = (dir / "bad.json").string();
  auto error_of = [&](const std::string& text) {
    test::write_file(dir / "bad.json", text);
    const Result<PatternSet> r = read_pattern_set_file(dir / "bad.json");
    EXPECT_FALSE(r.ok()) << text;
    const std::string m = r.ok() ? std::string() : r.error().message();
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    EXPECT_TRUE(has(m, file)) << m;
    return m;
  };
  const std::string head = R"({"format": "sawyer-pattern-set/1", "name": "x", )";
  const std::string tt = R"({"preset": "tt"})";
  auto one_class = [&](const std::string& cls) { return head + "\"classes\": [" + cls + "]}"; };

  std::string m = error_of(head + "\"classes\": [");
  EXPECT_TRUE(has(m, "malformed JSON")) << m;
  m = error_of(R"({"format": "sawyer-pattern/1", "boards": []})");
  EXPECT_TRUE(has(m, "format")) << m;
  m = error_of(head + "\"klasses\": []}");
  EXPECT_TRUE(has(m, "klasses: unknown key")) << m;
  m = error_of(R"({"format": "sawyer-pattern-set/1", "name": "x"})");
  EXPECT_TRUE(has(m, "pattern set 'x': classes: missing")) << m;
  m = error_of(head + "\"classes\": []}");
  EXPECT_TRUE(has(m, "pattern set 'x': has no classes")) << m;
  m = error_of(head + "\"neighbour_classes\": 7, \"classes\": []}");
  EXPECT_TRUE(has(m, "neighbour_classes: 7 is outside 0 to 2")) << m;
  m = error_of(one_class(R"({"max_diameter_mm": 200, "patterns": [)" + tt + "]}"));
  EXPECT_TRUE(has(m, "pattern set 'x', class 0: min_diameter_mm: missing")) << m;
  m = error_of(
      one_class(R"({"min_diameter_mm": 200, "max_diameter_mm": 150, "patterns": [)" + tt + "]}"));
  EXPECT_TRUE(has(m, "class 0 '200-150 mm': needs 0 <= min_diameter_mm < max_diameter_mm")) << m;
  m = error_of(one_class(R"({"min_diameter_mm": 100, "max_diameter_mm": 150, "patterns": []})"));
  EXPECT_TRUE(has(m, "class 0 '100-150 mm': has no patterns")) << m;
  m = error_of(one_class(R"({"min_diameter_mm": 100, "max_diameter_mm": 150, "patterns": [)" + tt +
                         R"(]}, {"min_diameter_mm": 160, "max_diameter_mm": 200, "patterns": [)" +
                         tt + "]}"));
  EXPECT_TRUE(has(m,
                  "pattern set 'x', class 1 '160-200 mm': starts at 160 mm, but the class "
                  "before ends at 150 mm"))
      << m;
  auto entry = [&](const std::string& p) {
    return one_class(R"({"min_diameter_mm": 100, "max_diameter_mm": 150, "patterns": [)" + p +
                     "]}");
  };
  m = error_of(entry(R"({"preset": "6ex"})"));
  EXPECT_TRUE(has(m, "pattern set 'x', class 0 '100-150 mm', pattern 0: preset: expected")) << m;
  m = error_of(entry(R"({"preset": "2ex", "centre_width": 125})"));
  EXPECT_TRUE(has(m, "pattern 0: centre_width: unknown key")) << m;
  m = error_of(entry(R"({"preset": "2ex", "centre_width_mm": "wide"})"));
  EXPECT_TRUE(has(m, "pattern 0: centre_width_mm: expected a number")) << m;
  m = error_of(entry(R"({"preset": "2ex", "centre_thickness_mm": -50})"));
  EXPECT_TRUE(has(m, "pattern 0: pattern '2ex -50x150") && has(m, "> 0")) << m;
  m = error_of(entry(R"({"preset": "tt", "board_count": 2.5})"));
  EXPECT_TRUE(has(m, "pattern 0: board_count: expected a whole number")) << m;
  m = error_of(entry(R"({"name": "p", "boards": [{"u_mm": 0, "v_mm": 0, "width_mm": 100}]})"));
  EXPECT_TRUE(has(m, "pattern 0: boards[0].thickness_mm: missing")) << m;
  m = error_of(entry(R"({"boards": [{"u_mm": 0, "v_mm": 0, "thickness_mm": 5, "width_mm": 9}]})"));
  EXPECT_TRUE(has(m, "pattern 0: has no name")) << m;
  m = error_of(entry(R"({"preset": "tt", "name": "same"}, {"preset": "2ex", "name": "same"})"));
  EXPECT_TRUE(has(m,
                  "pattern 1: 'same' is also the name of class 0's pattern 0, which saws other "
                  "boards"))
      << m;
  const Result<PatternSet> missing = read_pattern_set_file(dir / "nope.json");
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(has(missing.error().message(), "nope.json")) << missing.error().message();
}

// Sizes are refused before the classes, patterns or boards are made (the pattern reader's own
// limits hold for every pattern of a set too).
TEST(PatternSet, LimitsAreCheckedBeforeTheWork) {
  test::TempDir dir;
  auto error_of = [&](const std::string& text) {
    test::write_file(dir / "big.json", text);
    const Result<PatternSet> r = read_pattern_set_file(dir / "big.json");
    EXPECT_FALSE(r.ok());
    return r.ok() ? std::string() : r.error().message();
  };
  std::string classes;
  for (int i = 0; i <= kMaxPatternSetClasses; ++i)
    classes += std::string(i ? "," : "") + "{\"min_diameter_mm\": " + std::to_string(100 + i) +
               ", \"max_diameter_mm\": " + std::to_string(101 + i) +
               ", \"patterns\": [{\"preset\": \"tt\"}]}";
  std::string m =
      error_of(R"({"format": "sawyer-pattern-set/1", "name": "x", "classes": [)" + classes + "]}");
  EXPECT_TRUE(has(m, "has 101 classes, more than the 100 allowed")) << m;
  std::string patterns;
  for (int i = 0; i <= kMaxClassPatterns; ++i)
    patterns += std::string(i ? "," : "") +
                "{\"preset\": \"tt\", \"board_count\": " + std::to_string(i + 1) + "}";
  m = error_of(
      R"({"format": "sawyer-pattern-set/1", "name": "x", "classes": [{"min_diameter_mm": 100, "max_diameter_mm": 150, "patterns": [)" +
      patterns + "]}]}");
  EXPECT_TRUE(has(m, "patterns: has 21 patterns, more than the 20 allowed")) << m;
  m = error_of(
      R"({"format": "sawyer-pattern-set/1", "name": "x", "classes": [{"min_diameter_mm": 100, "max_diameter_mm": 150, "patterns": [{"preset": "tt", "board_count": 1000000000}]}]})");
  EXPECT_TRUE(has(m, "board_count: 1000000000 is outside 1 to 200")) << m;
  m = error_of(
      R"({"format": "sawyer-pattern-set/1", "name": "x", "classes": [{"min_diameter_mm": 100, "max_diameter_mm": 150, "patterns": [{"preset": "2ex", "side_boards_per_side": 1000000000}]}]})");
  EXPECT_TRUE(has(m, "side_boards_per_side: 1000000000 is outside 0 to 100")) << m;
}

// The choice on generated logs: the thin log's pattern fits it, the thick log's pattern is one
// the thin log could not be sawn with; each is the best of all candidates that fit (each sawn on
// its own as a single pattern gives no more), and the next best is the runner-up.
// The largest set the limits allow, one 200-board pattern repeated in every class (a name may
// recur when its boards are the same): read whole, and its candidates are that one pattern.
// (Each pattern was once compared with every earlier one: minutes for this file.)
TEST(PatternSet, TheLargestSetAllowedIsReadAndOneNameIsOneCandidate) {
  test::TempDir dir;
  const std::string entry =
      R"({"preset": "tt", "name": "x", "board_count": 200, "thickness_mm": 12})";
  std::string classes;
  for (int i = 0; i < kMaxPatternSetClasses; ++i) {
    std::string patterns;
    for (int k = 0; k < kMaxClassPatterns; ++k) patterns += (k ? "," : "") + entry;
    classes += std::string(i ? "," : "") + "{\"min_diameter_mm\": " + std::to_string(100 + 10 * i) +
               ", \"max_diameter_mm\": " + std::to_string(110 + 10 * i) + ", \"patterns\": [" +
               patterns + "]}";
  }
  test::write_file(
      dir / "big.json",
      R"({"format": "sawyer-pattern-set/1", "name": "big", "classes": [)" + classes + "]}");
  const Result<PatternSet> r = read_pattern_set_file(dir / "big.json");
  ASSERT_TRUE(r.ok()) << r.error().message();
  EXPECT_EQ(r.value().classes.size(), static_cast<size_t>(kMaxPatternSetClasses));
  EXPECT_EQ(r.value().patterns().size(), 1u);
  const std::vector<PatternCandidate> c = r.value().candidates(500.0);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].pattern->boards.size(), 200u);
}

TEST(PatternSetChoice, AThinLogGetsASmallerPatternThanAThickLog) {
  const SawSetup su = set_setup("nordic");
  const LogModel thin = generated(165, 3), thick = generated(330, 5);
  Result<SawingOutcome> a = saw_log_model(thin, su), b = saw_log_model(thick, su);
  ASSERT_TRUE(a.ok()) << a.error().message();
  ASSERT_TRUE(b.ok()) << b.error().message();
  const double thin_d = a.value().saw_log.usable_diameter_mm();
  const double thick_d = b.value().saw_log.usable_diameter_mm();
  ASSERT_LT(thin_d, thick_d);
  const Pattern& pa = a.value().pattern;
  const Pattern& pb = b.value().pattern;
  SCOPED_TRACE("thin " + std::to_string(thin_d) + " mm: " + pa.name + "; thick " +
               std::to_string(thick_d) + " mm: " + pb.name);
  EXPECT_LE(pa.required_diameter_mm(), thin_d);
  EXPECT_LE(pb.required_diameter_mm(), thick_d);
  EXPECT_GT(pb.required_diameter_mm(), thin_d);  // the thick log's pattern: too large for the thin
  EXPECT_GT(b.value().chosen_value().value, a.value().chosen_value().value);

  for (const Result<SawingOutcome>* r : {&a, &b}) {
    const SawingOutcome& out = r->value();
    ASSERT_TRUE(out.choice.has_value());
    const PatternChoice& c = *out.choice;
    EXPECT_EQ(c.set, "nordic");
    EXPECT_EQ(c.usable_diameter_mm, out.saw_log.usable_diameter_mm());
    ASSERT_GE(c.chosen, 0);
    ASSERT_GE(c.next_best, 0);
    const PatternCandidateResult& chosen = c.candidates[static_cast<size_t>(c.chosen)];
    EXPECT_EQ(chosen.name, out.pattern.name);
    EXPECT_EQ(chosen.value, out.chosen_value().value);
    EXPECT_EQ(chosen.expected_value, out.opt.best.smoothed);
    int fitting = 0;
    for (size_t i = 0; i < c.candidates.size(); ++i) {
      const PatternCandidateResult& k = c.candidates[i];
      EXPECT_EQ(k.fits, k.needed_diameter_mm <= c.usable_diameter_mm) << k.name;
      if (!k.fits) continue;
      ++fitting;
      EXPECT_LE(k.rank_value(), chosen.rank_value()) << k.name;
      if (static_cast<int>(i) != c.chosen) {
        EXPECT_LE(k.rank_value(), c.candidates[static_cast<size_t>(c.next_best)].rank_value());
      }
    }
    EXPECT_GE(fitting, 2);
    // The next best sawn on its own gives what the choice recorded.
    const PatternCandidateResult& next = c.candidates[static_cast<size_t>(c.next_best)];
    SawSetup one = su;
    one.pattern_set.reset();
    for (const Pattern* p : su.pattern_set->patterns())
      if (p->name == next.name) one.pattern = *p;
    ASSERT_EQ(one.pattern.name, next.name);
    const LogModel& log = r == &a ? thin : thick;
    Result<SawingOutcome> alone = saw_log_model(log, one);
    ASSERT_TRUE(alone.ok()) << alone.error().message();
    EXPECT_EQ(alone.value().opt.best.smoothed, next.expected_value);
    EXPECT_EQ(alone.value().chosen_value().value, next.value);
    EXPECT_FALSE(alone.value().choice.has_value());
  }
}

// At a given position the candidates are ranked by their value there.
TEST(PatternSetChoice, AtAGivenPositionTheValueThereDecides) {
  const SawSetup su = set_setup("nordic", "30,2,0");
  Result<SawingOutcome> out = saw_log_model(generated(220, 7), su);
  ASSERT_TRUE(out.ok()) << out.error().message();
  const PatternChoice& c = *out.value().choice;
  EXPECT_TRUE(c.at_given_position);
  const PatternCandidateResult& chosen = c.candidates[static_cast<size_t>(c.chosen)];
  EXPECT_FALSE(chosen.has_expected);
  EXPECT_EQ(chosen.value, out.value().given_value->value);
  for (const PatternCandidateResult& k : c.candidates) {
    if (k.fits) {
      EXPECT_LE(k.value, chosen.value) << k.name;
    }
  }
  EXPECT_TRUE(has(pattern_choice_line(c, "EUR"), "at the given position"))
      << pattern_choice_line(c, "EUR");
}

TEST(PatternSetChoice, ALogNoPatternFitsIsRefusedNamingTheSet) {
  // Below the set's smallest class.
  const LogModel small = test::cylinder_log(40.0);  // 80 mm across
  Result<SawingOutcome> r = saw_log_model(small, set_setup("nordic"));
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(has(r.error().message(), "no pattern of pattern set 'nordic' fits"))
      << r.error().message();
  EXPECT_TRUE(has(r.error().message(), "usable diameter is 80.0 mm")) << r.error().message();
  EXPECT_TRUE(has(r.error().message(), "below the set's smallest class (100-145 mm)"))
      << r.error().message();
  FitNeed need = fit_need(set_setup("nordic"), 80.0);
  EXPECT_EQ(need.pattern, "");
  EXPECT_EQ(need.needed_diameter_mm, 100.0);

  // In a class, but every candidate too large: the smallest is named.
  test::TempDir dir;
  test::write_file(dir / "big.json", R"({"format": "sawyer-pattern-set/1", "name": "big only",
    "classes": [{"min_diameter_mm": 50, "max_diameter_mm": 500, "patterns": [
      {"preset": "4ex", "centre_thickness_mm": 75, "centre_width_mm": 200},
      {"preset": "2ex", "centre_thickness_mm": 75, "centre_width_mm": 225}]}]})");
  const SawSetup su = set_setup((dir / "big.json").string());
  r = saw_log_model(test::cylinder_log(90.0), su);
  ASSERT_FALSE(r.ok());
  const std::string m = r.error().message();
  EXPECT_TRUE(has(m,
                  "log 'synthetic': no pattern of pattern set 'big only' fits: the smallest of "
                  "its candidates for class 50-500 mm, '2ex 75x225"))
      << m;
  EXPECT_TRUE(has(m, "needs a diameter of 272.1 mm, the log's usable diameter is 180.0 mm")) << m;
  need = fit_need(su, 180.0);
  EXPECT_EQ(need.pattern.rfind("2ex 75x225", 0), 0u) << need.pattern;
  EXPECT_NEAR(need.needed_diameter_mm, 272.1, 0.05);
}

// sawing.json keeps the choice and the chosen pattern whole; the run folder's line reads it back.
TEST(PatternSetChoice, SawingFileKeepsTheChoiceAndThePattern) {
  const SawSetup su = set_setup("nordic");
  const LogModel log = generated(200, 11);
  Result<SawingOutcome> out = saw_log_model(log, su);
  ASSERT_TRUE(out.ok()) << out.error().message();
  const nlohmann::ordered_json j = sawing_file_json(log, su, out.value());
  EXPECT_EQ(j["pattern"], out.value().pattern.name);
  EXPECT_EQ(j["inputs"]["pattern_set"], "nordic");
  Result<SawingRecord> back = sawing_record_from_json(j.dump(1));
  ASSERT_TRUE(back.ok()) << back.error().message();
  ASSERT_TRUE(back.value().pattern_choice.has_value());
  const PatternChoice& a = *out.value().choice;
  const PatternChoice& b = *back.value().pattern_choice;
  EXPECT_EQ(b.set, a.set);
  EXPECT_EQ(b.class_label, a.class_label);
  EXPECT_EQ(b.chosen, a.chosen);
  EXPECT_EQ(b.next_best, a.next_best);
  ASSERT_EQ(b.candidates.size(), a.candidates.size());
  for (size_t i = 0; i < a.candidates.size(); ++i) {
    EXPECT_EQ(b.candidates[i].name, a.candidates[i].name);
    EXPECT_EQ(b.candidates[i].fits, a.candidates[i].fits);
    EXPECT_EQ(b.candidates[i].value, a.candidates[i].value);
    EXPECT_EQ(b.candidates[i].expected_value, a.candidates[i].expected_value);
  }
  ASSERT_TRUE(back.value().chosen_pattern.has_value());
  EXPECT_EQ(pattern_to_json(*back.value().chosen_pattern), pattern_to_json(out.value().pattern));
  const std::string line = pattern_choice_line(b, "EUR");
  EXPECT_TRUE(has(line, "pattern '" + out.value().pattern.name + "' chosen from set 'nordic'"))
      << line;
  EXPECT_TRUE(has(line, "next best '")) << line;

  // A run folder's log: the viewer's line from sawing.json beside scan/.
  test::TempDir dir;
  std::filesystem::create_directories(dir / "run" / "scan");
  test::write_file(dir / "run" / "sawing.json", j.dump(1));
  EXPECT_EQ(run_pattern_choice_line(dir / "run" / "scan" / "log.json"),
            pattern_choice_line(a, su.prices.currency));
  EXPECT_EQ(run_pattern_choice_line(dir / "log.json"), "");
  // A bad choice block is refused naming the key.
  nlohmann::ordered_json bad = j;
  bad["pattern_choice"]["chosen"]["name"] = "nothing";
  Result<SawingRecord> r = sawing_record_from_json(bad.dump());
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(has(r.error().message(), "pattern_choice.chosen")) << r.error().message();
}

// --pattern and --pattern-set, a pattern set with options that suit only some of its patterns.
TEST(PatternSetChoice, OptionsAreCheckedAgainstEveryPatternOfTheSet) {
  test::TempDir dir;
  test::write_file(dir / "odd.json", R"({"format": "sawyer-pattern-set/1", "name": "odd",
    "classes": [{"min_diameter_mm": 50, "max_diameter_mm": 500, "patterns": [
      {"preset": "tt"},
      {"name": "one side", "boards": [{"u_mm": 40, "v_mm": 0, "thickness_mm": 25, "width_mm": 100}]}]}]})");
  SawNames n;
  n.pattern_set = (dir / "odd.json").string();
  OptimiseOptions o = coarse();
  o.rot_range_deg = 180;  // only for point-symmetric patterns
  Result<SawSetup> s = load_saw_setup(n, o);
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(has(s.error().message(), "pattern 'one side'")) << s.error().message();
}
