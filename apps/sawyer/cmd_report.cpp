// `sawyer report`: loads the run folder, writes <out>/report atomically, prints where it is (and,
// with --verbose, the time of each step). A missing or broken run folder gets one line naming the
// file and the problem, exit code 1, and no report folder.
#include "cmd_report.h"

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "sawyer/core/output_guard.h"
#include "sawyer/report/report.h"
#include "sawyer/report/run_folder.h"

namespace sawyer::app {
namespace {

namespace fs = std::filesystem;

struct ReportCli {
  std::string folder;
  bool verbose = false, quiet = false;
  report::ReportOptions options;
};

int run(const ReportCli& c) {
  // A run of the same folder (or another report) writing at the same time is refused.
  Result<OutputLock> lock = OutputLock::lock_only(c.folder, "");
  if (!lock) {
    std::cerr << "sawyer: " << lock.error().message() << "\n";
    return 1;
  }
  Result<report::RunFolder> folder = report::load_run_folder(c.folder);
  if (!folder) {
    std::cerr << "sawyer: " << folder.error().message() << "\n";
    return 1;
  }
  auto progress = [&c](int done, int total, const std::string& step) {
    if (c.quiet) return;
    if (done < total) std::fprintf(stderr, "report: [%d/%d] %s\n", done + 1, total, step.c_str());
  };
  const fs::path dir = fs::path(c.folder) / "report";
  Result<report::ReportFiles> files =
      report::write_report(folder.value(), dir, c.options, progress);
  if (!files) {
    std::cerr << "sawyer: " << dir.string() << ": " << files.error().message() << "\n";
    return 1;
  }
  const report::ReportFiles& f = files.value();
  if (c.verbose) {
    std::printf("%-14s %8s\n", "step", "seconds");
    for (const report::ReportFiles::Step& s : f.steps)
      std::printf("%-14s %8.3f\n", s.name.c_str(), s.seconds);
    std::printf("%-14s %8.3f\n", "total", f.seconds);
  }
  std::printf("wrote %s (report.pdf %d pages, report.html, boards.csv, report.json, %zu images)\n",
              f.dir.string().c_str(), f.pages, f.images.size());
  // A run that scanned the log but could not saw it (docs/run.md "Not sawn"): its report says
  // why, and so does this line.
  if (const auto& ns = folder.value().run.not_sawn)
    std::printf("not sawn: %s\n", ns->reason.c_str());
  return 0;
}

}  // namespace

void add_report_command(CLI::App& app, std::function<int()>& run_out) {
  auto c = std::make_shared<ReportCli>();
  CLI::App* cmd = app.add_subcommand(
      "report",
      "Write the cutting report of a run folder (scan/log.json, sawing.json, run.json) into "
      "<folder>/report: report.pdf, report.html, boards.csv, report.json, images/");
  cmd->add_option("folder", c->folder, "the run folder (`sawyer run -o`)")->required();
  cmd->add_flag("-v,--verbose", c->verbose, "print the time of each step");
  cmd->add_flag("-q,--quiet", c->quiet, "no progress on stderr");
  cmd->add_option("--board-px-per-cm", c->options.board_px_per_cm,
                  "resolution of the board face images")
      ->capture_default_str();
  cmd->add_option("--board-detail", c->options.board_detail_px_per_cm,
                  "resolution of the board faces rendered for the HTML page's zoom and the "
                  "PDF's crops around the knots that decide the grades (px/cm)")
      ->capture_default_str();
  cmd->add_option("--jpeg-quality", c->options.jpeg_quality,
                  "JPEG quality of the HTML page's board faces (1..100)")
      ->capture_default_str();
  cmd->add_option("--supersample", c->options.supersample,
                  "samples per pixel side for the board faces (1..4)")
      ->capture_default_str();
  cmd->callback([c, &run_out]() { run_out = [c]() { return run(*c); }; });
}

}  // namespace sawyer::app
