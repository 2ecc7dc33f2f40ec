// The scan's memory, planned up front (see memory_plan.h).
#include "sawyer/ct/scan/memory_plan.h"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <thread>

#include "sawyer/ct/scan/scan_log.h"
#include "sawyer/ct/stem/pith_track.h"

namespace sawyer::ct {
namespace {
constexpr double kMb = 1024.0 * 1024.0;
// Per slice, measured (6 000 against 2 000 slices of 512 x 512, 1 mm apart, the stem at 5 mm:
// 55 MB more for 4 000 slices, resident after the stem pass): the slice's records (outline and
// heartwood radii at 360 azimuths, levels, piths: StemSliceRecord) and the knot pass's mask.
constexpr double kRecordBytes = 16 * 1024;
// Per stem sample (one a slice where slices are stem_step_mm apart or more; 1 m and 4 m of the
// bundled log, 128 x 128 slices 5 mm apart, measured 32 KB a slice with the records): the stem
// and its copy in the log model.
constexpr double kStemSampleBytes = 16 * 1024;
constexpr double kSmallestCoreMm = 300, kCoreStepMm = 100;
}  // namespace

double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

std::string MemoryPlan::parts() const {
  char s[400];
  std::snprintf(s, sizeof s,
                "start-up %.0f, slices in flight %.0f, pith crops %.0f (%.0f more on disk), "
                "records %.0f, knot window %.0f (%.0f mm of log), report %.0f",
                startup_mb, slices_mb, crops_mb, crops_spilled_mb, records_mb, knots_mb,
                window.core_mm + 2 * window.margin_mm, report_mb);
  return s;
}

std::string MemoryPlan::describe() const {
  char s[80];
  std::snprintf(s, sizeof s, "about %.0f MB of %.0f: ", total_mb(), budget_mb);
  return s + parts();
}

void MemoryPlan::apply(ScanOptions* o) const {
  o->knots.window = window;
  o->stem.crop_memory_bytes = crop_memory_bytes;
}

Result<MemoryPlan> plan_memory(const VolumeGeometry& g, int threads, double budget_mb,
                               double report_mb, double stem_step_mm) {
  if (!(budget_mb > 0)) return Error("memory budget", "must be a positive number of MB");
  if (threads <= 0) threads = static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, 16);
  MemoryPlan p;
  p.budget_mb = budget_mb;
  p.report_mb = report_mb;
  p.startup_mb = peak_rss_mb();
  const int n = g.slice_count();
  const double slice_mb = static_cast<double>(g.width) * g.height * sizeof(float) / kMb;
  // Stem pass: the job queue (2 per thread), the pool and the tracker's few slices behind.
  p.slices_mb = (4.0 * threads + 6) * slice_mb;
  const int stem_samples = resampled_count(n, g.slice_spacing(), stem_step_mm);
  p.records_mb = (n * kRecordBytes + stem_samples * kStemSampleBytes) / kMb;
  const double all_crops_mb = n * static_cast<double>(pith_crop_bytes(g)) / kMb;
  // The log's radius is not known yet: the field of view's.
  const double r_max = 0.5 * std::min(g.width * g.spacing_x, g.height * g.spacing_y);
  KnotDetectOptions detect;
  auto window_mb = [&](const KnotWindowOptions& w) {
    return static_cast<double>(knot_grid_bytes(knot_window_planes(g, w, detect), r_max, detect)) /
           kMb;
  };
  const double crops_cap_mb = static_cast<double>(ScanOptions{}.stem.crop_memory_bytes) / kMb;
  p.window = ScanOptions{}.knots.window;
  p.crops_mb = std::min(all_crops_mb, crops_cap_mb);
  p.knots_mb = window_mb(p.window);
  while (p.total_mb() > budget_mb && p.window.core_mm > kSmallestCoreMm) {
    p.window.core_mm = std::max(kSmallestCoreMm, p.window.core_mm - kCoreStepMm);
    p.knots_mb = window_mb(p.window);
  }
  if (p.total_mb() > budget_mb) p.crops_mb = 0;  // every crop to disk
  p.crops_spilled_mb = all_crops_mb - p.crops_mb;
  p.crop_memory_bytes = static_cast<std::size_t>(p.crops_mb * kMb);
  if (p.total_mb() > budget_mb)
    return Error("memory budget", "this scan needs at least " +
                                      std::to_string(static_cast<int>(std::lround(p.total_mb()))) +
                                      " MB (" + p.parts() + "), over the budget of " +
                                      std::to_string(static_cast<int>(std::lround(budget_mb))) +
                                      " MB (--memory): give it more, or fewer threads");
  return p;
}

}  // namespace sawyer::ct
