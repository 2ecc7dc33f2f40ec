// Boards in the scanner frame (see placement.h).
#include "sawyer/sawing/placement.h"

#include <cmath>

namespace sawyer::sawing {

// saw(): pattern (u, v) = Rot(φ)·(scanner − line_at(z)) − offset, φ = 270° − horns azimuth +
// rotation.
double pattern_rotation(const SawLog& log, const LogPosition& pos) {
  return log.turn_at_zero() + pos.rotation_deg * kPi / 180.0;
}

Vec2 pattern_to_scanner(const SawLog& log, const LogPosition& pos, double u, double v, double z) {
  const double phi = pattern_rotation(log, pos);
  const double c = std::cos(phi), s = std::sin(phi);
  const Vec2 o = log.line_at(z);
  const double a = u + pos.offset_x_mm, b = v + pos.offset_y_mm;
  return {o.x + c * a + s * b, o.y - s * a + c * b};  // Rot(−φ)
}

double to_scanner_z(const LogModel& model, double z) {
  return model.scanner_frame ? model.scanner_frame->scanner_z(z) : z;
}

double from_scanner_z(const LogModel& model, double scanner_z) {
  if (!model.scanner_frame) return scanner_z;
  const ScannerFrame& f = *model.scanner_frame;
  return (scanner_z - f.z0_mm) * (f.z_dir < 0 ? -1.0 : 1.0);
}

ScannerPosition scanner_position(const SawLog& log, const LogPosition& pos) {
  const LogModel& m = log.model();
  const double z0 = m.stem.z_begin(), z1 = m.stem.z_end(), zm = 0.5 * (z0 + z1);
  ScannerPosition s;
  s.turn_deg = std::remainder(pattern_rotation(log, pos) * 180.0 / kPi, 360.0);
  if (s.turn_deg <= -180.0) s.turn_deg += 360.0;
  s.centre = pattern_to_scanner(log, pos, 0, 0, zm);
  s.centre_z = to_scanner_z(m, zm);
  const double dz = to_scanner_z(m, z1) - to_scanner_z(m, z0);
  if (dz != 0) {
    const Vec2 d = pattern_to_scanner(log, pos, 0, 0, z1) - pattern_to_scanner(log, pos, 0, 0, z0);
    s.slope = (1.0 / dz) * d;
  }
  return s;
}

std::array<Vec3, 2> pattern_centre_at_ends(const SawLog& log, const LogPosition& pos) {
  const ScannerPosition s = scanner_position(log, pos);
  const Stem& stem = log.model().stem;
  std::array<Vec3, 2> ends;
  const double zs[2] = {stem.z_begin(), stem.z_end()};
  for (int e = 0; e < 2; ++e) {
    const double sz = to_scanner_z(log.model(), zs[e]);
    const Vec2 c = s.centre_at(sz);
    ends[e] = {c.x, c.y, sz};
  }
  return ends;
}

BoardBox board_placement(const SawLog& log, const Board& b, const LogPosition& pos) {
  const double zmid = 0.5 * (b.z_begin + b.z_end);
  const Vec2 centre = pattern_to_scanner(log, pos, b.u_mm, b.v_mm, zmid);
  BoardBox p;
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
