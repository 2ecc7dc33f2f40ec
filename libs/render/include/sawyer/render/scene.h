// What the renderer draws, in the log frame (docs/architecture.md 3: mm, radians, z along the log).
//
//   BoardBox b = BoardBox::from_string("0,30,150,50,0,0,4000").value();  // board_box.h
//   Scene s;
//   s.boards.push_back(b);
//   s.cross_sections.push_back(1200.0);
//   s.log_surface = true;
#pragma once

#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/model/board_box.h"
#include "sawyer/render/camera.h"

namespace sawyer::render {

// The faces of a board, as a bit mask.
enum class Face : unsigned {
  kTop = 1,      // wide face on the +v side (v = the thickness direction)
  kBottom = 2,   // wide face on the -v side
  kLeft = 4,     // narrow face (edge) on the -u side (u = the width direction)
  kRight = 8,    // narrow face on the +u side
  kButt = 16,    // end at z0
  kTopEnd = 32,  // end at z1
};
inline constexpr unsigned kAllFaces = 63;
inline constexpr unsigned kLongFaces = 15;  // top, bottom, left, right

// "top", "bottom", "left", "right", "butt", "end".
const char* face_name(Face f);

// The face `f` of board box `b` (board_box.h) as a rectangle seen from outside the board. Long
// faces: image x along the log (z0 → z1), image y across the face. End faces: x along u, y along
// v (seen from outside). Where the box leaves the log (wane) the renderer draws nothing.
PlaneRect board_face(const BoardBox& b, Face f);

// A longitudinal section: the plane containing the log's mean pith line at azimuth `angle`
// (rad, docs/architecture.md 3), shifted by `offset` mm along its normal; spans the whole log.
struct LongitudinalSection {
  double angle = 0;
  double offset = 0;
};

// How fragments are coloured.
enum class ShadeMode {
  kWood,       // the knotted-wood colour with lighting (the paper's renderer and more)
  kTimeField,  // raw float output: (t, t_stem, t_knot, knot index + dead flag), for tests/tools
};

struct Scene {
  std::vector<BoardBox> boards;
  unsigned board_faces = kAllFaces;
  std::vector<double> cross_sections;  // heights z, mm
  std::vector<LongitudinalSection> longitudinal_sections;
  bool log_surface = false;  // the outer surface under the bark
  // The part of the outer surface drawn (mm along the log), e.g. up to where boards are sawn out.
  double surface_z0 = -1e30, surface_z1 = 1e30;
  // Extra rectangles drawn with the wood (e.g. a face view's plane).
  std::vector<PlaneRect> planes;
  // Skip the far sides of the log surface and of closed boards (all six faces): they are hidden
  // (the shader's discard keeps the GPU from testing depth before shading, so this halves their
  // cost). Turn off to look into a log whose ends are not drawn.
  bool cull_hidden = true;
};

}  // namespace sawyer::render
