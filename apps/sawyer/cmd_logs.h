// `sawyer logs [--db FILE] [filters] [--csv | --json]`: the log register (libs/register) as a
// table, CSV or JSON; `sawyer logs --db all.sqlite --merge shard_*.sqlite` merges registers
// (docs/batch.md).
//
//   std::function<int()> run_logs;
//   add_logs_command(app, run_logs);   // before app.parse()
//   ...
//   if (run_logs) return run_logs();   // after it: set only when the subcommand was given
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace sawyer::app {

// Adds the `logs` subcommand to `app`. When the command line selects it, parsing sets `run` to a
// function that does the work and returns the exit code (0, or 1 with one line on stderr).
void add_logs_command(CLI::App& app, std::function<int()>& run);

}  // namespace sawyer::app
