// Sawing patterns: boards in the cross-section, kerf and wane rules (docs/architecture.md section
// 9, docs/sawing.md).
//
// Pattern frame: u across the log (horizontal, +u to the right seen from +z), v up, both in mm,
// origin on the log's mean pith line once the log is positioned (see sawing.h). Every board is an
// axis-aligned rectangle in (u, v) running the whole log length before trimming.
//
//   Pattern p = two_ex_pattern({});                       // 2 × 50×150 centre, 25×100 sides
//   Result<Pattern> q = read_pattern_file("my.pattern.json");
//   Status fit = check_pattern_fits(p, usable_diameter_mm, "gran1_spruce");
//
// Thread safety: plain values; the free functions are reentrant.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/core/result.h"

namespace sawyer::sawing {

// Which pattern axis a board's thickness runs along. kU: the wide faces are planes u = const
// (vertical saw lines); kV: the faces are planes v = const.
enum class ThicknessAxis { kU, kV };

// One board of a pattern, nominal (green, as sawn) sizes in mm.
struct BoardSpec {
  std::string name;   // e.g. "centre 1", "side 2"
  double u_mm = 0.0;  // centre of the board's cross-section in the pattern frame
  double v_mm = 0.0;
  double thickness_mm = 0.0;
  double width_mm = 0.0;  // nominal width; for edged boards the widest allowed
  ThicknessAxis thickness_axis = ThicknessAxis::kU;
  // Side board: edged to the best standard width ≤ width_mm (Pattern::standard_widths_mm) and
  // dropped when too short; a non-edged (centre) board keeps width_mm and must fit the log.
  bool edged = false;
};

// Wane and length rules. Wane on a long side = the part of that side's width lying outside the
// log (under bark) at one height.
struct WaneRules {
  double max_face_fraction = 0.25;  // wane on a face ≤ this × board width
  double max_edge_fraction = 0.5;   // wane on an edge ≤ this × board thickness
  double min_length_mm = 1800.0;    // shorter boards are dropped
  double length_step_mm = 300.0;    // trimmed lengths are whole multiples of this (0: any)
};

// What a pattern may hold, checked by Pattern::validate() (so by every reader). Real patterns
// have a few dozen boards at most; through-and-through of the widest log a model may hold (3 m
// across, log_limits::kMaxRadiusMm) in 12 mm boards with 3 mm kerfs is 200. The limit bounds
// the sawing's work, which grows with the boards cut at every position (issue 44: 10 000 boards
// ran for minutes). Mills stock about ten standard widths. A board larger than that log is no
// board.
inline constexpr int kMaxPatternBoards = 200;
inline constexpr int kMaxStandardWidths = 100;
inline constexpr double kMaxBoardSizeMm = 3000.0;

struct Pattern {
  std::string name;
  double kerf_mm = 3.0;
  WaneRules wane;
  std::vector<double> standard_widths_mm = {75, 100, 115, 125, 150, 175, 200, 225};
  std::vector<BoardSpec> boards;

  // Sanity (sizes > 0, kerf ≥ 0, boards do not overlap, the counts and sizes within the limits
  // above); the message names the board. Readers call it on every file they load.
  Status validate() const;
  // Diameter (mm) of the smallest circle about the pattern origin holding every non-edged board.
  double required_diameter_mm() const;
};

// Cant sawing: `centre_boards` (2 or 4) boards of centre_thickness × centre_width side by side
// along u, split symmetrically about the pith (u = 0), separated by the kerf; then
// `side_boards_per_side` edged side boards of side_thickness (≤ side_width wide) outside them on
// each side. Mirror-symmetric about u = 0 and v = 0.
struct CantOptions {
  int centre_boards = 2;
  double centre_thickness_mm = 50.0;
  double centre_width_mm = 150.0;
  int side_boards_per_side = 1;
  double side_thickness_mm = 25.0;
  double side_width_mm = 100.0;
  double kerf_mm = 3.0;
};
Pattern cant_pattern(const CantOptions& o);
Pattern two_ex_pattern(CantOptions o);   // centre_boards = 2
Pattern four_ex_pattern(CantOptions o);  // centre_boards = 4

// Through-and-through: `boards` parallel boards of `thickness_mm` (thickness along u) centred on
// the pith, every one edged to the best standard width ≤ max_width_mm.
Pattern through_and_through_pattern(int boards, double thickness_mm, double max_width_mm = 225.0,
                                    double kerf_mm = 3.0);

// The bundled patterns' parameters (pattern_by_name, setup.h), which a pattern set's presets
// start from (pattern_set.h): "2ex" is two_ex_pattern(CantOptions{}), "4ex"
// four_ex_pattern(four_ex_options()) (38 × 100 centre boards), "tt" the through-and-through
// pattern of ThroughAndThroughOptions{} (7 boards of 25 mm).
CantOptions four_ex_options();
struct ThroughAndThroughOptions {
  int boards = 7;
  double thickness_mm = 25.0;
  double max_width_mm = 225.0;
  double kerf_mm = 3.0;
};

// Refuses a pattern that does not fit the log: an Error naming the log, the pattern's required
// diameter and the log's usable diameter, when required_diameter_mm() > usable_diameter_mm.
Status check_pattern_fits(const Pattern& p, double usable_diameter_mm, const std::string& log_id);

// The user pattern file (JSON, format tag "sawyer-pattern/1", docs/sawing.md). Errors name the
// file and the key.
Result<Pattern> pattern_from_json(const std::string& text);
std::string pattern_to_json(const Pattern& p);
Result<Pattern> read_pattern_file(const std::filesystem::path& path);
Status write_pattern_file(const std::filesystem::path& path, const Pattern& p);

}  // namespace sawyer::sawing
