#include "sawyer/render/field_tables.h"

#include "gpu_log_data.h"

namespace sawyer::render {

FieldTables field_tables(const LogModel& log, const RenderOptions& options) {
  const WoodField field(log, options.field);
  GpuLayoutOptions lo;
  lo.index_dz_mm = options.index_dz_mm;
  lo.index_dr_mm = options.index_dr_mm;
  lo.index_sectors = options.index_sectors;
  const GpuLogData g = build_gpu_log_data(field, lo);
  FieldTables t;
  t.pith_z0 = g.pith_z0;
  t.pith_step = g.pith_step;
  t.pith = g.pith;
  t.stem_z0 = g.stem_z0;
  t.stem_step = g.stem_step;
  t.stem_cols = g.stem_cols;
  t.stem_rows = g.stem_rows;
  t.stem = g.stem;
  t.track_step = g.track_step;
  t.tracks = g.tracks;
  for (const GpuKnot& k : g.knots)
    t.knots.push_back(
        {k.r_dead, k.r_end, k.d_dead, k.d_exp, k.half_dmax, k.track_offset, k.track_count, k.seed});
  t.cell_z0 = g.index.z0;
  t.cell_dz = g.index.dz;
  t.cell_dr = g.index.dr;
  t.cell_nz = g.index.nz;
  t.cell_nr = g.index.nr;
  t.cell_ns = g.index.ns;
  t.cell_start = g.cell_start;
  t.cell_knots = g.cell_knots;
  t.r_ref = g.r_ref;
  t.knot_noise = g.knot_noise;
  t.z_begin = g.z_begin;
  t.z_end = g.z_end;
  return t;
}

}  // namespace sawyer::render
