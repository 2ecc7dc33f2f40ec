// The sawing file, "sawyer-sawing/1" (docs/sawing.md, docs/formats.md): its one writer and its
// one reader. `sawyer saw` and `sawyer run` write a whole file (sawing_file_json: the options, the
// best, horns-down and horns-up positions, the ranked positions, the boards at the chosen
// position and the value surface); the viewer saves one position with its boards
// (position_file_json). The reader gives both back as a SawingRecord: the report reads a run's
// sawing.json with it, the viewer a saved position.
//
//   Result<SawingRecord> s = read_sawing_file("out/sawing.json");
//   if (!s) { std::cerr << s.error().message() << "\n"; ... }  // names the file and the key
//   const LogPosition& p = s.value().chosen.pos;
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/optimise.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/sawing_job.h"
#include "sawyer/sawing/value.h"

namespace sawyer::sawing {

inline constexpr const char* kSawingFormatTag = "sawyer-sawing/1";

// ---- writing ----

// The whole file of `sawyer saw` / `sawyer run` for the outcome of a sawing job.
nlohmann::ordered_json sawing_file_json(const LogModel& log, const SawSetup& setup,
                                        const SawingOutcome& out);

// One position as the viewer saves it: horns-down's value, the position, its value and gain over
// horns-down, and its boards (without their knots and wane).
struct SavedPosition {
  std::string log_id;
  const Pattern* pattern = nullptr;
  const GradingRules* rules = nullptr;
  const PriceTable* prices = nullptr;
  double horns_down_value = 0;
  LogPosition pos;
  const SawResult* sawn = nullptr;
  const LogValue* value = nullptr;
  double gain_over_horns_down = 0;
};
nlohmann::ordered_json position_file_json(const SavedPosition& p);

// ---- reading ----

// A log position with its value (currency) at the position and, where the optimiser gave one,
// its expected value under the positioning error.
struct PositionValue {
  bool present = false;  // the file holds this position
  LogPosition pos;
  double value = 0;
  double smoothed_value = 0;
  bool has_smoothed = false;
  // The same position in the scanner frame ("scanner"; absent in older files): the turn from
  // the log's orientation in the scanner and the pattern centre (x, y, z) at the log's two ends.
  bool has_scanner = false;
  double turn_deg = 0;
  std::array<Vec3, 2> centre_at_ends{};
};

// The log's bow as the sawing file states it ("bow"; absent in older files).
struct BowRecord {
  bool present = false;
  double arc_sagitta_mm = 0, chord_sweep_mm = 0, min_bow_mm = 0;
  bool straight = false;
};

// One board of sawing.json at the chosen position.
struct BoardRecord {
  std::string name;
  double thickness_mm = 0, width_mm = 0;
  ThicknessAxis thickness_axis = ThicknessAxis::kU;
  double u_mm = 0, v_mm = 0;            // centre in the pattern frame
  double z_begin_mm = 0, z_end_mm = 0;  // trimmed, log frame
  double volume_m3 = 0;
  std::string grade, limited_by;
  double price_per_m3 = 0, value = 0;
  int knots = 0, dead_knots = 0;  // knot crossings on its long sides (when sawing.json lists them)
  double max_wane_mm = 0;         // largest wane over its sides
  // Cross-cut to value ("offcuts_mm"): the pieces cut off its sawn length at z_begin and z_end.
  double offcut_begin_mm = 0, offcut_end_mm = 0;
  double length_mm() const { return z_end_mm - z_begin_mm; }
  // The board as the sawing model describes it (its box; grade and value stay here), as pattern
  // board `spec`: what the report, the renderer and the export draw from a run's sawing.json.
  Board board(int spec) const;
  // limited_by, and the offcuts where the board was cross-cut ("…; cross-cut, 0.60 m off at z 0.00
  // m").
  std::string limit_and_offcuts() const;
};

// The optimiser's value grid, flat index (rotation × n_x + x) × n_y + y.
struct ValueSurface {
  std::vector<double> rotations_deg, offsets_x_mm, offsets_y_mm;
  std::vector<double> value, smoothed_value;
  bool empty() const { return value.empty(); }
};

// One line for summaries, the report and the viewer: "pattern '2ex 63x150 + 2×25x100 sides' chosen
// from set 'nordic' (class 195-225 mm, usable diameter 202.0 mm), expected 123.45 EUR; next best
// '4ex 38x100 + 2×22x100 sides', expected 110.20 EUR (-10.8 %); 5 candidates, 4 fit". Values at
// the given position ("at the given position 120.00 EUR") when the choice was made there.
std::string pattern_choice_line(const PatternChoice& c, const std::string& currency);
// Candidate i of the choice in a few words for run.json and report.json: name, class, value and
// expected_value (when the choice was made on expected values); null for i < 0 (no next best).
nlohmann::ordered_json pattern_candidate_value_json(const PatternChoice& c, int i);

// For a log.json in a run folder (<run>/scan/log.json): the run's pattern choice as
// pattern_choice_line writes it, from <run>/sawing.json; "" when there is no such file, it
// cannot be read, or its pattern was not chosen from a set. What the viewer shows of the run.
std::string run_pattern_choice_line(const std::filesystem::path& log_json);

// sawing.json.
struct SawingRecord {
  std::string log_id, pattern, grading, prices, currency;
  // How the pattern was chosen from a set ("pattern_choice"; absent when one pattern was given),
  // and the chosen pattern itself ("pattern_choice.pattern", as a sawyer-pattern/1 file holds
  // it), so that readers can saw its boards again without the set.
  std::optional<PatternChoice> pattern_choice;
  std::optional<Pattern> chosen_pattern;
  PositionValue best, horns_down, horns_up;
  double gain_over_horns_down = 0, gain_over_horns_up = 0;  // of the best's expected value
  // The claim over horns-down under the scan's uncertainty ("claim"; present when the values
  // were drawn, OptimiseOptions::model_draws): held-out gain and its 90 % range (ClaimRange).
  std::optional<ClaimRange> claim;
  bool chosen_given = false;  // "chosen": "given"
  PositionValue chosen;       // best or given_position
  BowRecord bow;
  std::vector<BoardRecord> boards;  // at the chosen position
  ValueSurface surface;
};

// The file's text, parsed and checked; errors name the key. A file without "best" (a position
// the viewer saved) is read with its given position as the chosen one; best.present and
// horns_up.present say which positions the file holds.
Result<SawingRecord> sawing_record_from_json(const std::string& text);
// The same from a file; errors name the file and the key.
Result<SawingRecord> read_sawing_file(const std::filesystem::path& path);

}  // namespace sawyer::sawing
