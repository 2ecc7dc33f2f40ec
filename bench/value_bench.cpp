// Value gain of the positioning optimiser (libs/sawing): per log, the value at horns-down,
// horns-up and the best position (expected values under the positioning error, σ 5° / 2 mm, and
// the values at the positions themselves), the gain over horns-down, the average gain; then the
// speed of grading positions for gran1 on a 180 × 11 grid (2° over 360°, offsets ±10 mm step 2)
// with each bundled pattern (2ex, 4ex, tt) on 1 thread and on --threads threads (best of
// --repeats; wall clock, so noisy on a shared machine).
//
//   build-saw/bench/value_bench [--random 20] [--grading nordic|gost|file] [--threads 2]
//                               [--repeats 3] [--speed-only 1] [--only 2ex|4ex|tt]
//                               [--speed-rot-step 2] [--offsets 10]
// --offsets 0: rotation only (the published studies' comparison; docs/sawing.md "Value gain").
//
// For instruction counts: valgrind --tool=callgrind --toggle-collect='*optimise_position*'
// build-saw/bench/value_bench --random 0 --speed-only 1 --repeats 1 --threads 1 --only tt
// --speed-rot-step 45 (88 positions; saw() and value_of() show as its callees).
//
// Logs: the three bundled logs and `--random N` generated ones (spruce and pine alternately,
// seeds 1..N; pine_s8 and spruce_s77 are the bundled ones and counted once). Pattern 2ex 50×150
// + 25×100 sides, else 2ex 50×100, else 2ex 38×75 + 19×75 sides, whichever fits first; logs
// fitting none are listed and skipped. The same grading and prices for every position.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "bench_saw.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/model/log_json.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/optimise.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/setup.h"
#include "sawyer/sawing/value.h"

using namespace sawyer;
using namespace sawyer::sawing;

int main(int argc, char** argv) {
  const std::string src = SAWYER_SOURCE_DIR;
  int random = 20, threads = 2, repeats = 3;
  double speed_rot_step = 2, offsets = 10;
  bool speed_only = false;
  std::string only;
  std::string grading = "nordic";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--random"))
      random = std::max(0, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--grading"))
      grading = argv[i + 1];
    else if (!std::strcmp(argv[i], "--threads"))
      threads = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--repeats"))
      repeats = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--speed-only"))
      speed_only = std::atoi(argv[i + 1]) != 0;
    else if (!std::strcmp(argv[i], "--speed-rot-step"))
      speed_rot_step = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--offsets"))
      offsets = std::max(0.0, std::atof(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--only"))
      only = argv[i + 1];
  }
  const std::string grading_path = grading == "nordic"
                                       ? src + "/data/grading/nordic_appearance.json"
                                   : grading == "gost" ? src + "/data/grading/gost_8486_like.json"
                                                       : grading;
  Result<GradingRules> rules = read_grading_file(grading_path);
  Result<PriceTable> prices = read_price_file(src + "/data/prices/example_prices.json");
  if (!rules || !prices) {
    std::fprintf(stderr, "%s\n", (!rules ? rules.error() : prices.error()).message().c_str());
    return 1;
  }

  std::vector<LogModel> logs;
  for (const char* name : {"gran1_spruce", "pine_8", "spruce_77"}) {
    Result<LogModel> m = read_log_json(src + "/sample_logs/" + name + "/log.json");
    if (!m) {
      std::fprintf(stderr, "%s\n", m.error().message().c_str());
      return 1;
    }
    logs.push_back(std::move(m).value());
  }
  for (int s = 1; s <= random; ++s) {
    GeneratorOptions g;
    g.species = s % 2 ? Species::kSpruce : Species::kPine;
    g.seed = static_cast<std::uint64_t>(s);
    Result<LogModel> m = generate_log(g);
    if (!m) {
      std::fprintf(stderr, "%s\n", m.error().message().c_str());
      return 1;
    }
    // pine_8 and spruce_77 are bundled: do not count a log twice.
    if (std::any_of(logs.begin(), logs.end(),
                    [&](const LogModel& l) { return l.id == m.value().id; }))
      continue;
    logs.push_back(std::move(m).value());
  }

  OptimiseOptions o;
  o.threads = threads;
  o.offset_x_max_mm = offsets;
  std::printf(
      "grading %s, prices %s, σ %.0f° / %.0f mm, rotation step %.0f°, offsets ±%.0f mm "
      "step %.0f; values in %s (expected under the positioning error; at the position "
      "in brackets)\n\n",
      rules.value().name.c_str(), prices.value().name.c_str(), o.sigma_rot_deg, o.sigma_offset_mm,
      o.rot_step_deg, o.offset_x_max_mm, o.offset_x_step_mm, prices.value().currency.c_str());
  std::printf("| log | knots | pattern | horns-down | horns-up | best | best rot/x | gain %% |\n");
  std::printf("|---|---:|---|---:|---:|---:|---:|---:|\n");
  double gain_sum = 0;
  int n = 0;
  for (const LogModel& log : logs) {
    if (speed_only) break;
    const SawLog saw_log(log);
    const std::optional<bench::TwoEx> p =
        bench::widest_two_ex(saw_log.usable_diameter_mm(), log.id);
    if (!p) {
      std::printf("| %s | %zu | (usable diameter %.0f mm: no 2ex fits) | | | | | |\n",
                  log.id.c_str(), log.knots.size(), saw_log.usable_diameter_mm());
      continue;
    }
    Result<OptimiseResult> r =
        optimise_position(saw_log, p->pattern, rules.value(), prices.value(), o);
    if (!r) {
      std::fprintf(stderr, "%s: %s\n", log.id.c_str(), r.error().message().c_str());
      return 1;
    }
    const OptimiseResult& v = r.value();
    std::printf(
        "| %s | %zu | %s | %.2f (%.2f) | %.2f (%.2f) | %.2f (%.2f) | %.0f° / %+.0f | %+.1f |\n",
        log.id.c_str(), log.knots.size(), p->label, v.horns_down.smoothed, v.horns_down.value,
        v.horns_up.smoothed, v.horns_up.value, v.best.smoothed, v.best.value,
        v.best.pos.rotation_deg, v.best.pos.offset_x_mm, 100 * v.gain_over_horns_down);
    gain_sum += v.gain_over_horns_down;
    ++n;
  }
  if (n)
    std::printf("\naverage gain over horns-down: %+.1f %% over %d logs\n", 100 * gain_sum / n, n);

  // Speed: gran1, 2° over the full 360° (180 rotations) × 11 offsets, graded and valued, for
  // every bundled pattern on 1 thread and on `threads` threads.
  OptimiseOptions speed = o;
  speed.rot_range_deg = 360;
  speed.rot_step_deg = speed_rot_step;
  const SawLog gran1(logs[0]);
  std::printf(
      "\nspeed: %s, %.0f × 11 grid (%g° over 360°, offsets ±10 mm step 2), graded and "
      "valued, best of %d\n\n",
      logs[0].id.c_str(), 360 / speed_rot_step, speed_rot_step, repeats);
  std::printf("| pattern | threads | positions | seconds | positions/s |\n");
  std::printf("|---|---:|---:|---:|---:|\n");
  for (const char* name : {"2ex", "4ex", "tt"}) {
    if (!only.empty() && only != name) continue;
    const Result<Pattern> pat = pattern_by_name(name);
    if (!pat) return 1;
    for (int th : {1, threads}) {
      if (th == 1 && threads == 1 && th != threads) continue;
      speed.threads = th;
      double best_s = 1e9;
      int positions = 0;
      for (int rep = 0; rep < repeats; ++rep) {
        Result<OptimiseResult> r =
            optimise_position(gran1, pat.value(), rules.value(), prices.value(), speed);
        if (!r) return 1;
        best_s = std::min(best_s, r.value().seconds);
        positions = r.value().positions;
      }
      std::printf("| %s | %d | %d | %.3f | %.0f |\n", name, th, positions, best_s,
                  positions / best_s);
      if (threads == 1) break;
    }
  }
  return 0;
}
