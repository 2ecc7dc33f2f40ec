// Triangle meshes for the viewer's 3D view that the wood renderer does not draw: the knots as
// tubes around their axes (from the knot formula, docs/architecture.md 4) and line outlines (a
// board's box). Pure geometry in the log frame (mm); gl_layers.h draws them.
//
//   MeshOptions o;
//   Mesh tubes = knot_tubes(log, o);   // sound part brown, dead part near black
//   Mesh box = board_outline(board, {1, 1, 0.3f});
//   Mesh shell = bark_surface(log.stem, 8.0, {0.46f, 0.35f, 0.29f});   // the report's cut view
#pragma once

#include <array>
#include <vector>

#include "sawyer/model/log_model.h"
#include "sawyer/render/scene.h"

namespace sawyer::render {

using Rgb = std::array<float, 3>;

struct MeshVertex {
  float pos[3];
  float normal[3];
  float color[3];
};

// Triangles (three vertices each) or lines (two each).
struct Mesh {
  std::vector<MeshVertex> vertices;
  bool lines = false;
};

struct KnotTubeOptions {
  int rings = 28;  // samples along the pith distance, denser near the pith (the √r term)
  int sides = 12;  // vertices around each ring
  double min_diameter_mm = 2.0;  // thinner parts are drawn this thick, so every knot shows
  Rgb sound_color{0.62f, 0.33f, 0.16f};
  Rgb dead_color{0.10f, 0.09f, 0.08f};
};

// One closed tube per knot: rings perpendicular to the axis at pith distances 0 .. r_end with
// the diameter d(r); the sound part (r ≤ r_dead) in sound_color, the dead part in dead_color
// (the colour changes sharply at r_dead), a cap at r_end.
Mesh knot_tubes(const LogModel& log, const KnotTubeOptions& options = {});

// The twelve edges of a board's box, as lines.
Mesh board_outline(const BoardBox& board, const Rgb& color);

// The outer surface under the bark as a light mesh: `angles` around (the stem's outline,
// interpolated), a ring every `step_mm` along the log and at both ends, outward normals.
Mesh log_surface(const Stem& stem, const Rgb& color, int angles = 120, double step_mm = 20.0);

// The log's outer surface over its bark, for a translucent shell (the report's cut view): the
// outline radius plus the bark thickness at each height (Stem::bark_mm, linear between samples;
// `default_bark_mm` where the model has none), `angles` around, a ring every `step_mm`, outward
// normals, and at each end the bark's ring between the wood and the bark's outside.
Mesh bark_surface(const Stem& stem, double default_bark_mm, const Rgb& color, int angles = 120,
                  double step_mm = 20.0);

// A board's box as a closed solid: its six faces (two triangles each) with outward normals.
Mesh board_block(const BoardBox& board, const Rgb& color);

// The pith line from the first to the last stem sample, as lines.
Mesh pith_line(const Stem& stem, const Rgb& color);

}  // namespace sawyer::render
