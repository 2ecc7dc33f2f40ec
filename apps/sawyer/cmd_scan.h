// `sawyer scan <ct> -o <out>`: a CT scan in, the log model out (stem now; knots with issue 5):
// out/log.json, out/maps/ (the published map format), out/qa/ (slices with the pith, outer
// contour and heartwood border drawn, and a plot of the pith track).
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace sawyer::app {

// Adds the `scan` subcommand; when parsing selects it, `run` is set to the work (exit code).
void add_scan_command(CLI::App& app, std::function<int()>& run);

}  // namespace sawyer::app
