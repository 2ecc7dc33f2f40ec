// `sawyer report <out>`: regenerates <out>/report (the cutting report: PDF, HTML, boards.csv,
// report.json, images) from a run folder's saved results (libs/report, docs/report.md).
//
//   std::function<int()> run_report;
//   add_report_command(app, run_report);   // before app.parse()
//   ...
//   if (run_report) return run_report();   // after it: set only when the subcommand was given
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace sawyer::app {

// Adds the `report` subcommand to `app`. When the command line selects it, parsing sets `run` to a
// function that does the work and returns the exit code (0, or 1 with one line on stderr).
void add_report_command(CLI::App& app, std::function<int()>& run);

}  // namespace sawyer::app
