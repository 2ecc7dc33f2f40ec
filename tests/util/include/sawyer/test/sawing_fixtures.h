// Synthetic logs, knots and patterns whose sawing answers are known, shared by the sawing,
// grading and optimiser tests. Header-only: only tests that link sawyer::sawing include it.
#pragma once

#include <functional>
#include <vector>

#include "sawyer/model/log_model.h"
#include "sawyer/sawing/pattern.h"

namespace sawyer::test {

// A log along z from 0 to `length` (10 mm samples from z = 5), radius R(z), pith p(z), 360
// angles.
inline LogModel synthetic_log(
    double length, const std::function<double(double)>& radius,
    const std::function<Vec2(double)>& pith = [](double) {
      return Vec2{0, 0};
    }) {
  LogModel log;
  log.id = "synthetic";
  log.stem.dz_mm = 10.0;
  log.stem.z0_mm = 5.0;
  log.stem.n_angles = 360;
  const int n = static_cast<int>(length / 10.0);
  for (int i = 0; i < n; ++i) {
    const double z = log.stem.z_at(i);
    log.stem.pith.push_back(pith(z));
    log.stem.radius.push_back(std::vector<double>(360, radius(z)));
  }
  return log;
}

// A straight cylinder of radius R about the z axis.
inline LogModel cylinder_log(double R, double length = 3000.0) {
  return synthetic_log(length, [R](double) { return R; });
}

// A straight horizontal knot at height z0 along azimuth omega0 (rad): axis r ↦ (r cos ω, r sin ω,
// z0), diameter d(r) = d_dead·r/r_dead up to r_dead, then d_dead (dead), ending at r = 150.
inline Knot straight_knot(int id, double z0, double omega0, double r_dead = 60.0,
                          double d_dead = 30.0) {
  Knot k;
  k.id = id;
  k.z0 = z0;
  k.omega0 = omega0;
  k.r_dead = r_dead;
  k.r_end = 150.0;
  k.diameter.d_dead = d_dead;
  k.diameter.exponent = 1.0;
  return k;
}

// One board "b" centred at (u, v) of the pattern frame, kept at any length.
inline sawing::Pattern single_board_pattern(
    double u, double v, double thickness, double width,
    sawing::ThicknessAxis axis = sawing::ThicknessAxis::kU) {
  sawing::Pattern p;
  p.name = "test";
  p.wane.min_length_mm = 0;
  p.wane.length_step_mm = 0;
  sawing::BoardSpec b;
  b.name = "b";
  b.u_mm = u;
  b.v_mm = v;
  b.thickness_mm = thickness;
  b.width_mm = width;
  b.thickness_axis = axis;
  p.boards.push_back(b);
  return p;
}

}  // namespace sawyer::test
