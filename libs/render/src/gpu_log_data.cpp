#include "gpu_log_data.h"

#include <algorithm>
#include <cmath>

namespace sawyer::render {
namespace {

// The range of influence of a knot around its axis at pith distance r (wood_field.glsl's
// wf_range_outer, restated here for the index; tests compare the shader with WoodField).
double range_outer(double r, double r_ref) { return 0.2 * r_ref + r; }

// Angular distance from `w` to the sector [a, b] (0 inside), radians in [0, π].
double angle_to_sector(double w, double a, double b) {
  const double mid = 0.5 * (a + b), half = 0.5 * (b - a);
  const double d = std::abs(angle_diff(w, mid));
  return std::max(0.0, d - half);
}

}  // namespace

double knot_influence_end(const Knot& k) {
  return k.r_end + 2.0 * 0.5 * k.max_diameter() + 5.0 + 1.0;
}

double GpuLogData::bytes(double stem_texel_bytes) const {
  const double stem = stem_texel_bytes * stem_cols * stem_rows;  // uploaded in blocks or whole
  return 4.0 * (pith.size() + tracks.size() + cell_start.size() + cell_knots.size()) + stem +
         sizeof(GpuKnot) * knots.size();
}

float fill_stem_rows(const Stem& st, const GpuLogData& g, int row0, int rows, float* out) {
  float max_radius = 0;
  for (int row = row0; row < row0 + rows; ++row) {
    const double z = st.z_at(0) + row * (st.dz_mm / 2.0);
    for (int c = 0; c < g.stem_cols; ++c) {
      const double w = kTwoPi * c / g.stem_cols;
      const double R = st.radius_at(w, z);
      const size_t i = (static_cast<size_t>(row - row0) * g.stem_cols + c) * 2;
      out[i] = static_cast<float>(R);
      out[i + 1] = g.has_heartwood ? static_cast<float>(st.heartwood_at(w, z)) : 0.0f;
      max_radius = std::max(max_radius, static_cast<float>(R));
    }
  }
  return max_radius;
}

GpuLogData build_gpu_log_data(const WoodField& field, const GpuLayoutOptions& options) {
  const LogModel& log = field.log();
  const Stem& st = log.stem;
  GpuLogData g;
  g.r_ref = static_cast<float>(field.reference_radius());
  g.knot_noise = static_cast<float>(field.params().knot_noise);
  g.z_begin = static_cast<float>(st.z_begin());
  g.z_end = static_cast<float>(st.z_end());
  const int n = st.slice_count();

  // Pith: the model's Catmull-Rom curve every dz/8, over the samples (clamped beyond).
  {
    const double step = st.dz_mm / 8.0;
    const int count = std::max(2, (n - 1) * 8 + 1);
    g.pith_z0 = static_cast<float>(st.z_at(0));
    g.pith_step = static_cast<float>(step);
    g.pith.reserve(2 * count);
    Vec2 sum;
    for (int i = 0; i < count; ++i) {
      const Vec2 p = st.pith_at(st.z_at(0) + i * step);
      g.pith.push_back(static_cast<float>(p.x));
      g.pith.push_back(static_cast<float>(p.y));
    }
    for (const Vec2& p : st.pith) sum = sum + p;
    g.mean_pith = (1.0 / std::max(n, 1)) * sum;
  }
  // Stem radii: the bicubic surface resampled at 0.25 degrees and dz/2 (linear between).
  {
    g.stem_cols = 1440;
    g.stem_step = static_cast<float>(st.dz_mm / 2.0);
    g.stem_rows = std::max(2, (n - 1) * 2 + 1);
    g.stem_z0 = static_cast<float>(st.z_at(0));
    g.has_heartwood = st.has_heartwood();
    if (options.stem_table) {
      g.stem.resize(static_cast<size_t>(g.stem_cols) * g.stem_rows * 2);
      g.max_radius = fill_stem_rows(st, g, 0, g.stem_rows, g.stem.data());
    }
  }
  // Knots and their tracks (every 0.5 mm of pith distance, as WoodField::Slice).
  const double step = g.track_step;
  double max_reach_r = 0;
  for (size_t i = 0; i < log.knots.size(); ++i) {
    const Knot& k = log.knots[i];
    GpuKnot gk{};
    gk.r_dead = static_cast<float>(k.r_dead);
    gk.r_end = static_cast<float>(k.r_end);
    gk.d_dead = static_cast<float>(k.diameter.d_dead);
    gk.d_exp = static_cast<float>(k.diameter.exponent);
    gk.half_dmax = static_cast<float>(0.5 * k.max_diameter());
    gk.seed = static_cast<std::uint32_t>(k.id) * 7919u + 17u;
    const double r_lim = knot_influence_end(k);
    max_reach_r = std::max(max_reach_r, r_lim);
    const int count = static_cast<int>(std::ceil(r_lim / step)) + 2;
    gk.track_offset = static_cast<std::int32_t>(g.tracks.size() / 4);
    gk.track_count = count;
    // The azimuth unwrapped along the track (ω0 + twist·ln r), so it interpolates.
    for (int j = 0; j < count; ++j) {
      const double r = j * step;
      const Vec3 a = k.axis_point(r, st);
      g.tracks.push_back(static_cast<float>(a.x));
      g.tracks.push_back(static_cast<float>(a.y));
      g.tracks.push_back(static_cast<float>(a.z));
      g.tracks.push_back(static_cast<float>(k.omega0 + k.twist * std::log(std::max(r, 1.0))));
    }
    g.knots.push_back(gk);
  }

  // The knot index. A knot can touch a fragment at pith distance r, azimuth w, height z only if
  // the fragment lies within range_outer(r) of the knot's axis point at the same pith distance
  // (the shader's test). Both are r from the pith (the fragment's at z, the axis point's at its
  // own height), so their horizontal distance is at least 2 r sin(|Δw| / 2) minus the pith's
  // drift between the two heights. For each (pith-distance band, sector) the knot gets the
  // heights its axis ± the remaining vertical reach covers, sampled every 1 mm of r with margins.
  IndexLayout& L = g.index;
  L.dz = static_cast<float>(options.index_dz_mm);
  L.dr = static_cast<float>(options.index_dr_mm);
  L.ns = std::max(1, options.index_sectors);
  double zlo = st.z_begin(), zhi = st.z_end();
  double pith_slope = 0;
  for (int i = 0; i < n; ++i) {
    const Vec2 s = st.pith_slope_at(st.z_at(i));
    pith_slope = std::max(pith_slope, s.norm());
  }
  for (int i = 0; i + 1 < n; ++i)
    pith_slope = std::max(pith_slope, (st.pith[i + 1] - st.pith[i]).norm() / st.dz_mm);
  pith_slope = pith_slope * 1.5 + 1e-3;
  L.nr = std::max(1, static_cast<int>(std::ceil(max_reach_r / L.dr)));
  for (const Knot& k : log.knots) {
    double a, b;
    k.z_range(&a, &b);
    zlo = std::min(zlo, a - range_outer(knot_influence_end(k), g.r_ref));
    zhi = std::max(zhi, b + range_outer(knot_influence_end(k), g.r_ref));
  }
  L.z0 = static_cast<float>(zlo);
  L.nz = std::max(1, static_cast<int>(std::ceil((zhi - zlo) / L.dz)));
  std::vector<std::vector<std::int32_t>> lists(static_cast<size_t>(L.cells()));
  constexpr double kRStep = 1.0;
  for (size_t i = 0; i < log.knots.size(); ++i) {
    const Knot& k = log.knots[i];
    const double r_lim = knot_influence_end(k);
    for (int rb = 0; rb < L.nr; ++rb) {
      const double r0 = rb * L.dr, r1 = std::min((rb + 1) * static_cast<double>(L.dr), r_lim);
      if (r0 > r_lim) break;
      for (int sb = 0; sb < L.ns; ++sb) {
        const double w0 = kTwoPi * sb / L.ns, w1 = kTwoPi * (sb + 1) / L.ns;
        double cz_lo = 1e300, cz_hi = -1e300;
        for (double r = r0; r <= r1 + 1e-9; r += kRStep) {
          const double rr = std::min(r, r1);
          const double rs = std::min(rr + kRStep, r1);
          const double za = k.height_at(rr), zb = k.height_at(rs);
          const double wa = k.azimuth_at(rr);
          const double reach = range_outer(rs, g.r_ref) + 1.0;
          // The azimuth moves by twist·ln over the step; one degree covers it and rounding.
          const double dw =
              std::max(0.0, angle_to_sector(wa, w0, w1) -
                                std::abs(k.twist) * kRStep / std::max(rr, 1.0) - 0.02);
          const double drift = pith_slope * (reach + std::abs(zb - za));
          const double h = std::max(0.0, 2.0 * rr * std::sin(0.5 * dw) - drift);
          if (h >= reach) continue;
          const double v = std::sqrt(reach * reach - h * h) + 1.0;
          cz_lo = std::min(cz_lo, std::min(za, zb) - v);
          cz_hi = std::max(cz_hi, std::max(za, zb) + v);
        }
        if (cz_lo > cz_hi) continue;
        const int a = std::clamp(static_cast<int>(std::floor((cz_lo - L.z0) / L.dz)), 0, L.nz - 1);
        const int b = std::clamp(static_cast<int>(std::floor((cz_hi - L.z0) / L.dz)), 0, L.nz - 1);
        for (int zc = a; zc <= b; ++zc)
          lists[(static_cast<size_t>(zc) * L.nr + rb) * L.ns + sb].push_back(
              static_cast<std::int32_t>(i));
      }
    }
  }
  g.cell_start.reserve(lists.size() + 1);
  for (const auto& l : lists) {
    g.cell_start.push_back(static_cast<std::int32_t>(g.cell_knots.size()));
    g.cell_knots.insert(g.cell_knots.end(), l.begin(), l.end());
  }
  g.cell_start.push_back(static_cast<std::int32_t>(g.cell_knots.size()));
  if (g.cell_knots.empty()) g.cell_knots.push_back(0);  // no empty buffers
  if (g.knots.empty()) {
    g.knots.push_back(GpuKnot{});
    g.tracks.assign(8, 0.0f);
  }
  return g;
}

}  // namespace sawyer::render
