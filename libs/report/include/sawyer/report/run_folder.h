// A run folder as `sawyer run` leaves it, read back for the cutting report (docs/report.md):
//
//   <out>/scan/log.json   the log model (sawyer-log/1)
//   <out>/sawing.json     `sawyer saw`'s results (sawyer-sawing/1), plus "chosen": "best"|"given"
//   <out>/run.json        provenance (sawyer-run/1); optional, as is every key but "format"
//
//   Result<RunFolder> run = load_run_folder("out/");
//   if (!run) { std::cerr << run.error().message() << "\n"; ... }  // names the file and problem
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"

namespace sawyer::report {

// run.json. Empty strings and negative numbers mean "not given" (the report shows "—").
struct RunInfo {
  bool present = false;  // false when the folder has no run.json
  std::string log_id, species, scan_source, scan_description, scan_checksum, date, sawyer_version;
  // The names `sawyer saw` was given (pattern "2ex" or a file, grading "nordic" or a file, prices
  // file or "" for the example prices, position "rot,x,y" or "").
  std::string pattern, grading, prices, position;
  // What the reader had to do to the scan (slices interpolated along z, files ignored, ...),
  // one line each; the report states them under its header.
  std::vector<std::string> scan_notes;
  struct Stage {
    std::string name;
    double seconds = -1;
  };
  std::vector<Stage> stages;
};

// A log position with its value (currency) at the position and, where the optimiser gave one,
// its expected value under the positioning error.
struct PositionValue {
  sawing::LogPosition pos;
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
  sawing::ThicknessAxis thickness_axis = sawing::ThicknessAxis::kU;
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
  // limited_by, and the offcuts where the board was cross-cut ("…; cross-cut, 0.60 m off at z 0.00 m").
  std::string limit_and_offcuts() const;
};

// The optimiser's value grid, flat index (rotation × n_x + x) × n_y + y.
struct ValueSurface {
  std::vector<double> rotations_deg, offsets_x_mm, offsets_y_mm;
  std::vector<double> value, smoothed_value;
  bool empty() const { return value.empty(); }
};

// sawing.json.
struct SawingRecord {
  std::string log_id, pattern, grading, prices, currency;
  PositionValue best, horns_down, horns_up;
  double gain_over_horns_down = 0, gain_over_horns_up = 0;  // of the best's expected value
  bool chosen_given = false;                                // "chosen": "given"
  PositionValue chosen;                                     // best or given_position
  BowRecord bow;
  std::vector<BoardRecord> boards;                          // at the chosen position
  ValueSurface surface;
};

struct RunFolder {
  std::filesystem::path dir;
  LogModel log;
  RunInfo run;
  SawingRecord sawing;
};

// Reads and cross-checks the folder: scan/log.json and sawing.json must exist and parse, the
// log ids of log.json, sawing.json and run.json agree, and the chosen position has its boards.
// Errors name the file (and key) and what is wrong.
Result<RunFolder> load_run_folder(const std::filesystem::path& out);

}  // namespace sawyer::report
