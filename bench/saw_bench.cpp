// Speed of virtual sawing (libs/sawing): the 4 m Gran_1 spruce (108 knots) sawn at a grid of
// positions (rotation every 5°, offsets −10..10 mm) by cant and through-and-through patterns,
// one thread. Prints a table of positions/s and boards/s (wall clock; median of `--repeats`).
//
//   build-saw/bench/saw_bench [--repeats 5] [--log sample_logs/gran1_spruce/log.json] [--report 1]
//
// --report 1 also prints the 2ex boards at rotation 0 (horns down) with their knots.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "sawyer/model/log_json.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"

using namespace sawyer;
using namespace sawyer::sawing;

namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

int main(int argc, char** argv) {
  std::string path = std::string(SAWYER_SOURCE_DIR) + "/sample_logs/gran1_spruce/log.json";
  int repeats = 5;
  bool report = false;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--repeats"))
      repeats = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--log"))
      path = argv[i + 1];
    else if (!std::strcmp(argv[i], "--report"))
      report = std::atoi(argv[i + 1]) != 0;
  }
  Result<LogModel> model = read_log_json(path);
  if (!model) {
    std::fprintf(stderr, "%s\n", model.error().message().c_str());
    return 1;
  }
  const LogModel& log = model.value();
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

  std::vector<LogPosition> positions;
  for (int rot = 0; rot < 360; rot += 5)
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
    const bool fits = check_pattern_fits(c.pattern, saw_log.usable_diameter_mm(), log.id).ok();
    std::vector<double> times;
    size_t boards = 0, knots = 0;
    for (int r = 0; r < repeats; ++r) {
      boards = knots = 0;
      t0 = now_s();
      for (const LogPosition& p : positions) {
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
      "\n%zu positions (rotation 0..355° step 5°, offset x −10/0/+10 mm), median of %d runs, 1 "
      "thread\n",
      positions.size(), repeats);
  return 0;
}
