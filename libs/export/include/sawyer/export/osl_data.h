// The wood field's tables for shaders/osl/sawyer_wood.osl (Blender's Cycles with OSL): what
// `sawyer export --osl-data DIR` writes. docs/export.md ("OSL") says how to use them.
//
//   Status st = write_osl_data("osl", log, {});   // a new folder, or one this wrote before
//
// DIR holds, from render::field_tables (the GLSL renderer's own tables, at float precision):
//   pith.exr     pith_count × 1 texels (x, y, 0, 0), mm
//   stem.exr     stem_cols × stem_rows texels (R, H, 0, 0), mm
//   knots.exr    3 × knot_count texels: (r_dead, r_end, d_dead, d_exp),
//                (half_dmax, track_offset, track_count, seed & 0xffff), (seed >> 16, 0, 0, 0)
//   tracks.exr   kOslTrackRow × track_rows texels (x, y, z, azimuth), track i at
//                (i mod kOslTrackRow, i / kOslTrackRow)
//   cell_start.exr, cell_knots.exr   the knot index (render::FieldTables' cell_start and
//                cell_knots), one integer a texel in R, laid out as tracks.exr
//   wood_bar_color.bmp   the colour strip (when the colour maps are at hand)
//   sawyer_osl.json      "sawyer-osl/1": the log id and the shader's parameters by name: the
//                tables' sizes and steps, the index's cells, and the look's colours ([r, g, b])
//                and figures (wood.frag's, for the species of RenderOptions or the log)
// All EXRs are 32-bit float RGBA, row 0 first.
#pragma once

#include <filesystem>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"
#include "sawyer/render/wood_renderer.h"

namespace sawyer::exporter {

inline constexpr const char* kOslFormatTag = "sawyer-osl/1";
inline constexpr int kOslTrackRow = 1024;  // SW_TRACK_ROW in shaders/osl/sawyer_wood.h

// Whether `dir` may be written: absent, an empty folder, or a folder holding sawyer_osl.json
// (this writer's own). The error names `option` and the path.
Status check_osl_data_dir(const std::filesystem::path& dir, const std::string& option);

// Writes the folder atomically (staged beside it, then swapped in). `options`: the field's
// parameters and the colour maps folder, as the renderer's.
Status write_osl_data(const std::filesystem::path& dir, const LogModel& log,
                      const render::RenderOptions& options);

}  // namespace sawyer::exporter
