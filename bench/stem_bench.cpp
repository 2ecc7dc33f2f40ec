// stem_bench: accuracy and speed of the stem pass (issue 4) on phantoms with ground truth.
//
//   stem_bench [--slices N] [--spacing MM] [--pixel MM] [--random K] [--speed-slices M] [--only
//   LOG_ID]
//              [--condition clean|hard|noise2|touch] [--seed S] [--at F] [--verbose 1]
//
// For each log (the three bundled ones and K freshly generated ones) and each condition
// ("clean": 512 x 512, 0.8 mm, the default 20 HU noise and bed; "hard": twice the noise, the
// bed touching the log, 5 % missing slices; "noise2" and "touch", only when asked for: twice
// the noise alone, the bed touching alone) it renders N slices in memory, runs scan_stem on
// them and compares with the phantom's truth: pith error (median, 95th percentile, worst slice),
// outer radius RMS over every angle and slice, heartwood radius RMS (--verbose 1 lists every
// slice). A second table times the whole stem pass on M slices with one and two threads.
// Rendering is not timed.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/phantom/phantom.h"
#include "sawyer/ct/phantom/phantom_source.h"
#include "sawyer/ct/scan/stem_scan.h"
#include "sawyer/ct/stem/stem_detect.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/model/log_json.h"

using namespace sawyer;
using namespace sawyer::ct;

namespace {

bool verbose = false;
double pixel_mm = 0.8;  // --pixel

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

struct Row {
  std::string log, condition;
  int slices = 0;
  double pith_median = 0, pith_p95 = 0, pith_worst = 0;
  int worst_slice = -1;
  double radius_rms = 0, heart_rms = 0;
  bool heart = false;
  double slices_per_s = 0;
};

Result<Row> run(const LogModel& log, const std::string& condition, int n, double spacing,
                std::uint64_t seed, double at) {
  PhantomOptions o;
  o.slice_spacing_mm = spacing;
  o.pixel_mm = pixel_mm;
  const double mid = log.stem.z_begin() + at * log.stem.length_mm();
  o.from_mm = mid - 0.5 * spacing * (n - 1);
  o.to_mm = mid + 0.5 * spacing * (n - 1);
  o.seed = seed;
  if (condition == "noise2") o.noise_hu *= 2;  // one of hard's three parts at a time
  if (condition == "touch") o.bed_gap_mm = 0;
  if (condition == "hard") {
    o.noise_hu *= 2;
    o.bed_gap_mm = 0;  // the log lies on the belt
    o.drop_slices = std::max(1, n / 20);
  }
  auto ph = Phantom::create(log, o);
  if (!ph) return ph.error();
  const Phantom& p = *ph.value();
  auto raw = std::make_unique<PhantomSource>(p, true);
  OpenOptions oo;
  auto src = make_uniform_z(std::move(raw), oo);
  if (!src) return src.error();
  StemScanOptions so;
  auto scan = scan_stem(*src.value(), so);
  if (!scan) return scan.error();
  const StemScan& s = scan.value();
  const LogModel truth = p.truth_log();
  Row row;
  row.log = log.id;
  row.condition = condition;
  row.slices = static_cast<int>(s.slices.size());
  row.slices_per_s = s.slices_per_second();
  std::vector<double> err;
  double r2 = 0, h2 = 0;
  long rn = 0, hn = 0;
  for (size_t j = 0; j < s.slices.size(); ++j) {
    const StemSliceRecord& rec = s.slices[j];
    const double z = rec.z;
    const Vec2 want = truth.stem.pith_at(z);
    const double e = (rec.pith - want).norm();
    err.push_back(e);
    if (verbose)
      std::printf("  truth %.2f %.2f ", want.x, want.y),
          std::printf(
              "  %s %s slice %2zu z %.0f: raw %s refined %s smoothed %.2f mm%s\n", log.id.c_str(),
              condition.c_str(), j, z,
              rec.pith_raw.found
                  ? std::to_string((rec.pith_raw.pith_mm - want).norm()).substr(0, 5).c_str()
                  : "-",
              rec.pith_refined.found
                  ? std::to_string((rec.pith_refined.pith_mm - want).norm()).substr(0, 5).c_str()
                  : "-",
              e, rec.pith_outlier ? " (outlier)" : "");
    if (e > row.pith_worst) {
      row.pith_worst = e;
      row.worst_slice = static_cast<int>(j);
    }
    // Radii are compared on the truth's own pith, so a pith error does not count twice: the
    // measured point at azimuth w is re-expressed around the true pith.
    auto add_squares = [&](std::vector<double> rad, std::vector<bool> ok, auto truth_at,
                           double& sum2, long& count) {
      recentre_contour(rec.pith, want, rad, ok);
      for (size_t k = 0; k < rad.size(); ++k) {
        if (!ok[k]) continue;
        const double d = rad[k] - truth_at(kTwoPi * k / rad.size());
        sum2 += d * d;
        ++count;
      }
    };
    add_squares(
        rec.contour.radius, rec.contour.valid, [&](double w) { return truth.stem.radius_at(w, z); },
        r2, rn);
    if (rec.heartwood.present && !truth.stem.heartwood.empty())
      add_squares(
          rec.heartwood.radius, rec.heartwood.valid,
          [&](double w) { return truth.stem.heartwood_at(w, z); }, h2, hn);
  }
  row.pith_median = percentile(err, 0.5);
  row.pith_p95 = percentile(err, 0.95);
  row.radius_rms = rn ? std::sqrt(r2 / rn) : NAN;
  row.heart = hn > 0;
  row.heart_rms = hn ? std::sqrt(h2 / hn) : NAN;
  return row;
}

// The whole stem pass (tracking, refinement, contour, heartwood, assembly) on `n` slices of a
// log's middle, pre-rendered in memory, with 1 and with 2 threads: ms per slice and the time an
// 800-slice scan would take at that rate. Best of kSpeedRuns runs each.
constexpr int kSpeedRuns = 5;

struct Speed {
  int slices = 0;
  double cpu_ms = 0;  // processor time of the pass, all threads, per slice
  double ms_one = 0, ms_two = 0;
};

double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

Speed time_stem_pass(const LogModel& log, int n, double spacing) {
  PhantomOptions o;
  o.slice_spacing_mm = spacing;
  const double mid = log.stem.z_begin() + 0.5 * log.stem.length_mm();
  const double half = std::min(0.5 * spacing * (n - 1), 0.5 * log.stem.length_mm() - 20.0);
  o.from_mm = mid - half;
  o.to_mm = mid + half;
  Speed sp;
  auto ph = Phantom::create(log, o);
  if (!ph) return sp;
  PhantomSource src(*ph.value(), true);
  sp.slices = src.geometry().slice_count();
  for (int threads : {1, 2}) {
    double best = 1e30;
    for (int rep = 0; rep < kSpeedRuns; ++rep) {
      StemScanOptions so;
      so.threads = threads;
      const double c0 = cpu_seconds();
      auto scan = scan_stem(src, so);
      const double cpu = cpu_seconds() - c0;
      if (!scan) return sp;
      if (threads == 1)
        sp.cpu_ms =
            rep == 0 ? 1000.0 * cpu / sp.slices : std::min(sp.cpu_ms, 1000.0 * cpu / sp.slices);
      best = std::min(best, scan.value().seconds);
      if (verbose)
        std::printf(
            "  %d thread(s): %.3f s = tracking + contours %.3f s, refinement %.3f s; "
            "CPU reading + first track %.3f s, contours %.3f s; %d whole-slice "
            "searches, %d refinements in %d passes\n",
            threads, scan.value().seconds, scan.value().seconds_tracking,
            scan.value().seconds_refining, scan.value().cpu_reading_tracking,
            scan.value().cpu_contours, scan.value().pith_full_searches,
            scan.value().pith_refinements, scan.value().pith_refine_passes);
    }
    (threads == 1 ? sp.ms_one : sp.ms_two) = 1000.0 * best / sp.slices;
  }
  return sp;
}

}  // namespace

int main(int argc, char** argv) {
  int n = 40, random_logs = 2;
  double spacing = 5.0;
  std::string only;
  int speed_slices = 160;
  std::uint64_t seed = 7;
  double at = 0.5;
  std::string only_condition;
  for (int a = 1; a + 1 < argc; a += 2) {
    if (!std::strcmp(argv[a], "--slices"))
      n = std::atoi(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--spacing"))
      spacing = std::atof(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--pixel"))
      pixel_mm = std::atof(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--random"))
      random_logs = std::atoi(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--verbose"))
      verbose = std::atoi(argv[a + 1]) != 0;
    else if (!std::strcmp(argv[a], "--only"))
      only = argv[a + 1];
    else if (!std::strcmp(argv[a], "--speed-slices"))
      speed_slices = std::atoi(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--seed"))
      seed = std::strtoull(argv[a + 1], nullptr, 10);
    else if (!std::strcmp(argv[a], "--at"))
      at = std::atof(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--condition"))
      only_condition = argv[a + 1];
  }
  std::vector<LogModel> logs;
  for (const char* name : {"gran1_spruce", "pine_8", "spruce_77"}) {
    auto r = read_log_json(std::string(SAWYER_SOURCE_DIR) + "/sample_logs/" + name + "/log.json");
    if (!r) {
      std::fprintf(stderr, "stem_bench: %s\n", r.error().message().c_str());
      return 1;
    }
    logs.push_back(std::move(r).value());
  }
  for (int k = 0; k < random_logs; ++k) {
    GeneratorOptions g;
    g.species = k % 2 ? Species::kSpruce : Species::kPine;
    g.seed = 1000 + k;
    auto r = generate_log(g);
    if (r) logs.push_back(std::move(r).value());
  }
  std::printf("Stem accuracy on phantoms (512 x 512, %.2f mm, %d slices at %.1f mm)\n\n", pixel_mm,
              n, spacing);
  std::printf(
      "| log | condition | slices | pith median mm | pith p95 mm | worst mm (slice) | "
      "radius RMS mm | heartwood RMS mm | slices/s |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const LogModel& log : logs) {
    if (!only.empty() && log.id != only) continue;
    for (const char* cond : {"clean", "hard", "noise2", "touch"}) {
      // noise2 and touch (two of hard's three parts alone) only when asked for.
      if (only_condition.empty() ? std::strcmp(cond, "clean") && std::strcmp(cond, "hard")
                                 : only_condition != cond)
        continue;
      auto row = run(log, cond, n, spacing, seed, at);
      if (!row) {
        std::printf("| %s | %s | error: %s |\n", log.id.c_str(), cond,
                    row.error().message().c_str());
        continue;
      }
      const Row& r = row.value();
      std::printf("| %s | %s | %d | %.2f | %.2f | %.2f (%d) | %.2f | %s | %.0f |\n", r.log.c_str(),
                  r.condition.c_str(), r.slices, r.pith_median, r.pith_p95, r.pith_worst,
                  r.worst_slice, r.radius_rms,
                  r.heart ? std::to_string(r.heart_rms).substr(0, 5).c_str() : "-", r.slices_per_s);
      std::fflush(stdout);
    }
  }
  if (speed_slices <= 0) return 0;
  std::printf(
      "\nWhole stem pass on %d slices of each log's middle (in memory, reading excluded), "
      "best of 5. CPU ms/slice: processor time of all threads (the work one core would "
      "do); wall ms/slice with 1 worker thread (the reading thread runs beside it) and "
      "with 2\n\n| log | slices | CPU ms/slice | wall ms/slice, 1 worker | "
      "wall ms/slice, 2 workers | 800 slices, 2 workers (s) |\n"
      "|---|---:|---:|---:|---:|---:|\n",
      speed_slices);
  for (const LogModel& log : logs) {
    if (!only.empty() && log.id != only) continue;
    const Speed sp = time_stem_pass(log, speed_slices, spacing);
    std::printf("| %s | %d | %.2f | %.2f | %.2f | %.2f |\n", log.id.c_str(), sp.slices, sp.cpu_ms,
                sp.ms_one, sp.ms_two, 0.8 * sp.ms_two);
    std::fflush(stdout);
  }
  return 0;
}
