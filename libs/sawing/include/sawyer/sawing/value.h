// Board and log value from a price table per grade and nominal dimension (docs/sawing.md).
//
//   Result<PriceTable> prices = read_price_file("data/prices/example_prices.json");
//   if (Status s = prices.value().check_covers(rules); !s) ...;   // every grade has a price
//   LogValue v = value_of(saw_result, rules, prices.value());
//
// Price unit: currency per m³ of board (PriceTable::currency, e.g. EUR). Board value =
// Board::volume_m3 × price(grade, thickness × width); a dimension not listed takes the default
// prices. "reject" may be priced like a grade (e.g. as chip wood); unpriced reject is worth 0.
//
// Thread safety: plain values; the free functions are reentrant.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/sawing.h"

namespace sawyer::sawing {

// The shortest length step a price list may give (PriceTable::length_step_mm, when not 0).
inline constexpr double kMinLengthStepMm = 100.0;

struct PriceTable {
  std::string name;
  std::string currency = "EUR";
  struct Dimension {
    double thickness_mm = 0, width_mm = 0;
    std::map<std::string, double> per_m3;  // grade name -> price per m³
  };
  std::vector<Dimension> dimensions;
  std::map<std::string, double> default_per_m3;  // for dimensions not listed
  // Lengths boards are sold in ("lengths": {"step_mm", "min_mm"}, optional): a board may be
  // cross-cut to a whole number of steps shorter at either end when that is worth more
  // (trim_to_value). 0: boards are sold as sawn.
  double length_step_mm = 0;
  double min_length_mm = 0;

  // Price per m³ of a board of `grade` (a grade name or "reject") and nominal size; a dimension
  // matches within 0.5 mm, in either order.
  double price(const std::string& grade, double thickness_mm, double width_mm) const;
  // An Error naming "default.<grade>" for a grade of `rules` without a default price.
  Status check_covers(const GradingRules& rules) const;
};

struct BoardValue {
  BoardGrade grade;
  double price_per_m3 = 0;
  double value = 0;  // volume × price
};

struct LogValue {
  std::vector<BoardValue> boards;  // as SawResult::boards
  double value = 0;                // sum
};

LogValue value_of(const SawResult& sawn, const GradingRules& rules, const PriceTable& prices);

// Cross-cutting to value: each board is cut shorter by whole length steps of the price list at
// either end (never under its minimum length) where the shorter board, graded again on the knots
// and wane left on it, is worth more (a dead knot near one end costs a short piece, not a
// grade). Ties keep the longer board. Nothing happens when the price list has no length step.
// The board's sawn_begin / sawn_end keep the length before the cut; volume, wane, knots and
// their along_mm are those of the piece sold.
void trim_to_value(SawResult& sawn, const GradingRules& rules, const PriceTable& prices);

// The boards as sold at `pos`: saw(), then trim_to_value().
SawResult saw_for_sale(const SawLog& log, const Pattern& pattern, const LogPosition& pos,
                       const GradingRules& rules, const PriceTable& prices);

// The part [z0, z1] of a board sawn by saw() (within its sawn length): knots, wane and volume of
// that piece.
Board cut_board(const Board& b, double z0, double z1);

// "sawyer-prices/1" (docs/sawing.md). Errors name the key; the file reader adds the file name.
Result<PriceTable> prices_from_json(const std::string& text);
Result<PriceTable> read_price_file(const std::filesystem::path& path);

}  // namespace sawyer::sawing
