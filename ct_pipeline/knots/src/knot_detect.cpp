// Knot detection and segmentation (issue 5, see knot_detect.h).
//
// The steps, one function each:
//   1. unroll()        the volume around the pith track into a (slice, r, ω) grid of HU, with
//                      the wood class of every sample (heartwood, sapwood, neither) from the
//                      stem, or from estimate_heartwood() when the stem has no heartwood radius;
//   2. to_contrast()   HU minus the wood level of the same slice, wood class and ring (bin of
//                      the outline-normalised radius), so that only what differs from the wood
//                      around it is left: knots, cracks; scan_signal() then measures the scan's
//                      noise and ring signal, which set the thresholds;
//   3. label_shell()   per shell (fixed r), 2D blobs in (ω, slice) of strong contrast
//                      (hysteresis), ω circular; blobs shaped as sheets (rings) left out;
//   4. track_inwards() links the blobs of neighbouring shells into knots, from the bark side
//                      towards the pith, because knots of a whorl are apart near the surface and
//                      all meet at the pith: a blob claimed by two knots is split between them;
//                      resolve_branches() does the same outwards for knots that touch further
//                      out and part towards the pith;
//   5. measure_shell() centroid, diameter, contrast and ring of each knot on each shell
//                      (shells cut by the heartwood border band are left out: truncated());
//   6. follow_outwards() beyond the segmented part (the sapwood, where a knot differs from the
//                      wood by tens of HU only) along the axis extrapolated from the inner
//                      shells, to where the knot ends;
//   7. merge_pieces()  joins traces that are pieces of one knot.
#include "sawyer/ct/knots/knot_detect.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <thread>
#include <unordered_map>

#include "sawyer/core/stats.h"
#include "sawyer/core/vec.h"

namespace sawyer::ct {
namespace {

// Contrast value of samples that belong to no wood class: outside the log, in the bark, or on
// the heartwood border where a sample mixes both classes.
constexpr std::int16_t kInvalid = std::numeric_limits<std::int16_t>::min();

// Nearest integer as int16 (std::lround is a library call, and this runs per sample).
std::int16_t round_hu(double x) {
  x = std::clamp(x, -32000.0, 32000.0);
  return static_cast<std::int16_t>(x >= 0 ? x + 0.5 : x - 0.5);
}

template <class F>
void parallel_for(int n, int threads, F&& f) {
  threads = std::clamp(threads, 1, std::max(1, n));
  if (threads == 1) {
    for (int i = 0; i < n; ++i) f(i);
    return;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&, t] {
      for (int i = t; i < n; i += threads) f(i);
    });
  for (auto& th : pool) th.join();
}

// The unrolled volume: slice i, shell j (r = r0 + j·dr), azimuth k (ω = k·dω).
struct Grid {
  int ns = 0, nr = 0, nw = 0;
  double r0 = 0, dr = 1, dw = 0;
  std::vector<double> z;  // slice heights (scanner mm)
  // Per slice and azimuth [i·nw + k], the shells where the wood class changes: heartwood below
  // heart_in, the border band up to sap_in, sapwood up to out, then bark and air. The border
  // band (±2 mm of the heartwood radius) belongs to no class because blur and the border's own
  // roughness mix the two there; the last 2 mm under the bark neither (bark, blur).
  std::vector<std::int16_t> heart_in, sap_in, out;
  std::vector<std::int16_t> hu;  // HU, then contrast [(i·nr + j)·nw + k]
  std::vector<char> live;        // per slice: a log to unroll there
  // The window's own slices (streamed pass): what is rejected elsewhere is counted elsewhere.
  int core_lo = 0, core_hi = std::numeric_limits<int>::max();
  bool owns(int i) const { return i >= core_lo && i < core_hi; }
  // Unrolling: per azimuth cos/spacing_x and sin/spacing_y, and the pixel spacing.
  std::vector<double> cw, sw;
  double sx = 1, sy = 1;
  // Outline radius (under bark) per slice and azimuth [i·nw + k], mm, and its mean per slice.
  std::vector<float> outer;
  std::vector<double> outer_mean;
  // The wood level each contrast was taken from, per slice, class and bin of the outline-
  // normalised radius u [(i·2 + c)·nb + b] (NaN where none; see to_contrast): contrast + level
  // gives the HU back.
  int nb = 0;
  // The bin width, a power of two so that dividing by it is multiplying by kInvDu, exactly
  // (bin_of runs per voxel, twice in to_contrast).
  static constexpr double du = 0.25, kInvDu = 1.0 / du;
  std::vector<float> level;
  // Outline-normalised radius of shell j at (i, k): the pith distance scaled so that the
  // outline sits at the slice's mean outline radius. Annual rings follow the outline (a log's
  // ovality and its eccentric growth are the rings' own), so a ring keeps one u all round.
  double u_of(int i, int j, int k) const {
    const float o = outer[static_cast<size_t>(i) * nw + k];
    return o > 0 ? r(j) * outer_mean[static_cast<size_t>(i)] / o : r(j);
  }
  int bin_of(double u) const { return std::clamp(static_cast<int>(u * kInvDu), 0, nb - 1); }
  float level_at(int i, int c, int j, int k) const {
    return level[(static_cast<size_t>(i) * 2 + c) * nb + bin_of(u_of(i, j, k))];
  }
  double hu_at(int i, int j, int k) const {
    const int c = wood_class(i, j, k);
    const std::int16_t v = hu[at(i, j, k)];
    if (c < 0 || v == kInvalid) return NAN;
    return v + level_at(i, c, j, k);
  }

  double r(int j) const { return r0 + j * dr; }
  size_t at(int i, int j, int k) const { return (static_cast<size_t>(i) * nr + j) * nw + k; }
  // First shell with radius > r.
  std::int16_t shell_above(double rr) const {
    return static_cast<std::int16_t>(
        std::clamp(static_cast<int>(std::floor((rr - r0) / dr)) + 1, 0, nr));
  }
  void set_heartwood(size_t q, double h, double band) {
    heart_in[q] = std::min(out[q], shell_above(h - band));
    sap_in[q] = std::min(out[q], shell_above(h + band));
  }
  // 0 heartwood, 1 sapwood, -1 neither (see kInvalid).
  int wood_class(int i, int j, int k) const {
    const size_t q = static_cast<size_t>(i) * nw + k;
    if (j < heart_in[q]) return 0;
    if (j < sap_in[q]) return -1;
    return j < out[q] ? 1 : -1;
  }
};

// One slice of a Grid, for the per-voxel loops: its azimuths' class borders and outline
// radius, and u (Grid::u_of) from a shell's radius rj and rj · outer_mean computed once per
// shell. The same numbers as Grid::wood_class and Grid::u_of.
struct SliceView {
  const std::int16_t *heart_in, *sap_in, *out;
  const float* outer;
  double outer_mean;
  SliceView(const Grid& g, int i)
      : heart_in(&g.heart_in[static_cast<size_t>(i) * g.nw]),
        sap_in(&g.sap_in[static_cast<size_t>(i) * g.nw]),
        out(&g.out[static_cast<size_t>(i) * g.nw]),
        outer(&g.outer[static_cast<size_t>(i) * g.nw]),
        outer_mean(g.outer_mean[static_cast<size_t>(i)]) {}
  int wood_class(int j, int k) const {
    if (j < heart_in[k]) return 0;
    if (j < sap_in[k]) return -1;
    return j < out[k] ? 1 : -1;
  }
  double u(double rj, double rj_outer_mean, int k) const {
    const float o = outer[k];
    return o > 0 ? rj_outer_mean / o : rj;
  }
};

// One slice's pixels for the unroll: a plane the stem pass kept (16 bits, cropped) or the whole
// slice read again (float, quantised here exactly as LogVolume::keep stores it, so that both
// give the same grid).
struct PlaneRef {
  const std::int16_t* q = nullptr;
  const float* f = nullptr;
  int x0 = 0, y0 = 0, width = 0, height = 0;
  float at(size_t idx) const { return q ? q[idx] : quantise_hu(f[idx]); }
};

PlaneRef plane_ref(const LogPlane& p) {
  return {p.hu.data(), nullptr, p.x0, p.y0, p.width, p.height};
}
PlaneRef plane_ref(const Slice& s) { return {nullptr, s.hu.data(), 0, 0, s.width, s.height}; }

// A slice read again, quantised once (quantise_hu, as PlaneRef::at would per corner) over the
// pixels the grid can sample: within r_mm of the pith at its height, and one pixel more. The
// samples are the same as from the whole float slice, read from a quarter of the bytes and
// without four quantisations each (the window's slices: ~40 % of the knot pass's unroll).
// The pixels live in a buffer of the calling thread until its next call.
PlaneRef quantised_crop(const Slice& s, const VolumeGeometry& geo, Vec2 pith, double r_mm) {
  thread_local std::vector<std::int16_t> buf;
  const double margin = 3.0;  // pixels: the bilinear's neighbour and rounding, generously
  const int x0 =
      std::max(0, static_cast<int>(std::floor((pith.x - r_mm) / geo.spacing_x - margin)));
  const int y0 =
      std::max(0, static_cast<int>(std::floor((pith.y - r_mm) / geo.spacing_y - margin)));
  const int x1 =
      std::min(s.width, static_cast<int>(std::ceil((pith.x + r_mm) / geo.spacing_x + margin)));
  const int y1 =
      std::min(s.height, static_cast<int>(std::ceil((pith.y + r_mm) / geo.spacing_y + margin)));
  if (x1 - x0 < 2 || y1 - y0 < 2) return plane_ref(s);
  const int w = x1 - x0, h = y1 - y0;
  buf.resize(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    const float* src = &s.hu[static_cast<size_t>(y0 + y) * s.width + x0];
    std::int16_t* dst = &buf[static_cast<size_t>(y) * w];
    for (int x = 0; x < w; ++x) dst[x] = quantise_hu(src[x]);
  }
  // A crop that ends inside the slice cuts no sample off: every sample lies within r_mm of
  // the pith, more than a pixel from the crop's last column and row.
  return {buf.data(), nullptr, x0, y0, w, h};
}

// Planes of the grid: runs of `run` consecutive slices of `geo` (the last may be shorter).
struct Planes {
  int run = 1, slices = 0;
  int count() const { return (slices + run - 1) / run; }
  int first(int p) const { return p * run; }
  int end(int p) const { return std::min(slices, (p + 1) * run); }
};

// At most this many slices to a plane: the streamed pass reads a plane's slices together, so
// this bounds the slices in flight for very fine spacings (0.25 mm and finer: planes closer than
// grid_dz_mm).
constexpr int kMaxPlaneRun = 8;

Planes planes_of(const VolumeGeometry& geo, const KnotDetectOptions& o) {
  Planes pl;
  pl.slices = geo.slice_count();
  const double dz = geo.slice_spacing();
  if (o.grid_dz_mm > 0 && dz > 0)
    pl.run = std::clamp(static_cast<int>(std::floor(o.grid_dz_mm / dz + 1e-6)), 1, kMaxPlaneRun);
  return pl;
}

// The height of plane p: its slices' mean.
double plane_z(const VolumeGeometry& geo, const Planes& pl, int p) {
  double s = 0;
  for (int i = pl.first(p); i < pl.end(p); ++i) s += geo.z[static_cast<size_t>(i)];
  return s / (pl.end(p) - pl.first(p));
}

// Whether slice i (scan index) is unrolled: it has a log (`kept`) within the stem's heights.
template <class Kept>
bool unrolled(const VolumeGeometry& geo, const Stem& stem, const Kept& kept, int i) {
  const double z = geo.z[static_cast<size_t>(i)];
  return kept(i) && z >= stem.z_begin() && z <= stem.z_end();
}

// The grid of planes [a, b) of `geo` with everything but the samples: the outline and wood
// classes of every (plane, azimuth), the shells; samples all kInvalid (unroll_plane fills them).
// `kept(i)` (scan index) says whether slice i has a log to unroll; a plane is live when one of
// its slices is.
template <class Kept>
Grid make_grid(const VolumeGeometry& geo, const Planes& pl, int a, int b, const Stem& stem,
               const KnotDetectOptions& o, int threads, const Kept& kept) {
  Grid g;
  g.ns = b - a;
  g.nw = std::max(8, o.n_omega);
  g.dw = kTwoPi / g.nw;
  g.dr = o.dr_mm > 0 ? o.dr_mm : 1.0;
  g.r0 = g.dr;
  g.z.resize(static_cast<size_t>(g.ns));
  const size_t nq = static_cast<size_t>(g.ns) * g.nw;
  std::vector<float> outer(nq, 0.f), heart(nq, 0.f);
  g.live.assign(static_cast<size_t>(g.ns), 0);
  for (int i = 0; i < g.ns; ++i) {
    g.z[static_cast<size_t>(i)] = plane_z(geo, pl, a + i);
    for (int s = pl.first(a + i); s < pl.end(a + i); ++s)
      if (unrolled(geo, stem, kept, s)) g.live[static_cast<size_t>(i)] = 1;
  }
  parallel_for(g.ns, threads, [&](int i) {
    if (!g.live[static_cast<size_t>(i)]) return;
    const double z = g.z[static_cast<size_t>(i)];
    for (int k = 0; k < g.nw; ++k) {
      const size_t q = static_cast<size_t>(i) * g.nw + k;
      outer[q] = static_cast<float>(stem.radius_at(k * g.dw, z));
      if (stem.has_heartwood()) heart[q] = static_cast<float>(stem.heartwood_at(k * g.dw, z));
    }
  });
  const double rmax = nq ? *std::max_element(outer.begin(), outer.end()) : 0.0;
  g.nr = std::max(1, static_cast<int>(std::ceil((rmax - g.r0) / g.dr)) + 1);
  g.heart_in.assign(nq, 0), g.sap_in.assign(nq, 0), g.out.assign(nq, 0);
  for (size_t q = 0; q < nq; ++q) {
    if (outer[q] <= 0) continue;
    g.out[q] = g.shell_above(outer[q] - 2.0);
    if (heart[q] > 0) g.set_heartwood(q, heart[q], 2.0);
  }
  // The outline the rings follow: the log's overall shape, not the bark's local bumps or a
  // stretch of outline the stem pass got wrong (loose bark, a log touching this one): per
  // slice, the running median of the outline radius over ±30°, kept within 0.8-1.25 of the
  // slice's median (a log's ovality stays inside that; beyond it the outline is not the
  // rings').
  g.outer.assign(nq, 0.f);
  g.outer_mean.assign(static_cast<size_t>(g.ns), 0.0);
  parallel_for(g.ns, threads, [&](int i) {
    const float* ro = &outer[static_cast<size_t>(i) * g.nw];
    std::vector<float> w;
    for (int k = 0; k < g.nw; ++k)
      if (ro[k] > 0) w.push_back(ro[k]);
    if (w.empty()) return;
    const double med = median_inplace(w);
    const int half = std::max(1, static_cast<int>(std::lround(g.nw / 12.0)));
    double s = 0;
    int n = 0;
    for (int k = 0; k < g.nw; ++k) {
      if (ro[k] <= 0) continue;
      w.clear();
      for (int d = -half; d <= half; d += 2) {
        const float x = ro[((k + d) % g.nw + g.nw) % g.nw];
        if (x > 0) w.push_back(x);
      }
      const double sm = std::clamp(median_inplace(w), 0.8 * med, 1.25 * med);
      g.outer[static_cast<size_t>(i) * g.nw + k] = static_cast<float>(sm);
      s += sm, ++n;
    }
    g.outer_mean[static_cast<size_t>(i)] = n ? s / n : 0.0;
  });
  g.hu.assign(static_cast<size_t>(g.ns) * g.nr * g.nw, kInvalid);
  g.cw.resize(static_cast<size_t>(g.nw)), g.sw.resize(static_cast<size_t>(g.nw));
  for (int k = 0; k < g.nw; ++k)
    g.cw[k] = std::cos(k * g.dw) / geo.spacing_x, g.sw[k] = std::sin(k * g.dw) / geo.spacing_y;
  g.sx = geo.spacing_x, g.sy = geo.spacing_y;
  return g;
}

// The samples of grid plane i from one slice's pixels (the slice at height z, around the pith
// there): bilinear, inside the plane's outline shells; sink(j, k, value) takes each.
template <class Sink>
void sample_slice(const Grid& g, int i, double z, const PlaneRef& pl, const Stem& stem,
                  const Sink& sink) {
  if (pl.width < 2) return;
  const Vec2 p = stem.pith_at(z);
  const double c0 = p.x / g.sx - pl.x0, r0 = p.y / g.sy - pl.y0;
  for (int k = 0; k < g.nw; ++k) {
    const int jend = g.out[static_cast<size_t>(i) * g.nw + k];
    for (int j = 0; j < jend; ++j) {
      const double rr = g.r(j);
      const double c = c0 + rr * g.cw[k], r = r0 + rr * g.sw[k];
      if (!(c >= 0.0 && r >= 0.0 && c < pl.width - 1 && r < pl.height - 1)) continue;
      const int ci = static_cast<int>(c), ri = static_cast<int>(r);
      const float fc = static_cast<float>(c - ci), fr = static_cast<float>(r - ri);
      const size_t v = static_cast<size_t>(ri) * pl.width + ci;
      const float v00 = pl.at(v), v01 = pl.at(v + 1);
      const float v10 = pl.at(v + pl.width), v11 = pl.at(v + pl.width + 1);
      const float a = v00 + fc * (v01 - v00);
      const float b = v10 + fc * (v11 - v10);
      sink(j, k, a + fr * (b - a));
    }
  }
}

// Grid plane i (grid index; `plane` its index in the scan's planes) from its slices' pixels:
// slice(s) gives scan slice s's PlaneRef, and only the slices `use(s)` says are sampled. One
// slice: its samples; several: their mean where any sampled it.
template <class SliceAt, class Use>
void unroll_plane(Grid& g, int i, const VolumeGeometry& geo, const Planes& planes, int plane,
                  const Stem& stem, const SliceAt& slice, const Use& use) {
  if (!g.live[static_cast<size_t>(i)]) return;
  const int s0 = planes.first(plane), s1 = planes.end(plane);
  if (s1 - s0 == 1) {
    sample_slice(g, i, geo.z[static_cast<size_t>(s0)], slice(s0), stem,
                 [&](int j, int k, float v) { g.hu[g.at(i, j, k)] = round_hu(v); });
    return;
  }
  const size_t n = static_cast<size_t>(g.nr) * g.nw;
  std::vector<float> sum(n, 0.f);
  std::vector<std::uint8_t> count(n, 0);  // at most kMaxPlaneRun
  for (int s = s0; s < s1; ++s) {
    if (!use(s)) continue;
    sample_slice(g, i, geo.z[static_cast<size_t>(s)], slice(s), stem, [&](int j, int k, float v) {
      const size_t q = static_cast<size_t>(j) * g.nw + k;
      sum[q] += v, ++count[q];
    });
  }
  for (int j = 0; j < g.nr; ++j)
    for (int k = 0; k < g.nw; ++k) {
      const size_t q = static_cast<size_t>(j) * g.nw + k;
      if (count[q]) g.hu[g.at(i, j, k)] = round_hu(sum[q] / count[q]);
    }
}

Grid unroll(const LogVolume& volume, const Stem& stem, const KnotDetectOptions& o, int threads) {
  const VolumeGeometry& geo = volume.geometry();
  const Planes planes = planes_of(geo, o);
  auto kept = [&](int s) { return volume.plane(s).width > 1; };
  Grid g = make_grid(geo, planes, 0, planes.count(), stem, o, threads, kept);
  parallel_for(g.ns, threads, [&](int i) {
    unroll_plane(
        g, i, geo, planes, i, stem, [&](int s) { return plane_ref(volume.plane(s)); },
        [&](int s) { return unrolled(geo, stem, kept, s); });
  });
  return g;
}

// The heartwood border from the data, for stems that do not carry one (a model without it, a
// scan that did not measure it): per slice and 10° sector, the median HU of each shell (knots
// cover little of a sector), then the median of five slices; the sapwood level is that of the
// outermost wood shells, and the border is where, going inwards, the profile first drops
// 200 HU below it (dry heartwood is some 450 HU lighter than wet sapwood; no drop: no
// heartwood in that sector). Between sector centres the border is interpolated in ω, and the
// unclassified band around it is wider (±3 mm) than for a measured border.
void estimate_heartwood(Grid& g, int threads) {
  constexpr int kSectors = 36;
  constexpr double kDrop = 200, kBand = 3.0;
  const int per = std::max(1, g.nw / kSectors);
  const size_t n_prof = static_cast<size_t>(kSectors) * g.nr;
  std::vector<float> prof(static_cast<size_t>(g.ns) * n_prof,
                          std::numeric_limits<float>::quiet_NaN());
  parallel_for(g.ns, threads, [&](int i) {
    std::vector<std::int16_t> v;
    for (int sct = 0; sct < kSectors; ++sct)
      for (int j = 0; j < g.nr; ++j) {
        v.clear();
        for (int k = sct * per; k < std::min(g.nw, (sct + 1) * per); ++k) {
          const std::int16_t x = g.hu[g.at(i, j, k)];
          if (x != kInvalid && j < g.out[static_cast<size_t>(i) * g.nw + k]) v.push_back(x);
        }
        if (v.size() * 2 < static_cast<size_t>(per)) continue;
        prof[i * n_prof + static_cast<size_t>(sct) * g.nr + j] = median_inplace(v);
      }
  });
  parallel_for(g.ns, threads, [&](int i) {
    std::array<double, kSectors> border{};
    std::vector<float> w, p(static_cast<size_t>(g.nr));
    for (int sct = 0; sct < kSectors; ++sct) {
      int last = -1;  // outermost shell with a profile value
      for (int j = 0; j < g.nr; ++j) {
        w.clear();
        for (int ii = std::max(0, i - 2); ii <= std::min(g.ns - 1, i + 2); ++ii) {
          const float x = prof[ii * n_prof + static_cast<size_t>(sct) * g.nr + j];
          if (!std::isnan(x)) w.push_back(x);
        }
        p[static_cast<size_t>(j)] = std::numeric_limits<float>::quiet_NaN();
        if (w.empty()) continue;
        p[static_cast<size_t>(j)] = median_inplace(w);
        last = j;
      }
      if (last < 8) continue;
      double sap = 0;
      int ns = 0;
      for (int j = last; j > last - 5; --j)
        if (!std::isnan(p[static_cast<size_t>(j)])) sap += p[static_cast<size_t>(j)], ++ns;
      sap /= std::max(1, ns);
      for (int j = last - 5; j >= 0; --j)
        if (p[static_cast<size_t>(j)] < sap - kDrop) {
          border[static_cast<size_t>(sct)] = g.r(j) + 0.5 * g.dr;
          break;
        }
    }
    for (int k = 0; k < g.nw; ++k) {
      // Linear between the two nearest sector centres, circular; a sector without heartwood
      // next to one with it gives no heartwood on its half.
      const double f = (k + 0.5) / per - 0.5;
      const int s0 = static_cast<int>(std::floor(f));
      const double t = f - s0;
      const double b0 = border[static_cast<size_t>((s0 % kSectors + kSectors) % kSectors)];
      const double b1 = border[static_cast<size_t>(((s0 + 1) % kSectors + kSectors) % kSectors)];
      const double h = (b0 > 0 && b1 > 0) ? b0 + t * (b1 - b0) : (t < 0.5 ? b0 : b1);
      const size_t q = static_cast<size_t>(i) * g.nw + k;
      if (h > 0) g.set_heartwood(q, h, kBand);
    }
  });
}

// HU → contrast. The wood level of (slice i, wood class c, outline-normalised radius u) is the
// median of that slice's samples of class c whose u falls in the same 0.25 mm bin, then the
// median of those levels over the slices within ±20 mm (at least half_window slices either
// side): at a whorl near the pith the knots cover most of the circumference over their own
// height, and the slices beyond it carry the level there. Annual rings follow the outline, not
// circles around the pith: binning by u rather than by shell makes each ring (a latewood band
// of +150 to +400 HU in strong-latewood wood) one level, subtracted whole, where a shell would
// cut an oval ring into arcs that read as bright sheets along the log. For a round log u is r
// and this is the median over ω per shell. The median also takes out the radial density trend,
// the cupping, a calibration's offset and slope and the dry/wet level of the wood: the
// contrast is what differs from the wood around it at the same ring: knots, cracks, rot.
void to_contrast(Grid& g, int threads, int half_window) {
  const float kNone = std::numeric_limits<float>::quiet_NaN();
  const int stride = g.nw >= 180 ? 2 : 1;
  double umax = g.r(g.nr - 1);
  for (int i = 0; i < g.ns; ++i)
    for (int k = 0; k < g.nw; ++k)
      if (g.outer[static_cast<size_t>(i) * g.nw + k] > 0)
        umax = std::max(umax, g.u_of(i, g.nr - 1, k));
  g.nb = static_cast<int>(std::ceil(umax / g.du)) + 2;
  const size_t per_slice = static_cast<size_t>(2) * g.nb;
  std::vector<float> level(static_cast<size_t>(g.ns) * per_slice, kNone);
  // Fewest samples for a bin's median (every other azimuth: a bin of a round log's shell holds
  // 180); emptier bins are interpolated from their neighbours along u.
  const int min_n = std::max(8, g.nw / stride / 20);
  parallel_for(g.ns, threads, [&](int i) {
    std::vector<int> count(per_slice + 1, 0);
    std::vector<std::pair<int, std::int16_t>> smp;
    const SliceView sv(g, i);
    for (int j = 0; j < g.nr; ++j) {
      const std::int16_t* row = &g.hu[g.at(i, j, 0)];
      const double rj = g.r(j), rom = rj * sv.outer_mean;
      // Every other azimuth is plenty for a median (and halves the cost of the pass).
      for (int k = 0; k < g.nw; k += stride) {
        const int c = sv.wood_class(j, k);
        if (c < 0 || row[k] == kInvalid) continue;
        const int b = c * g.nb + g.bin_of(sv.u(rj, rom, k));
        smp.emplace_back(b, row[k]);
        ++count[static_cast<size_t>(b) + 1];
      }
    }
    for (size_t b = 1; b <= per_slice; ++b) count[b] += count[b - 1];
    std::vector<std::int16_t> sorted(smp.size());
    std::vector<int> fill(count.begin(), count.end() - 1);
    for (const auto& [b, v] : smp) sorted[static_cast<size_t>(fill[static_cast<size_t>(b)]++)] = v;
    float* lv = &level[static_cast<size_t>(i) * per_slice];
    for (size_t b = 0; b < per_slice; ++b) {
      const int n = count[b + 1] - count[b];
      if (n < min_n) continue;
      auto first = sorted.begin() + count[b], mid = first + n / 2;
      std::nth_element(first, mid, first + n);
      lv[b] = *mid;
    }
    // Gaps (a round log fills one bin per 1 mm shell) linear between the nearest filled bins,
    // up to 3 mm apart.
    const int max_gap = static_cast<int>(std::ceil(3.0 / g.du));
    for (int c = 0; c < 2; ++c) {
      float* l = lv + static_cast<size_t>(c) * g.nb;
      int prev = -1;
      for (int b = 0; b < g.nb; ++b) {
        if (std::isnan(l[b])) continue;
        if (prev >= 0 && b - prev > 1 && b - prev <= max_gap)
          for (int m = prev + 1; m < b; ++m)
            l[m] = l[prev] + (l[b] - l[prev]) * static_cast<float>(m - prev) / (b - prev);
        prev = b;
      }
    }
  });
  double dz = 5.0;
  if (g.ns >= 2) dz = std::max(0.1, (g.z.back() - g.z.front()) / (g.ns - 1));
  const int hw = std::clamp(static_cast<int>(std::lround(20.0 / dz)), half_window, 20);
  std::vector<float> smooth(level.size(), kNone);
  parallel_for(g.ns, threads, [&](int i) {
    std::vector<float> w;
    for (size_t b = 0; b < per_slice; ++b) {
      w.clear();
      for (int ii = std::max(0, i - hw); ii <= std::min(g.ns - 1, i + hw); ++ii) {
        const float l = level[static_cast<size_t>(ii) * per_slice + b];
        if (!std::isnan(l)) w.push_back(l);
      }
      if (!w.empty()) smooth[static_cast<size_t>(i) * per_slice + b] = median_inplace(w);
    }
  });
  g.level = std::move(smooth);
  parallel_for(g.ns, threads, [&](int i) {
    const SliceView sv(g, i);
    const float* lv = &g.level[static_cast<size_t>(i) * 2 * g.nb];
    for (int j = 0; j < g.nr; ++j) {
      std::int16_t* row = &g.hu[g.at(i, j, 0)];
      const double rj = g.r(j), rom = rj * sv.outer_mean;
      for (int k = 0; k < g.nw; ++k) {
        const int c = sv.wood_class(j, k);
        if (c < 0 || row[k] == kInvalid) {
          row[k] = kInvalid;
          continue;
        }
        const float l = lv[c * g.nb + g.bin_of(sv.u(rj, rom, k))];
        if (std::isnan(l)) {
          row[k] = kInvalid;
          continue;
        }
        row[k] = round_hu(static_cast<double>(row[k]) - l);
      }
    }
  });
}

// The scan's own noise and ring signal, from the contrast grid (knots are a small share of
// the samples, so robust spreads see the wood): noise from the differences between
// neighbouring slices at the same (r, ω) (rings run along the log and cancel there; the noise
// of separate slices does not), 1.4826·MAD/√2; the residual spread of the contrast itself
// (noise plus what the ring levels did not take out: rings that wander off the outline's
// shape, the pith's error), from its 10th and 90th percentiles (a MAD misses a latewood band
// that covers a third of the samples); and the ring signal, the RMS of the level profile along
// u about its own 5 mm running median (the rings the levels took out).
struct ScanSignal {
  double noise_hu = 0, residual_hu = 0, ring_hu = 0;
};

double mad_sigma(std::vector<float>& v) {
  if (v.size() < 16) return 0;
  const double m = median_inplace(v);
  for (float& x : v) x = std::abs(x - static_cast<float>(m));
  return 1.4826 * median_inplace(v);
}

// (p90 − p10) / 2.563: σ for Gaussian samples; for knots a tail of up to 10 % is ignored.
double quantile_sigma(std::vector<float>& v) {
  if (v.size() < 16) return 0;
  const size_t lo = v.size() / 10, hi = v.size() - 1 - v.size() / 10;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(lo), v.end());
  const float a = v[lo];
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(hi), v.end());
  return (v[hi] - a) / 2.563;
}

ScanSignal scan_signal(const Grid& g) {
  ScanSignal s;
  std::vector<float> dif, con, ring;
  const int sj = std::max(1, g.nr / 40), sk = std::max(1, g.nw / 90);
  const int si = std::max(1, g.ns / 100);
  for (int i = 0; i + 1 < g.ns; i += si)
    for (int j = 0; j < g.nr; j += sj)
      for (int k = (i / si + j) % sk; k < g.nw; k += sk) {
        const std::int16_t a = g.hu[g.at(i, j, k)], b = g.hu[g.at(i + 1, j, k)];
        if (a == kInvalid) continue;
        con.push_back(a);
        if (b != kInvalid) dif.push_back(static_cast<float>(b - a));
      }
  s.noise_hu = mad_sigma(dif) / std::sqrt(2.0);
  s.residual_hu = quantile_sigma(con);
  const int half = static_cast<int>(std::lround(2.5 / g.du));
  std::vector<float> w;
  for (int i = 0; i < g.ns; i += si)
    for (int c = 0; c < 2; ++c) {
      const float* l = &g.level[(static_cast<size_t>(i) * 2 + c) * g.nb];
      for (int b = half; b + half < g.nb; b += 2) {
        if (std::isnan(l[b])) continue;
        w.clear();
        for (int m = b - half; m <= b + half; ++m)
          if (!std::isnan(l[m])) w.push_back(l[m]);
        if (static_cast<int>(w.size()) > half)
          ring.push_back(l[b] - static_cast<float>(median_inplace(w)));
      }
    }
  double ss = 0;
  for (float x : ring) ss += static_cast<double>(x) * x;
  s.ring_hu = ring.empty() ? 0.0 : std::sqrt(ss / static_cast<double>(ring.size()));
  return s;
}

// A connected set of samples of one shell; pixels are i·nw + k.
struct Blob {
  std::vector<int> pix;
};

// Blobs of one shell: samples ≥ low connected (8-neighbourhood, ω circular), kept when one of
// them reaches high and their area on the cylinder (r·dω per sample times the slice spacing) is
// at least a quarter of a min_diameter disc (partial volume in z shrinks small knots).
// A knot crosses a shell as a compact disc, about as tall as it is wide. A blob that runs along
// the log (taller than sheet_z_mm and 2.5 times its width) or round it (wider than sheet_arc_mm
// and three times its height, beyond the whorls near the pith where a whorl's knots merge into
// one band) is part of a sheet: a latewood band the ring levels did not take out (a ring that
// wanders off the outline's shape, the pith's error), the heartwood border. A blob much taller
// than wide (KnotDetectOptions::streak_*) is a line repeated over slices: a metal streak. Those
// are counted in *sheets and left out.
std::vector<Blob> label_shell(const Grid& g, int j, double low, double high, double min_area,
                              double dz, const KnotDetectOptions& o, int* sheets) {
  std::vector<Blob> out;
  const int n = g.ns * g.nw;
  std::vector<std::uint8_t> seen(static_cast<size_t>(n), 0), col(static_cast<size_t>(g.nw), 0);
  std::vector<int> stack;
  const double px_area = g.r(j) * g.dw * dz;
  for (int s = 0; s < n; ++s) {
    if (seen[s]) continue;
    const std::int16_t c0 = g.hu[g.at(s / g.nw, j, s % g.nw)];
    if (c0 == kInvalid || c0 < low) continue;
    Blob b;
    bool strong = false;
    stack.assign(1, s);
    seen[s] = 1;
    while (!stack.empty()) {
      const int p = stack.back();
      stack.pop_back();
      b.pix.push_back(p);
      const int i = p / g.nw, k = p % g.nw;
      strong = strong || g.hu[g.at(i, j, k)] >= high;
      for (int di = -1; di <= 1; ++di) {
        const int ii = i + di;
        if (ii < 0 || ii >= g.ns) continue;
        for (int dk = -1; dk <= 1; ++dk) {
          const int kk = (k + dk + g.nw) % g.nw;
          const int q = ii * g.nw + kk;
          if (seen[q]) continue;
          const std::int16_t c = g.hu[g.at(ii, j, kk)];
          if (c == kInvalid || c < low) continue;
          seen[q] = 1;
          stack.push_back(q);
        }
      }
    }
    if (!strong || static_cast<double>(b.pix.size()) * px_area < min_area) continue;
    // Height: the slices' z span plus one spacing; width: the azimuths it covers, as arc.
    int i0 = g.ns, i1 = -1, cols = 0;
    for (int p : b.pix) {
      i0 = std::min(i0, p / g.nw), i1 = std::max(i1, p / g.nw);
      if (!col[static_cast<size_t>(p % g.nw)]) col[static_cast<size_t>(p % g.nw)] = 1, ++cols;
    }
    for (int p : b.pix) col[static_cast<size_t>(p % g.nw)] = 0;
    const double height = g.z[static_cast<size_t>(i1)] - g.z[static_cast<size_t>(i0)] + dz;
    const double width = cols * g.r(j) * g.dw;
    const bool along = height > std::max(o.sheet_z_mm, 2.5 * width) ||
                       height - 2 * dz > std::max(o.streak_min_z_mm, o.streak_ratio * width);
    const bool round = g.r(j) >= o.sheet_min_r_mm && width > std::max(o.sheet_arc_mm, 3 * height);
    if (along || round) {
      if (g.owns(i0)) ++*sheets;
      continue;
    }
    out.push_back(std::move(b));
  }
  return out;
}

// One knot while tracking: its blob on each shell, from the outside in.
struct Track {
  std::vector<int> shell;             // shell index j of each entry
  std::vector<std::vector<int>> pix;  // the knot's samples on that shell
  double w = 0, z = 0;                // centroid of the latest shell (for splitting)
  bool active = true;
  int parent = -1;     // the track this one branched off (knots that touched)
  bool split = false;  // ended by branching: its shells go to its branches
  int gap = 0;         // shells in a row without a blob
};

void centroid(const Grid& g, int j, const std::vector<int>& pix, double* w, double* z) {
  // Circular mean in ω (the blob may straddle ω = 0), contrast-weighted.
  double sx = 0, sy = 0, sz = 0, sw = 0;
  for (int p : pix) {
    const int i = p / g.nw, k = p % g.nw;
    const double c = std::max(1.0, static_cast<double>(g.hu[g.at(i, j, k)]));
    sx += c * std::cos(k * g.dw), sy += c * std::sin(k * g.dw);
    sz += c * g.z[static_cast<size_t>(i)], sw += c;
  }
  *w = wrap_angle(std::atan2(sy, sx));
  *z = sw > 0 ? sz / sw : 0;
}

// Distance on the cylinder of radius r between (w0, z0) and (w1, z1), mm.
double cyl_dist(double r, double w0, double z0, double w1, double z1) {
  return std::hypot(r * angle_diff(w0, w1), z0 - z1);
}

// Gives each sample of `pix` (shell j) to the nearest of `centres` (ω, z); returns the parts.
std::vector<std::vector<int>> split_nearest(const Grid& g, int j, const std::vector<int>& pix,
                                            const std::vector<std::pair<double, double>>& centres) {
  std::vector<std::vector<int>> parts(centres.size());
  for (int p : pix) {
    const double w = (p % g.nw) * g.dw, z = g.z[static_cast<size_t>(p / g.nw)];
    size_t best = 0;
    double bd = 1e300;
    for (size_t c = 0; c < centres.size(); ++c) {
      const double d = cyl_dist(g.r(j), w, z, centres[c].first, centres[c].second);
      if (d < bd) bd = d, best = c;
    }
    parts[best].push_back(p);
  }
  return parts;
}

// Links the blobs of all shells into tracks, from the outermost shell to j_min.
//  - A blob that overlaps the previous shell's samples of no track starts one.
//  - A blob that overlaps two or more tracks is where knots meet (towards the pith, a whorl):
//    its samples go to the nearest track's last centroid.
//  - Several blobs overlapping one track: noise breaking a knot up (close together: all
//    continue the track), or two knots that touched further out and part here (centroids at
//    least min_split_mm apart, each a quarter of the larger): the track ends and each part
//    starts a branch; resolve_branches() then shares the touching part between the branches.
std::vector<Track> track_inwards(const Grid& g, const std::vector<std::vector<Blob>>& blobs,
                                 int j_min, double min_split_mm) {
  const int max_gap = static_cast<int>(std::ceil(3.0 / g.dr));
  std::vector<Track> tracks;
  std::vector<int> owner(static_cast<size_t>(g.ns) * g.nw, -1);  // track of the previous shell
  for (int j = g.nr - 1; j >= j_min; --j) {
    const double rr = g.r(j);
    std::unordered_map<int, std::vector<int>> next;  // track → its samples on this shell
    std::unordered_map<int, std::vector<const Blob*>> single;  // track → blobs only it claims
    for (const Blob& b : blobs[static_cast<size_t>(j)]) {
      std::vector<int> claim;
      auto add = [&claim](int t) {
        if (t >= 0 && std::find(claim.begin(), claim.end(), t) == claim.end()) claim.push_back(t);
      };
      for (int p : b.pix) add(owner[p]);
      // A small knot rising through 5 mm slices moves from one slice to the next between
      // shells without overlapping itself: failing a direct overlap, one slice above or below
      // counts.
      if (claim.empty())
        for (int p : b.pix) {
          if (p >= g.nw) add(owner[p - g.nw]);
          if (p + g.nw < g.ns * g.nw) add(owner[p + g.nw]);
        }
      if (claim.empty()) {
        tracks.push_back({});
        next[static_cast<int>(tracks.size()) - 1] = b.pix;
      } else if (claim.size() == 1) {
        single[claim[0]].push_back(&b);
      } else {
        std::vector<std::pair<double, double>> c;
        for (int t : claim)
          c.emplace_back(tracks[static_cast<size_t>(t)].w, tracks[static_cast<size_t>(t)].z);
        auto parts = split_nearest(g, j, b.pix, c);
        for (size_t n = 0; n < claim.size(); ++n) {
          // A claimant nearer to none of the samples gets nothing here (and no empty shell).
          if (parts[n].empty()) continue;
          auto& v = next[claim[n]];
          v.insert(v.end(), parts[n].begin(), parts[n].end());
        }
      }
    }
    for (auto& [t, bl] : single) {
      // Parts big enough to be a knot of their own, and their centroids.
      size_t largest = 0;
      for (const Blob* b : bl) largest = std::max(largest, b->pix.size());
      std::vector<const Blob*> big;
      std::vector<std::pair<double, double>> c;
      for (const Blob* b : bl)
        if (b->pix.size() * 4 >= largest) {
          double w = 0, z = 0;
          centroid(g, j, b->pix, &w, &z);
          big.push_back(b);
          c.emplace_back(w, z);
        }
      double spread = 0;
      for (size_t m = 0; m < c.size(); ++m)
        for (size_t n = m + 1; n < c.size(); ++n)
          spread = std::max(spread, cyl_dist(rr, c[m].first, c[m].second, c[n].first, c[n].second));
      if (big.size() < 2 || spread < min_split_mm) {
        auto& v = next[t];
        for (const Blob* b : bl) v.insert(v.end(), b->pix.begin(), b->pix.end());
        continue;
      }
      tracks[static_cast<size_t>(t)].split = true;  // ends here: not in `next`
      std::vector<int> branch;
      for (size_t n = 0; n < big.size(); ++n) {
        tracks.push_back({});
        tracks.back().parent = t;
        branch.push_back(static_cast<int>(tracks.size()) - 1);
      }
      for (const Blob* b : bl) {  // small parts join the nearest branch
        double w = 0, z = 0;
        centroid(g, j, b->pix, &w, &z);
        size_t best = 0;
        for (size_t n = 1; n < c.size(); ++n)
          if (cyl_dist(rr, w, z, c[n].first, c[n].second) <
              cyl_dist(rr, w, z, c[best].first, c[best].second))
            best = n;
        auto& v = next[branch[best]];
        v.insert(v.end(), b->pix.begin(), b->pix.end());
      }
    }
    // A track that finds no blob on this shell keeps its last samples as the overlap target
    // for up to max_gap shells: small knots dip under the thresholds for a shell or two, and
    // ending them there would cut one knot into several.
    auto release = [&](int t) {
      for (int p : tracks[static_cast<size_t>(t)].pix.back())
        if (owner[p] == t) owner[p] = -1;
    };
    for (size_t t = 0; t < tracks.size(); ++t) {
      Track& tr = tracks[t];
      if (!tr.active || tr.shell.empty()) continue;
      const bool continued = next.count(static_cast<int>(t)) > 0;
      if (continued || tr.split || ++tr.gap > max_gap) release(static_cast<int>(t));
      if (!continued && (tr.split || tr.gap > max_gap)) tr.active = false;
    }
    for (size_t t = 0; t < tracks.size(); ++t) {
      auto it = next.find(static_cast<int>(t));
      if (it == next.end()) continue;
      Track& tr = tracks[t];
      tr.gap = 0;
      tr.shell.push_back(j);
      tr.pix.push_back(std::move(it->second));
      centroid(g, j, tr.pix.back(), &tr.w, &tr.z);
      for (int p : tr.pix.back()) owner[p] = static_cast<int>(t);
    }
  }
  return tracks;
}

// Shares the shells of each track that branched (two knots touching further out) between its
// branches, walking outwards from where they part: each sample goes to the branch whose
// centroid on the previous (inner) shell is nearest. Parents come before their branches in
// `tracks`, so a branch that branches again passes on what it received.
void resolve_branches(const Grid& g, std::vector<Track>& tracks) {
  for (size_t t = 0; t < tracks.size(); ++t) {
    if (!tracks[t].split) continue;
    std::vector<size_t> br;
    for (size_t u = t + 1; u < tracks.size(); ++u)
      if (tracks[u].parent == static_cast<int>(t) && !tracks[u].shell.empty()) br.push_back(u);
    Track& parent = tracks[t];
    if (br.empty()) continue;
    std::vector<std::pair<double, double>> c;
    for (size_t u : br) {
      double w = 0, z = 0;
      centroid(g, tracks[u].shell.front(), tracks[u].pix.front(), &w, &z);
      c.emplace_back(w, z);
    }
    std::vector<std::vector<int>> shells(br.size());
    std::vector<std::vector<std::vector<int>>> pix(br.size());
    for (size_t n = parent.shell.size(); n-- > 0;) {  // inner to outer
      const int j = parent.shell[n];
      auto parts = split_nearest(g, j, parent.pix[n], c);
      for (size_t m = 0; m < br.size(); ++m) {
        if (parts[m].empty()) continue;
        centroid(g, j, parts[m], &c[m].first, &c[m].second);
        shells[m].push_back(j);
        pix[m].push_back(std::move(parts[m]));
      }
    }
    for (size_t m = 0; m < br.size(); ++m) {  // prepend, outermost first
      Track& b = tracks[br[m]];
      b.shell.insert(b.shell.begin(), shells[m].rbegin(), shells[m].rend());
      b.pix.insert(b.pix.begin(), std::make_move_iterator(pix[m].rbegin()),
                   std::make_move_iterator(pix[m].rend()));
    }
    parent.shell.clear();
    parent.pix.clear();
  }
}

double sq(double x) { return x * x; }

// Measures a segmented knot on shell j. The diameter comes from the cross-section area on the
// cylinder with partial volume accounted for: slices are 5 mm thick, so a knot of 10 mm spans
// two or three slices, most of them only partly; each sample counts with the fraction
// contrast / knot contrast (clamped to [0, 1]) of its r·dω·dz cell, over the blob and the
// samples of the slices just above and below it. Alternatively (options.diameter_from_arc) the
// diameter is the widest arc of the blob (samples over half the knot contrast), which ignores z.
KnotShell measure_shell(const Grid& g, int j, const std::vector<int>& pix,
                        const std::vector<std::uint8_t>& taken, bool from_arc) {
  KnotShell s;
  s.r = g.r(j);
  s.voxels = static_cast<int>(pix.size());
  centroid(g, j, pix, &s.omega, &s.z);
  std::vector<double> c;
  c.reserve(pix.size());
  double sum = 0;
  for (int p : pix) {
    const double v = g.hu[g.at(p / g.nw, j, p % g.nw)];
    c.push_back(v);
    sum += v;
  }
  s.contrast = sum / std::max<size_t>(1, pix.size());
  // The knot's own contrast: a high quantile, the samples fully inside the knot.
  std::vector<double> cs = c;
  const size_t q = cs.size() * 9 / 10;
  std::nth_element(cs.begin(), cs.begin() + q, cs.end());
  const double full = std::max(1.0, cs[q]);
  // Core HU: the mean HU of the samples at least half the knot's own contrast (blur and the
  // slices' partial volume put the rest between knot and wood).
  double core = 0;
  int core_n = 0;
  for (size_t n = 0; n < pix.size(); ++n) {
    if (c[n] < 0.5 * full) continue;
    const double h = g.hu_at(pix[n] / g.nw, j, pix[n] % g.nw);
    if (!std::isnan(h)) core += h, ++core_n;
  }
  if (core_n) s.core_hu = core / core_n;
  const double cell_w = s.r * g.dw;
  auto dz_of = [&](int i) {
    const int a = std::max(0, i - 1), b = std::min(g.ns - 1, i + 1);
    return b > a ? (g.z[static_cast<size_t>(b)] - g.z[static_cast<size_t>(a)]) / (b - a) : 5.0;
  };
  if (from_arc) {
    std::unordered_map<int, int> per_row;
    for (size_t n = 0; n < pix.size(); ++n)
      if (c[n] >= 0.5 * full) ++per_row[pix[n] / g.nw];
    int widest = 0;
    for (auto& kv : per_row) widest = std::max(widest, kv.second);
    s.diameter = widest * cell_w;
  } else {
    double area = 0;
    std::vector<std::uint8_t> in(static_cast<size_t>(g.ns) * g.nw, 0);
    for (int p : pix) in[p] = 1;
    for (int p : pix) {
      const int i = p / g.nw, k = p % g.nw;
      area += std::clamp(g.hu[g.at(i, j, k)] / full, 0.0, 1.0) * cell_w * dz_of(i);
      for (int di : {-1, 1}) {  // the knot's partial-volume fringe above and below
        const int ii = i + di;
        if (ii < 0 || ii >= g.ns) continue;
        const int qq = ii * g.nw + k;
        if (in[qq] || taken[qq]) continue;
        in[qq] = 1;
        const std::int16_t v = g.hu[g.at(ii, j, k)];
        if (v != kInvalid) area += std::clamp(v / full, 0.0, 1.0) * cell_w * dz_of(ii);
      }
    }
    s.diameter = 2.0 * std::sqrt(area / (kTwoPi / 2));
  }
  // Ring: 1 to 3 mm of arc beyond each side of the blob's rows.
  std::unordered_map<int, std::pair<int, int>> extent;  // row → (first k, last k), unwrapped
  const int kc = static_cast<int>(std::lround(s.omega / g.dw));
  for (int p : pix) {
    const int i = p / g.nw;
    int k = p % g.nw;
    int d = k - kc;
    d = ((d % g.nw) + g.nw + g.nw / 2) % g.nw - g.nw / 2;
    auto it = extent.find(i);
    if (it == extent.end())
      extent[i] = {d, d};
    else
      it->second = {std::min(it->second.first, d), std::max(it->second.second, d)};
  }
  const int k1 = std::max(1, static_cast<int>(std::lround(1.0 / cell_w)));
  const int k3 = std::max(k1 + 1, static_cast<int>(std::lround(3.0 / cell_w)));
  double rs = 0;
  int rn = 0;
  for (auto& [i, e] : extent)
    for (int side : {-1, 1})
      for (int d = k1; d <= k3; ++d) {
        const int k = ((kc + (side < 0 ? e.first - d : e.second + d)) % g.nw + g.nw) % g.nw;
        const std::int16_t v = g.hu[g.at(i, j, k)];
        if (v == kInvalid || taken[static_cast<size_t>(i) * g.nw + k]) continue;
        rs += v, ++rn;
      }
  s.ring_hu = rn ? rs / rn : 0;
  return s;
}

// True when the blob touches unclassified samples (the heartwood border band, the bark side)
// along more than a few of its edges: part of the knot's cross-section is missing there, so its
// centroid and diameter are biased, and the shell is better left to the axis extrapolation.
bool truncated(const Grid& g, int j, const std::vector<int>& pix) {
  int cut = 0;
  for (int p : pix) {
    const int i = p / g.nw, k = p % g.nw;
    const int kl = (k + g.nw - 1) % g.nw, kr = (k + 1) % g.nw;
    cut += g.hu[g.at(i, j, kl)] == kInvalid || g.hu[g.at(i, j, kr)] == kInvalid ||
           (i > 0 && g.hu[g.at(i - 1, j, k)] == kInvalid) ||
           (i + 1 < g.ns && g.hu[g.at(i + 1, j, k)] == kInvalid);
  }
  return cut * 20 > static_cast<int>(pix.size());
}

// Least squares of y = Σ c_m·f_m(r) (m < 3) with a tiny ridge so short traces stay defined.
template <int M>
std::array<double, M> least_squares(const std::vector<std::array<double, M>>& f,
                                    const std::vector<double>& y) {
  std::array<std::array<double, M + 1>, M> a{};
  for (size_t n = 0; n < y.size(); ++n)
    for (int p = 0; p < M; ++p) {
      for (int q = 0; q < M; ++q) a[p][q] += f[n][p] * f[n][q];
      a[p][M] += f[n][p] * y[n];
    }
  for (int p = 0; p < M; ++p) a[p][p] += 1e-6 * (1 + a[p][p]);
  for (int p = 0; p < M; ++p) {  // Gauss-Jordan with partial pivoting
    int piv = p;
    for (int q = p + 1; q < M; ++q)
      if (std::abs(a[q][p]) > std::abs(a[piv][p])) piv = q;
    std::swap(a[p], a[piv]);
    for (int q = 0; q < M; ++q) {
      if (q == p || a[p][p] == 0) continue;
      const double m = a[q][p] / a[p][p];
      for (int c = p; c <= M; ++c) a[q][c] -= m * a[p][c];
    }
  }
  std::array<double, M> x{};
  for (int p = 0; p < M; ++p) x[p] = a[p][p] != 0 ? a[p][M] / a[p][p] : 0;
  return x;
}

// The knot's axis from its segmented shells, in the knot formula's terms: z = c0 + c1·√r + c2·r
// and ω = d0 + d1·ln r (ω unwrapped around the outermost shell). Short or near-pith-only traces
// fall back to a straight line in r for z, which extrapolates more safely than the √r term.
struct Axis {
  std::array<double, 3> z{};
  std::array<double, 2> w{};
  double z_at(double r) const { return z[0] + z[1] * std::sqrt(r) + z[2] * r; }
  double w_at(double r) const { return wrap_angle(w[0] + w[1] * std::log(std::max(r, 1.0))); }
};

Axis fit_axis(const std::vector<KnotShell>& shells) {
  Axis a;
  const double w_ref = shells.back().omega;
  std::vector<std::array<double, 3>> fz;
  std::vector<std::array<double, 2>> fw;
  std::vector<double> yz, yw;
  const double r_in = shells.front().r, r_out = shells.back().r;
  // Shells near the pith are shared with whorl neighbours: fit on the outer part when long.
  const double r_from = std::max(r_in, std::min(8.0, r_out - 10.0));
  const bool sqrt_term = r_out - r_from >= 20.0;
  for (const KnotShell& s : shells) {
    if (s.r < r_from) continue;
    fz.push_back({1.0, sqrt_term ? std::sqrt(s.r) : 0.0, s.r});
    yz.push_back(s.z);
    fw.push_back({1.0, std::log(std::max(s.r, 1.0))});
    yw.push_back(w_ref + angle_diff(s.omega, w_ref));
  }
  a.z = least_squares<3>(fz, yz);
  a.w = least_squares<2>(fw, yw);
  return a;
}

// Least-squares slope dz/dr of the shells' centres.
double z_slope(const std::vector<KnotShell>& shells) {
  double sr = 0, sz = 0;
  for (const KnotShell& s : shells) sr += s.r, sz += s.z;
  const double n = static_cast<double>(shells.size());
  const double mr = sr / n, mz = sz / n;
  double srr = 0, srz = 0;
  for (const KnotShell& s : shells) srr += (s.r - mr) * (s.r - mr), srz += (s.r - mr) * (s.z - mz);
  return srr > 0 ? srz / srr : 0.0;
}

// Least-squares slope of the arc position r·(ω − ω_ref) against r (ω unwrapped around the
// outermost shell): how many mm round the log the centre moves per mm outwards.
double arc_slope(const std::vector<KnotShell>& shells) {
  const double w_ref = shells.back().omega;
  double sr = 0, sa = 0;
  for (const KnotShell& s : shells) sr += s.r, sa += s.r * angle_diff(s.omega, w_ref);
  const double n = static_cast<double>(shells.size());
  const double mr = sr / n, ma = sa / n;
  double srr = 0, sra = 0;
  for (const KnotShell& s : shells) {
    srr += (s.r - mr) * (s.r - mr);
    sra += (s.r - mr) * (s.r * angle_diff(s.omega, w_ref) - ma);
  }
  return srr > 0 ? sra / srr : 0.0;
}

// What the knot looks like on shell j around the predicted axis point: mean contrast inside the
// disc of the knot's diameter on the cylinder, and mean contrast in the 2 mm ring around it.
// Returns false when the disc has no wood samples (bark side, heartwood border band).
bool probe(const Grid& g, int j, double w, double z, double d, KnotShell* s) {
  const double rr = g.r(j), rad = 0.5 * d, ring = rad + 2.0;
  double in_s = 0, ring_s = 0, core_s = 0;
  int in_n = 0, ring_n = 0, core_n = 0;
  const int kc = static_cast<int>(std::lround(w / g.dw));
  const int kr = static_cast<int>(std::ceil(ring / (rr * g.dw)));
  for (int i = 0; i < g.ns; ++i) {
    const double dz = g.z[static_cast<size_t>(i)] - z;
    if (std::abs(dz) > ring) continue;
    for (int dk = -kr; dk <= kr; ++dk) {
      const int k = ((kc + dk) % g.nw + g.nw) % g.nw;
      const std::int16_t v = g.hu[g.at(i, j, k)];
      if (v == kInvalid) continue;
      const double da = rr * angle_diff(k * g.dw, w);
      const double e = std::sqrt(da * da + dz * dz);
      if (e <= 0.5 * rad) {
        const double h = g.hu_at(i, j, k);
        if (!std::isnan(h)) core_s += h, ++core_n;
      }
      if (e <= rad)
        in_s += v, ++in_n;
      else if (e <= ring)
        ring_s += v, ++ring_n;
    }
  }
  if (in_n == 0) return false;
  s->r = rr;
  s->omega = wrap_angle(w);
  s->z = z;
  s->diameter = d;
  s->contrast = in_s / in_n;
  s->ring_hu = ring_n ? ring_s / ring_n : 0;
  s->core_hu = core_n ? core_s / core_n : NAN;
  s->voxels = in_n;
  s->predicted = true;
  return true;
}

// Where the knot's centre is near (w, z) on shell j: the centroid of sign·contrast (sign +1 for
// a knot brighter than the wood, -1 for a darker one) over the disc of radius `rad`. False when
// nothing there has that sign.
bool local_centre(const Grid& g, int j, double w, double z, double rad, double sign, double* wc,
                  double* zc) {
  const double rr = g.r(j);
  const int kc = static_cast<int>(std::lround(w / g.dw));
  const int kr = static_cast<int>(std::ceil(rad / (rr * g.dw)));
  double sw = 0, sa = 0, sz = 0;
  for (int i = 0; i < g.ns; ++i) {
    const double dz = g.z[static_cast<size_t>(i)] - z;
    if (std::abs(dz) > rad) continue;
    for (int dk = -kr; dk <= kr; ++dk) {
      const int k = ((kc + dk) % g.nw + g.nw) % g.nw;
      const std::int16_t v = g.hu[g.at(i, j, k)];
      const double da = rr * dk * g.dw;
      if (v == kInvalid || da * da + dz * dz > rad * rad) continue;
      const double wt = std::max(0.0, sign * v);
      sw += wt, sa += wt * da, sz += wt * dz;
    }
  }
  if (sw <= 0) return false;
  *wc = wrap_angle(kc * g.dw + sa / sw / rr);
  *zc = z + sz / sw;
  return true;
}

// Extends a segmented knot outwards along its extrapolated axis until its contrast is gone.
// Where the knot still shows clearly (mean contrast beyond twice follow_min) the
// path is pulled towards the local centroid (a third of the way per shell), so that the
// extrapolation, fitted on the heartwood part only, does not drift off a long sapwood part.
// Evidence of the knot on a shell is the mean of it and its two neighbours (noise): brighter
// than the wood (a sound knot in the sapwood), or darker, or with a dark ring (a dead knot and
// its encased bark); the knot ends after follow_misses shells without evidence.
void follow_outwards(const Grid& g, const KnotDetectOptions& o, double follow_min, KnotTrace* t) {
  const Axis axis = fit_axis(t->shells);
  // The diameter carried outwards: the mean of the last few segmented shells.
  double d = 0;
  int nd = 0;
  for (size_t n = t->shells.size(); n-- > 0 && nd < 5;) d += t->shells[n].diameter, ++nd;
  d = std::max(o.min_diameter_mm, d / std::max(1, nd));
  const int j0 = static_cast<int>(std::lround((t->shells.back().r - g.r0) / g.dr)) + 1;
  std::vector<KnotShell> probed;
  int miss = 0, blind = 0;
  double off_w = 0, off_z = 0;  // pull of the path off the extrapolated axis
  // Shells without wood samples on the axis: the heartwood border band (4-6 mm) is crossed
  // blind; more than 8 mm of them is the bark side.
  const int max_blind = static_cast<int>(std::ceil(8.0 / g.dr));
  auto evidence = [&](size_t from, size_t to) {  // mean over probed[from, to)
    double c = 0, ring = 0;
    for (size_t q = from; q < to; ++q) c += probed[q].contrast, ring += probed[q].ring_hu;
    c /= static_cast<double>(to - from), ring /= static_cast<double>(to - from);
    return std::abs(c) >= follow_min || ring <= -2 * follow_min;
  };
  for (int j = j0; j < g.nr; ++j) {
    KnotShell s;
    const double rr = g.r(j);
    const double w = wrap_angle(axis.w_at(rr) + off_w), z = axis.z_at(rr) + off_z;
    if (!probe(g, j, w, z, d, &s)) {
      if (++blind > max_blind) break;
      continue;
    }
    blind = 0;
    probed.push_back(s);
    if (std::abs(s.contrast) >= 2 * follow_min) {
      double wc = 0, zc = 0;
      if (local_centre(g, j, w, z, 0.5 * d + 2.0, s.contrast > 0 ? 1.0 : -1.0, &wc, &zc)) {
        off_w += angle_diff(wc, w) / 3;
        off_z += (zc - z) / 3;
      }
    }
    const size_t n = probed.size();
    miss = evidence(n >= 3 ? n - 3 : 0, n) ? 0 : miss + 1;
    if (miss > o.follow_misses) break;
  }
  // Keep the probed shells up to the last one with evidence, now with centred means (the
  // trailing mean used for stopping lags by a shell).
  size_t keep = 0;
  for (size_t n = 0; n < probed.size(); ++n)
    if (evidence(n > 0 ? n - 1 : 0, std::min(probed.size(), n + 2))) keep = n + 1;
  for (size_t n = 0; n < keep; ++n) t->shells.push_back(probed[n]);
}

// Joins traces that are pieces of one knot: a knot whose contrast dips for more than the
// tracking gap (a small knot straddling two slices) is segmented as an inner and an outer piece,
// and the inner piece's followed part runs over the outer piece. Two traces are one knot when
// they share at least three shells and their centres there are, on average, within a third of
// the knot's diameter (whorl neighbours that meet near the pith diverge quickly, and so fail).
// The joined trace keeps, per shell, the segmented measurement over a predicted one.
std::vector<KnotTrace> merge_pieces(std::vector<KnotTrace> traces) {
  std::sort(traces.begin(), traces.end(), [](const KnotTrace& a, const KnotTrace& b) {
    return a.shells.front().r < b.shells.front().r;
  });
  std::vector<KnotTrace> out;
  for (KnotTrace& b : traces) {
    KnotTrace* into = nullptr;
    for (KnotTrace& a : out) {
      double sum = 0, dsum = 0;
      int n = 0;
      for (const KnotShell& sb : b.shells)
        for (const KnotShell& sa : a.shells)
          if (std::abs(sa.r - sb.r) < 0.25) {
            sum += cyl_dist(sa.r, sa.omega, sa.z, sb.omega, sb.z);
            dsum += std::max(sa.diameter, sb.diameter);
            ++n;
          }
      if (n >= 3 && sum < dsum / 3) {
        into = &a;
        break;
      }
    }
    if (!into) {
      out.push_back(std::move(b));
      continue;
    }
    std::vector<KnotShell> all = into->shells;
    all.insert(all.end(), b.shells.begin(), b.shells.end());
    std::stable_sort(all.begin(), all.end(), [](const KnotShell& x, const KnotShell& y) {
      return x.r < y.r || (x.r == y.r && !x.predicted && y.predicted);
    });
    into->shells.clear();
    for (const KnotShell& sh : all)
      if (into->shells.empty() || std::abs(into->shells.back().r - sh.r) >= 0.25)
        into->shells.push_back(sh);
    into->r_last_seen = into->shells.back().r;
    into->reaches_surface = into->reaches_surface || b.reaches_surface;
  }
  return out;
}

// Steps 2 to 7 on an unrolled grid (slices with no log are all kInvalid): the traces, ordered,
// and what was done in *sum (the unroll's time is the caller's).
std::vector<KnotTrace> detect_in_grid(Grid& g, const Stem& stem, const KnotDetectOptions& options,
                                      int threads, KnotDetectSummary& sum) {
  using Clock = std::chrono::steady_clock;
  auto t_prev = Clock::now();
  auto lap = [&t_prev]() {
    const auto now = Clock::now();
    const double s = std::chrono::duration<double>(now - t_prev).count();
    t_prev = now;
    return s;
  };
  if (!stem.has_heartwood()) estimate_heartwood(g, threads);
  sum.unroll_s += lap();
  to_contrast(g, threads, options.level_half_window);
  // Thresholds from the scan itself: the contrast's spread where there is no knot sets how far
  // above it a knot must stand: the noise, and half of what the ring levels left (the rest of
  // the rings is told from knots by shape below: a threshold over every latewood arc would be
  // over the dead knots too). The options' values are floors, met by a clean scan.
  const ScanSignal sig = scan_signal(g);
  const double ring_left = std::sqrt(std::max(0.0, sq(sig.residual_hu) - sq(sig.noise_hu)));
  const double spread = std::hypot(sig.noise_hu, 0.5 * ring_left);
  const double low = std::max(options.low_contrast, options.low_sigmas * spread);
  const double high = std::max(options.high_contrast, options.high_sigmas * spread);
  const double follow_min = std::max(options.follow_min_contrast, options.follow_sigmas * spread);
  sum.noise_hu = sig.noise_hu, sum.residual_hu = sig.residual_hu, sum.ring_hu = sig.ring_hu;
  sum.low_hu = low, sum.high_hu = high, sum.follow_hu = follow_min;
  sum.contrast_s = lap();
  sum.shells = g.nr, sum.slices = g.ns, sum.omegas = g.nw;

  double dz = 5.0;
  if (g.ns >= 2) dz = (g.z.back() - g.z.front()) / (g.ns - 1);
  const double min_area = 0.25 * (kTwoPi / 8) * sq(options.min_diameter_mm);
  std::vector<std::vector<Blob>> blobs(static_cast<size_t>(g.nr));
  std::vector<int> sheets(static_cast<size_t>(g.nr), 0);
  const int j_min = std::max(0, static_cast<int>(std::ceil((options.min_r_mm - g.r0) / g.dr)));
  parallel_for(g.nr - j_min, threads, [&](int n) {
    const int j = j_min + n;
    blobs[static_cast<size_t>(j)] =
        label_shell(g, j, low, high, min_area, dz, options, &sheets[static_cast<size_t>(j)]);
  });
  sum.segment_s = lap();
  for (const auto& b : blobs) sum.blobs += static_cast<int>(b.size());
  for (int n : sheets) sum.rejected_sheet_blobs += n;
  std::vector<Track> tracks = track_inwards(g, blobs, j_min, options.min_split_mm);
  resolve_branches(g, tracks);
  sum.tracks = static_cast<int>(tracks.size());
  sum.track_s = lap();

  std::vector<KnotTrace> out;
  // All segmented samples of a shell, so that a knot's ring and fringe skip its neighbours'.
  std::vector<std::vector<std::uint8_t>> taken(static_cast<size_t>(g.nr));
  for (const Track& t : tracks)
    for (size_t n = 0; n < t.shell.size(); ++n) {
      auto& m = taken[static_cast<size_t>(t.shell[n])];
      if (m.empty()) m.assign(static_cast<size_t>(g.ns) * g.nw, 0);
      for (int p : t.pix[n]) m[static_cast<size_t>(p)] = 1;
    }
  for (const Track& t : tracks) {
    if (t.shell.empty()) continue;
    // Rejections are counted by the window that owns the track's innermost samples.
    int own = 1;
    for (size_t n = t.pix.size(); n-- > 0;)
      if (!t.pix[n].empty()) {
        own = g.owns(t.pix[n].front() / g.nw);
        break;
      }
    const double span = (t.shell.front() - t.shell.back()) * g.dr;
    if (span < options.min_length_mm) {
      sum.rejected_short += own;
      continue;
    }
    KnotTrace kt;
    for (size_t n = t.shell.size(); n-- > 0;)
      if (!t.pix[n].empty() && !truncated(g, t.shell[n], t.pix[n]))
        kt.shells.push_back(measure_shell(g, t.shell[n], t.pix[n],
                                          taken[static_cast<size_t>(t.shell[n])],
                                          options.diameter_from_arc));
    // What is left after the truncated shells must still be long enough to be a knot.
    if (kt.shells.size() < 2 ||
        kt.shells.back().r - kt.shells.front().r + g.dr < options.min_length_mm) {
      sum.rejected_short += own;
      continue;
    }
    // A knot rises slowly with r (the measured logs: dz/dr between -0.3 and 0.8). A run whose
    // centre climbs or falls steeply is something lying along the log (the heartwood border, a
    // crack, a support), not a branch: following it outwards would extrapolate that slope.
    if (std::abs(z_slope(kt.shells)) > options.max_axis_slope) {
      sum.rejected_steep += own;
      continue;
    }
    // Nor does it turn round the log: ω = d0 + d1·ln r moves a knot's centre by d1 mm of arc
    // per mm of r, and d1 stays well under one. A run that slides round the log as it goes
    // out is a ring: an oval latewood band cut by the shells into arcs that move with r.
    if (std::abs(arc_slope(kt.shells)) > options.max_arc_slope) {
      sum.rejected_drift += own;
      continue;
    }
    double dmax = 0;
    for (const KnotShell& s : kt.shells) dmax = std::max(dmax, s.diameter);
    if (dmax < options.min_diameter_mm) {
      sum.rejected_small += own;
      continue;
    }
    follow_outwards(g, options, follow_min, &kt);
    // A knot is a tube running out from the pith: longer along r than it is thick. A pocket
    // (resin between two rings, a wet patch, rot) is a lens or a blob no longer than wide.
    std::vector<double> ds;
    for (const KnotShell& s : kt.shells)
      if (!s.predicted) ds.push_back(s.diameter);
    const double d_med = ds.empty() ? 0.0 : median_inplace(ds);
    if (kt.shells.back().r - kt.shells.front().r + g.dr < options.min_length_diameters * d_med) {
      sum.rejected_stubby += own;
      continue;
    }
    const KnotShell& last = kt.shells.back();
    kt.r_last_seen = last.r;
    kt.reaches_surface = last.r >= stem.radius_at(last.omega, last.z) - options.surface_mm;
    out.push_back(std::move(kt));
  }
  out = merge_pieces(std::move(out));
  // Deterministic order: by height at the innermost shell, then azimuth.
  std::sort(out.begin(), out.end(), [](const KnotTrace& a, const KnotTrace& b) {
    if (a.shells.front().z != b.shells.front().z) return a.shells.front().z < b.shells.front().z;
    return a.shells.front().omega < b.shells.front().omega;
  });
  sum.follow_s = lap();
  sum.traces = static_cast<int>(out.size());
  return out;
}

int thread_count(const KnotDetectOptions& o) {
  return o.threads > 0 ? o.threads
                       : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

}  // namespace

std::vector<KnotTrace> detect_knots(const LogVolume& volume, const Stem& stem,
                                    const KnotDetectOptions& options, KnotDetectSummary* summary) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  const int threads = thread_count(options);
  if (volume.slice_count() < 2 || stem.slice_count() == 0) return {};
  Grid g = unroll(volume, stem, options, threads);
  KnotDetectSummary sum;
  sum.unroll_s = std::chrono::duration<double>(Clock::now() - t_start).count();
  sum.grid_bytes = g.hu.size() * sizeof(std::int16_t);
  std::vector<KnotTrace> out = detect_in_grid(g, stem, options, threads, sum);
  sum.total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
  if (summary) *summary = sum;
  return out;
}

namespace {
// Slices [read_begin, read_end) read for a window whose own slices are [core_begin, core_end).
struct Window {
  int read_begin = 0, read_end = 0, core_begin = 0, core_end = 0;
};

std::vector<Window> plan_windows(int n, double dz, const KnotWindowOptions& o) {
  const int core = std::max(1, static_cast<int>(std::lround(o.core_mm / dz)));
  const int margin = std::max(0, static_cast<int>(std::ceil(o.margin_mm / dz)));
  if (n <= core + 2 * margin) return {{0, n, 0, n}};
  const int count = (n + core - 1) / core;
  const int each = (n + count - 1) / count;
  std::vector<Window> out;
  for (int c = 0; c < n; c += each) {
    const int e = std::min(n, c + each);
    out.push_back({std::max(0, c - margin), std::min(n, e + margin), c, e});
  }
  return out;
}

double spacing_of(const VolumeGeometry& g) {
  return g.slice_spacing() > 0 ? g.slice_spacing() : 1.0;
}
}  // namespace

std::size_t knot_grid_bytes(int planes, double r_max_mm, const KnotDetectOptions& o) {
  const double dr = o.dr_mm > 0 ? o.dr_mm : 1.0;
  const double shells = std::max(1.0, std::ceil(r_max_mm / dr));
  const double samples = static_cast<double>(planes) * shells * std::max(8, o.n_omega);
  return static_cast<std::size_t>(samples * 2 * 1.3);
}

int knot_plane_run(const VolumeGeometry& geometry, const KnotDetectOptions& options) {
  return planes_of(geometry, options).run;
}

int knot_window_planes(const VolumeGeometry& geometry, const KnotWindowOptions& window,
                       const KnotDetectOptions& options) {
  const Planes planes = planes_of(geometry, options);
  int most = 0;
  for (const Window& w : plan_windows(planes.count(), planes.run * spacing_of(geometry), window))
    most = std::max(most, w.read_end - w.read_begin);
  return most;
}

Result<std::vector<KnotTrace>> detect_knots(SliceSource& source, const Stem& stem,
                                            const std::vector<char>* has_log,
                                            const KnotDetectOptions& options,
                                            const KnotWindowOptions& window,
                                            KnotDetectSummary* summary,
                                            const KnotSliceVisitor& visit) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  const VolumeGeometry& geo = source.geometry();
  const int n = geo.slice_count();
  const int threads = thread_count(options);
  KnotDetectSummary sum;
  sum.windows = 0;
  std::vector<KnotTrace> out;
  if (n < 2 || stem.slice_count() == 0) {
    if (summary) *summary = sum;
    return out;
  }
  if (has_log && static_cast<int>(has_log->size()) != n)
    return Error("knot scan", "the slice mask does not match the scan's slices");
  auto kept = [&](int i) { return !has_log || (*has_log)[static_cast<size_t>(i)] != 0; };
  // Windows of planes (runs of slices, KnotDetectOptions::grid_dz_mm), read a batch of whole
  // planes at a time.
  const Planes planes = planes_of(geo, options);
  const double dz = planes.run * spacing_of(geo);
  const std::vector<Window> windows = plan_windows(planes.count(), dz, window);
  const int batch = std::max(threads, 4 * threads / planes.run);  // planes
  // The b-th plane of a batch has its slices at b * run + (slice - its first): `at` holds the
  // scan index of each slice read, -1 where none was.
  std::vector<Slice> slices(static_cast<size_t>(batch * planes.run));
  std::vector<int> at(slices.size(), -1);
  int visited = -1;
  double weight = 0;
  KnotDetectSummary mean;  // signal figures, weighted by the windows' own slices
  // The rows the next window shares with this one, unrolled already (HU, before contrast): the
  // overlap is neither read nor unrolled twice.
  int carried_from = 0, carried_to = 0, carried_nr = 0;  // slices [from, to), shells
  std::vector<std::int16_t> carried;
  for (size_t wi = 0; wi < windows.size(); ++wi) {
    const Window& w = windows[wi];
    auto t0 = Clock::now();
    Grid g = make_grid(geo, planes, w.read_begin, w.read_end, stem, options, threads, kept);
    g.core_lo = w.core_begin - w.read_begin, g.core_hi = w.core_end - w.read_begin;
    // Shells beyond the outline are never sampled, and both grids reach every slice's outline.
    int i = w.read_begin;
    for (; i >= carried_from && i < std::min(carried_to, w.read_end); ++i) {
      const int nr = std::min(g.nr, carried_nr);
      for (int j = 0; j < nr; ++j)
        std::copy_n(&carried[(static_cast<size_t>(i - carried_from) * carried_nr + j) * g.nw], g.nw,
                    &g.hu[g.at(i - w.read_begin, j, 0)]);
    }
    while (i < w.read_end) {
      std::vector<int> todo;  // planes of this batch with a slice to unroll
      const auto tr = Clock::now();
      for (; i < w.read_end && static_cast<int>(todo.size()) < batch; ++i) {
        if (!g.live[static_cast<size_t>(i - w.read_begin)]) continue;
        const size_t base = todo.size() * static_cast<size_t>(planes.run);
        for (int s = planes.first(i); s < planes.end(i); ++s) {
          const size_t q = base + static_cast<size_t>(s - planes.first(i));
          at[q] = -1;
          if (!unrolled(geo, stem, kept, s)) continue;
          const Status st = source.read(s, slices[q]);
          if (!st) return st.error();
          at[q] = s;
        }
        todo.push_back(i);
      }
      sum.read_s += std::chrono::duration<double>(Clock::now() - tr).count();
      auto slot = [&](int b, int s) {
        return static_cast<size_t>(b) * planes.run +
               static_cast<size_t>(s - planes.first(todo[static_cast<size_t>(b)]));
      };
      parallel_for(static_cast<int>(todo.size()), threads, [&](int b) {
        const int p = todo[static_cast<size_t>(b)];
        unroll_plane(
            g, p - w.read_begin, geo, planes, p, stem,
            [&](int s) {
              return quantised_crop(slices[slot(b, s)], geo, stem.pith_at(geo.z[s]), g.r(g.nr - 1));
            },
            [&](int s) { return at[slot(b, s)] == s; });
      });
      if (visit)
        for (size_t b = 0; b < todo.size(); ++b)
          for (int s = planes.first(todo[b]); s < planes.end(todo[b]); ++s)
            if (at[slot(static_cast<int>(b), s)] == s && s > visited) {
              visited = s;
              visit(s, slices[slot(static_cast<int>(b), s)]);
            }
    }
    if (wi + 1 < windows.size()) {
      carried_from = std::max(w.read_begin, windows[wi + 1].read_begin);
      carried_to = w.read_end;
      carried_nr = g.nr;
      carried.assign(
          g.hu.begin() + static_cast<std::ptrdiff_t>(g.at(carried_from - w.read_begin, 0, 0)),
          g.hu.end());
    }
    KnotDetectSummary ws;
    ws.unroll_s = std::chrono::duration<double>(Clock::now() - t0).count();
    sum.grid_bytes = std::max(sum.grid_bytes, g.hu.size() * sizeof(std::int16_t));
    std::vector<KnotTrace> traces = detect_in_grid(g, stem, options, threads, ws);
    g = Grid{};
    // This window's own: the traces whose innermost shell lies in its core.
    const double z_lo = wi == 0 ? -HUGE_VAL : plane_z(geo, planes, w.core_begin) - 0.5 * dz;
    const double z_hi =
        wi + 1 == windows.size() ? HUGE_VAL : plane_z(geo, planes, w.core_end - 1) + 0.5 * dz;
    for (KnotTrace& t : traces) {
      const double z = t.shells.front().z;
      if (z >= z_lo && z < z_hi) out.push_back(std::move(t));
    }
    const double wt = w.core_end - w.core_begin;
    weight += wt;
    mean.noise_hu += wt * ws.noise_hu, mean.residual_hu += wt * ws.residual_hu;
    mean.ring_hu += wt * ws.ring_hu, mean.low_hu += wt * ws.low_hu;
    mean.high_hu += wt * ws.high_hu, mean.follow_hu += wt * ws.follow_hu;
    sum.high_hu_min = sum.windows == 0 ? ws.high_hu : std::min(sum.high_hu_min, ws.high_hu);
    sum.high_hu_max = std::max(sum.high_hu_max, ws.high_hu);
    ++sum.windows;
    sum.shells = std::max(sum.shells, ws.shells), sum.omegas = ws.omegas;
    sum.slices += w.core_end - w.core_begin;
    sum.blobs += ws.blobs, sum.tracks += ws.tracks;
    sum.rejected_sheet_blobs += ws.rejected_sheet_blobs, sum.rejected_drift += ws.rejected_drift;
    sum.rejected_short += ws.rejected_short, sum.rejected_steep += ws.rejected_steep;
    sum.rejected_small += ws.rejected_small, sum.rejected_stubby += ws.rejected_stubby;
    sum.unroll_s += ws.unroll_s, sum.contrast_s += ws.contrast_s, sum.segment_s += ws.segment_s;
    sum.track_s += ws.track_s, sum.follow_s += ws.follow_s;
  }
  if (weight > 0) {
    sum.noise_hu = mean.noise_hu / weight, sum.residual_hu = mean.residual_hu / weight;
    sum.ring_hu = mean.ring_hu / weight, sum.low_hu = mean.low_hu / weight;
    sum.high_hu = mean.high_hu / weight, sum.follow_hu = mean.follow_hu / weight;
  }
  std::sort(out.begin(), out.end(), [](const KnotTrace& a, const KnotTrace& b) {
    if (a.shells.front().z != b.shells.front().z) return a.shells.front().z < b.shells.front().z;
    return a.shells.front().omega < b.shells.front().omega;
  });
  sum.traces = static_cast<int>(out.size());
  sum.total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
  if (summary) *summary = sum;
  return out;
}

}  // namespace sawyer::ct
