// The knot pass: detect, fit in parallel, number (see knot_scan.h).
#include "sawyer/ct/scan/knot_scan.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <numeric>
#include <thread>

namespace sawyer::ct {
namespace {
constexpr double kMinCommonMm = 10.0;

// A short piece of a knot near the pith, cut off from the rest of it where the knot is still
// thin (a few voxels across), is fitted as a knot of its own that ends where the piece ends. It
// is part of the longer knot `q` when it ends well before q does and, over its outer 10 mm
// (where it was cut off from q; further in, both axes are extrapolations towards the pith), its
// axis stays inside q's tube (q's axis formula continued inwards where q's own trace starts
// later), give or take half a slice spacing; in height, half a slice more (a thin knot that
// straddles two slices can be cut into its upper and lower half). A neighbour of the same whorl
// is not: it runs on to its own end, and 20 degrees apart at r = 20 mm is already 7 mm of arc
// off q's axis.
bool inner_piece_of(const Knot& k, const KnotTrace& trace, const Knot& q, double dz) {
  if (trace.shells.empty() || k.r_end > q.r_end - kMinCommonMm) return false;
  const double r0 = std::max(trace.shells.front().r, k.r_end - kMinCommonMm);
  double excess = 0;
  int n = 0;
  for (double r = r0; r <= k.r_end; r += 2.0, ++n) {
    const double dh = std::max(0.0, std::abs(k.height_at(r) - q.height_at(r)) - 0.5 * dz);
    excess +=
        std::hypot(dh, r * angle_diff(k.azimuth_at(r), q.azimuth_at(r))) - 0.5 * q.diameter_at(r);
  }
  return n > 0 && excess / n < 0.5 * dz;
}

using Clock = std::chrono::steady_clock;

int thread_count(const KnotScanOptions& options) {
  const int threads =
      options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  return std::clamp(threads, 1, 16);
}

// Fits the detected traces, drops doubles, numbers the knots (slices dz mm apart).
void fit_and_number(std::vector<KnotTrace> traces, double dz, const KnotScanOptions& options,
                    int threads, Clock::time_point t0, Clock::time_point t1, KnotScan& out) {
  out.traces_found = static_cast<int>(traces.size());
  out.rejected_as_rings = out.detect.rejected_as_rings();

  // Fits are independent: threads take traces in turn.
  std::vector<Result<KnotFitReport>> fits(traces.size(), Error("not fitted"));
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i = next++; i < traces.size(); i = next++)
      fits[i] = fit_knot(traces[i], options.fit);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  const auto t2 = Clock::now();

  std::vector<size_t> kept;
  for (size_t i = 0; i < traces.size(); ++i) {
    if (!fits[i].ok()) {
      out.rejected.push_back(fits[i].error().message());
      continue;
    }
    if (fits[i].value().knot.max_diameter() < options.min_diameter_mm) {
      out.rejected.push_back("knot thinner than the minimum diameter");
      continue;
    }
    kept.push_back(i);
  }
  // A small knot that rises through the slices can be segmented as several parallel traces, one
  // per slice it steps into, each then fitted on its own: the same knot found twice. Two fitted
  // knots whose axes stay closer than a slice spacing plus half the larger diameter over at least
  // kMinCommonMm of common length are one; the better supported stays.
  std::sort(kept.begin(), kept.end(), [&](size_t a, size_t b) {
    return fits[a].value().knot.support > fits[b].value().knot.support;
  });
  std::vector<size_t> unique;
  for (size_t i : kept) {
    const Knot& k = fits[i].value().knot;
    bool same = false;
    for (size_t u : unique) {
      const Knot& q = fits[u].value().knot;
      if (inner_piece_of(k, traces[i], q, dz)) {
        same = true;
        break;
      }
      const double r0 = std::max(traces[i].shells.front().r, traces[u].shells.front().r);
      const double r1 = std::min(k.r_end, q.r_end);
      if (r1 - r0 < kMinCommonMm) continue;
      double sum = 0;
      int n = 0;
      for (double r = r0; r <= r1; r += 2.0, ++n) {
        sum += std::hypot(k.height_at(r) - q.height_at(r),
                          r * angle_diff(k.azimuth_at(r), q.azimuth_at(r)));
      }
      if (sum / n < dz + 0.5 * std::max(k.max_diameter(), q.max_diameter())) {
        same = true;
        break;
      }
    }
    if (same) {
      ++out.duplicates;
      continue;
    }
    unique.push_back(i);
  }
  kept = std::move(unique);
  std::sort(kept.begin(), kept.end(),
            [&](size_t a, size_t b) { return fits[a].value().knot.z0 < fits[b].value().knot.z0; });
  int id = 1;
  for (size_t i : kept) {
    KnotFitReport f = fits[i].value();
    f.knot.id = id++;
    out.knots.push_back(f.knot);
    out.fits.push_back(std::move(f));
    out.traces.push_back(std::move(traces[i]));
  }
  out.seconds_detect = std::chrono::duration<double>(t1 - t0).count();
  out.seconds_fit = std::chrono::duration<double>(t2 - t1).count();
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
}

// Detects with `detect(options with threads)` (traces or an error), then fits and numbers.
template <class Detect>
Result<KnotScan> scan_with(const Stem& stem, const VolumeGeometry& geometry,
                           const KnotScanOptions& options, Detect detect) {
  const auto t0 = Clock::now();
  KnotScan out;
  if (stem.slice_count() == 0) return Error("knot scan", "the stem is empty (no log found)");
  const int threads = thread_count(options);
  KnotDetectOptions o = options.detect;
  if (o.threads <= 0) o.threads = threads;
  Result<std::vector<KnotTrace>> traces = detect(o, &out.detect);
  if (!traces) return traces.error();
  const double dz = geometry.slice_spacing() > 0 ? geometry.slice_spacing() : 1.0;
  fit_and_number(std::move(traces.value()), dz, options, threads, t0, Clock::now(), out);
  return out;
}
}  // namespace

Result<KnotScan> scan_knots(const LogVolume& volume, const Stem& stem,
                            const KnotScanOptions& options) {
  return scan_with(
      stem, volume.geometry(), options,
      [&](const KnotDetectOptions& o, KnotDetectSummary* sum) -> Result<std::vector<KnotTrace>> {
        return detect_knots(volume, stem, o, sum);
      });
}

Result<KnotScan> scan_knots(SliceSource& source, const Stem& stem, const std::vector<char>* has_log,
                            const KnotScanOptions& options, const KnotSliceVisitor& visit) {
  return scan_with(stem, source.geometry(), options,
                   [&](const KnotDetectOptions& o, KnotDetectSummary* sum) {
                     return detect_knots(source, stem, has_log, o, options.window, sum, visit);
                   });
}

}  // namespace sawyer::ct
