// Board grading from rule tables read from data files (docs/architecture.md section 9,
// docs/sawing.md).
//
// A rule set is a list of grades, best first. Each grade limits, per face and per edge of a
// board: the size of the largest sound and dead knot (allowed = mm + per_width × the side's
// width, so limits scale with board size: Nordic style uses mm + per_width, GOST style
// per_width only), the number of knots and of dead knots per metre of board and per board, and
// the wane (fraction of the side's width and fraction of the board's length). A board gets the
// best grade whose every rule holds; the rule that kept it out of the grade above is recorded.
//
//   Result<GradingRules> rules = read_grading_file("data/grading/nordic_appearance.json");
//   BoardGrade g = grade_board(board, rules.value());
//   std::cout << rules.value().grade_name(g.grade) << ": " << describe(g.limit, rules.value());
//
// Knot size is KnotOnSide::width_mm (extent across the side); knots narrower than
// GradingRules::min_knot_mm are disregarded (neither sized nor counted). A knot is dead when
// KnotOnSide::dead. Faces are Side::kFacePlus/kFaceMinus (side width = board width), edges the
// other two (side width = board thickness).
//
// Thread safety: plain values; the free functions are reentrant.
#pragma once

#include <array>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/sawing/sawing.h"

namespace sawyer::sawing {

constexpr double kNoLimit = std::numeric_limits<double>::infinity();

// allowed = mm + per_width × side width (mm). Both infinite / absent: no limit.
struct SizeLimit {
  double mm = kNoLimit;
  double per_width = 0.0;
  double allowed(double side_width_mm) const { return mm + per_width * side_width_mm; }
};

struct SideRules {
  SizeLimit sound_knot;
  SizeLimit dead_knot;
  double knots_per_m = kNoLimit;       // all knots on one side, per metre of board length
  double dead_knots_per_m = kNoLimit;  // dead knots on one side, per metre
  double knots_per_board = kNoLimit;   // all knots on one side, whole board
  double wane_fraction = kNoLimit;     // largest wane / side width
};

struct GradeRule {
  std::string name;
  SideRules face, edge;
  double wane_length_fraction = kNoLimit;  // length with wane (any side) / board length
};

struct GradingRules {
  std::string name;
  double min_knot_mm = 0.0;       // knots narrower than this across the side are disregarded
  std::vector<GradeRule> grades;  // best first
  int reject() const { return static_cast<int>(grades.size()); }  // the grade index of "reject"
  std::string grade_name(int grade) const {
    return grade < reject() ? grades[grade].name : "reject";
  }
  Status validate() const;  // ≥ 1 grade, unique names, limits ≥ 0 and not NaN
};

// Which rule failed.
enum class LimitKind {
  kNone,       // best grade
  kSoundKnot,  // knot size over the limit
  kDeadKnot,
  kKnotCount,  // per metre
  kDeadKnotCount,
  kKnotsPerBoard,
  kWane,
  kWaneLength,
};

// The rule that kept a board out of grade `grade` (the one above its own), with what it measured.
struct GradeLimit {
  LimitKind kind = LimitKind::kNone;
  int grade = -1;  // the grade that failed
  Side side = Side::kFacePlus;
  int knot = -1;          // index into Board::knots for knot size rules
  double measured = 0.0;  // mm, count or fraction
  double allowed = 0.0;
  double along_mm = 0.0;  // knot position along the board
};

struct BoardGrade {
  int grade = 0;  // index into GradingRules::grades; reject() when no grade holds
  GradeLimit limit;
};

BoardGrade grade_board(const Board& board, const GradingRules& rules);
// grade_board(cut_board(board, z0, z1), rules).grade without building the piece: the knots of
// `board` crossing within [z0, z1] and the piece's wane per side (`wane`, as cut_board() sums it
// from the slabs). For cross-cutting to value (trim_to_value), which tries many pieces: it looks
// only at the knots listed in `counted` (indices into board.knots, in order), counted_knots():
// those at least rules.min_knot_mm wide, the only ones the rules count.
int piece_grade(const Board& board, double z0, double z1, const std::array<SideWane, 4>& wane,
                const GradingRules& rules, const std::vector<int>& counted);
std::vector<int> counted_knots(const Board& board, const GradingRules& rules);
// e.g. "dead knot 34 mm on face+ at 1.20 m > 25 mm allowed in A4"; "none" for kNone.
std::string describe(const GradeLimit& limit, const GradingRules& rules);

// A knot that decides a board's grade: one whose size breaks the knot-size rule of the grade
// above the board's (the sound-knot rule for a sound knot, the dead-knot rule for a dead one), so
// that the board would not reach that grade while the knot is there. Positions are those of the
// board's KnotOnSide (mm).
struct LimitingKnot {
  int index = -1;   // into Board::knots
  int knot_id = 0;  // the log model's knot id
  Side side = Side::kFacePlus;
  double z_mm = 0, along_mm = 0, across_mm = 0;
  double width_mm = 0;  // across the side, as graded
  bool dead = false;
  int grade = -1;                     // the better grade whose rule it breaks
  LimitKind rule = LimitKind::kNone;  // kSoundKnot or kDeadKnot
  double allowed_mm = 0;              // that rule's limit on this side
};

// The knots of `board` that keep it out of grade `grade` − 1 by their size (`grade`: the board's
// grade under `rules`, as grade_board() gives it; reject() for a rejected board), largest excess
// over the limit first. Empty for the best grade, and when the grade above is kept out only by
// counts or wane. Knots narrower than rules.min_knot_mm are not graded and never listed.
std::vector<LimitingKnot> limiting_knots(const Board& board, const GradingRules& rules, int grade);
// e.g. "knot 68, dead, 31 mm on face+ at 2.41 m: over 25 mm allowed in A".
std::string describe(const LimitingKnot& knot, const GradingRules& rules);

// The rule file, "sawyer-grading/1" (docs/sawing.md). Errors name the key; the file reader puts
// the file name in front.
Result<GradingRules> grading_from_json(const std::string& text);
Result<GradingRules> read_grading_file(const std::filesystem::path& path);

}  // namespace sawyer::sawing
