// `sawyer export`: parses the options into ExportOptions (libs/export/export_job.h), loads the
// log, bakes the boards headless (EGL) and writes the .glb (or the .gltf and its files)
// atomically.
#include "cmd_export.h"
#include "cli_error.h"

#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "sawyer/core/output_guard.h"
#include "sawyer/export/export_job.h"
#include "sawyer/maps/open_log.h"

namespace sawyer::app {
namespace {

namespace fs = std::filesystem;

struct ExportCli {
  std::string input, output, sawing, color_maps, species, osl_data;
  std::vector<std::string> boards;
  double px_per_mm = 1.0;
  int supersample = 2;
  bool scanner_frame = false, quiet = false;
};

int run(const ExportCli& c) {
  exporter::ExportOptions o;
  o.output = c.output;
  o.sawing = c.sawing;
  for (const std::string& b : c.boards) {
    Result<BoardBox> box = BoardBox::from_string(b);
    if (!box) return fail(box.error());
    o.boards.push_back(box.value());
  }
  o.boards_in_scanner_frame = c.scanner_frame;
  o.px_per_mm = c.px_per_mm;
  o.supersample = c.supersample;
  o.color_maps = c.color_maps;
  o.species = c.species;
  o.osl_data = c.osl_data;
  if (Status st = exporter::check_export(o); !st) return fail(st.error());
  std::error_code ec;
  if (!fs::exists(c.input, ec)) return fail(Error(c.input, "no such file or folder"));
  if (!c.sawing.empty() && !fs::is_regular_file(c.sawing, ec))
    return fail(Error(c.sawing, "no such file"));
  Result<OutputLock> lock =
      OutputLock::acquire({c.output, OutputKind::kFile, {c.input, c.sawing, c.color_maps}, "-o"});
  if (!lock) return fail(lock.error());
  Result<LogModel> log = maps::open_log(c.input);
  if (!log) return fail(log.error());
  Result<exporter::ExportSummary> s = exporter::run_export(log.value(), o);
  if (!s) return fail(s.error());
  if (!c.quiet) {
    std::cout << s.value().brief(c.output, c.px_per_mm) << "\n";
    for (const exporter::ExportedBoard& b : s.value().boards)
      std::cout << "  " << b.name << ": " << b.box.width << " x " << b.box.thickness << " x "
                << (b.box.z1 - b.box.z0) << " mm, textures " << b.atlas_width << " x "
                << b.atlas_height << "\n";
  }
  return 0;
}

}  // namespace

void add_export_command(CLI::App& app, std::function<int()>& run_out) {
  auto c = std::make_shared<ExportCli>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Export boards as glTF 2.0, binary (.glb) or text (.gltf with its .bin and PNG textures "
      "beside it): a mesh per board in metres with baked colour, normal and roughness textures "
      "of every face (docs/export.md)");
  cmd->add_option("input", c->input, "log.json (or a maps / stem-bank folder)")->required();
  cmd->add_option(
         "-o,--output", c->output,
         "the .glb or .gltf to write (a .gltf writes <name>.bin and <name>_board<N>_<map>.png "
         "beside it)")
      ->required();
  cmd->add_option("--sawing", c->sawing,
                  "sawing.json of `sawyer saw` or `sawyer run`: its boards at the chosen position");
  cmd->add_option("--board", c->boards,
                  "a board as \"x,y,w,t,rot,z0,z1\" (as `sawyer render --board`); repeatable");
  cmd->add_flag("--scanner-frame", c->scanner_frame,
                "--board centres are scanner-frame coordinates, not offsets from the mean pith");
  cmd->add_option("--px-per-mm", c->px_per_mm, "texture resolution on every face (0.05..8)")
      ->capture_default_str();
  cmd->add_option("--supersample", c->supersample,
                  "n x n samples per texel: for the colour where the wood changes within it, "
                  "for the normal and roughness maps in every texel (1..4)")
      ->capture_default_str();
  cmd->add_option("--color-maps", c->color_maps,
                  "folder with the wood colour, normal and specular strips (default: bundled)");
  cmd->add_option("--species", c->species, "the look: spruce or pine (default: the log's)");
  cmd->add_option("--osl-data", c->osl_data,
                  "also write the wood field's tables for shaders/osl/sawyer_wood.osl (Blender "
                  "Cycles with OSL) into this folder");
  cmd->add_flag("-q,--quiet", c->quiet, "no summary");
  cmd->callback([c, &run_out]() { run_out = [c]() { return run(*c); }; });
}

}  // namespace sawyer::app
