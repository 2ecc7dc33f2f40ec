// The work of `sawyer scan`, shared with `sawyer run`: a CT scan read and analysed into the log
// model (stem, then knots), and the scan folder written from it (log.json, maps/, maps_float/,
// qa/ with slices drawn, the pith track and unrolled cylinders, knots.csv).
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "ct_options.h"
#include "sawyer/core/result.h"
#include "sawyer/ct/knot_scan.h"
#include "sawyer/ct/stem_scan.h"
#include "sawyer/model/log_model.h"

namespace sawyer::app {

struct ScanJobOptions {
  std::string input, species = "unknown", id;  // id "": the scan's folder or file name
  CtCliOptions ct;
  int threads = 0;  // 0: every core
  int qa_slices = 4;
};

struct ScanJob {
  std::unique_ptr<ct::SliceSource> source;  // kept open: the QA images read a few slices again
  std::unique_ptr<ct::LogVolume> volume;
  ct::StemScan stem;
  ct::KnotScan knots;
  LogModel log;
};

// (stage, done, total): "stem" per slice read and analysed, then "knots" 0/1 and 1/1.
using ScanProgress = std::function<void(const char* stage, int done, int total)>;

// Opens the scan (headers only: format, geometry, the z grid). Errors name the input.
Result<std::unique_ptr<ct::SliceSource>> open_scan(const ScanJobOptions& options);

// Analyses the scan, opened by open_scan() (or here when `opened` is null). Errors name the
// input and the problem.
Result<ScanJob> scan_ct(const ScanJobOptions& options, const ScanProgress& progress,
                        std::unique_ptr<ct::SliceSource> opened = nullptr);

// Writes the scan folder's files into `dir` (an existing, empty folder): log.json, then
// write_scan_extras().
Status write_scan_files(const ScanJob& job, const ScanJobOptions& options,
                        const std::filesystem::path& dir);
// Everything but log.json: maps/, maps_float/, qa/. Reads a few slices again through
// job.source, so it may run beside other work but not beside another user of job.source.
Status write_scan_extras(const ScanJob& job, const ScanJobOptions& options,
                         const std::filesystem::path& dir);

// The one-line summary `sawyer scan` prints.
std::string scan_summary(const ScanJob& job, const std::string& input);

}  // namespace sawyer::app
