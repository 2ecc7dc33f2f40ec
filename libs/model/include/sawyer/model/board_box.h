// A board as a box in the scanner frame: the one board shape that the sawing library places
// (sawing::board_placement), the renderer draws (render::Scene, render_board_faces), the viewer
// outlines and the report pictures. A sawn board with its knots, wane and grade is
// sawing::Board; this is only where it lies.
//
//   BoardBox b = BoardBox::from_string("0,30,150,50,0,0,4000").value();  // x,y,w,t,rot°,z0,z1
//   Vec3 across = b.u(), through = b.v();
#pragma once

#include <string>

#include "sawyer/core/result.h"
#include "sawyer/core/vec.h"

namespace sawyer {

// The cross-section is centred on (cx, cy) and rotated by `rotation` about the log axis:
// u = (cos r, sin r, 0) across the width, v = (−sin r, cos r, 0) across the thickness. The box
// spans [z0, z1] along the log. Millimetres and radians.
struct BoardBox {
  double cx = 0, cy = 0;     // mm
  double width = 150;        // mm, along u
  double thickness = 50;     // mm, along v
  double rotation = 0;       // rad
  double z0 = 0, z1 = 1000;  // mm

  Vec3 u() const;
  Vec3 v() const;
  // Checks that every value is finite, sizes > 0, z0 < z1 and all within the log model's limits
  // (log_limits, log_json.h); the error names the bad value.
  Status validate() const;
  // Parses "x,y,w,t,rot_deg,z0,z1" (mm and degrees); errors come from "BoardBox::from_string".
  static Result<BoardBox> from_string(const std::string& text);
};

}  // namespace sawyer
