// `sawyer run <ct> -o <out>`: the main job end to end. The CT scan is analysed (stem and knots),
// sawn over the rotation × offset grid (or at --position), and the cutting report written; the
// log goes into the register. Progress per stage on stderr, a one-screen summary on stdout.
// <out> appears whole or not at all: scan/ (as `sawyer scan`), sawing.json (as `sawyer saw`),
// run.json (provenance and stage times), report/ (docs/report.md).
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace sawyer::app {

void add_run_command(CLI::App& app, std::function<int()>& run);

}  // namespace sawyer::app
