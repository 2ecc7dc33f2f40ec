// `sawyer export <log> -o boards.glb (--sawing sawing.json | --board ...)`: the boards of a
// sawing position, or given boxes, as binary glTF 2.0 with baked PBR textures (libs/export,
// docs/export.md).
//
//   std::function<int()> run_export;
//   add_export_command(app, run_export);   // before app.parse()
//   if (run_export) return run_export();   // after it: set only when the subcommand was given
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace sawyer::app {

void add_export_command(CLI::App& app, std::function<int()>& run);

}  // namespace sawyer::app
