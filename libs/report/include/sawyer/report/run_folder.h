// A run folder as `sawyer run` leaves it, read back for the cutting report (docs/report.md):
//
//   <out>/scan/log.json   the log model (sawyer-log/1)
//   <out>/sawing.json     `sawyer saw`'s results (sawyer-sawing/1), plus "chosen": "best"|"given";
//                         absent when run.json says the log was not sawn (NotSawn below)
//   <out>/run.json        provenance (sawyer-run/1); optional, as is every key but "format";
//                         written by write_run_file below
//
//   Result<RunFolder> run = load_run_folder("out/");
//   if (!run) { std::cerr << run.error().message() << "\n"; ... }  // names the file and problem
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/sawing_file.h"

namespace sawyer::report {

// Why a run with a complete scan sawed nothing (run.json "outcome": "not sawn", "not_sawn"):
// the chosen pattern cannot be sawn from the log at any position (docs/run.md, "Not sawn").
struct NotSawn {
  std::string reason;   // one line, e.g. check_pattern_fits()'s "pattern '2ex ...' does not fit:
                        // it needs a diameter of 182.0 mm, the log's usable diameter is ..."
  std::string pattern;  // the pattern's name; with a pattern set its smallest candidate's ("":
                        // the log is below the set's smallest class)
  std::string pattern_set;  // the pattern set's name, when the pattern was to be chosen from one
  double needed_diameter_mm = -1;  // Pattern::required_diameter_mm()
  double usable_diameter_mm = -1;  // SawLog::usable_diameter_mm()
  // Not sawn because the pattern needs more than the log's usable diameter (both known); else
  // for `reason` (an offset off the log's wood).
  bool pattern_too_large() const {
    return needed_diameter_mm >= 0 && usable_diameter_mm >= 0 &&
           needed_diameter_mm > usable_diameter_mm;
  }
};

// run.json. Empty strings and negative numbers mean "not given" (the report shows "—").
struct RunInfo {
  bool present = false;  // false when the folder has no run.json
  std::string log_id, species, scan_source, scan_description, scan_checksum, date, sawyer_version;
  // The names `sawyer saw` was given (pattern "2ex" or a file, grading "nordic" or a file, prices
  // file or "" for the example prices, position "rot,x,y" or "").
  std::string pattern, grading, prices, position;
  // The pattern set `sawyer run` was given ("nordic" or a file; "" for one pattern).
  std::string pattern_set;
  // What the reader had to do to the scan (slices interpolated along z, files ignored, ...),
  // one line each; the report states them under its header.
  std::vector<std::string> scan_notes;
  struct Stage {
    std::string name;
    double seconds = -1;
    double peak_mb = -1;  // the process's peak resident memory by the stage's end (-1: unknown)
  };
  std::vector<Stage> stages;
  // From the run's start to its decision (scan and saw done, the position printed), and to the
  // last write of run.json (everything but the register's row and the folder's rename); -1:
  // not given (a run.json of an older Sawyer).
  double seconds_to_decision = -1, seconds_total = -1;
  // Set when the run scanned the log but did not saw it: the folder then has no sawing.json.
  std::optional<NotSawn> not_sawn;
};

// run.json as `sawyer run` writes it: what RunInfo reads back, and what only the file keeps for
// people and other tools (how the reader resampled z, the scanner frame, the slice and knot
// counts, the scan's QA verdict).
struct RunRecord {
  RunInfo info;
  struct ZResampling {
    bool resampled = false;
    int source_slices = 0, invented_slices = 0, gaps = 0;
    double widest_gap_mm = 0, widest_gap_z0_mm = 0;
  } z_resampling;
  std::optional<ScannerFrame> scanner_frame;
  size_t slices = 0, knots = 0;
  std::optional<ScanQa> qa;
  // How the pattern was chosen from the set (sawing.json has it whole): the set, the log's class,
  // the chosen and the next best pattern with their values.
  std::optional<sawing::PatternChoice> pattern_choice;
  std::string currency;
};

// run.json's one writer (its reader is load_run_folder): the text, and the file written
// atomically.
std::string run_json_text(const RunRecord& run);
Status write_run_file(const RunRecord& run, const std::filesystem::path& path);

// sawing.json's records: owned by the sawing library (sawyer/sawing/sawing_file.h).
using sawing::BoardRecord;
using sawing::BowRecord;
using sawing::PositionValue;
using sawing::SawingRecord;
using sawing::ValueSurface;

struct RunFolder {
  std::filesystem::path dir;
  LogModel log;
  RunInfo run;
  SawingRecord sawing;  // empty when the log was not sawn (run.not_sawn)
  bool sawn() const { return !run.not_sawn; }
};

// Reads and cross-checks the folder: scan/log.json and sawing.json must exist and parse, the
// log ids of log.json, sawing.json and run.json agree, and the chosen position has its boards.
// A folder whose run.json says "not sawn" needs no sawing.json (one there is not read).
// Errors name the file (and key) and what is wrong.
Result<RunFolder> load_run_folder(const std::filesystem::path& out);

}  // namespace sawyer::report
