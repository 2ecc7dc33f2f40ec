// `sawyer run` (see cmd_run.h).
#include "cmd_run.h"
#include "cli_error.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <future>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cmd_saw.h"
#include "progress.h"
#include "sawyer/core/file_util.h"
#include "sawyer/core/output_guard.h"
#include "sawyer/model/log_json.h"
#include "sawyer/model/log_summary.h"
#include "sawyer/register/ct_checksum.h"
#include "sawyer/register/log_register.h"
#include "sawyer/report/report.h"
#include "sawyer/report/run_folder.h"
#include "sawyer/sawing/sawing_file.h"
#include "sawyer/sawing/sawing_job.h"
#include "scan_job.h"

namespace sawyer::app {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;

struct RunCli {
  ScanJobOptions scan;
  std::string output, db;
  sawing::SawNames names;
  sawing::OptimiseOptions o;
  bool no_register = false, no_report = false, quiet = false;
};

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char s[32];
  std::strftime(s, sizeof s, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return s;
}

using Stage = report::RunInfo::Stage;

report::RunRecord run_record(const RunCli& c, const ScanJob& scan, const std::string& source,
                             const std::string& checksum, const std::string& date,
                             const std::vector<Stage>& stages) {
  report::RunRecord r;
  report::RunInfo& in = r.info;
  in.log_id = scan.log().id;
  in.species = scan.log().species;
  in.scan_source = source;
  in.scan_description = scan.source->description();
  // Every note of the reader (resampled gaps, ignored files), and the resampling in one line.
  if (std::string z = ct::resampling_summary(scan.source->geometry()); !z.empty())
    in.scan_notes.push_back(z);
  for (const std::string& n : scan.source->notes()) in.scan_notes.push_back(with_flags(n));
  const ct::ZResampling& zr = scan.source->geometry().z_resampling;
  r.z_resampling = {zr.resampled, zr.source_slices, zr.invented_slices,
                    zr.gaps,      zr.widest_gap_mm, zr.widest_gap_z0};
  r.scanner_frame = scan.log().scanner_frame;
  in.scan_checksum = checksum;
  r.slices = scan.scan.stem.slices.size();
  r.knots = scan.log().knots.size();
  r.qa = scan.log().qa;
  in.date = date;
  in.sawyer_version = SAWYER_VERSION;
  in.pattern = c.names.pattern;
  in.grading = c.names.grading;
  in.prices = c.names.prices;
  in.position = c.names.position;
  in.stages = stages;
  return r;
}

reg::LogRecord register_record(const LogModel& log, const LogSummary& s, const sawing::SawSetup& su,
                               const sawing::SawingOutcome& out, const std::string& source,
                               const std::string& checksum, const fs::path& out_dir,
                               const std::string& date) {
  reg::LogRecord r;
  r.scan_source = source;
  r.scan_checksum = checksum;
  r.log_id = log.id;
  r.species = log.species;
  r.length_m = s.length_mm * 1e-3;
  r.butt_diameter_mm = s.butt_diameter_mm;
  r.top_diameter_mm = s.top_diameter_mm;
  r.mean_diameter_mm = s.mean_diameter_mm;
  r.volume_m3 = s.volume_m3;
  r.taper_mm_per_m = s.taper_mm_per_m;
  r.knot_count = s.knot_count;
  r.pattern = su.pattern.name;
  r.grading = su.rules.name;
  const sawing::LogPosition p = su.position ? *su.position : out.opt.best.pos;
  r.rotation_deg = p.rotation_deg;
  r.offset_x_mm = p.offset_x_mm;
  r.offset_y_mm = p.offset_y_mm;
  r.value = out.chosen_value().value;
  const double hd = out.opt.horns_down.value;
  r.gain_over_horns_down =
      su.position ? (hd > 0 ? r.value / hd - 1 : 0.0) : out.opt.gain_over_horns_down;
  r.currency = su.prices.currency;
  r.output_dir = out_dir.string();
  r.report_path = (out_dir / "report" / "report.pdf").string();
  r.scanned_at = date;
  return r;
}

int run(const RunCli& c) {
  const auto t_all = Clock::now();
  const std::string date = utc_now();
  // Everything named on the command line is checked before the scan starts.
  Result<sawing::SawSetup> setup = load_saw_setup(c.names, c.o);
  if (!setup) return fail(setup.error());
  const sawing::SawSetup& su = setup.value();
  std::error_code ec;
  const fs::path out_dir = fs::absolute(c.output, ec).lexically_normal();
  const fs::path source_path = fs::weakly_canonical(c.scan.input, ec);
  const std::string source = ec ? c.scan.input : source_path.string();
  std::optional<reg::LogRegister> reg;
  fs::path db;
  if (!c.no_register) {
    Result<fs::path> db_path = reg::register_path(c.db, "--db", "--no-register");
    if (!db_path) return fail(db_path.error());
    db = db_path.value();
    Result<reg::LogRegister> r = reg::LogRegister::open(db);
    if (!r) return fail(r.error());
    reg.emplace(std::move(r.value()));
  }
  // Then the scan is opened (headers only), then the output is checked.
  auto opened = open_scan(c.scan);
  if (!opened) return fail(opened.error());
  // The output may replace only an empty folder or an earlier run folder, never the scan or a
  // folder around it; the lock makes a second run of the same -o refuse at once.
  OutputRequest out_req{c.output, OutputKind::kRunFolder, {c.scan.input}, "-o"};
  for (const fs::path& f : saw_input_files(c.names)) out_req.inputs.push_back(f);
  if (!c.db.empty()) out_req.inputs.emplace_back(c.db);
  Result<OutputLock> lock = OutputLock::acquire(out_req);
  if (!lock) return fail(lock.error());

  StageBar bar(c.quiet);
  std::vector<Stage> stages;
  auto t = Clock::now();
  Result<ScanJob> scanned = scan_ct(
      c.scan,
      [&](const char* stage, int done, int total) {
        if (std::string(stage) == "stem")
          bar.update("scan", done, total, "slices");
        else if (done == 0)
          bar.update("scan", 1, 1, "slices; knots...");
      },
      std::move(opened.value()));
  if (!scanned) return fail(scanned.error());
  const ScanJob& scan = scanned.value();
  stages.push_back({"scan", since(t)});
  const LogModel& log = scan.log();
  const LogSummary summary = summarize(log);
  {
    char note[128];
    std::snprintf(note, sizeof note, "%zu slices, %zu knots", scan.scan.stem.slices.size(),
                  log.knots.size());
    bar.done("scan", stages.back().seconds, note);
  }

  t = Clock::now();
  Result<sawing::SawingOutcome> sawn = saw_log_model(
      log, su, [&](int done, int total) { bar.update("saw", done, total, "positions"); });
  if (!sawn) return fail(sawn.error().with_context(log.id));
  const sawing::SawingOutcome& out = sawn.value();
  stages.push_back({"saw", since(t)});
  {
    char note[128];
    std::snprintf(note, sizeof note, "%d positions, %zu boards", out.opt.positions,
                  out.chosen_sawn().boards.size());
    bar.done("saw", stages.back().seconds, note);
  }
  // The decision first, for the operator at the saw: the files and the report follow.
  {
    const sawing::LogPosition& p = su.position ? *su.position : out.opt.best.pos;
    std::printf("position: rot %.1f° x %+.1f y %+.1f mm, %.2f %s; saw set-up: %s\n", p.rotation_deg,
                p.offset_x_mm, p.offset_y_mm, out.chosen_value().value, su.prices.currency.c_str(),
                sawing::saw_setup_line(out.saw_log, p).c_str());
    std::fflush(stdout);
  }

  std::string checksum;
  double report_seconds = 0;
  report::ReportFiles report_files;
  Status st = write_dir_atomic(out_dir, [&](const fs::path& tmp) -> Status {
    fs::create_directories(tmp / "scan");
    if (Status w = write_log_json(log, tmp / "scan" / "log.json"); !w) return w;
    const Json saw_file = sawing_file_json(log, su, out);
    if (Status w = write_text_file_atomic(tmp / "sawing.json", saw_file.dump(1) + "\n"); !w)
      return w;
    if (!c.no_register) {
      t = Clock::now();
      Result<std::string> sum = reg::ct_checksum(c.scan.input);
      if (!sum) return sum.error();
      checksum = sum.value();
      stages.push_back({"checksum", since(t)});
    }
    if (Status w = report::write_run_file(run_record(c, scan, source, checksum, date, stages),
                                          tmp / "run.json");
        !w)
      return w;
    // The maps and QA images are written beside the report (mostly single-threaded work on
    // both sides); the future's destructor waits for them on every way out of this function.
    double write_seconds = 0;
    std::future<Status> extras = std::async(std::launch::async, [&] {
      const auto t0 = Clock::now();
      Status w = write_scan_extras(scan, c.scan, tmp / "scan");
      write_seconds = since(t0);
      return w;
    });
    if (!c.no_report) {
      t = Clock::now();
      Result<report::RunFolder> folder = report::load_run_folder(tmp);
      if (!folder) return folder.error();
      Result<report::ReportFiles> files = report::write_report(
          folder.value(), tmp / "report", {}, [&](int done, int total, const std::string&) {
            bar.update("report", done, total, "steps");
          });
      if (!files) return files.error();
      report_files = files.value();
      report_seconds = since(t);
      char note[128];
      std::snprintf(note, sizeof note, "%d pages, %zu images", report_files.pages,
                    report_files.images.size());
      bar.done("report", report_seconds, note);
    }
    if (Status w = extras.get(); !w) return w;
    // run.json again with the times of the work done since (the report shows scan and saw).
    stages.push_back({"write", write_seconds});
    if (!c.no_report) stages.push_back({"report", report_seconds});
    if (Status w = report::write_run_file(run_record(c, scan, source, checksum, date, stages),
                                          tmp / "run.json");
        !w)
      return w;
    // Last, so that a register that refuses the row leaves no output behind either.
    if (reg) {
      if (Status w =
              reg->upsert(register_record(log, summary, su, out, source, checksum, out_dir, date));
          !w)
        return w;
    }
    return Status::Ok();
  });
  if (!st) return fail(st.error());

  // The one-screen summary.
  const std::string& cur = su.prices.currency;
  const sawing::LogPosition p = su.position ? *su.position : out.opt.best.pos;
  std::printf(
      "\nlog %s (%s): %.2f m, diameter butt %.0f / top %.0f / mean %.0f mm, %.3f m3, "
      "taper %.1f mm/m, %d knots (%d with a dead part)\n",
      log.id.c_str(), log.species.c_str(), summary.length_mm * 1e-3, summary.butt_diameter_mm,
      summary.top_diameter_mm, summary.mean_diameter_mm, summary.volume_m3, summary.taper_mm_per_m,
      summary.knot_count, summary.dead_knots);
  std::printf("pattern %s, grading %s: %s position rot %.1f° x %+.1f y %+.1f mm, value %.2f %s",
              su.pattern.name.c_str(), su.rules.name.c_str(), su.position ? "given" : "best",
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
  if (out.opt.model_draws > 0)
    std::printf("values averaged over the model and %d draws of its scan uncertainty (%s)\n",
                out.opt.model_draws, out.opt.spread_note.c_str());
  if (const std::string note = with_flags(sawing::offset_edge_note(out.opt));
      !su.position && !note.empty())
    std::printf("note: %s\n", note.c_str());
  if (std::string z = ct::resampling_summary(scan.source->geometry()); !z.empty())
    std::printf("note: %s\n", z.c_str());
  double board_m3 = 0;
  for (const auto& b : out.chosen_sawn().boards) board_m3 += b.volume_m3;
  print_boards(out.chosen_sawn(), out.chosen_value(), su.rules, cur, stdout);
  std::printf("boards %.4f m3 of %.4f m3: volume yield %.1f %%\n", board_m3, summary.volume_m3,
              summary.volume_m3 > 0 ? 100 * board_m3 / summary.volume_m3 : 0.0);
  std::printf("time:");
  for (const Stage& s : stages) std::printf(" %s %.2f s,", s.name.c_str(), s.seconds);
  std::printf(" total %.2f s\n", since(t_all));
  if (reg) std::printf("register: %s\n", db.string().c_str());
  std::printf("%s\n", qa_report(log.qa.value_or(ScanQa{})).c_str());
  if (!c.no_report)
    std::printf("report: %s\n        %s\n", (out_dir / "report" / "report.pdf").string().c_str(),
                (out_dir / "report" / "report.html").string().c_str());
  else
    std::printf("results: %s\n", out_dir.string().c_str());
  // Everything was written; the scan's QA verdict failed, so the position is not to be trusted:
  // "completed with warnings" (README, exit codes).
  if (!scan.trusted()) {
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
      "report (PDF, HTML, CSV, JSON) out; the log registered");
  cmd->add_option("input", c->scan.input, "CT scan: DICOM/TIFF/PNG folder, .vti, .mha, .nrrd")
      ->required();
  cmd->add_option("-o,--output", c->output,
                  "folder to write (scan/, sawing.json, run.json, report/); replaced whole")
      ->required();
  cmd->add_option("--id", c->scan.id, "log id (default: the scan's folder name)");
  cmd->add_option("--species", c->scan.species, "species")->capture_default_str();
  cmd->add_option("--pattern", c->names.pattern, "2ex | 4ex | tt | a sawyer-pattern/1 file")
      ->capture_default_str();
  cmd->add_option("--grading", c->names.grading, "nordic | gost | a sawyer-grading/1 file")
      ->capture_default_str();
  cmd->add_option("--prices", c->names.prices,
                  "a sawyer-prices/1 file (default: the bundled example prices)");
  cmd->add_option("--position", c->names.position,
                  "saw here instead of at the optimiser's best: rot[,x[,y]] (degrees, mm, mm)");
  sawing::OptimiseOptions& o = c->o;
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
      "--db", c->db,
      "log register (SQLite; default: $SAWYER_DB or ~/.local/share/sawyer/logs.sqlite)");
  cmd->add_flag("--no-register", c->no_register, "do not add the log to the register");
  cmd->add_flag("--no-report", c->no_report, "scan and saw only");
  cmd->add_option("--threads", c->scan.threads, "worker threads, 1-256 (default: all cores)")
      ->check(CLI::Range(1, 256));
  cmd->add_flag("-q,--quiet", c->quiet, "no progress on stderr");
  add_ct_options(cmd, c->scan.ct);
  cmd->callback([c, &run_out] {
    c->o.threads = c->scan.threads;
    run_out = [c] { return run(*c); };
  });
}

}  // namespace sawyer::app
