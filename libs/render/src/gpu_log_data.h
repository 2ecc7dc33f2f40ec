// The log model laid out for the GPU (shaders/wood_log_data.glsl): float arrays built on the CPU
// from a LogModel with the same rules as WoodField, uploaded by wood_renderer.cpp. No OpenGL here,
// so the layout and the knot index can be checked on their own.
#pragma once

#include <cstdint>
#include <vector>

#include "sawyer/field/wood_field.h"
#include "sawyer/model/log_model.h"

namespace sawyer::render {

// std430 layout of one knot (12 four-byte fields; shaders/wood_log_data.glsl's WoodKnot).
struct GpuKnot {
  float r_dead, r_end, d_dead, d_exp, half_dmax, pad0;
  std::int32_t track_offset, track_count;
  std::uint32_t seed, pad1, pad2, pad3;
};
static_assert(sizeof(GpuKnot) == 48);

struct IndexLayout {
  float z0 = 0, dz = 20, dr = 20;
  int nz = 1, nr = 1, ns = 1;
  int cells() const { return nz * nr * ns; }
};

struct GpuLogData {
  // Pith every pith_step mm from pith_z0 (x, y pairs).
  float pith_z0 = 0, pith_step = 1;
  std::vector<float> pith;
  // Outer and heartwood radius: stem_cols azimuths × stem_rows heights (every stem_step mm
  // from stem_z0), interleaved (R, H).
  float stem_z0 = 0, stem_step = 1;
  int stem_cols = 0, stem_rows = 0;
  std::vector<float> stem;
  bool has_heartwood = false;
  // Knots and their axis tracks (x, y, z, unwrapped azimuth every track_step mm of r).
  float track_step = 0.5f;
  std::vector<GpuKnot> knots;
  std::vector<float> tracks;
  // The knot index (compressed rows: cell c lists cell_knots[cell_start[c] .. cell_start[c+1])).
  IndexLayout index;
  std::vector<std::int32_t> cell_start, cell_knots;
  // Field parameters.
  float r_ref = 0, knot_noise = 0;
  float z_begin = 0, z_end = 0, max_radius = 0;
  Vec2 mean_pith;

  // Bytes on the GPU, the stem table at `stem_texel_bytes` a texel (WoodRenderer's RG16: 4).
  double bytes(double stem_texel_bytes = 8) const;
};

struct GpuLayoutOptions {
  double index_dz_mm = 20, index_dr_mm = 20;
  int index_sectors = 16;
  // false: the stem table's size and step are set but `stem` stays empty (max_radius 0), for a
  // caller that fills it in blocks of rows (fill_stem_rows) as it uploads them, so that the
  // whole table is never held beside the GPU's copy (issue 24: ~23 KB a stem sample).
  bool stem_table = true;
};

// Builds everything from `field` (its log, parameters and reference radius).
GpuLogData build_gpu_log_data(const WoodField& field, const GpuLayoutOptions& options);

// Rows [row0, row0 + rows) of the stem table (g's stem_cols, stem_step, stem_z0 and
// has_heartwood, set by build_gpu_log_data) into out (rows × stem_cols × 2 floats); returns
// the largest outer radius among them.
float fill_stem_rows(const Stem& stem, const GpuLogData& g, int row0, int rows, float* out);

// Pith distance beyond which knot k has no effect (the rule of WoodField).
double knot_influence_end(const Knot& k);

}  // namespace sawyer::render
