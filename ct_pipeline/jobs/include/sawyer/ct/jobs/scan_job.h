// The work of `sawyer scan`, shared with `sawyer run`: the CT input opened, turned into the
// scanner's axes, scanned by the scan library's one call (ct::scan_log: stem, knots, QA
// verdict), and the scan folder written from it (log.json, maps/, maps_float/, qa/).
//
//   ScanJobOptions o{.input = "scans/log17", .species = "spruce"};
//   Result<std::unique_ptr<SliceSource>> src = open_scan(o);        // headers only
//   Result<ScanJob> job = scan_ct(o, progress, std::move(src).value());
//   Status st = write_scan_files(job.value(), o, empty_dir);
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/scan/memory_plan.h"
#include "sawyer/ct/scan/scan_log.h"

namespace sawyer::ct {

struct ScanJobOptions {
  std::string input, species = "unknown", id;  // id "": the scan's folder or file name
  OpenOptions open;                            // series, spacings, rescale, the z policy
  int threads = 0;                             // 0: every core
  int qa_slices = 4;                           // cross-sections in qa/
  double stem_step_mm = kDefaultStemStepMm;    // StemScanOptions::stem_step_mm
  // The memory budget, MB (memory_plan.h): the scan is fitted into it or refused before a
  // slice is read. report_mb: what the caller will add after the scan (`sawyer run`'s report).
  double memory_mb = kDefaultMemoryBudgetMb;
  double report_mb = 0;
};

struct ScanJob {
  std::unique_ptr<SliceSource> source;  // kept open: the QA images read a few slices again
  ScanResult scan;
  MemoryPlan memory;  // the plan the scan ran under
  const LogModel& log() const { return scan.log; }
  bool trusted() const { return scan.qa.verdict.trusted; }
};

// Opens the scan (headers only: format, geometry, the z grid), turned into the scanner's axes.
// Errors name the input.
Result<std::unique_ptr<SliceSource>> open_scan(const ScanJobOptions& options);

// Analyses the scan opened by open_scan(). Errors name the input and the problem; a scan that
// cannot be done within options.memory_mb is refused before any slice is read.
Result<ScanJob> scan_ct(const ScanJobOptions& options, const ScanProgress& progress,
                        std::unique_ptr<SliceSource> opened);

// Writes the scan folder's files into `dir` (an existing, empty folder): log.json, then
// write_scan_extras().
Status write_scan_files(const ScanJob& job, const ScanJobOptions& options,
                        const std::filesystem::path& dir);
// Everything but log.json: maps/, maps_float/, qa/. Reads a few slices again through
// job.source, so it may run beside other work but not beside another user of job.source.
Status write_scan_extras(const ScanJob& job, const ScanJobOptions& options,
                         const std::filesystem::path& dir);

// The QA verdict for a terminal: the headline, then each failed stage's notes, indented.
std::string qa_report(const ScanQa& qa);

}  // namespace sawyer::ct
