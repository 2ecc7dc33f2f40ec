// `sawyer run` (see cmd_run.h): the options, one library call (ct::run_job), the summary.
#include "cmd_run.h"
#include "cli_checks.h"
#include "cli_error.h"

#include <cstdio>
#include <memory>
#include <string>

#include "cmd_saw.h"
#include "ct_options.h"
#include "progress.h"
#include "sawyer/core/interrupt.h"
#include "sawyer/ct/jobs/run_job.h"

namespace sawyer::app {

namespace {

struct RunCli {
  ct::RunJobOptions job;
  CtCliOptions ct;
  bool quiet = false;
};

// The log's figures, the first line of the summary.
void print_log_line(const ct::RunOutcome& run) {
  const LogModel& log = run.log();
  const LogSummary& summary = run.summary;
  std::printf(
      "\nlog %s (%s): %.2f m, diameter butt %.0f / top %.0f / mean %.0f mm, %.3f m3, "
      "taper %.1f mm/m, %d knots (%d with a dead part)\n",
      log.id.c_str(), log.species.c_str(), summary.length_mm * 1e-3, summary.butt_diameter_mm,
      summary.top_diameter_mm, summary.mean_diameter_mm, summary.volume_m3, summary.taper_mm_per_m,
      summary.knot_count, summary.dead_knots);
}

// The end of the summary: times, memory, register, the QA verdict, where the files are.
void print_summary_end(const ct::RunOutcome& run, bool no_report) {
  std::printf("time:");
  for (const auto& s : run.stages) std::printf(" %s %.2f s,", s.name.c_str(), s.seconds);
  std::printf(" total %.2f s (the decision at %.2f s)\n", run.seconds, run.seconds_to_decision);
  std::printf("memory: peak %.0f MB; planned %s\n", ct::peak_rss_mb(),
              run.scan.memory.describe().c_str());
  if (!run.db.empty())
    std::printf(run.not_sawn ? "register: %s not changed (a log that was not sawn has no row)\n"
                             : "register: %s\n",
                run.db.string().c_str());
  std::printf("%s\n", ct::qa_report(run.log().qa.value_or(ScanQa{})).c_str());
  if (!no_report)
    std::printf("report: %s\n        %s\n",
                (run.out_dir / "report" / "report.pdf").string().c_str(),
                (run.out_dir / "report" / "report.html").string().c_str());
  else
    std::printf("results: %s\n", run.out_dir.string().c_str());
}

// The summary of a run whose log was not sawn: the log's figures, why, and where the files are.
void print_not_sawn_summary(const ct::RunOutcome& run, bool no_report) {
  const report::NotSawn& ns = *run.not_sawn;
  print_log_line(run);
  if (ns.pattern_too_large() && !ns.pattern_set.empty())
    std::printf("NOT SAWN: %s\n", ns.reason.c_str());
  else if (ns.pattern_too_large())
    std::printf(
        "NOT SAWN: pattern '%s' needs a diameter of %.1f mm; the log's usable diameter is %.1f "
        "mm (inscribed in the top end, under bark)\n",
        ns.pattern.c_str(), ns.needed_diameter_mm, ns.usable_diameter_mm);
  else
    std::printf("NOT SAWN: %s\n", ns.reason.c_str());
  print_summary_end(run, no_report);
}

// The one-screen summary of a finished run on stdout.
void print_summary(const ct::RunOutcome& run, bool no_report) {
  const LogSummary& summary = run.summary;
  const sawing::SawSetup& su = run.setup;
  const sawing::SawingOutcome& out = run.outcome();
  const std::string& cur = su.prices.currency;
  const sawing::LogPosition& p = run.position();
  print_log_line(run);
  if (out.choice) std::printf("%s\n", sawing::pattern_choice_line(*out.choice, cur).c_str());
  std::printf("pattern %s, grading %s: %s position rot %.1f° x %+.1f y %+.1f mm, value %.2f %s",
              out.pattern.name.c_str(), su.rules.name.c_str(), su.position ? "given" : "best",
              p.rotation_deg, p.offset_x_mm, p.offset_y_mm, out.chosen_value().value, cur.c_str());
  const double hd = out.opt.horns_down.value;
  if (su.position)
    std::printf(" (horns-down %.2f: %+.1f %%)\n", hd,
                hd > 0 ? 100 * (out.chosen_value().value / hd - 1) : 0.0);
  else
    std::printf(" (expected %.2f; gain over horns-down %+.1f %%)\n", out.opt.best.smoothed,
                100 * out.opt.gain_over_horns_down);
  std::printf("saw set-up: %s\n%s\n", sawing::saw_setup_line(out.saw_log, p).c_str(),
              sawing::bow_line(out.saw_log.bow()).c_str());
  if (out.opt.model_draws > 0) {
    std::printf("values averaged over the model and %d draws of its scan uncertainty (%s)\n",
                out.opt.model_draws, out.opt.spread_note.c_str());
    if (!su.position)
      std::printf("claim over horns-down, held out from the draws that chose it: %s\n",
                  sawing::claim_text(out.opt.claim).c_str());
  }
  if (const std::string note = with_flags(sawing::offset_edge_note(out.opt));
      !su.position && !note.empty())
    std::printf("note: %s\n", note.c_str());
  if (std::string z = ct::resampling_summary(run.scan.source->geometry()); !z.empty())
    std::printf("note: %s\n", z.c_str());
  double board_m3 = 0;
  for (const auto& b : out.chosen_sawn().boards) board_m3 += b.volume_m3;
  print_boards(out.chosen_sawn(), out.chosen_value(), su.rules, cur, stdout);
  std::printf("boards %.4f m3 of %.4f m3: volume yield %.1f %%\n", board_m3, summary.volume_m3,
              summary.volume_m3 > 0 ? 100 * board_m3 / summary.volume_m3 : 0.0);
  print_summary_end(run, no_report);
}

int run(const RunCli& c) {
  StageBar bar(c.quiet);
  ct::RunObserver obs;
  obs.update = [&](const char* stage, int done, int total, const char* unit) {
    bar.update(stage, done, total, unit);
  };
  obs.done = [&](const char* stage, double seconds, const std::string& note) {
    bar.done(stage, seconds, note);
  };
  obs.decision = [](const std::string& line) {
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
  };
  Result<std::unique_ptr<ct::RunOutcome>> run = ct::run_job(c.job, obs);
  if (!run) return fail(run.error());
  // The scan was complete, the pattern cannot be sawn from the log: the folder holds the scan,
  // run.json and a report that say why; "not sawn" (README, exit codes).
  if (const auto& ns = run.value()->not_sawn) {
    print_not_sawn_summary(*run.value(), c.job.no_report);
    std::fflush(stdout);
    std::fprintf(stderr, "sawyer: %s; not sawn: the scan%s are in %s\n", ns->reason.c_str(),
                 c.job.no_report ? " and run.json" : ", run.json and report",
                 run.value()->out_dir.string().c_str());
    return kExitNotSawn;  // `sawyer batch` counts it "not_sawn" (reg::JobResult::not_sawn)
  }
  print_summary(*run.value(), c.job.no_report);
  // Everything was written; the scan's QA verdict failed, so the position is not to be trusted:
  // "completed with warnings" (README, exit codes).
  if (!run.value()->scan.trusted()) {
    std::fprintf(stderr,
                 "sawyer: completed with warnings: the scan's QA verdict failed; the chosen "
                 "position is not to be trusted (run.json \"qa\")\n");
    return 3;
  }
  return 0;
}

}  // namespace

void add_run_command(CLI::App& app, std::function<int()>& run_out) {
  auto c = std::make_shared<RunCli>();
  CLI::App* cmd = app.add_subcommand(
      "run",
      "The main job: a CT scan in; stem and knots, the best sawing position, the cutting "
      "report (PDF, HTML, CSV, JSON) out; the log registered. Exit 0 done; 3 done, but the "
      "scan's QA verdict failed; 4 not sawn: the pattern does not fit the log (scan, run.json "
      "and a report saying why written, no register row); 1 bad input, nothing written");
  cmd->add_option("input", c->job.scan.input, "CT scan: DICOM/TIFF/PNG folder, .vti, .mha, .nrrd")
      ->required();
  cmd->add_option("-o,--output", c->job.output,
                  "folder to write (scan/, sawing.json, run.json, report/); replaced whole")
      ->required();
  cmd->add_option("--id", c->job.scan.id, "log id (default: the scan's folder name)");
  cmd->add_option("--species", c->job.scan.species, "species")->capture_default_str();
  CLI::Option* pattern =
      cmd->add_option("--pattern", c->job.names.pattern, "2ex | 4ex | tt | a sawyer-pattern/1 file")
          ->capture_default_str();
  cmd->add_option("--pattern-set", c->job.names.pattern_set,
                  "nordic | a sawyer-pattern-set/1 file: choose the pattern per log as well as "
                  "the position (the log's diameter class and its neighbours; docs/sawing.md)")
      ->excludes(pattern);
  cmd->add_option("--grading", c->job.names.grading, "nordic | gost | a sawyer-grading/1 file")
      ->capture_default_str();
  cmd->add_option("--prices", c->job.names.prices,
                  "a sawyer-prices/1 file (default: the bundled example prices)");
  cmd->add_option("--position", c->job.names.position,
                  "saw here instead of at the optimiser's best: rot[,x[,y]] (degrees, mm, mm)");
  sawing::OptimiseOptions& o = c->job.optimise;
  cmd->add_option("--rot-step", o.rot_step_deg, "rotation step, degrees")->capture_default_str();
  cmd->add_option("--offsets", o.offset_x_max_mm, "x offsets −mm..+mm")->capture_default_str();
  cmd->add_option("--offset-step", o.offset_x_step_mm, "x offset step, mm")->capture_default_str();
  cmd->add_option("--offsets-y", o.offset_y_max_mm, "y offsets −mm..+mm (0: none)")
      ->capture_default_str();
  cmd->add_option("--sigma-rot", o.sigma_rot_deg, "positioning error σ in rotation, degrees")
      ->capture_default_str();
  cmd->add_option("--sigma-offset", o.sigma_offset_mm, "positioning error σ in offset, mm")
      ->capture_default_str();
  cmd->add_option("--scan-draws", o.model_draws,
                  "expected value also over this many draws of the scanned knots' diameter and "
                  "r_dead within the scan's uncertainty (0: the model as it is; docs/sawing.md)")
      ->capture_default_str();
  cmd->add_option(
      "--db", c->job.db,
      "log register (SQLite; default: $SAWYER_DB or ~/.local/share/sawyer/logs.sqlite)");
  cmd->add_flag("--no-register", c->job.no_register, "do not add the log to the register");
  cmd->add_flag("--no-report", c->job.no_report, "scan and saw only");
  add_threads_option(cmd, c->job.scan.threads);
  cmd->add_option("--stem-step", c->job.scan.stem_step_mm,
                  "the model's stem samples at most this far apart along z, mm: finer slices are "
                  "averaged (0: one sample per slice)")
      ->check(number_in(0, 1000, " mm"))
      ->capture_default_str();
  cmd->add_option("--memory", c->job.scan.memory_mb,
                  "memory budget, MB: the run fits into it (narrower knot windows, pith crops on "
                  "disk) or is refused before the scan is read")
      ->check(number_in(1, 1e7, " MB"))
      ->capture_default_str();
  cmd->add_flag("-q,--quiet", c->quiet, "no progress on stderr");
  add_ct_options(cmd, c->ct);
  cmd->callback([c, &run_out] {
    c->job.optimise.threads = c->job.scan.threads;
    c->job.scan.open = to_open_options(c->ct);
    c->job.word_note = with_flags;
    run_out = [c] { return run(*c); };
  });
}

}  // namespace sawyer::app
