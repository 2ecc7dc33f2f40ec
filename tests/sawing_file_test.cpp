// sawing.json ("sawyer-sawing/1") through its one writer and its one reader
// (sawyer/sawing/sawing_file.h): what `sawyer saw` writes and what the viewer saves come back as
// they were sawn.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "sawyer/sawing/sawing_file.h"
#include "sawyer/sawing/sawing_job.h"
#include "sawyer/test/test_util.h"

using namespace sawyer;
using namespace sawyer::sawing;
using ::testing::HasSubstr;

namespace {

SawSetup setup_for(const std::string& position) {
  OptimiseOptions o;
  o.rot_step_deg = 10;  // a coarse grid: the file's contents matter here, not the optimum
  o.offset_x_max_mm = 4;
  o.offset_x_step_mm = 2;
  Result<SawSetup> s = load_saw_setup({"2ex", "nordic", "", position, ""}, o);
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message());
  return s.value();
}

void expect_boards(const std::vector<BoardRecord>& got, const SawResult& sawn, const LogValue& v,
                   const GradingRules& rules) {
  ASSERT_EQ(got.size(), sawn.boards.size());
  for (size_t i = 0; i < got.size(); ++i) {
    const Board& b = sawn.boards[i];
    EXPECT_EQ(got[i].name, b.name);
    EXPECT_EQ(got[i].width_mm, b.width_mm);
    EXPECT_EQ(got[i].z_begin_mm, b.z_begin);
    EXPECT_EQ(got[i].z_end_mm, b.z_end);
    EXPECT_EQ(got[i].volume_m3, b.volume_m3);
    EXPECT_EQ(got[i].grade, rules.grade_name(v.boards[i].grade.grade));
    EXPECT_EQ(got[i].value, v.boards[i].value);
    EXPECT_NEAR(got[i].offcut_begin_mm, b.z_begin - b.sawn_begin, 1e-9);
    EXPECT_NEAR(got[i].offcut_end_mm, b.sawn_end - b.z_end, 1e-9);
  }
}

}  // namespace

TEST(SawingFile, WhatSawWritesReadsBackAsItWasSawn) {
  const LogModel& log = test::sample_model("gran1_spruce");
  for (const std::string position : {"", "30,2,0"}) {
    SCOPED_TRACE("position '" + position + "'");
    const SawSetup su = setup_for(position);
    Result<SawingOutcome> out = saw_log_model(log, su);
    ASSERT_TRUE(out.ok()) << out.error().message();
    const OptimiseResult& r = out.value().opt;
    Result<SawingRecord> back =
        sawing_record_from_json(sawing_file_json(log, su, out.value()).dump(1));
    ASSERT_TRUE(back.ok()) << back.error().message();
    const SawingRecord& s = back.value();
    EXPECT_EQ(s.log_id, log.id);
    EXPECT_EQ(s.pattern, su.pattern.name);
    EXPECT_TRUE(s.best.present && s.horns_down.present && s.horns_up.present);
    EXPECT_EQ(s.best.pos.rotation_deg, r.best.pos.rotation_deg);
    EXPECT_EQ(s.best.pos.offset_x_mm, r.best.pos.offset_x_mm);
    EXPECT_EQ(s.best.value, r.best.value);
    EXPECT_EQ(s.best.smoothed_value, r.best.smoothed);
    EXPECT_EQ(s.horns_down.value, r.horns_down.value);
    EXPECT_EQ(s.gain_over_horns_down, r.gain_over_horns_down);
    EXPECT_TRUE(s.best.has_scanner);
    EXPECT_EQ(s.bow.present, true);
    EXPECT_EQ(s.bow.straight, out.value().saw_log.bow().straight);
    EXPECT_EQ(s.surface.value, r.value);
    EXPECT_EQ(s.surface.rotations_deg, r.rotations_deg);
    EXPECT_EQ(s.chosen_given, !position.empty());
    if (position.empty()) {
      EXPECT_EQ(s.chosen.pos.rotation_deg, r.best.pos.rotation_deg);
      expect_boards(s.boards, out.value().best_sawn, out.value().best_value, su.rules);
    } else {
      EXPECT_EQ(s.chosen.pos.rotation_deg, 30.0);
      EXPECT_EQ(s.chosen.pos.offset_x_mm, 2.0);
      expect_boards(s.boards, *out.value().given_sawn, *out.value().given_value, su.rules);
    }
  }
}

TEST(SawingFile, APositionTheViewerSavesReadsBackWithItsBoards) {
  const LogModel& log = test::sample_model("gran1_spruce");
  const SawSetup su = setup_for("");
  const SawLog saw_log(log);
  const LogPosition pos{42.0, -3.0, 1.0};
  const SawResult sawn = saw_for_sale(saw_log, su.pattern, pos, su.rules, su.prices);
  const LogValue value = value_of(sawn, su.rules, su.prices);
  SavedPosition p;
  p.log_id = log.id;
  p.pattern = &su.pattern;
  p.rules = &su.rules;
  p.prices = &su.prices;
  p.horns_down_value = 123.5;
  p.pos = pos;
  p.sawn = &sawn;
  p.value = &value;
  p.gain_over_horns_down = value.value / 123.5 - 1;
  Result<SawingRecord> back = sawing_record_from_json(position_file_json(p).dump());
  ASSERT_TRUE(back.ok()) << back.error().message();
  const SawingRecord& s = back.value();
  EXPECT_FALSE(s.best.present);  // a saved position holds no optimiser results
  EXPECT_TRUE(s.chosen_given);
  EXPECT_EQ(s.chosen.pos.rotation_deg, 42.0);
  EXPECT_EQ(s.chosen.pos.offset_x_mm, -3.0);
  EXPECT_EQ(s.chosen.pos.offset_y_mm, 1.0);
  EXPECT_EQ(s.chosen.value, value.value);
  EXPECT_EQ(s.horns_down.value, 123.5);
  expect_boards(s.boards, sawn, value, su.rules);
}

TEST(SawingFile, ABadFileIsRefusedNamingTheKey) {
  auto message = [](const std::string& text) {
    Result<SawingRecord> r = sawing_record_from_json(text);
    return r.ok() ? std::string("accepted") : r.error().message();
  };
  EXPECT_THAT(message("[1, 2"), HasSubstr("not valid JSON"));
  EXPECT_THAT(message("{\"format\": \"sawyer-log/1\"}"), HasSubstr("format"));
  EXPECT_THAT(message("{\"format\": \"sawyer-sawing/1\"}"), HasSubstr("horns_down: missing"));
  const std::string pos =
      "{\"rotation_deg\": 0, \"offset_x_mm\": 0, \"offset_y_mm\": 0, "
      "\"value\": 1}";
  EXPECT_THAT(message("{\"format\": \"sawyer-sawing/1\", \"horns_down\": " + pos +
                      ", \"best\": " + pos + ", \"horns_up\": " + pos + "}"),
              HasSubstr("boards: missing"));
  EXPECT_THAT(message("{\"format\": \"sawyer-sawing/1\", \"horns_down\": " + pos + ", \"best\": " +
                      pos + ", \"horns_up\": " + pos + ", \"boards\": [{\"name\": \"a\"}]}"),
              HasSubstr("boards[0].thickness_mm: missing"));
  Result<SawingRecord> missing = read_sawing_file("/nonexistent/sawing.json");
  ASSERT_FALSE(missing.ok());
  EXPECT_THAT(missing.error().message(), HasSubstr("/nonexistent/sawing.json: missing"));
}

// The claim under the scan's uncertainty (OptimiseResult::claim) is written only when the values
// were drawn, reads back as written, and a range that does not hold its claim is refused.
TEST(SawingFile, TheClaimWithItsRangeReadsBackAndABrokenRangeIsRefused) {
  const LogModel& log = test::sample_model("gran1_spruce");
  const SawSetup su = setup_for("");
  Result<SawingOutcome> out = saw_log_model(log, su);
  ASSERT_TRUE(out.ok()) << out.error().message();
  SawingOutcome o = out.value();
  Result<SawingRecord> plain = sawing_record_from_json(sawing_file_json(log, su, o).dump());
  ASSERT_TRUE(plain.ok()) << plain.error().message();
  EXPECT_FALSE(plain.value().claim.has_value());  // no draws, no claim range

  o.opt.claim = {0.12, 0.081, 0.153, 5};
  nlohmann::ordered_json j = sawing_file_json(log, su, o);
  Result<SawingRecord> back = sawing_record_from_json(j.dump());
  ASSERT_TRUE(back.ok()) << back.error().message();
  ASSERT_TRUE(back.value().claim.has_value());
  EXPECT_EQ(back.value().claim->gain, 0.12);
  EXPECT_EQ(back.value().claim->low, 0.081);
  EXPECT_EQ(back.value().claim->high, 0.153);
  EXPECT_EQ(back.value().claim->groups, 5);
  EXPECT_EQ(claim_text(*back.value().claim), "+12.0 % (90 % range +8.1 to +15.3 %)");

  j["claim"]["low"] = 0.2;  // above the claim
  Result<SawingRecord> bad = sawing_record_from_json(j.dump());
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.error().message(), HasSubstr("claim"));
  j["claim"]["low"] = "low";
  bad = sawing_record_from_json(j.dump());
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.error().message(), HasSubstr("claim.low"));
}
