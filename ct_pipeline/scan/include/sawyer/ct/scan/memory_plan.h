// The memory a scan will hold, planned up front from the scan's geometry (issue 24): `sawyer
// scan` and `sawyer run` take a budget (--memory) and either fit the scan into it, by narrowing
// the knot pass's windows and sending the pith crops to a temporary file, or refuse before any
// slice is read, naming the figure.
//
//   Result<MemoryPlan> plan = plan_memory(source.geometry(), threads, 2048, kReportMb, 4.0);
//   if (!plan) ...                        // "needs about 912 MB ..., over the budget of 600 MB"
//   plan.value().apply(&scan_options);    // the knot windows and the crops' share
//
// What grows with the log is only the slices' records and the stem built from them (~32 KB a
// slice: 6.5 MB a metre at 5 mm, 32 MB at 1 mm) and the part of the pith crops kept in memory
// (capped at 32 MB); the rest is the slice size times a fixed count of slices in flight, and
// one knot window (KnotWindowOptions, ~1.3 m of log).
#pragma once

#include <cstddef>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/knots/knot_detect.h"

namespace sawyer::ct {

struct ScanOptions;

// What the report stage of `sawyer run` adds at its peak (rendering the boards' faces and the
// log views, encoding the PDF and the HTML), MB; measured on the bundled log (docs/run.md).
inline constexpr double kReportMemoryMb = 220;
// --memory's default: a share of a node that runs other jobs beside Sawyer.
inline constexpr double kDefaultMemoryBudgetMb = 2048;

struct MemoryPlan {
  double budget_mb = 0;
  // The parts, MB: the process so far (its own peak RSS when planned: libraries, start-up),
  // slices in flight (stem pass queue and tracker, or the knot pass's read batch), the pith
  // crops kept in memory, the slices' records, one knot window's grid, the report.
  double startup_mb = 0, slices_mb = 0, crops_mb = 0, records_mb = 0, knots_mb = 0, report_mb = 0;
  KnotWindowOptions window;           // the knot pass's windows
  std::size_t crop_memory_bytes = 0;  // the pith crops' share in memory
  double crops_spilled_mb = 0;        // the rest, in a temporary file
  double total_mb() const {
    return startup_mb + slices_mb + crops_mb + records_mb + knots_mb + report_mb;
  }
  // "start-up 150, slices in flight 24, pith crops 20 (0 more on disk), records 5, knot window
  // 93 (1340 mm of log), report 220"; describe() puts "about 532 MB of 2048: " before it.
  std::string parts() const;
  std::string describe() const;
  void apply(ScanOptions* options) const;
};

// The plan for a scan of `geometry` on `threads` threads (0: every core) within `budget_mb`,
// the report's share `report_mb` included (0 for a scan alone), with the stem sampled at most
// `stem_step_mm` apart (StemScanOptions::stem_step_mm). Errors: the budget is smaller
// than the scan needs with its smallest knot window (300 mm) and every crop on disk; the
// message gives the figure and the parts.
Result<MemoryPlan> plan_memory(const VolumeGeometry& geometry, int threads, double budget_mb,
                               double report_mb, double stem_step_mm);

// The process's peak resident memory so far, MB (getrusage).
double peak_rss_mb();

}  // namespace sawyer::ct
