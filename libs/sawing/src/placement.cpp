// Boards in the scanner frame (see placement.h).
#include "sawyer/sawing/placement.h"

#include <cmath>

namespace sawyer::sawing {

// saw(): pattern (u, v) = Rot(φ)·(scanner − line_at(z)) − offset, φ = 270° − horns azimuth +
// rotation.
double pattern_rotation(const SawLog& log, const LogPosition& pos) {
  return (1.5 * kPi - log.bow().horns_azimuth) + pos.rotation_deg * kPi / 180.0;
}

Vec2 pattern_to_scanner(const SawLog& log, const LogPosition& pos, double u, double v, double z) {
  const double phi = pattern_rotation(log, pos);
  const double c = std::cos(phi), s = std::sin(phi);
  const Vec2 o = log.line_at(z);
  const double a = u + pos.offset_x_mm, b = v + pos.offset_y_mm;
  return {o.x + c * a + s * b, o.y - s * a + c * b};  // Rot(−φ)
}

BoardPlacement board_placement(const SawLog& log, const Board& b, const LogPosition& pos) {
  const double zmid = 0.5 * (b.z_begin + b.z_end);
  const Vec2 centre = pattern_to_scanner(log, pos, b.u_mm, b.v_mm, zmid);
  BoardPlacement p;
  p.cx = centre.x;
  p.cy = centre.y;
  // Pattern u in the scanner frame is Rot(−φ)(1, 0), at angle −φ. The placement's width runs
  // along its rotation, so a board whose thickness runs along u is turned a further 90°.
  const bool thick_along_u = b.thickness_axis == ThicknessAxis::kU;
  p.rotation = -pattern_rotation(log, pos) + (thick_along_u ? 0.5 * kPi : 0.0);
  p.width = b.width_mm;
  p.thickness = b.thickness_mm;
  p.z0 = b.z_begin;
  p.z1 = b.z_end;
  return p;
}

}  // namespace sawyer::sawing
