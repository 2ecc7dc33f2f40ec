// Speed of virtual sawing (libs/sawing): the 4 m Gran_1 spruce (108 knots) sawn at a grid of
// positions (rotation every 5°, offsets −10..10 mm) by cant and through-and-through patterns,
// one thread. Prints a table of positions/s and boards/s (wall clock; median of `--repeats`).
//
//   build-saw/bench/saw_bench [--repeats 5] [--log sample_logs/gran1_spruce/log.json] [--report 1]
//                             [--dump file.txt] [--only 4ex] [--rot-step 5]
//
// --only runs the patterns whose name contains the text; --rot-step sets the rotation step (e.g.
// 45 with --repeats 1 for callgrind: valgrind --tool=callgrind
// --toggle-collect='sawyer::sawing::saw(*' build-saw/bench/saw_bench --repeats 1 --rot-step 45
// --only 4ex, then instructions / positions).
//
// --report 1 also prints the 2ex boards at rotation 0 (horns down) with their knots.
// --dump writes, for gran1 and two generated logs (pine seed 5, spruce seed 9) and the bundled
// 2ex, 4ex and tt patterns, the boards, grades and values (nordic rules, example prices) at 200
// pseudo-random positions each, then 44 positions in the optimiser's order (4 rotations, each at
// offsets x −10..10 mm step 2, the order saw()'s per-rotation caches see), every number in full
// precision: a fixture to compare sawing before and after a change (e.g. scripts or diff), no
// timing.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "sawyer/model/log_generator.h"
#include "sawyer/model/log_json.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/setup.h"
#include "sawyer/sawing/value.h"

using namespace sawyer;
using namespace sawyer::sawing;

namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Boards, grades and values at pseudo-random positions, full precision (see --dump above).
int dump(const LogModel& gran1, const char* out_path) {
  std::FILE* f = std::fopen(out_path, "w");
  if (!f) return 1;
  std::vector<LogModel> logs{gran1};
  for (auto [species, seed] : {std::pair{Species::kPine, 5}, std::pair{Species::kSpruce, 9}}) {
    GeneratorOptions g;
    g.species = species;
    g.seed = static_cast<std::uint64_t>(seed);
    Result<LogModel> m = generate_log(g);
    if (!m) return 1;
    logs.push_back(std::move(m.value()));
  }
  const GradingRules rules = grading_by_name("nordic").value();
  const PriceTable prices = prices_by_name("").value();
  for (const LogModel& lm : logs) {
    const SawLog sl(lm);
    for (const char* pname : {"2ex", "4ex", "tt"}) {
      const Pattern p = pattern_by_name(pname).value();
      std::uint64_t state = 12345;
      auto uni = [&state] {  // splitmix64 → [0, 1)
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
      };
      for (int k = 0; k < 200 + 44; ++k) {
        sawing::LogPosition pos{360 * uni(), -12 + 24 * uni(), k % 4 == 0 ? -5 + 10 * uni() : 0.0};
        if (k < 4) pos = {90.0 * k, 0, 0};
        // The optimiser's order: one rotation at every offset, then the next rotation.
        if (k >= 200) pos = {17.0 + 83.0 * ((k - 200) / 11), -10.0 + 2.0 * ((k - 200) % 11), 0};
        const SawResult r = saw(sl, p, pos);
        const LogValue v = value_of(r, rules, prices);
        std::fprintf(f, "pos %s %s %.17g %.17g %.17g boards %zu dropped %zu value %.17g\n",
                     lm.id.c_str(), pname, pos.rotation_deg, pos.offset_x_mm, pos.offset_y_mm,
                     r.boards.size(), r.dropped.size(), v.value);
        for (const DroppedBoard& d : r.dropped)
          std::fprintf(f, " dropped %d %s\n", d.spec, d.reason.c_str());
        for (size_t bi = 0; bi < r.boards.size(); ++bi) {
          const Board& b = r.boards[bi];
          std::fprintf(f,
                       " board %d %gx%g z %.17g %.17g vol %.17g box %.17g grade %d value %.17g\n",
                       b.spec, b.thickness_mm, b.width_mm, b.z_begin, b.z_end, b.volume_m3,
                       b.box_volume_m3, v.boards[bi].grade.grade, v.boards[bi].value);
          for (int s = 0; s < 4; ++s)
            std::fprintf(f, "  wane %d %.17g %.17g\n", s, b.wane[s].max_mm, b.wane[s].length_mm);
          for (const KnotOnSide& ks : b.knots)
            std::fprintf(f, "  knot %d %s %s z %.17g across %.17g r %.17g w %.17g l %.17g %d\n",
                         ks.knot, side_name(ks.side), knot_kind_name(ks.kind), ks.z_mm,
                         ks.across_mm, ks.r_mm, ks.width_mm, ks.length_mm, ks.dead ? 1 : 0);
          for (int h : b.hidden_knots) std::fprintf(f, "  hidden %d\n", h);
        }
      }
    }
  }
  std::fclose(f);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string path = std::string(SAWYER_SOURCE_DIR) + "/sample_logs/gran1_spruce/log.json";
  int repeats = 5;
  bool report = false;
  const char* dump_path = nullptr;
  const char* only = "";
  int rot_step = 5;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--repeats"))
      repeats = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--log"))
      path = argv[i + 1];
    else if (!std::strcmp(argv[i], "--report"))
      report = std::atoi(argv[i + 1]) != 0;
    else if (!std::strcmp(argv[i], "--dump"))
      dump_path = argv[i + 1];
    else if (!std::strcmp(argv[i], "--only"))
      only = argv[i + 1];
    else if (!std::strcmp(argv[i], "--rot-step"))
      rot_step = std::clamp(std::atoi(argv[i + 1]), 1, 360);
  }
  Result<LogModel> model = read_log_json(path);
  if (!model) {
    std::fprintf(stderr, "%s\n", model.error().message().c_str());
    return 1;
  }
  const LogModel& log = model.value();
  if (dump_path) return dump(log, dump_path);
  double t0 = now_s();
  const SawLog saw_log(log);
  const double prep_ms = 1e3 * (now_s() - t0);
  std::printf(
      "log %s: %.0f mm, %zu knots, usable diameter %.0f mm, bow %.1f mm; SawLog %.2f ms\n\n",
      log.id.c_str(), log.stem.length_mm(), log.knots.size(), saw_log.usable_diameter_mm(),
      saw_log.bow().height_mm, prep_ms);

  if (report) {
    const SawResult r = saw(saw_log, two_ex_pattern({}), {});
    for (const Board& b : r.boards) {
      std::printf(
          "%s: %gx%g, z %.0f..%.0f, %.4f m3 (box %.4f), wane max face %.1f/%.1f edge %.1f/%.1f mm, "
          "%zu knots on sides, %zu hidden\n",
          b.name.c_str(), b.thickness_mm, b.width_mm, b.z_begin, b.z_end, b.volume_m3,
          b.box_volume_m3, b.wane[0].max_mm, b.wane[1].max_mm, b.wane[2].max_mm, b.wane[3].max_mm,
          b.knots.size(), b.hidden_knots.size());
      for (const KnotOnSide& k : b.knots)
        std::printf(
            "  knot %3d %-5s %-5s z %6.0f across %6.1f r %5.1f d %5.1f width %5.1f length %5.1f "
            "angle %4.0f %s\n",
            k.knot_id, side_name(k.side), knot_kind_name(k.kind), k.z_mm, k.across_mm, k.r_mm,
            k.diameter_mm, k.width_mm, k.length_mm, k.angle_deg, k.dead ? "dead" : "sound");
    }
    std::printf("\n");
  }

  std::vector<sawing::LogPosition> positions;
  for (int rot = 0; rot < 360; rot += rot_step)
    for (double ox : {-10.0, 0.0, 10.0}) positions.push_back({double(rot), ox, 0.0});

  struct Case {
    const char* name;
    Pattern pattern;
  };
  CantOptions small{.centre_thickness_mm = 50,
                    .centre_width_mm = 100,
                    .side_thickness_mm = 19,
                    .side_width_mm = 100};
  const Case cases[] = {
      {"2ex 50x150 + 2 sides", two_ex_pattern({})},
      {"2ex 50x100 + 2 sides", two_ex_pattern(small)},
      {"4ex 38x100 + 2 sides",
       four_ex_pattern(
           {.centre_thickness_mm = 38, .centre_width_mm = 100, .side_thickness_mm = 19})},
      {"through-and-through 7x25", through_and_through_pattern(7, 25.0)},
  };
  std::printf(
      "| pattern | fits | boards/position | knots on sides/position | positions/s | boards/s |\n");
  std::printf("|---|---|---:|---:|---:|---:|\n");
  for (const Case& c : cases) {
    if (!std::strstr(c.name, only)) continue;
    const bool fits = check_pattern_fits(c.pattern, saw_log.usable_diameter_mm(), log.id).ok();
    std::vector<double> times;
    size_t boards = 0, knots = 0;
    for (int r = 0; r < repeats; ++r) {
      boards = knots = 0;
      t0 = now_s();
      for (const sawing::LogPosition& p : positions) {
        const SawResult res = saw(saw_log, c.pattern, p);
        boards += res.boards.size();
        for (const Board& b : res.boards) knots += b.knots.size();
      }
      times.push_back(now_s() - t0);
    }
    std::sort(times.begin(), times.end());
    const double t = times[times.size() / 2];
    const double n = static_cast<double>(positions.size());
    std::printf("| %s | %s | %.2f | %.1f | %.0f | %.0f |\n", c.name, fits ? "yes" : "no",
                boards / n, knots / n, n / t, boards / t);
  }
  std::printf(
      "\n%zu positions (rotation 0..%d° step %d°, offset x −10/0/+10 mm), median of %d runs, 1 "
      "thread\n",
      positions.size(), 360 - rot_step, rot_step, repeats);
  return 0;
}
