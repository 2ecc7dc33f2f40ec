// knot_bench: accuracy and speed of the knot pass (issue 5) on phantoms with ground truth.
//
//   knot_bench [--slices N] [--random K] [--only LOG_ID]
//              [--condition clean|hard|placed|clutter|coarse] [--seed S] [--at F] [--speed 0|1]
//              [--list 0|1|2]
//
// For each log (the three bundled ones and K freshly generated pine and spruce logs) and each
// condition ("clean": 512 x 512, 0.8 mm, 5 mm slices, 20 HU noise, the scanner bed; "hard":
// twice the noise; and only when asked for with --condition: "placed", tilted 3°, 15 mm off
// centre, rolled 40°, lying on the bed, 5 % of the slices missing, 0.9 mm pixels; "clutter", placed
// with steel support bars and a chain in some slices; "coarse", 10 mm slices of 1 mm pixels over
// the same length) it renders N slices (5 mm apart) around F of the log's length in memory, runs
// the stem pass (which keeps the log's voxels) and the knot pass, and matches the knots found to
// the phantom's true knots (ct_pipeline/knots/include/sawyer/ct/knots/knot_match.h): a pair has its
// azimuth within 15° and its height within 15 mm at r = min(50 mm, both knots' r_end), nearest
// first. True knots count when they lie whole
// inside the section (5 mm from its ends) and, for recall, are at least 10 mm thick; a found
// knot is spurious when it matches no true knot at all. Errors on the pairs: azimuth and height
// at r = 50 mm (median), diameter RMSE over the common length (every 2 mm), r_dead (knots with
// a dead part in the truth) and r_end (median); r_end of a knot that reaches the bark is
// compared with the outer radius there. --list 1 prints the missed and the spurious knots,
// --list 2 also every pair (true and found diameter profile, r_dead, r_end).
// --speed 1 times the whole pass on the whole gran1 log (rendering excluded).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "sawyer/ct/knots/knot_match.h"
#include "sawyer/ct/knots/log_volume.h"
#include "sawyer/ct/phantom/phantom.h"
#include "sawyer/ct/phantom/phantom_source.h"
#include "sawyer/ct/scan/knot_scan.h"
#include "sawyer/ct/scan/scan_log.h"
#include "sawyer/ct/scan/stem_scan.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/model/log_json.h"

using namespace sawyer;
using namespace sawyer::ct;

namespace {

bool list_knots = false;
bool list_pairs = false;  // --list 2: every pair too

struct Row {
  std::string log, condition;
  int slices = 0;
  int truth_big = 0, found_big = 0;  // true knots >= 10 mm in the section, of which matched
  int found = 0, spurious = 0;
  double az_deg = NAN, height_mm = NAN, diam_rmse = NAN, r_dead = NAN, r_end = NAN;
  int dead_pairs = 0;
  double seconds_stem = 0, seconds_knots = 0;
};

Result<Row> run(const LogModel& log, const std::string& condition, int n, std::uint64_t seed,
                double at) {
  PhantomOptions o;
  const double spacing = o.slice_spacing_mm;
  const double mid = log.stem.z_begin() + at * log.stem.length_mm();
  const double from = std::max(log.stem.z_begin(), mid - 0.5 * spacing * (n - 1));
  o.from_mm = from;
  o.to_mm = std::min(log.stem.z_end(), from + spacing * (n - 1));
  o.seed = seed;
  if (condition == "hard") o.noise_hu *= 2;
  if (condition == "placed" || condition == "clutter") {
    // A log as it lies on a real bed: tilted, off centre, touching; clutter adds steel support
    // bars and a chain in some slices.
    o.placement.tilt_x_deg = 3;
    o.placement.offset_x_mm = 15;
    o.placement.roll_deg = 40;
    o.bed_gap_mm = 0;
    o.drop_slices = std::max(1, n / 20);
    o.clutter = condition == "clutter";
    o.pixel_mm = 0.9;  // a 461 mm field of view: logs up to 43 cm 15 mm off centre fit
  }
  if (condition == "coarse") {  // a production scanner's spacing: 10 mm slices, 1 mm pixels,
    o.slice_spacing_mm = 10;    // over the same length of log
    o.pixel_mm = 1.0;
  }
  auto ph = Phantom::create(log, o);
  if (!ph) return ph.error();
  const Phantom& p = *ph.value();
  auto uniform = make_uniform_z(std::make_unique<PhantomSource>(p, true), OpenOptions{});
  if (!uniform) return uniform.error();
  SliceSource& src = *uniform.value();
  auto scanned = scan_log(src, {});  // as `sawyer scan` does
  if (!scanned) return scanned.error();
  const StemScan& stem = scanned.value().stem;
  const KnotScan& knots = scanned.value().knots;
  const LogModel truth = p.truth_log();
  const double zlo = src.geometry().z.front() + 5.0, zhi = src.geometry().z.back() - 5.0;

  Row row;
  row.log = log.id;
  row.condition = condition;
  row.slices = src.geometry().slice_count();
  row.seconds_stem = stem.seconds;
  row.seconds_knots = knots.seconds;
  KnotMatchOptions mo;
  mo.z_lo = zlo, mo.z_hi = zhi;
  const KnotMatch m = match_knots(knots.knots, truth.knots, truth.stem, mo);
  row.found = m.found;
  row.truth_big = m.truth_counted;
  row.found_big = m.truth_found;
  row.spurious = m.spurious;
  row.dead_pairs = static_cast<int>(m.r_dead_mm.size());
  row.az_deg = median_of(m.azimuth_deg);
  row.height_mm = median_of(m.height_mm);
  row.diam_rmse = m.diameter_rmse();
  row.r_dead = median_of(m.r_dead_mm);
  row.r_end = median_of(m.r_end_mm);
  if (list_knots) {
    for (const std::string& l : m.missed)
      std::printf("  %s %s: %s\n", log.id.c_str(), condition.c_str(), l.c_str());
    for (const std::string& l : m.spurious_list)
      std::printf("  %s %s: %s\n", log.id.c_str(), condition.c_str(), l.c_str());
    if (list_pairs)
      for (const std::string& l : m.pairs)
        std::printf("  %s %s: %s\n", log.id.c_str(), condition.c_str(), l.c_str());
  }
  return row;
}

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// The whole pass on the whole log, rendering excluded: the stem pass keeping the voxels, then
// detection and fits, best of 3.
void time_whole_log(const LogModel& log) {
  PhantomOptions o;
  auto ph = Phantom::create(log, o);
  if (!ph) {
    std::printf("speed: %s\n", ph.error().message().c_str());
    return;
  }
  PhantomSource src(*ph.value(), true);
  double best_stem = 1e9, best_detect = 1e9, best_fit = 1e9, best_total = 1e9, cpu = 0;
  size_t bytes = 0;
  int knots = 0;
  for (int rep = 0; rep < 3; ++rep) {
    ScanOptions so;
    so.threads = 2;
    const double c0 = process_cpu_seconds();
    auto scanned = scan_log(src, so);
    if (!scanned) return;
    const double c1 = process_cpu_seconds();
    const KnotScan& s = scanned.value().knots;
    const StemScan& stem = scanned.value().stem;
    const LogVolume& vol = *scanned.value().volume;
    if (s.seconds < best_total) {
      best_total = s.seconds, best_detect = s.seconds_detect, best_fit = s.seconds_fit;
      cpu = c1 - c0;
    }
    best_stem = std::min(best_stem, stem.seconds);
    bytes = vol.bytes();
    knots = static_cast<int>(s.knots.size());
  }
  std::printf(
      "\nWhole log %s, %d slices in memory, 2 threads, best of 3 (s):\n\n"
      "| stem pass (keeps the voxels) | knot detection | knot fits | knot pass | "
      "knots | voxels kept (MB) | CPU, stem + knots (s) |\n|---:|---:|---:|---:|---:|---:|---:|\n"
      "| %.2f | %.2f | %.2f | %.2f | %d | %.0f | %.2f |\n",
      log.id.c_str(), src.geometry().slice_count(), best_stem, best_detect, best_fit, best_total,
      knots, bytes / 1e6, cpu);
}

}  // namespace

int main(int argc, char** argv) {
  int n = 160, random_logs = 4;
  std::string only, only_condition;
  std::uint64_t seed = 7;
  double at = 0.5;
  bool speed = true;
  for (int a = 1; a + 1 < argc; a += 2) {
    if (!std::strcmp(argv[a], "--slices"))
      n = std::atoi(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--random"))
      random_logs = std::atoi(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--only"))
      only = argv[a + 1];
    else if (!std::strcmp(argv[a], "--condition"))
      only_condition = argv[a + 1];
    else if (!std::strcmp(argv[a], "--seed"))
      seed = std::strtoull(argv[a + 1], nullptr, 10);
    else if (!std::strcmp(argv[a], "--at"))
      at = std::atof(argv[a + 1]);
    else if (!std::strcmp(argv[a], "--speed"))
      speed = std::atoi(argv[a + 1]) != 0;
    else if (!std::strcmp(argv[a], "--list")) {
      list_knots = std::atoi(argv[a + 1]) != 0;
      list_pairs = std::atoi(argv[a + 1]) >= 2;
    } else {
      std::fprintf(stderr, "knot_bench: unknown option %s\n", argv[a]);
      return 2;
    }
  }
  if (!only_condition.empty() && only_condition != "clean" && only_condition != "hard" &&
      only_condition != "placed" && only_condition != "clutter" && only_condition != "coarse") {
    std::fprintf(stderr,
                 "knot_bench: unknown condition %s (clean, hard, placed, clutter, coarse)\n",
                 only_condition.c_str());
    return 2;
  }
  std::vector<LogModel> logs;
  for (const char* name : {"gran1_spruce", "pine_8", "spruce_77"}) {
    auto r = read_log_json(std::string(SAWYER_SOURCE_DIR) + "/sample_logs/" + name + "/log.json");
    if (!r) {
      std::fprintf(stderr, "knot_bench: %s\n", r.error().message().c_str());
      return 1;
    }
    logs.push_back(std::move(r).value());
  }
  for (int k = 0; k < random_logs; ++k) {
    GeneratorOptions g;
    g.species = k % 2 ? Species::kSpruce : Species::kPine;
    g.seed = 2000 + k;
    auto r = generate_log(g);
    if (r) logs.push_back(std::move(r).value());
  }
  std::printf(
      "Knots on phantoms (512 x 512, 0.8 mm, %d slices at 5 mm around %.0f %% of each "
      "log)\n\n| log | condition | true >= 10 mm | found of them | recall %% | found | "
      "spurious | precision %% | azimuth err median deg | height err @50 median mm | "
      "diameter RMSE mm | r_dead err median mm (n) | r_end err median mm |\n"
      "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
      n, 100 * at);
  int tb = 0, fb = 0, nf = 0, ns = 0;
  for (const LogModel& log : logs) {
    if (!only.empty() && log.id != only) continue;
    for (const char* cond : {"clean", "hard", "placed", "clutter", "coarse"}) {
      const bool asked = !only_condition.empty();
      if (asked ? only_condition != cond : std::strcmp(cond, "clean") && std::strcmp(cond, "hard"))
        continue;
      auto row = run(log, cond, n, seed, at);
      if (!row) {
        std::printf("| %s | %s | error: %s |\n", log.id.c_str(), cond,
                    row.error().message().c_str());
        continue;
      }
      const Row& r = row.value();
      tb += r.truth_big, fb += r.found_big, nf += r.found, ns += r.spurious;
      std::printf(
          "| %s | %s | %d | %d | %.1f | %d | %d | %.1f | %.2f | %.2f | %.2f | %.1f (%d) | %.1f |\n",
          r.log.c_str(), r.condition.c_str(), r.truth_big, r.found_big,
          r.truth_big ? 100.0 * r.found_big / r.truth_big : 100.0, r.found, r.spurious,
          r.found ? 100.0 * (r.found - r.spurious) / r.found : 100.0, r.az_deg, r.height_mm,
          r.diam_rmse, r.r_dead, r.dead_pairs, r.r_end);
      std::fflush(stdout);
    }
  }
  std::printf("| all | | %d | %d | %.1f | %d | %d | %.1f | | | | | |\n", tb, fb,
              tb ? 100.0 * fb / tb : 100.0, nf, ns, nf ? 100.0 * (nf - ns) / nf : 100.0);
  if (speed && (only.empty() || only == "gran1_spruce")) time_whole_log(logs[0]);
  return 0;
}
