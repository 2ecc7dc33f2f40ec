// `sawyer saw`: parses the options, loads the log, pattern, grading and prices, runs the
// positioning optimiser, prints a one-screen summary and writes sawing.json atomically (nothing
// is left under the output name on failure).
#include "cmd_saw.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "log_source.h"
#include "sawyer/core/file_util.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/optimise.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/sawing_json.h"
#include "sawyer/sawing/setup.h"
#include "sawyer/sawing/value.h"

namespace sawyer::app {
namespace {

namespace fs = std::filesystem;
using namespace sawyer::sawing;
using Json = nlohmann::ordered_json;

struct SawCli {
  std::string input, output, pattern = "2ex", grading = "nordic", prices, position;
  OptimiseOptions o;
  bool quiet = false;
};

int fail(const Error& e) {
  std::cerr << "sawyer: " << e.message() << "\n";
  return 1;
}

Json ranked_json(const RankedPosition& r) {
  Json j = position_json(r.pos);
  j["value"] = r.value;
  j["smoothed_value"] = r.smoothed;
  return j;
}

void print_boards(const SawResult& sawn, const LogValue& v, const GradingRules& rules,
                  const std::string& currency) {
  std::printf("  %-10s %9s %6s %8s %-6s %9s  %s\n", "board", "size mm", "len m", "m3", "grade",
              currency.c_str(), "limited by");
  for (size_t i = 0; i < sawn.boards.size(); ++i) {
    const Board& b = sawn.boards[i];
    char size[32];
    std::snprintf(size, sizeof size, "%.0fx%.0f", b.thickness_mm, b.width_mm);
    std::printf("  %-10s %9s %6.2f %8.4f %-6s %9.2f  %s\n", b.name.c_str(), size,
                b.length_mm() * 1e-3, b.volume_m3,
                rules.grade_name(v.boards[i].grade.grade).c_str(), v.boards[i].value,
                describe(v.boards[i].grade.limit, rules).c_str());
  }
  for (const DroppedBoard& d : sawn.dropped)
    std::printf("  (dropped board %d: %s)\n", d.spec, d.reason.c_str());
}

int run(const SawCli& c) {
  Result<LogModel> model = load_log(c.input);
  if (!model) return fail(model.error());
  Result<Pattern> pattern = pattern_by_name(c.pattern);
  if (!pattern) return fail(pattern.error());
  Result<GradingRules> rules = grading_by_name(c.grading);
  if (!rules) return fail(rules.error());
  const fs::path prices_path =
      c.prices.empty() ? bundled_data_dir() / "prices/example_prices.json" : fs::path(c.prices);
  Result<PriceTable> prices = prices_by_name(c.prices);
  if (!prices) return fail(prices.error());
  if (Status s = prices.value().check_covers(rules.value()); !s)
    return fail(s.error().with_context(prices_path.string()));
  std::optional<LogPosition> given;
  if (!c.position.empty()) {
    Result<LogPosition> p = parse_position(c.position);
    if (!p) return fail(p.error());
    given = p.value();
  }
  if (Status s = c.o.validate(pattern.value()); !s) return fail(s.error());

  const LogModel& log = model.value();
  const SawLog saw_log(log);
  if (Status s = check_pattern_fits(pattern.value(), saw_log.usable_diameter_mm(), log.id); !s)
    return fail(s.error());

  auto progress = [&c](int done, int total) {
    if (c.quiet) return;
    std::fprintf(stderr, "\rsawing %d / %d positions", done, total);
    if (done == total) std::fprintf(stderr, "\n");
  };
  Result<OptimiseResult> opt =
      optimise_position(saw_log, pattern.value(), rules.value(), prices.value(), c.o, progress);
  if (!opt) return fail(opt.error());
  const OptimiseResult& r = opt.value();
  const SawResult best_sawn = saw(saw_log, pattern.value(), r.best.pos);
  const LogValue best_value = value_of(best_sawn, rules.value(), prices.value());
  const std::string& cur = prices.value().currency;

  Json j;
  j["format"] = "sawyer-sawing/1";
  j["log"] = log.id;
  j["pattern"] = pattern.value().name;
  j["grading"] = rules.value().name;
  j["prices"] = prices.value().name;
  j["currency"] = cur;
  j["options"] = {
      {"rot_step_deg", c.o.rot_step_deg},       {"rot_range_deg", r.rot_range_deg},
      {"offset_x_max_mm", c.o.offset_x_max_mm}, {"offset_x_step_mm", c.o.offset_x_step_mm},
      {"offset_y_max_mm", c.o.offset_y_max_mm}, {"offset_y_step_mm", c.o.offset_y_step_mm},
      {"sigma_rot_deg", c.o.sigma_rot_deg},     {"sigma_offset_mm", c.o.sigma_offset_mm}};
  j["pattern_point_symmetric"] = r.symmetric;
  j["best"] = ranked_json(r.best);
  j["horns_down"] = ranked_json(r.horns_down);
  j["horns_up"] = ranked_json(r.horns_up);
  j["gain_over_horns_down"] = r.gain_over_horns_down;
  j["gain_over_horns_up"] = r.gain_over_horns_up;
  Json ranked = Json::array();
  for (const RankedPosition& p : r.ranked) ranked.push_back(ranked_json(p));
  j["ranked"] = ranked;
  j["boards"] = boards_json(best_sawn, best_value, rules.value(), true);
  if (given) {
    const SawResult gs = saw(saw_log, pattern.value(), *given);
    const LogValue gv = value_of(gs, rules.value(), prices.value());
    j["given_position"] = position_json(*given);
    j["given_position"]["value"] = gv.value;
    j["given_position"]["boards"] = boards_json(gs, gv, rules.value(), true);
  }
  j["surface"] = {{"index", "(rotation × offsets_x + x) × offsets_y + y"},
                  {"rotations_deg", r.rotations_deg},
                  {"offsets_x_mm", r.offsets_x_mm},
                  {"offsets_y_mm", r.offsets_y_mm},
                  {"value", r.value},
                  {"smoothed_value", r.smoothed}};
  if (Status s = write_text_file_atomic(c.output, j.dump(1) + "\n"); !s) return fail(s.error());

  std::printf("log %s: %zu knots, usable diameter %.0f mm; pattern %s%s; grading %s\n",
              log.id.c_str(), log.knots.size(), saw_log.usable_diameter_mm(),
              pattern.value().name.c_str(), r.symmetric ? " (point-symmetric: 180°)" : "",
              rules.value().name.c_str());
  std::printf(
      "%d positions (%zu rotations × %zu × %zu offsets) on %d threads in %.2f s (%.0f/s); "
      "σ %.1f° / %.1f mm\n",
      r.positions, r.rotations_deg.size(), r.offsets_x_mm.size(), r.offsets_y_mm.size(), r.threads,
      r.seconds, r.positions / std::max(r.seconds, 1e-9), c.o.sigma_rot_deg, c.o.sigma_offset_mm);
  auto line = [&](const char* name, const RankedPosition& p) {
    std::printf("  %-11s rot %6.1f° x %+5.1f y %+5.1f mm: %8.2f %s (expected %8.2f)\n", name,
                p.pos.rotation_deg, p.pos.offset_x_mm, p.pos.offset_y_mm, p.value, cur.c_str(),
                p.smoothed);
  };
  line("best", r.best);
  line("horns-down", r.horns_down);
  line("horns-up", r.horns_up);
  line("best (raw)", r.best_raw);
  std::printf("gain of best over horns-down %+.1f %%, over horns-up %+.1f %% (expected values)\n",
              100 * r.gain_over_horns_down, 100 * r.gain_over_horns_up);
  std::printf("boards at the best position:\n");
  print_boards(best_sawn, best_value, rules.value(), cur);
  if (given) {
    const SawResult gs = saw(saw_log, pattern.value(), *given);
    const LogValue gv = value_of(gs, rules.value(), prices.value());
    std::printf("given position rot %.1f° x %+.1f y %+.1f mm: %.2f %s\n", given->rotation_deg,
                given->offset_x_mm, given->offset_y_mm, gv.value, cur.c_str());
    print_boards(gs, gv, rules.value(), cur);
  }
  std::printf("wrote %s\n", c.output.c_str());
  return 0;
}

}  // namespace

void add_saw_command(CLI::App& app, std::function<int()>& run_out) {
  auto c = std::make_shared<SawCli>();
  CLI::App* cmd = app.add_subcommand(
      "saw",
      "Saw a log model over a grid of rotations and offsets: boards graded and priced, the best "
      "position under the positioning error, its gain over horns-down/up");
  cmd->add_option("input", c->input, "log.json (or a maps / stem-bank folder)")->required();
  cmd->add_option("-o,--output", c->output, "sawing.json to write")->required();
  cmd->add_option("--pattern", c->pattern, "2ex | 4ex | tt | a sawyer-pattern/1 file")
      ->capture_default_str();
  cmd->add_option("--grading", c->grading, "nordic | gost | a sawyer-grading/1 file")
      ->capture_default_str();
  cmd->add_option("--prices", c->prices,
                  "a sawyer-prices/1 file (default: data/prices/example_prices.json)");
  OptimiseOptions& o = c->o;
  cmd->add_option("--rot-step", o.rot_step_deg, "rotation step, degrees")->capture_default_str();
  cmd->add_option("--rot-range", o.rot_range_deg,
                  "180 | 360 (default: 180 for a point-symmetric pattern, else 360)");
  cmd->add_option("--offsets", o.offset_x_max_mm, "x offsets −mm..+mm")->capture_default_str();
  cmd->add_option("--offset-step", o.offset_x_step_mm, "x offset step, mm")->capture_default_str();
  cmd->add_option("--offsets-y", o.offset_y_max_mm, "y offsets −mm..+mm (0: none)")
      ->capture_default_str();
  cmd->add_option("--offset-y-step", o.offset_y_step_mm, "y offset step, mm")
      ->capture_default_str();
  cmd->add_option("--sigma-rot", o.sigma_rot_deg, "positioning error σ in rotation, degrees")
      ->capture_default_str();
  cmd->add_option("--sigma-offset", o.sigma_offset_mm, "positioning error σ in offset, mm")
      ->capture_default_str();
  cmd->add_option("--position", c->position,
                  "also report this position: rot[,x[,y]] (degrees, mm, mm)");
  cmd->add_option("--threads", o.threads, "worker threads (default: all cores)");
  cmd->add_flag("-q,--quiet", c->quiet, "no progress on stderr");
  cmd->callback([c, &run_out]() { run_out = [c]() { return run(*c); }; });
}

}  // namespace sawyer::app
