// The wood field's tables as the GLSL renderer uploads them (shaders/wood_log_data.glsl), for
// other evaluators of the same field: the OSL shader of shaders/osl/ reads them from files that
// `sawyer export --osl-data` writes (libs/export osl_data.h). Built by the same code as the
// renderer's upload (build_gpu_log_data), so the two see identical numbers.
//
//   FieldTables t = field_tables(log, {});     // render::RenderOptions: field and index options
//   float x = t.pith[2 * i], y = t.pith[2 * i + 1];
//
// No OpenGL. Millimetres, radians; the scanner frame.
#pragma once

#include <cstdint>
#include <vector>

#include "sawyer/model/log_model.h"
#include "sawyer/render/wood_renderer.h"

namespace sawyer::render {

// One knot (wood_log_data.glsl's WoodKnot without its padding).
struct FieldKnot {
  float r_dead = 0, r_end = 0, d_dead = 0, d_exp = 0, half_dmax = 0;
  std::int32_t track_offset = 0, track_count = 0;
  std::uint32_t seed = 0;
};

struct FieldTables {
  // Pith (x, y) every pith_step mm of height from pith_z0; linear between.
  float pith_z0 = 0, pith_step = 1;
  std::vector<float> pith;
  // Outer and heartwood radius (R, H interleaved; H 0: none): stem_cols azimuths (column c at
  // 2π c / stem_cols) × stem_rows heights every stem_step mm from stem_z0. The shader samples it
  // as a texture: bilinear, periodic in azimuth, clamped in height, at texel coordinate
  // (ω / 2π · cols − 0.5, (z − z0) / step).
  float stem_z0 = 0, stem_step = 1;
  int stem_cols = 0, stem_rows = 0;
  std::vector<float> stem;
  // Knots and their axis tracks (x, y, z, unwrapped azimuth every track_step mm of pith
  // distance from 0).
  float track_step = 0.5f;
  std::vector<FieldKnot> knots;
  std::vector<float> tracks;
  // The knot index (wood_log_data.glsl's cell_start[], cell_knots[]): cell (zc, rc, sc) of
  // height from cell_z0 in steps of cell_dz, pith distance in steps of cell_dr and azimuth in
  // cell_ns sectors is (zc × cell_nr + rc) × cell_ns + sc; it lists the knots
  // cell_knots[cell_start[cell] .. cell_start[cell + 1]), those whose range of influence can
  // reach it (the last band and the first and last heights take what lies beyond them).
  float cell_z0 = 0, cell_dz = 20, cell_dr = 20;
  int cell_nz = 1, cell_nr = 1, cell_ns = 1;
  std::vector<std::int32_t> cell_start, cell_knots;
  // The field's parameters.
  float r_ref = 0, knot_noise = 0;
  float z_begin = 0, z_end = 0;
};

// The tables of `log` with the field parameters of `options` (RenderOptions::field).
FieldTables field_tables(const LogModel& log, const RenderOptions& options = {});

}  // namespace sawyer::render
