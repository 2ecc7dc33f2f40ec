// `sawyer phantom <log.json> -o <folder>`: synthetic CT of a log model with ground truth
// (ct_pipeline/phantom, docs/phantom.md).
//
//   std::function<int()> run_phantom;
//   add_phantom_command(app, run_phantom);   // before app.parse()
//   ...
//   if (run_phantom) return run_phantom();   // after it: set only when the subcommand was given
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace sawyer::app {

// Adds the `phantom` subcommand to `app`. When the command line selects it, parsing sets `run`
// to a function that does the work and returns the exit code (0, or 1 with one line on stderr).
void add_phantom_command(CLI::App& app, std::function<int()>& run);

}  // namespace sawyer::app
