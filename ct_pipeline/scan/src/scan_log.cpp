// The scan of a log as one call (see scan_log.h).
#include "sawyer/ct/scan/scan_log.h"

#include <chrono>
#include <cstdio>
#include <string>
#include <utility>

#include "sawyer/core/instruction_count.h"
#include "sawyer/core/process_memory.h"

namespace sawyer::ct {

Result<ScanResult> scan_log(SliceSource& src, const ScanOptions& options,
                            const ScanProgress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  ScanResult out;
  // The voxels are kept through the stem pass only when asked for (tools, tests); otherwise the
  // knot pass reads the scan again, window by window along the log, and the QA's unrolled
  // views are taken from the slices on the way.
  if (options.keep_volume && options.find_knots)
    out.volume = std::make_unique<LogVolume>(LogVolume::empty_like(src.geometry()));
  StemScanOptions so = options.stem;
  so.threads = options.threads;
  so.volume = out.volume.get();
  auto stem = scan_stem(src, so, [&](int done, int all) {
    if (progress) progress("stem", done, all);
  });
  if (!stem) return stem.error();
  out.stem = std::move(stem.value());
  mark_stage_end("stem");
  // The slices the stem pass found the log's outline on (those it would have kept), and the
  // QA's per-slice figures: what the rest needs of the records' radii, before they go.
  std::vector<char> has_log(out.stem.slices.size(), 0);
  for (size_t i = 0; i < out.stem.slices.size(); ++i) {
    const StemSliceRecord& rec = out.stem.slices[i];
    if (!rec.measured) continue;
    for (size_t k = 0; k < rec.contour.radius.size(); ++k)
      if (rec.contour.valid[k] && rec.contour.radius[k] > 0) {
        has_log[i] = 1;
        break;
      }
  }
  std::vector<QaSlice> qa_slices = assess_slices(out.stem, src.geometry(), options.qa);
  if (options.outline_slices >= 0) {
    const int n = static_cast<int>(out.stem.slices.size());
    std::vector<char> keep(out.stem.slices.size(), 0);
    for (int i : qa_image_slices(n, options.outline_slices)) keep[static_cast<size_t>(i)] = 1;
    for (size_t i = 0; i < out.stem.slices.size(); ++i)
      if (!keep[i]) {  // the arrays go; the levels and flags stay
        StemSliceRecord& rec = out.stem.slices[i];
        std::vector<double>().swap(rec.contour.radius);
        std::vector<bool>().swap(rec.contour.valid);
        std::vector<double>().swap(rec.heartwood.radius);
        std::vector<bool>().swap(rec.heartwood.valid);
      }
    release_free_memory();  // the radii were allocated on the stem pass's workers
  }
  const std::vector<double> view_radii = {30.0, 60.0, 90.0};
  if (options.find_knots) {
    if (progress) progress("knots", 0, 1);
    KnotScanOptions ko = options.knots;
    ko.threads = options.threads;
    Result<KnotScan> knots = Error("knot scan", "not run");
    if (out.volume) {
      knots = scan_knots(*out.volume, out.stem.stem, ko);
      out.voxel_bytes = out.volume->bytes();
      for (double r : view_radii)
        out.unrolled.push_back(unroll_view(*out.volume, out.stem.stem, r));
    } else {
      std::vector<UnrolledViewBuilder> views;
      for (double r : view_radii) views.emplace_back(src.geometry(), out.stem.stem, r);
      knots = scan_knots(src, out.stem.stem, &has_log, ko, [&](int i, const Slice& slice) {
        for (UnrolledViewBuilder& v : views) v.add(i, slice);
      });
      for (UnrolledViewBuilder& v : views) out.unrolled.push_back(v.take());
      if (knots) out.voxel_bytes = knots.value().detect.grid_bytes;
    }
    if (!knots) return knots.error();
    out.knots = std::move(knots.value());
    if (progress) progress("knots", 1, 1);
    mark_stage_end("knots");
  } else {
    for (double r : view_radii)
      out.unrolled.push_back(UnrolledViewBuilder(src.geometry(), out.stem.stem, r).take());
  }
  out.qa = assess_scan(out.stem, options.find_knots ? &out.knots : nullptr, src.geometry(),
                       options.qa, std::move(qa_slices));

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
  mark_stage_end("qa");
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
                "(detection %.2f s in %d window%s: unroll %.2f (reading %.2f), contrast %.2f, "
                "segment %.2f, track %.2f, "
                "follow %.2f; "
                "fits %.2f s; %zu candidates not fitted)",
                input.c_str(), s.slices.size(), s.seconds, s.slices_per_second(), s.threads,
                s.stem.slice_count(), s.stem.dz_mm,
                s.stem.heartwood.empty() ? "" : " with heartwood", outliers, ks.knots.size(),
                ks.seconds, ks.seconds_detect, ks.detect.windows, ks.detect.windows == 1 ? "" : "s",
                ks.detect.unroll_s, ks.detect.read_s, ks.detect.contrast_s, ks.detect.segment_s,
                ks.detect.track_s, ks.detect.follow_s, ks.seconds_fit, ks.rejected.size());
  return std::string(line) + "\n" + qa_headline(scan.qa.verdict);
}

}  // namespace sawyer::ct
