// The viewer's sawing mode without a window: the pattern, grading and prices loaded as
// `sawyer saw` loads them, the log sawn at one position (boards, grades, value, the gain over
// horns-down), boards placed in the scanner frame for drawing, the heat map's colours, and the
// chosen position saved as JSON (a subset of sawyer-sawing/1, docs/viewer.md).
//
//   Result<std::unique_ptr<SawingSession>> s = SawingSession::create(log, {"2ex", "nordic", ""});
//   s.value()->set_position({.rotation_deg = 30});          // saw() + grading, about 1 ms
//   s.value()->value().value, s.value()->board_in_scanner(0) ...
//   s.value()->save("log_dir/sawing_position.json", log.id);
//
// Not thread safe; the SawLog inside is read-only, so an optimiser may read saw_log(), pattern(),
// rules() and prices() from another thread while nothing calls load functions.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/model/board_box.h"
#include "sawyer/model/log_model.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/value.h"

namespace sawyer::sawing {

// What to saw with: "2ex" | "4ex" | "tt" | a sawyer-pattern/1 file; "nordic" | "gost" | a
// sawyer-grading/1 file; a sawyer-prices/1 file, empty for data/prices/example_prices.json.
struct SawingChoice {
  std::string pattern = "2ex";
  std::string grading = "nordic";
  std::string prices;
};

// (Loaded by name as `sawyer saw` does: sawyer/sawing/setup.h.)

// Colour of a value in [0, 1] on the heat map (dark blue, purple, orange, light yellow), RGB
// 0..255; values outside are clamped, NaN is grey.
std::array<unsigned char, 3> heat_colour(double t);
// Colour of grade `grade` of `grades` grades: the best green, through yellow, the last orange;
// reject (grade ≥ grades) red.
std::array<unsigned char, 3> grade_colour(int grade, int grades);

class SawingSession {
 public:
  // Loads the pattern, grading and prices, checks that the prices cover the grades and that the
  // pattern fits the log; saws at horns-down. `log` must outlive the session.
  static Result<std::unique_ptr<SawingSession>> create(const LogModel& log,
                                                       const SawingChoice& choice);

  // Saws at `pos` and values the boards (cheap: saw() and grading).
  void set_position(const sawing::LogPosition& pos);
  const sawing::LogPosition& position() const { return pos_; }
  const sawing::SawResult& sawn() const { return sawn_; }
  const sawing::LogValue& value() const { return value_; }
  double horns_down_value() const { return horns_down_; }
  // value / horns-down value − 1 (0 when horns-down is worth nothing).
  double gain_over_horns_down() const;

  const sawing::SawLog& saw_log() const { return *saw_log_; }
  const sawing::Pattern& pattern() const { return pattern_; }
  const sawing::GradingRules& rules() const { return rules_; }
  const sawing::PriceTable& prices() const { return prices_; }
  const SawingChoice& choice() const { return choice_; }

  // Board i of sawn() as a box in the scanner frame (sawing::board_placement: centre at the
  // board's middle height on the mean pith line; the pith line's small tilt is not followed).
  BoardBox board_in_scanner(size_t i) const;
  // The corners of a pattern-frame rectangle (centre u, v; sizes along u and v) at height z in
  // the scanner frame (x, y), at the current position.
  std::array<Vec2, 4> rect_in_scanner(double u, double v, double size_u, double size_v,
                                      double z) const;
  // Scanner-frame displacement (dx, dy) as a pattern-frame offset change (for dragging).
  Vec2 scanner_to_pattern_delta(double dx, double dy) const;

  // The position, its value and boards as JSON (format "sawyer-sawing/1", key "given_position").
  std::string to_json(const std::string& log_id) const;
  // Writes to_json() atomically (a temporary file beside `path`, then a rename).
  Status save(const std::filesystem::path& path, const std::string& log_id) const;

 private:
  SawingSession() = default;
  double phi() const;

  const LogModel* log_ = nullptr;
  std::unique_ptr<sawing::SawLog> saw_log_;
  sawing::Pattern pattern_;
  sawing::GradingRules rules_;
  sawing::PriceTable prices_;
  SawingChoice choice_;
  sawing::LogPosition pos_;
  sawing::SawResult sawn_;
  sawing::LogValue value_;
  double horns_down_ = 0;
};

// Reads the position back from a file written by SawingSession::save() (or `sawyer saw` with
// --position): "given_position", else "best". Errors name the file and the key.
Result<sawing::LogPosition> read_saw_position(const std::filesystem::path& path);

}  // namespace sawyer::sawing
