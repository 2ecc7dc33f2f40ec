#include "cmd_scan.h"
#include "cli_checks.h"
#include "cli_error.h"

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "ct_options.h"
#include "sawyer/core/file_util.h"
#include "sawyer/core/output_guard.h"
#include "sawyer/ct/jobs/scan_job.h"

namespace sawyer::app {

namespace fs = std::filesystem;

namespace {

struct ScanCli {
  ct::ScanJobOptions job;
  CtCliOptions ct;
  std::string output;
};

int run_scan(const ScanCli& c) {
  // The input is opened first (a bad scan is named before anything else), then the output is
  // checked and locked, before the scan's real work.
  auto source = ct::open_scan(c.job);
  if (!source) return fail(source.error());
  Result<OutputLock> lock =
      OutputLock::acquire({c.output, OutputKind::kScanFolder, {c.job.input}, "-o"});
  if (!lock) return fail(lock.error());
  int next = 1;
  Result<ct::ScanJob> job = ct::scan_ct(
      c.job,
      [&](const char* stage, int done, int all) {
        if (std::string(stage) == "knots") {
          if (done == 0) std::cerr << "knots: detecting and fitting...\n";
          return;
        }
        if (done * 10 >= next * all) {
          std::cerr << "scan: " << next * 10 << "% (" << done << "/" << all << " slices)\n";
          ++next;
        }
      },
      std::move(source.value()));
  if (!job) return fail(job.error());
  Status st = write_dir_atomic(
      c.output, [&](const fs::path& tmp) { return ct::write_scan_files(job.value(), c.job, tmp); });
  if (!st) return fail(st.error());
  std::printf("%s\nmemory: peak %.0f MB; planned %s\nwrote %s\n",
              ct::scan_brief(job.value().scan, c.job.input).c_str(), ct::peak_rss_mb(),
              job.value().memory.describe().c_str(), c.output.c_str());
  if (std::string z = ct::resampling_summary(job.value().source->geometry()); !z.empty())
    std::printf("note: %s\n", z.c_str());
  // A scan whose QA verdict fails is written whole, and says so: exit 3 (README).
  if (!job.value().trusted()) {
    std::fprintf(stderr, "sawyer: %s\n", ct::qa_report(job.value().log().qa.value()).c_str());
    return 3;
  }
  return 0;
}

}  // namespace

void add_scan_command(CLI::App& app, std::function<int()>& run) {
  auto c = std::make_shared<ScanCli>();
  CLI::App* cmd = app.add_subcommand(
      "scan",
      "Analyse a CT scan of a log: pith, outer shape, heartwood and knots (log.json, maps, QA)");
  cmd->add_option("input", c->job.input, "CT scan: DICOM/TIFF/PNG folder, .vti, .mha, .nrrd")
      ->required();
  cmd->add_option("-o,--output", c->output, "folder to write (log.json, maps/, maps_float/, qa/)")
      ->required();
  cmd->add_option("--species", c->job.species, "species written into log.json")
      ->capture_default_str();
  cmd->add_option("--id", c->job.id, "log id (default: the scan's folder name)");
  add_threads_option(cmd, c->job.threads);
  cmd->add_option("--stem-step", c->job.stem_step_mm,
                  "the model's stem samples at most this far apart along z, mm: finer slices are "
                  "averaged (0: one sample per slice)")
      ->check(number_in(0, 1000, " mm"))
      ->capture_default_str();
  cmd->add_option("--memory", c->job.memory_mb,
                  "memory budget, MB: the scan fits into it (narrower knot windows, pith crops on "
                  "disk) or is refused before a slice is read")
      ->check(number_in(1, 1e7, " MB"))
      ->capture_default_str();
  cmd->add_option("--qa-slices", c->job.qa_slices, "how many slices to draw in qa/")
      ->capture_default_str();
  add_ct_options(cmd, c->ct);
  cmd->callback([c, &run] {
    c->job.open = to_open_options(c->ct);
    run = [c] { return run_scan(*c); };
  });
}

}  // namespace sawyer::app
