// `sawyer render <log.json> -o <image>`: headless images of a log model with the knotted-wood
// renderer (libs/render, docs/render.md): a board's faces, a cross-section, a longitudinal
// section, or a 3D view.
//
//   std::function<int()> run_render;
//   add_render_command(app, run_render);   // before app.parse()
//   ...
//   if (run_render) return run_render();   // after it: set only when the subcommand was given
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace sawyer::app {

void add_render_command(CLI::App& app, std::function<int()>& run);

}  // namespace sawyer::app
