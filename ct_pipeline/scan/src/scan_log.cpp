// The scan of a log as one call (see scan_log.h).
#include "sawyer/ct/scan/scan_log.h"

#include <chrono>
#include <cstdio>
#include <string>
#include <utility>

namespace sawyer::ct {

Result<ScanResult> scan_log(SliceSource& src, const ScanOptions& options,
                            const ScanProgress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  ScanResult out;
  out.volume = std::make_unique<LogVolume>(LogVolume::empty_like(src.geometry()));
  StemScanOptions so = options.stem;
  so.threads = options.threads;
  so.volume = options.find_knots ? out.volume.get() : nullptr;
  auto stem = scan_stem(src, so, [&](int done, int all) {
    if (progress) progress("stem", done, all);
  });
  if (!stem) return stem.error();
  out.stem = std::move(stem.value());
  if (options.find_knots) {
    if (progress) progress("knots", 0, 1);
    KnotScanOptions ko = options.knots;
    ko.threads = options.threads;
    auto knots = scan_knots(*out.volume, out.stem.stem, ko);
    if (!knots) return knots.error();
    out.knots = std::move(knots.value());
    if (progress) progress("knots", 1, 1);
  }
  // What the QA needs of the voxels, then the voxels go (the largest thing a scan holds: the
  // log's cross-section on every slice at 16 bits).
  out.voxel_bytes = out.volume->bytes();
  for (double r : {30.0, 60.0, 90.0})
    out.unrolled.push_back(unroll_view(*out.volume, out.stem.stem, r));
  if (!options.keep_volume) out.volume.reset();
  out.qa =
      assess_scan(out.stem, options.find_knots ? &out.knots : nullptr, src.geometry(), options.qa);

  LogModel& log = out.log;
  log.id = options.id;
  log.species = options.species;
  log.source = "sawyer scan of " +
               (options.source_name.empty() ? std::string("scan") : options.source_name) + " (" +
               src.description() + ")";
  log.stem = out.stem.stem;
  log.knots = out.knots.knots;
  log.qa = out.qa.verdict;
  // The passes measured from pixel (0, 0); the model holds the scanner's x, y
  // (docs/formats.md).
  const VolumeGeometry& g = src.geometry();
  place_in_scanner_frame(log, {g.origin.x, g.origin.y}, scanner_frame_of(g));
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

std::string scan_brief(const ScanResult& scan, const std::string& input) {
  const StemScan& s = scan.stem;
  const KnotScan& ks = scan.knots;
  int outliers = 0;
  for (const auto& r : s.slices) outliers += r.pith_outlier;
  char line[1024];
  std::snprintf(line, sizeof line,
                "scanned %s: %zu slices in %.2f s, %.0f slices/s on %d threads; stem %d samples "
                "of %.1f mm%s; %d refined piths rejected as outliers; %zu knots in %.2f s "
                "(detection %.2f s, fits %.2f s; %zu candidates not fitted)",
                input.c_str(), s.slices.size(), s.seconds, s.slices_per_second(), s.threads,
                s.stem.slice_count(), s.stem.dz_mm,
                s.stem.heartwood.empty() ? "" : " with heartwood", outliers, ks.knots.size(),
                ks.seconds, ks.seconds_detect, ks.seconds_fit, ks.rejected.size());
  return std::string(line) + "\n" + qa_headline(scan.qa.verdict);
}

}  // namespace sawyer::ct
