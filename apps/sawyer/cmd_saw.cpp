// `sawyer saw`: parses the options, loads the log, pattern, grading and prices, runs the
// positioning optimiser, prints a one-screen summary and writes sawing.json atomically (nothing
// is left under the output name on failure).
#include "cmd_saw.h"
#include "cli_checks.h"
#include "cli_error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "sawyer/core/file_util.h"
#include "sawyer/core/output_guard.h"
#include "sawyer/maps/open_log.h"
#include "sawyer/sawing/sawing_file.h"
#include "sawyer/sawing/sawing_job.h"

namespace sawyer::app {

using namespace sawyer::sawing;

void print_boards(const SawResult& sawn, const LogValue& v, const GradingRules& rules,
                  const std::string& currency, std::FILE* f) {
  std::fprintf(f, "  %-10s %9s %6s %8s %-6s %9s  %s\n", "board", "size mm", "len m", "m3", "grade",
               currency.c_str(), "limited by");
  for (size_t i = 0; i < sawn.boards.size(); ++i) {
    const Board& b = sawn.boards[i];
    char size[32];
    std::snprintf(size, sizeof size, "%.0fx%.0f", b.thickness_mm, b.width_mm);
    std::string limit = describe(v.boards[i].grade.limit, rules);
    if (b.trimmed()) limit += offcut_note(b.sawn_begin, b.sawn_end, b.z_begin, b.z_end);
    std::fprintf(f, "  %-10s %9s %6.2f %8.4f %-6s %9.2f  %s\n", b.name.c_str(), size,
                 b.length_mm() * 1e-3, b.volume_m3,
                 rules.grade_name(v.boards[i].grade.grade).c_str(), v.boards[i].value,
                 limit.c_str());
  }
  for (const DroppedBoard& d : sawn.dropped)
    std::fprintf(f, "  (dropped board %d: %s)\n", d.spec, d.reason.c_str());
}

void print_sawing_summary(const LogModel& log, const SawSetup& su, const SawingOutcome& out,
                          std::FILE* f) {
  const OptimiseResult& r = out.opt;
  const std::string& cur = su.prices.currency;
  std::fprintf(f, "log %s: %zu knots, usable diameter %.0f mm; pattern %s%s; grading %s\n",
               log.id.c_str(), log.knots.size(), out.saw_log.usable_diameter_mm(),
               out.pattern.name.c_str(), r.symmetric ? " (point-symmetric: 180°)" : "",
               su.rules.name.c_str());
  if (out.choice) {
    std::fprintf(f, "%s\n", pattern_choice_line(*out.choice, cur).c_str());
    // Every candidate: what it needs, and what it gave where it fits.
    for (const PatternCandidateResult& c : out.choice->candidates) {
      std::fprintf(f, "  %-44s class %-12s needs %6.1f mm", ("'" + c.name + "'").c_str(),
                   c.class_label.c_str(), c.needed_diameter_mm);
      if (c.fits)
        std::fprintf(f, ": %9.2f %s%s\n", c.rank_value(), cur.c_str(),
                     c.has_expected ? " expected" : " at the given position");
      else
        std::fprintf(f, ": does not fit\n");
    }
  }
  std::fprintf(f,
               "%d positions (%zu rotations × %zu × %zu offsets) on %d threads in %.2f s (%.0f/s); "
               "σ %.1f° / %.1f mm\n",
               r.positions, r.rotations_deg.size(), r.offsets_x_mm.size(), r.offsets_y_mm.size(),
               r.threads, r.seconds, r.positions / std::max(r.seconds, 1e-9),
               su.options.sigma_rot_deg, su.options.sigma_offset_mm);
  auto line = [&](const char* name, const RankedPosition& p) {
    std::fprintf(f, "  %-11s rot %6.1f° x %+5.1f y %+5.1f mm: %8.2f %s (expected %8.2f)\n", name,
                 p.pos.rotation_deg, p.pos.offset_x_mm, p.pos.offset_y_mm, p.value, cur.c_str(),
                 p.smoothed);
  };
  line("best", r.best);
  line("horns-down", r.horns_down);
  line("horns-up", r.horns_up);
  line("best (raw)", r.best_raw);
  if (r.model_draws > 0) {
    std::fprintf(f, "values averaged over the model and %d draws of its scan uncertainty (%s)\n",
                 r.model_draws, r.spread_note.c_str());
    std::fprintf(f, "claim over horns-down, held out from the draws that chose it: %s\n",
                 claim_text(r.claim).c_str());
  }
  std::fprintf(f, "%s\n", bow_line(out.saw_log.bow()).c_str());
  std::fprintf(f, "saw set-up at the best position: %s\n",
               saw_setup_line(out.saw_log, r.best.pos).c_str());
  std::fprintf(f,
               "gain of best over horns-down %+.1f %%, over horns-up %+.1f %% (expected "
               "values)\n",
               100 * r.gain_over_horns_down, 100 * r.gain_over_horns_up);
  if (const std::string note = with_flags(offset_edge_note(r)); !note.empty())
    std::fprintf(f, "note: %s\n", note.c_str());
  std::fprintf(f, "boards at the best position:\n");
  print_boards(out.best_sawn, out.best_value, su.rules, cur, f);
  if (out.given_sawn) {
    const LogPosition& g = *su.position;
    std::fprintf(f, "given position rot %.1f° x %+.1f y %+.1f mm: %.2f %s\n", g.rotation_deg,
                 g.offset_x_mm, g.offset_y_mm, out.given_value->value, cur.c_str());
    std::fprintf(f, "saw set-up at the given position: %s\n",
                 saw_setup_line(out.saw_log, g).c_str());
    print_boards(*out.given_sawn, *out.given_value, su.rules, cur, f);
  }
}

namespace {

using Json = nlohmann::ordered_json;

struct SawCli {
  std::string input, output;
  SawNames names;
  OptimiseOptions o;
  bool quiet = false;
};

namespace fs = std::filesystem;

int run(const SawCli& c) {
  Result<LogModel> model = maps::open_log(c.input);
  if (!model) return fail(model.error());
  Result<SawSetup> setup = load_saw_setup(c.names, c.o);
  if (!setup) return fail(setup.error());
  // Never the log itself, a folder, a device or FIFO; a second `saw` to the same file refuses.
  OutputRequest req{c.output, OutputKind::kFile, {c.input}, "-o"};
  for (const fs::path& f : setup_input_files(c.names)) req.inputs.push_back(f);
  Result<OutputLock> lock = OutputLock::acquire(req);
  if (!lock) return fail(lock.error());
  const SawSetup& su = setup.value();
  const LogModel& log = model.value();

  auto progress = [&c](int done, int total) {
    if (c.quiet) return;
    std::fprintf(stderr, "\rsawing %d / %d positions", done, total);
    if (done == total) std::fprintf(stderr, "\n");
  };
  Result<SawingOutcome> outcome = saw_log_model(log, su, progress);
  if (!outcome) return fail(outcome.error());
  const SawingOutcome& out = outcome.value();
  const Json j = sawing_file_json(log, su, out);
  if (Status s = write_text_file_atomic(c.output, j.dump(1) + "\n"); !s) return fail(s.error());
  print_sawing_summary(log, su, out, stdout);
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
  CLI::Option* pattern =
      cmd->add_option("--pattern", c->names.pattern, "2ex | 4ex | tt | a sawyer-pattern/1 file")
          ->capture_default_str();
  cmd->add_option("--pattern-set", c->names.pattern_set,
                  "nordic | a sawyer-pattern-set/1 file: choose the pattern as well as the "
                  "position (the log's diameter class and its neighbours; docs/sawing.md)")
      ->excludes(pattern);
  cmd->add_option("--grading", c->names.grading, "nordic | gost | a sawyer-grading/1 file")
      ->capture_default_str();
  cmd->add_option("--prices", c->names.prices,
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
  cmd->add_option("--scan-draws", o.model_draws,
                  "expected value also over this many draws of the scanned knots' diameter and "
                  "r_dead within the scan's uncertainty (0: the model as it is; docs/sawing.md)")
      ->capture_default_str();
  cmd->add_option("--position", c->names.position,
                  "the chosen position, reported beside the best: rot[,x[,y]] (degrees, mm, mm)");
  add_threads_option(cmd, o.threads);
  cmd->add_flag("-q,--quiet", c->quiet, "no progress on stderr");
  cmd->callback([c, &run_out]() { run_out = [c]() { return run(*c); }; });
}

}  // namespace sawyer::app
