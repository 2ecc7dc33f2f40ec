// `sawyer batch`: reads the manifest, keeps the shard's rows, builds one `sawyer run` command per
// row and hands them to the job pool (libs/register/job_pool.h). The children are this very
// executable (/proc/self/exe), so a batch never mixes versions. Every child registers its own
// log in the shared register (WAL + busy timeout make concurrent writers safe on a local disk);
// the batch only reads it back for the value column of batch_<i>.csv.
#include "cmd_batch.h"
#include "cli_checks.h"
#include "cli_error.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "sawyer/core/file_util.h"
#include "sawyer/core/interrupt.h"
#include "sawyer/core/output_guard.h"
#include "sawyer/register/job_pool.h"
#include "sawyer/register/log_register.h"
#include "sawyer/register/manifest.h"

namespace sawyer::app {
namespace {

namespace fs = std::filesystem;
using namespace sawyer::reg;

struct BatchCli {
  std::string manifest, output, shard = "0/1", db;
  int jobs = 1;
  double timeout_s = 0;
  bool no_register = false;
  std::vector<std::string> pass;  // after "--": handed to every `sawyer run`
};

// Options the batch sets itself for each log; given after "--" they would clash.
bool batch_owned(const std::string& a) {
  for (const char* o : {"-o", "--output", "--id", "--db", "--no-register"})
    if (a == o || a.rfind(std::string(o) + "=", 0) == 0) return true;
  return false;
}

// Removes `--name value` and `--name=value` from args: a manifest cell overrides the batch-wide
// pass-through option (CLI11 refuses a single-valued option given twice).
void drop_option(std::vector<std::string>& args, const std::string& name) {
  std::vector<std::string> kept;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == name) {
      ++i;  // and its value
      continue;
    }
    if (args[i].rfind(name + "=", 0) == 0) continue;
    kept.push_back(args[i]);
  }
  args = std::move(kept);
}

Result<fs::path> self_exe() {
  std::error_code ec;
  fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return Error("/proc/self/exe", "cannot find this executable: " + ec.message());
  return p;
}

std::vector<std::string> run_command(const fs::path& exe, const ManifestRow& row,
                                     const fs::path& out_dir, const std::string& db,
                                     const BatchCli& c) {
  std::vector<std::string> a = {
      exe.string(), "run", row.ct_path.string(), "-o", (out_dir / row.id).string(), "--id", row.id};
  if (c.no_register)
    a.push_back("--no-register");
  else
    a.insert(a.end(), {"--db", db});
  std::vector<std::string> pass = c.pass;
  drop_option(pass, "--quiet");
  drop_option(pass, "-q");
  auto cell = [&](const char* option, const std::string& value) {
    if (value.empty()) return;
    drop_option(pass, option);
    a.insert(a.end(), {option, value});
  };
  cell("--species", row.species);
  // A row's pattern or pattern set replaces the batch-wide one of either kind (`sawyer run`
  // takes one of them).
  if (!row.pattern.empty() || !row.pattern_set.empty()) {
    drop_option(pass, "--pattern");
    drop_option(pass, "--pattern-set");
  }
  cell("--pattern", row.pattern);
  cell("--pattern-set", row.pattern_set);
  cell("--grading", row.grading);
  cell("--prices", row.prices);
  cell("--position", row.position);
  a.insert(a.end(), pass.begin(), pass.end());
  // Each run uses every core by default: with several at once, share the cores out instead of
  // oversubscribing them (an explicit --threads after -- wins).
  const bool has_threads = std::any_of(pass.begin(), pass.end(), [](const std::string& x) {
    return x == "--threads" || x.rfind("--threads=", 0) == 0;
  });
  if (c.jobs > 1 && !has_threads) {
    const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
    a.insert(a.end(), {"--threads", std::to_string(std::max(1u, cores / c.jobs))});
  }
  a.push_back("--quiet");
  return a;
}

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", s);
  return buf;
}

int run(const BatchCli& c) {
  Result<Manifest> manifest = read_manifest(c.manifest);
  if (!manifest) return fail(manifest.error());
  Result<Shard> shard = parse_shard(c.shard);
  if (!shard) return fail(shard.error());
  if (c.jobs < 1) return fail(Error("--jobs", "must be at least 1"));
  for (const std::string& a : c.pass)
    if (batch_owned(a))
      return fail(Error("options after --", "'" + a + "' is set by the batch for each log"));
  Result<fs::path> exe = self_exe();
  if (!exe) return fail(exe.error());

  // The batch's own names in the output folder cannot be log ids: a log "logs" would replace the
  // folder of every log's .out/.err.
  for (const ManifestRow& r : manifest.value().rows) {
    if (r.id == "logs" || (r.id.starts_with("batch_") && r.id.ends_with(".csv")))
      return fail(Error(c.manifest, "id '" + r.id + "' (row " + std::to_string(r.index + 1) +
                                        ") is reserved for the batch's own files (logs/, "
                                        "batch_<i>.csv); give the log another id"));
  }
  // Several shards write one batch folder at once (each its own batch_<i>.csv), so there is no
  // lock on it; but it must be empty, new, or a batch folder, and each log's `sawyer run`
  // guards and locks its own <dir>/<id>. The batch never replaces the folder whole, so a
  // manifest kept in it is fine.
  if (Status st = check_output({c.output, OutputKind::kBatchFolder, {}, "-o"}); !st)
    return fail(st.error());
  const fs::path out_dir = fs::absolute(c.output);

  // Open (and create) the register before starting anything: a bad db file should stop the
  // batch once, not fail every log (and leave no batch folder behind).
  fs::path db;
  if (!c.no_register) {
    Result<fs::path> db_path = register_path(c.db, "--db", "--no-register");
    if (!db_path) return fail(db_path.error());
    db = fs::absolute(db_path.value());
    Result<LogRegister> reg = LogRegister::open(db);
    if (!reg) return fail(reg.error());
  }
  std::error_code ec;
  fs::create_directories(out_dir / "logs", ec);
  if (ec) return fail(Error(out_dir.string(), "cannot create folder: " + ec.message()));

  std::vector<const ManifestRow*> rows;
  for (const ManifestRow& r : manifest.value().rows)
    if (shard.value().owns(r.index)) rows.push_back(&r);
  const std::string shard_text =
      std::to_string(shard.value().index) + "/" + std::to_string(shard.value().count);

  std::vector<Job> jobs;
  for (const ManifestRow* r : rows) {
    Job j;
    j.id = r->id;
    j.argv = run_command(exe.value(), *r, out_dir, db.string(), c);
    j.stdout_path = out_dir / "logs" / (r->id + ".out");
    j.stderr_path = out_dir / "logs" / (r->id + ".err");
    jobs.push_back(std::move(j));
  }
  std::cout << "batch " << c.manifest << ": " << rows.size() << " of "
            << manifest.value().rows.size() << " logs (shard " << shard_text << "), " << c.jobs
            << (c.jobs == 1 ? " job" : " jobs") << " at a time -> " << out_dir.string() << "\n"
            << std::flush;

  JobPoolOptions po;
  po.jobs = c.jobs;
  po.timeout_s = c.timeout_s;
  po.on_finished = [](const JobResult& r, int done, int total) {
    std::cout << "[" << done << "/" << total << "] " << r.id << " "
              << (r.ok()         ? "ok"
                  : r.warned()   ? "ok, QA warnings"
                  : r.not_sawn() ? "NOT SAWN"
                                 : "FAILED")
              << " " << seconds_text(r.seconds) << " s";
    // Why, for a failed log and for one the pattern does not fit.
    if (!r.completed() || r.not_sawn()) std::cout << ": " << r.error;
    std::cout << "\n" << std::flush;
  };
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<JobResult> results = run_jobs(jobs, po);
  const double total_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // A run stopped by --timeout removes its temporary output itself (SIGTERM); one that had to be
  // killed outright cannot, so its leftovers are swept here, under the run folder's lock.
  for (size_t i = 0; i < rows.size(); ++i)
    if (!results[i].completed()) (void)OutputLock::lock_only(out_dir / rows[i]->id, "");

  // The value of each good log, read back from the register its run wrote to.
  std::optional<LogRegister> reg;
  if (!c.no_register) {
    Result<LogRegister> r = LogRegister::open_read_only(db);
    if (r) reg.emplace(std::move(r).value());
  }
  // The pattern each log was sawn with (chosen per log with --pattern-set), from the register.
  std::string csv = "id,ct,status,exit_code,seconds,value,pattern,error\n";
  int failed = 0, warned = 0, not_sawn = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    const JobResult& r = results[i];
    failed += !r.completed();
    warned += r.warned();
    not_sawn += r.not_sawn();
    std::string value, pattern;
    // A log that was not sawn has no register row of this run (an earlier run's may be there).
    if (r.completed() && !r.not_sawn() && reg) {
      const fs::path source = fs::weakly_canonical(rows[i]->ct_path, ec);
      Result<std::optional<LogRecord>> rec = reg->find(source.string());
      if (rec && rec.value()) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.2f", rec.value()->value);
        value = buf;
        pattern = rec.value()->pattern;
      }
    }
    csv += csv_cell(r.id) + "," + csv_cell(rows[i]->ct_path.string()) + "," +
           (r.ok()         ? "ok"
            : r.warned()   ? "qa_warnings"
            : r.not_sawn() ? "not_sawn"
                           : "failed") +
           "," + std::to_string(r.exit_code) + "," + seconds_text(r.seconds) + "," + value + "," +
           csv_cell(pattern) + "," + csv_cell(r.error) + "\n";
  }
  const fs::path csv_path = out_dir / ("batch_" + std::to_string(shard.value().index) + ".csv");
  if (Status s = write_text_file_atomic(csv_path, csv); !s) return fail(s.error());
  std::cout << "batch: " << rows.size() - static_cast<size_t>(failed + not_sawn) << " ok ("
            << warned << " with QA warnings), " << not_sawn << " not sawn, " << failed
            << " failed of " << rows.size() << " in " << seconds_text(total_s) << " s; "
            << csv_path.string() << "\n";
  // A log that was not sawn is done (its scan and report are written; another pattern, not a
  // rerun, would saw it): it does not make the batch partial.
  return failed ? 2 : 0;
}

}  // namespace

void add_batch_command(CLI::App& app, std::function<int()>& run_out) {
  auto c = std::make_shared<BatchCli>();
  CLI::App* cmd = app.add_subcommand(
      "batch",
      "Run `sawyer run` on every CT scan of a manifest (ct,id,species,... CSV), one subprocess "
      "per log, and register them; exit 0 all done (ok, QA warnings or not sawn), 2 some "
      "failed, 1 bad manifest or options");
  cmd->add_option("manifest", c->manifest,
                  "CSV with a header: ct (required; relative to the manifest's folder), id, "
                  "species, pattern or pattern_set, grading, prices, position")
      ->required();
  cmd->add_option("-o,--output", c->output,
                  "output folder: <dir>/<id>/ per log, <dir>/logs/<id>.err, <dir>/batch_<i>.csv")
      ->required();
  cmd->add_option("-j,--jobs", c->jobs,
                  "logs at once, 1-256, each its own process (memory: N times one log's peak)")
      ->capture_default_str()
      ->check(whole_number_in(1, 256, "processes at once"));
  cmd->add_option("--shard", c->shard,
                  "i/N: only rows with row_index % N == i, 0-based, e.g. "
                  "${SLURM_ARRAY_TASK_ID}/${SLURM_ARRAY_TASK_COUNT}")
      ->capture_default_str();
  cmd->add_option("--db", c->db,
                  "the register every log goes into (default: $SAWYER_DB, else "
                  "~/.local/share/sawyer/logs.sqlite)");
  cmd->add_flag("--no-register", c->no_register, "do not register the logs");
  cmd->add_option("--timeout", c->timeout_s,
                  "seconds a log may take before it is stopped and counted failed (0: no limit)")
      ->capture_default_str()
      ->check(number_in(0, 1e7, " s", 0, "0: no limit"));
  cmd->add_option(
      "run_options", c->pass,
      "after --: options for every `sawyer run` (--pattern or --pattern-set, --grading, "
      "--prices, "
      "...); manifest cells override them");
  cmd->callback([c, &run_out]() { run_out = [c]() { return run(*c); }; });
}

}  // namespace sawyer::app
