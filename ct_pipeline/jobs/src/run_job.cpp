// The main job, `sawyer run` (see run_job.h): scan, saw, then the run folder and the register.
#include "sawyer/ct/jobs/run_job.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <future>
#include <optional>
#include <utility>

#include "sawyer/core/file_util.h"
#include "sawyer/core/instruction_count.h"
#include "sawyer/core/output_guard.h"
#include "sawyer/model/log_json.h"
#include "sawyer/register/ct_checksum.h"
#include "sawyer/register/log_register.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/sawing_file.h"

namespace sawyer::ct {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using Stage = report::RunInfo::Stage;

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

std::string note_text(const char* format, auto... values) {
  char note[128];
  std::snprintf(note, sizeof note, format, values...);
  return note;
}

report::RunRecord run_record(const RunJobOptions& c, const RunOutcome& run,
                             const std::string& source, const std::string& checksum,
                             const std::string& date) {
  const ScanJob& scan = run.scan;
  report::RunRecord r;
  report::RunInfo& in = r.info;
  in.not_sawn = run.not_sawn;
  in.log_id = scan.log().id;
  in.species = scan.log().species;
  in.scan_source = source;
  in.scan_description = scan.source->description();
  // Every note of the reader (resampled gaps, ignored files), and the resampling in one line.
  if (std::string z = resampling_summary(scan.source->geometry()); !z.empty())
    in.scan_notes.push_back(z);
  for (const std::string& n : scan.source->notes())
    in.scan_notes.push_back(c.word_note ? c.word_note(n) : n);
  const ZResampling& zr = scan.source->geometry().z_resampling;
  r.z_resampling = {zr.resampled, zr.source_slices, zr.invented_slices,
                    zr.gaps,      zr.widest_gap_mm, zr.widest_gap_z0};
  r.scanner_frame = scan.log().scanner_frame;
  in.scan_checksum = checksum;
  r.slices = static_cast<std::size_t>(scan.source->geometry().slice_count());
  r.knots = scan.log().knots.size();
  r.qa = scan.log().qa;
  in.date = date;
  in.sawyer_version = SAWYER_VERSION;
  // With a pattern set the pattern is chosen per log: the set is the option given.
  in.pattern = c.names.pattern_set.empty() ? c.names.pattern : "";
  in.pattern_set = c.names.pattern_set;
  in.grading = c.names.grading;
  in.prices = c.names.prices;
  in.position = c.names.position;
  in.stages = run.stages;
  in.seconds_to_decision = run.seconds_to_decision;
  in.seconds_total = run.seconds;
  if (run.sawn && run.sawn->choice) r.pattern_choice = run.sawn->choice;
  r.currency = run.setup.prices.currency;
  return r;
}

reg::LogRecord register_record(const RunOutcome& run, const std::string& source,
                               const std::string& checksum, const std::string& date) {
  const LogModel& log = run.log();
  const LogSummary& s = run.summary;
  const sawing::SawSetup& su = run.setup;
  const sawing::SawingOutcome& out = run.outcome();
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
  r.pattern = out.pattern.name;  // with a pattern set, the one chosen
  r.grading = su.rules.name;
  const sawing::LogPosition& p = run.position();
  r.rotation_deg = p.rotation_deg;
  r.offset_x_mm = p.offset_x_mm;
  r.offset_y_mm = p.offset_y_mm;
  r.value = out.chosen_value().value;
  const double hd = out.opt.horns_down.value;
  r.gain_over_horns_down =
      su.position ? (hd > 0 ? r.value / hd - 1 : 0.0) : out.opt.gain_over_horns_down;
  r.currency = su.prices.currency;
  r.output_dir = run.out_dir.string();
  r.report_path = (run.out_dir / "report" / "report.pdf").string();
  r.scanned_at = date;
  return r;
}

// What a run's files hold once written: the per-slice records and QA figures, the scan pass's
// own copy of the stem, the log model's outline, heartwood and bark (log.json holds them, and the
// report reads them back), the QA's unrolled views, the knots' traces and fit reports. The log
// model's pith, knots and QA verdict stay, for the run's record and summary (issue 24: each of
// these grows with the log's length, and the report would stack on them).
void release_written_detail(ScanResult& scan) {
  std::vector<StemSliceRecord>().swap(scan.stem.slices);
  std::vector<QaSlice>().swap(scan.qa.slices);
  scan.stem.stem = Stem{};
  Stem& st = scan.log.stem;
  std::vector<std::vector<double>>().swap(st.radius);
  std::vector<std::vector<double>>().swap(st.heartwood);
  std::vector<double>().swap(st.bark_mm);
  std::vector<std::vector<double>>().swap(st.bark);
  std::vector<UnrolledView>().swap(scan.unrolled);
  std::vector<KnotTrace>().swap(scan.knots.traces);
  std::vector<KnotFitReport>().swap(scan.knots.fits);
}

// Why the log cannot be sawn, when that is why saw_log_model() failed: the pattern (with a
// pattern set, every candidate for the log's class) needs a larger diameter than the log's usable
// one (check_setup_fits, whose message is the reason), or the position or offset grid asked for
// leaves the log's wood (check_offsets_reach: the scanned volume was checked before the scan, the
// log is known only after it). Empty for any other error.
std::optional<report::NotSawn> not_sawn_reason(const LogModel& log, const sawing::SawSetup& su,
                                               const Error& error) {
  const sawing::SawLog saw_log(log, 2);  // the usable diameter only: no knot detail
  const double usable = saw_log.usable_diameter_mm();
  const sawing::FitNeed need = sawing::fit_need(su, usable);
  if (!sawing::check_setup_fits(su, usable, log.id) ||
      !sawing::check_offsets_reach(su, sawing::wood_reach_mm(saw_log), "the log's wood"))
    return report::NotSawn{error.message(), need.pattern,
                           su.pattern_set ? su.pattern_set->name : "", need.needed_diameter_mm,
                           usable};
  return std::nullopt;
}

}  // namespace

const sawing::LogPosition& RunOutcome::position() const {
  return setup.position ? *setup.position : sawn->opt.best.pos;
}

std::string decision_line(const sawing::SawSetup& su, const sawing::SawingOutcome& out) {
  const sawing::LogPosition& p = su.position ? *su.position : out.opt.best.pos;
  // With a pattern set the saw needs to know which pattern too.
  return (out.choice ? "pattern '" + out.pattern.name + "', " : std::string()) +
         note_text("position: rot %.1f° x %+.1f y %+.1f mm, %.2f ", p.rotation_deg, p.offset_x_mm,
                   p.offset_y_mm, out.chosen_value().value) +
         su.prices.currency + "; saw set-up: " + sawing::saw_setup_line(out.saw_log, p);
}

Result<std::unique_ptr<RunOutcome>> run_job(const RunJobOptions& c, const RunObserver& obs) {
  const auto t_all = Clock::now();
  const std::string date = utc_now();
  auto update = [&](const char* stage, int done, int total, const char* unit) {
    if (obs.update) obs.update(stage, done, total, unit);
  };
  auto stage_done = [&](const char* stage, double seconds, const std::string& note) {
    if (obs.done) obs.done(stage, seconds, note);
  };
  auto run = std::make_unique<RunOutcome>();
  // Everything named in the options is checked before the scan starts.
  Result<sawing::SawSetup> setup = sawing::load_saw_setup(c.names, c.optimise);
  if (!setup) return setup.error();
  run->setup = std::move(setup.value());
  const sawing::SawSetup& su = run->setup;
  std::error_code ec;
  run->out_dir = fs::absolute(c.output, ec).lexically_normal();
  const fs::path source_path = fs::weakly_canonical(c.scan.input, ec);
  const std::string source = ec ? c.scan.input : source_path.string();
  std::optional<reg::LogRegister> reg;
  if (!c.no_register) {
    Result<fs::path> db_path =
        reg::register_path(c.db, "RunJobOptions::db", "RunJobOptions::no_register");
    if (!db_path) return db_path.error();
    run->db = db_path.value();
    // A register that exists is opened (and checked) now; a new one is made only when its row
    // is written, last, so that a run refused or failed on the way leaves no register behind
    // (issue 44). Whether it could be made is checked now, before the scan.
    if (fs::exists(fs::symlink_status(run->db, ec))) {
      Result<reg::LogRegister> r = reg::LogRegister::open(run->db);
      if (!r) return r.error();
      reg.emplace(std::move(r.value()));
    } else if (Status can = reg::check_register_creatable(run->db); !can) {
      return can.error();
    }
  }
  // Then the scan is opened (headers only), then the output is checked.
  auto opened = open_scan(c.scan);
  if (!opened) return opened.error();
  {
    // The log lies inside the scanned box, so offsets longer than its diagonal saw nothing of
    // it: refused now, before the scan (the log's own reach is checked once it is known).
    const VolumeGeometry& g = opened.value()->geometry();
    const double box =
        std::sqrt(std::pow(g.width * g.spacing_x, 2) + std::pow(g.height * g.spacing_y, 2) +
                  std::pow(g.z.empty() ? 0.0 : g.z.back() - g.z.front(), 2));
    if (Status st = sawing::check_offsets_reach(su, box, "the scanned volume"); !st)
      return st.error();
  }
  // The output may replace only an empty folder or an earlier run folder, never the scan or a
  // folder around it; the lock makes a second run of the same output refuse at once.
  OutputRequest out_req{c.output, OutputKind::kRunFolder, {c.scan.input}, "RunJobOptions::output"};
  for (const fs::path& f : sawing::setup_input_files(c.names)) out_req.inputs.push_back(f);
  if (!c.db.empty()) out_req.inputs.emplace_back(c.db);
  Result<OutputLock> lock = OutputLock::acquire(out_req);
  if (!lock) return lock.error();

  std::vector<Stage>& stages = run->stages;
  // A GL context made ahead for the report and not taken (an error on the way) is dropped
  // before returning.
  struct DropContext {
    ~DropContext() { render::drop_prewarmed_headless_context(); }
  } drop_context;
  // The register's checksum of the scan's files runs beside the scan (it only reads them, and
  // the scan leaves a core part idle): the decision does not wait for it (issue 42).
  double checksum_seconds = 0;
  std::future<Result<std::string>> checksum_job;
  if (!c.no_register)
    checksum_job = std::async(std::launch::async, [&c, &checksum_seconds] {
      const auto t0 = Clock::now();
      Result<std::string> sum = reg::ct_checksum(c.scan.input);
      checksum_seconds = since(t0);
      return sum;
    });
  mark_stage_end("setup");
  auto t = Clock::now();
  ScanJobOptions scan_options = c.scan;
  scan_options.report_mb = c.no_report ? 0.0 : kReportMemoryMb;
  Result<ScanJob> scanned = scan_ct(
      scan_options,
      [&](const char* stage, int done, int total) {
        if (std::string(stage) == "stem")
          update("scan", done, total, "slices");
        else if (done == 0)
          update("scan", 1, 1, "slices; knots...");
      },
      std::move(opened.value()));
  if (!scanned) return scanned.error();
  run->scan = std::move(scanned.value());
  const ScanJob& scan = run->scan;
  stages.push_back({"scan", since(t), peak_rss_mb()});
  const LogModel& log = scan.log();
  run->summary = summarize(log);
  stage_done("scan", stages.back().seconds,
             note_text("%zu slices, %zu knots", scan.scan.stem.slices.size(), log.knots.size()));

  t = Clock::now();
  Result<sawing::SawingOutcome> sawn = sawing::saw_log_model(
      log, su, [&](int done, int total) { update("saw", done, total, "positions"); });
  if (sawn) {
    run->sawn.emplace(std::move(sawn.value()));
  } else {
    // A complete scan is never thrown away (issue 41): a pattern too large for the log leaves
    // the scan, run.json and a report that says why. Any other failure is one.
    run->not_sawn = not_sawn_reason(log, su, sawn.error());
    if (!run->not_sawn) return sawn.error().with_context(log.id);
    // The reason may name an option (an offset off the log): in the front end's words.
    if (c.word_note) run->not_sawn->reason = c.word_note(run->not_sawn->reason);
  }
  stages.push_back({"saw", since(t), peak_rss_mb()});
  mark_stage_end("saw");
  if (run->sawn) {
    const sawing::SawingOutcome& out = run->outcome();
    stage_done(
        "saw", stages.back().seconds,
        note_text("%d positions, %zu boards", out.opt.positions, out.chosen_sawn().boards.size()));
    // The decision first, for the operator at the saw: the files and the report follow.
    if (obs.decision) obs.decision(decision_line(su, out));
  } else {
    const report::NotSawn& ns = *run->not_sawn;
    stage_done("saw", stages.back().seconds,
               ns.pattern_too_large()
                   ? note_text("not sawn: the pattern needs %.1f mm, the log has %.1f mm",
                               ns.needed_diameter_mm, ns.usable_diameter_mm)
                   : "not sawn: the offsets asked for leave the log");
  }
  run->seconds_to_decision = since(t_all);
  // The report's GL context is made while the files are written on one core (loading the GL
  // driver keeps the dynamic loader busy ~0.3 s); not beside the scan, which the decision waits
  // for and which keeps both cores busy.
  if (!c.no_report) render::prewarm_headless_context();

  std::string checksum;
  double report_seconds = 0;
  Status st = write_dir_atomic(run->out_dir, [&](const fs::path& tmp) -> Status {
    fs::create_directories(tmp / "scan");
    if (Status w = write_log_json(log, tmp / "scan" / "log.json"); !w) return w;
    // No sawing.json for a log that was not sawn: it would have no position (run.json says why).
    if (run->sawn) {
      const nlohmann::ordered_json saw_file = sawing::sawing_file_json(log, su, *run->sawn);
      if (Status w = write_text_file_atomic(tmp / "sawing.json", saw_file.dump(1) + "\n"); !w)
        return w;
    }
    if (checksum_job.valid()) {
      Result<std::string> sum = checksum_job.get();
      if (!sum) return sum.error();
      checksum = sum.value();
      stages.push_back({"checksum", checksum_seconds});
    }
    if (Status w =
            report::write_run_file(run_record(c, *run, source, checksum, date), tmp / "run.json");
        !w)
      return w;
    // The maps and QA images are drawn beside the report (issue 42: the report draws on one
    // core for most of its time), then the scan's per-slice arrays and views, which are in those
    // files now, are released.
    double write_seconds = 0, write_peak_mb = 0;
    auto write_extras = [&]() -> Status {
      const auto t_write = Clock::now();
      Status w = write_scan_extras(scan, c.scan, tmp / "scan");
      write_seconds = since(t_write);
      write_peak_mb = peak_rss_mb();
      return w;
    };
    std::future<Status> extras;
    if (c.no_report) {
      if (Status w = write_extras(); !w) return w;
      mark_stage_end("write");
    } else {
      extras = std::async(std::launch::async, write_extras);
      // The report saws the boards again from the files; the run's own sawing tables (per stem
      // sample) would only sit beside its own (issue 24: the run's peak).
      if (run->sawn) run->sawn->saw_log.release_tables();
      t = Clock::now();
      Result<report::RunFolder> folder = report::load_run_folder(tmp);
      if (!folder) return folder.error();
      Result<report::ReportFiles> files = report::write_report(
          folder.value(), tmp / "report", {},
          [&](int done, int total, const std::string&) { update("report", done, total, "steps"); });
      if (!files) return files.error();
      run->report = files.value();
      report_seconds = since(t);
      if (Status w = extras.get(); !w) return w;
      mark_stage_end("report");
      stage_done("report", report_seconds,
                 note_text("%d pages, %zu images", run->report.pages, run->report.images.size()));
    }
    release_written_detail(run->scan.scan);
    // run.json again with the times of the work done since (the report shows scan and saw).
    stages.push_back({"write", write_seconds, write_peak_mb});
    if (!c.no_report) stages.push_back({"report", report_seconds, peak_rss_mb()});
    run->seconds = since(t_all);
    if (Status w =
            report::write_run_file(run_record(c, *run, source, checksum, date), tmp / "run.json");
        !w)
      return w;
    // Last, so that a register that refuses the row leaves no output behind either. A log that
    // was not sawn has no position or value to record, and the register no column to say so.
    if (!c.no_register && run->sawn) {
      if (!reg) {
        Result<reg::LogRegister> r = reg::LogRegister::open(run->db);
        if (!r) return r.error();
        reg.emplace(std::move(r.value()));
      }
      if (Status w = reg->upsert(register_record(*run, source, checksum, date)); !w) return w;
    }
    return Status::Ok();
  });
  if (!st) return st.error();
  run->seconds = since(t_all);
  return run;
}

}  // namespace sawyer::ct
