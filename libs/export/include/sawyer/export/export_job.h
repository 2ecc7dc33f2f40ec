// `sawyer export` as one call: the boards of a sawing position (a run's or `sawyer saw`'s
// sawing.json) or boxes given one by one, baked with the knotted-wood renderer into PBR textures
// (board_bake.h) and written as glTF 2.0 (glb_writer.h): one binary .glb, or a text .gltf with
// its .bin and PNG images beside it (the output's extension says which); a mesh per board, in
// metres, named "board 3 (A)" (its number and grade), the log's id in the scene's extras.
// docs/export.md says what is in the file and how other tools open it.
//
//   ExportOptions o;
//   o.sawing = "run/sawing.json";
//   o.output = "boards.glb";
//   if (Status st = check_export(o); !st) ...            // before the log is loaded
//   Result<ExportSummary> s = run_export(log, o);        // headless GL (EGL)
//   std::cout << s.value().brief() << "\n";
//
// Messages name the options' fields ("ExportOptions::output", ...); a front end puts its own
// names in (option_names.h). The files are written atomically: on failure nothing is left under
// their names. A .gltf's files beside it must be free or an earlier Sawyer export's of the same
// name (whose files it no longer uses are removed).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/model/board_box.h"
#include "sawyer/model/log_model.h"

namespace sawyer::exporter {

struct ExportOptions {
  // The boards: those of `sawing` (a sawing.json: its boards at the chosen position, named by
  // number and grade), or `boards` (boxes, named "board 1", ...). Exactly one of the two.
  std::filesystem::path sawing;
  std::vector<BoardBox> boards;
  // `boards`' centres are scanner-frame coordinates; else offsets from the log's mean pith line
  // (as render::RenderJob::boards).
  bool boards_in_scanner_frame = false;
  double px_per_mm = 1.0;        // texture resolution (0.05..8)
  int supersample = 2;           // n x n samples where the wood changes within a texel (1..4)
  std::filesystem::path output;  // the .glb or .gltf to write
  // Also the wood field's tables for the OSL shader (osl_data.h) into this folder: absent, empty
  // or written by Sawyer before. Empty: none.
  std::filesystem::path osl_data;
  // Folder with the renderer's colour strips (render::RenderOptions::color_maps); empty: the
  // bundled ones.
  std::filesystem::path color_maps;
  std::string species;  // the look (render::wood_look); empty: the log's species
};

// The options on their own: the output's extension, exactly one source of boards, the ranges.
Status check_export(const ExportOptions& options);

struct ExportedBoard {
  std::string name;                       // "board 3 (A)"
  int number = 0;                         // 1-based
  std::string grade;                      // empty for a given box
  BoardBox box;                           // scanner frame, mm
  int atlas_width = 0, atlas_height = 0;  // texels of each of its three maps
};

struct ExportSummary {
  std::string log_id;
  std::vector<ExportedBoard> boards;
  std::uintmax_t bytes = 0;                  // the file's size (a .gltf's with its files)
  std::vector<std::filesystem::path> files;  // a .gltf's files beside it (.bin, images)
  double seconds = 0;                        // baking and writing
  std::string context;                       // the GL context's description
  // "wrote boards.glb: 8 boards, 12.3 MiB, 1 px/mm, 4.2 s (llvmpipe ...)"; a .gltf says how
  // many files it has beside it.
  std::string brief(const std::filesystem::path& output, double px_per_mm) const;
};

// Loads the boards (sawing.json against `log`: its log id must match), bakes them on a new
// headless context and writes the .glb or .gltf. Errors name the file and the key, the board, or
// the option.
Result<ExportSummary> run_export(const LogModel& log, const ExportOptions& options);

}  // namespace sawyer::exporter
