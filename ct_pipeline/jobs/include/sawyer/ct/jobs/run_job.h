// The main job, `sawyer run`, as one library call: a CT scan in; its stem and knots, the best
// sawing position, the run folder (scan/, sawing.json, run.json, report/) and the register's row
// out. The front end parses options, calls run_job() and prints the outcome.
//
//   RunJobOptions o;
//   o.scan.input = "scans/log17";
//   o.output = "runs/log17";
//   RunObserver obs{.update = bar_update, .done = bar_done, .decision = print_line};
//   Result<std::unique_ptr<RunOutcome>> r = run_job(o, obs);
//   if (r && !r.value()->scan.trusted()) ...   // written whole, but the QA verdict failed
//   if (r && r.value()->not_sawn) ...           // scanned and written, but not sawn: why
//
// Order: everything named in the options is checked before the scan starts (the sawing files,
// the register), then the scan is opened (headers only), then the output is checked and locked.
// The run folder is written whole or not at all (write_dir_atomic); the register's row is the
// last thing written, so a register that refuses it leaves no output behind either.
//
// A complete scan is never thrown away: when the pattern cannot be sawn from the log (it needs
// a larger diameter than the log's usable one, or the position or offsets asked for leave the
// log's wood, known only once it is scanned), the job still succeeds with `not_sawn` set and
// writes the folder without sawing.json: scan/, run.json ("outcome": "not sawn" and why) and a
// report that says why. The register has no column for such a log, so it gets no row (an earlier
// row of the same scan stays as it was). The front end exits 4 (docs/run.md).
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/ct/jobs/scan_job.h"
#include "sawyer/model/log_summary.h"
#include "sawyer/report/report.h"
#include "sawyer/report/run_folder.h"
#include "sawyer/sawing/sawing_job.h"

namespace sawyer::ct {

struct RunJobOptions {
  ScanJobOptions scan;
  std::string output;  // the run folder to write; replaced whole (an earlier run or empty)
  std::string db;      // the register; "": $SAWYER_DB or the default (register_path)
  sawing::SawNames names;
  sawing::OptimiseOptions optimise;
  bool no_register = false, no_report = false;
  // How a reader's note that names a library option reads in run.json (the front end's words
  // for it, e.g. its flags); unchanged when empty.
  std::function<std::string(const std::string&)> word_note;
};
// Messages about the options name them as "RunJobOptions::output", "RunJobOptions::db" and
// "RunJobOptions::no_register" (docs/style.md 6).

// Progress, all called on the calling thread (`update` also from the scan's and the
// optimiser's progress callbacks, which they call on it).
struct RunObserver {
  // A stage ("scan", "saw", "report") has done `done` of `total` units.
  std::function<void(const char* stage, int done, int total, const char* unit)> update;
  // A stage ended after `seconds`, with a short note ("793 slices, 108 knots").
  std::function<void(const char* stage, double seconds, const std::string& note)> done;
  // The decision, as soon as it is known and before the files are written: one line (not
  // called for a log that is not sawn).
  std::function<void(const std::string& line)> decision;
};

// Held by pointer: the sawing outcome refers to the scan's log model inside it. Once the scan
// folder is written, what its files hold is released: the scan's per-slice records and QA
// figures, its own stem copy, QA views and knot traces, and the log model's outline, heartwood
// and bark arrays (its pith, knots and QA verdict stay; the folder's scan/log.json is the whole
// model); with a report the sawing outcome's SawLog tables too (SawLog::release_tables: its
// line, bow and turn stay). The report would otherwise stack on them.
struct RunOutcome {
  ScanJob scan;
  sawing::SawSetup setup;
  std::optional<sawing::SawingOutcome> sawn;  // set once the job has sawn the log
  // Set instead of `sawn` when the pattern cannot be sawn from the log: why, with the diameter
  // the pattern needs and the log's usable diameter (as run.json states it).
  std::optional<report::NotSawn> not_sawn;
  LogSummary summary;
  std::vector<report::RunInfo::Stage> stages;  // as run.json states them
  report::ReportFiles report;                  // empty with no_report
  std::filesystem::path out_dir, db;           // db: empty with no_register
  double seconds = 0;                          // the whole job
  // From the job's start to the decision (scan and saw done, the decision line printed): what
  // the saw line waits for. For a log that was not sawn, to the end of the sawing attempt.
  double seconds_to_decision = 0;
  const LogModel& log() const { return scan.log(); }
  // Only when the log was sawn (not_sawn empty).
  const sawing::SawingOutcome& outcome() const { return *sawn; }
  // The position the files state: the given one, else the optimiser's best (sawn logs only).
  const sawing::LogPosition& position() const;
};

Result<std::unique_ptr<RunOutcome>> run_job(const RunJobOptions& options,
                                            const RunObserver& observer = {});

// The decision line printed before the files are written: "position: rot 30.0° x +5.0 y +0.0 mm,
// 123.45 EUR; saw set-up: ...".
std::string decision_line(const sawing::SawSetup& setup, const sawing::SawingOutcome& sawing);

}  // namespace sawyer::ct
