// One sawing job as `sawyer saw` and `sawyer run` do it: the inputs named on a command line
// loaded and checked before any work, the optimiser run over a log, and the `sawyer-sawing/1`
// file (docs/sawing.md) that the report and the viewer read.
//
//   Result<SawSetup> setup = load_saw_setup({"2ex", "nordic", "", "", ""}, OptimiseOptions{});
//   Result<SawingOutcome> out = saw_log_model(log, setup.value(), progress);
//   nlohmann::ordered_json file = sawing_file_json(log, setup.value(), out.value());
//
// With a pattern set (SawNames::pattern_set, pattern_set.h) the job chooses the pattern as well
// as the position: every candidate of the log's class and its neighbours that fits the log is
// optimised, and the one worth the most is sawn (SawingOutcome::pattern, ::choice).
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/optimise.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/pattern_set.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/value.h"

namespace sawyer::sawing {

// What the user named: bundled names or files (setup.h), and a position "rot[,x[,y]]" or "".
struct SawNames {
  std::string pattern = "2ex", grading = "nordic", prices, position;
  // "nordic" or a sawyer-pattern-set/1 file: the pattern is chosen per log from this set and
  // `pattern` is not used; "": `pattern` is sawn.
  std::string pattern_set;
};

struct SawSetup {
  SawNames names;
  Pattern pattern;                        // the pattern named; empty with a pattern set
  std::optional<PatternSet> pattern_set;  // the set named, if any
  GradingRules rules;
  PriceTable prices;
  std::filesystem::path prices_path;  // the file the prices came from
  OptimiseOptions options;
  std::optional<LogPosition> position;  // the user's position: it is the chosen one
};

// Loads the pattern (or the pattern set), rules and prices, checks that the prices cover every
// grade and that the options suit the pattern (every pattern of the set), parses the position.
// Errors name the file or the option.
Result<SawSetup> load_saw_setup(const SawNames& names, const OptimiseOptions& options);

// The pattern, grading and price files the names point at (names such as "2ex" or "nordic" are
// no files): inputs an output must never replace (`sawyer saw`, `sawyer run`).
std::vector<std::filesystem::path> setup_input_files(const SawNames& names);

// One candidate of a pattern set as the job tried it on a log.
struct PatternCandidateResult {
  std::string name;               // the pattern's
  std::string class_label;        // its class (DiameterClass::label)
  bool own_class = false;         // the log's own class, not a neighbour's
  double needed_diameter_mm = 0;  // Pattern::required_diameter_mm
  bool fits = false;              // needed ≤ the log's usable diameter: only then is it sawn
  // Sawn candidates: the value of its boards (sold, as the run reports it) at its best position
  // (the given one when the position is given), and its best position's expected value under
  // the positioning error (none at a given position).
  double value = 0, expected_value = 0;
  bool has_expected = false;
  // What the candidates are ranked by: the expected value, the value at a given position.
  double rank_value() const { return has_expected ? expected_value : value; }
};

// How the pattern was chosen from a set for one log.
struct PatternChoice {
  std::string set;                                 // the set's name
  std::string class_label;                         // the log's class
  double usable_diameter_mm = 0;                   // what the class and the fit are taken from
  bool at_given_position = false;                  // ranked by the value at the given position
  std::vector<PatternCandidateResult> candidates;  // in the set's order (PatternSet::candidates)
  int chosen = -1;     // index into candidates: the highest rank_value (the first of equals)
  int next_best = -1;  // the runner-up; -1 when only one candidate fits
};

struct SawingOutcome {
  SawLog saw_log;
  Pattern pattern;                      // the pattern sawn: the setup's, or the set's chosen one
  std::optional<PatternChoice> choice;  // with a pattern set
  OptimiseResult opt;
  SawResult best_sawn;
  LogValue best_value;
  std::optional<SawResult> given_sawn;  // at SawSetup::position
  std::optional<LogValue> given_value;
  // The position the report shows: the user's when given, else the optimiser's best.
  bool chosen_is_given() const { return given_sawn.has_value(); }
  const SawResult& chosen_sawn() const { return given_sawn ? *given_sawn : best_sawn; }
  const LogValue& chosen_value() const { return given_value ? *given_value : best_value; }
};

// How far from its centre line (SawLog::line_at) the wood of `log` reaches at any height: per
// stem sample the pith's distance from the line plus the largest outline radius, mm. A pattern
// centre farther than this lies outside the log at every height.
double wood_reach_mm(const SawLog& log);

// The offsets of `setup` against `reach_mm`: the given position's (x, y), and the optimiser's
// grid (±offset_x_max_mm, ±offset_y_max_mm). One farther than the reach saws nothing of the log
// (issue 44: offsets of metres were accepted). `reach_what` says what bounds the reach ("the
// log's wood", "the scan's field of view"). Errors name the option (SawNames::position,
// offset_x_max_mm, offset_y_max_mm) and the largest offset accepted.
Status check_offsets_reach(const SawSetup& setup, double reach_mm, const std::string& reach_what);

// What a log of `usable_diameter_mm` must fit to be sawn with `setup`: the setup's pattern and the
// diameter it needs; with a pattern set, the candidate for the log's class needing the smallest
// diameter (no other fits when it does not), or for a log below the set's smallest class no
// pattern ("") and the diameter that class starts at.
struct FitNeed {
  std::string pattern;
  double needed_diameter_mm = 0;
};
FitNeed fit_need(const SawSetup& setup, double usable_diameter_mm);

// check_pattern_fits for a setup: with a pattern set, an error naming the log, the set, the
// smallest candidate (or the set's smallest class) and both diameters when no candidate fits.
Status check_setup_fits(const SawSetup& setup, double usable_diameter_mm,
                        const std::string& log_id);

// Refuses a log that nothing of the setup fits (check_setup_fits, naming its usable diameter) and
// offsets that leave the log (check_offsets_reach with wood_reach_mm), then runs the optimiser
// and saws the best and the given position; with a pattern set, for every candidate that fits,
// keeping the one with the highest PatternCandidateResult::rank_value. `progress` as
// optimise_position's (with a set, over all candidates).
Result<SawingOutcome> saw_log_model(const LogModel& log, const SawSetup& setup,
                                    const std::function<void(int, int)>& progress = {});

// "" when the best position lies inside the offset grid; else a note that it sits on the grid's
// edge (x or y at ±max) and that a wider range may be worth more, for the summaries.
std::string offset_edge_note(const OptimiseResult& result);

// One line each for the summaries: how horns-down was found ("horns-down from an arc bow of
// 12.7 mm (sweep 22.0 mm)" or that the log is straight and horns-down a convention), and
// `pos` as the saw executes it (turn from the scan, pattern centre at the log's ends).
std::string bow_line(const BowInfo& bow);
std::string saw_setup_line(const SawLog& log, const LogPosition& pos);
// The same text from its parts (a position read back from sawing.json, for the report).
std::string saw_setup_text(double turn_deg, const std::array<Vec3, 2>& pattern_centre_at_ends,
                           bool scanner_frame);
// "; cross-cut from 3.90 m: 0.60 m off at z 0.05 m, 0.00 m at z 3.95 m" for a board sold as
// [z_begin, z_end] of its sawn [sawn_begin, sawn_end] (trim_to_value), for the board tables.
std::string offcut_note(double sawn_begin, double sawn_end, double z_begin, double z_end);

}  // namespace sawyer::sawing
