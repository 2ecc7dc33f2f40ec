// The knot pass's voxel store (see log_volume.h).
#include "sawyer/ct/knots/log_volume.h"

#include <algorithm>
#include <cmath>

namespace sawyer::ct {

LogVolume LogVolume::empty_like(const VolumeGeometry& geometry) {
  LogVolume v;
  v.geometry_ = geometry;
  v.planes_.resize(static_cast<size_t>(geometry.slice_count()));
  return v;
}

void LogVolume::keep(int i, const Slice& slice, Vec2 centre, double reach_mm) {
  LogPlane& p = planes_[static_cast<size_t>(i)];
  p = LogPlane{};
  if (slice.width <= 0 || slice.height <= 0 || !(reach_mm > 0)) return;
  const double sx = geometry_.spacing_x, sy = geometry_.spacing_y;
  const int x0 =
      std::clamp(static_cast<int>(std::floor((centre.x - reach_mm) / sx)), 0, slice.width);
  const int y0 =
      std::clamp(static_cast<int>(std::floor((centre.y - reach_mm) / sy)), 0, slice.height);
  const int x1 =
      std::clamp(static_cast<int>(std::ceil((centre.x + reach_mm) / sx)) + 1, 0, slice.width);
  const int y1 =
      std::clamp(static_cast<int>(std::ceil((centre.y + reach_mm) / sy)) + 1, 0, slice.height);
  if (x1 <= x0 || y1 <= y0) return;
  p.x0 = x0, p.y0 = y0, p.width = x1 - x0, p.height = y1 - y0;
  p.hu.resize(static_cast<size_t>(p.width) * p.height);
  for (int y = 0; y < p.height; ++y) {
    const float* src = &slice.hu[static_cast<size_t>(y0 + y) * slice.width + x0];
    std::int16_t* dst = &p.hu[static_cast<size_t>(y) * p.width];
    for (int x = 0; x < p.width; ++x) dst[x] = quantise_hu(src[x]);
  }
}

float LogVolume::at(int i, double x_mm, double y_mm) const {
  const LogPlane& p = planes_[static_cast<size_t>(i)];
  return bilinear_hu([&](std::size_t k) { return static_cast<float>(p.hu[k]); }, p.width, p.height,
                     x_mm / geometry_.spacing_x - p.x0, y_mm / geometry_.spacing_y - p.y0);
}

std::size_t LogVolume::bytes() const {
  std::size_t n = 0;
  for (const LogPlane& p : planes_) n += p.hu.size() * sizeof(std::int16_t);
  return n;
}

Result<LogVolume> read_log_volume(SliceSource& source, const Stem& stem, double margin_mm) {
  const VolumeGeometry& g = source.geometry();
  LogVolume v = LogVolume::empty_like(g);
  if (stem.slice_count() == 0) return v;
  Slice s;
  for (int i = 0; i < g.slice_count(); ++i) {
    const double z = g.z[static_cast<size_t>(i)];
    if (z < stem.z_begin() || z > stem.z_end()) continue;
    const Status st = source.read(i, s);
    if (!st) return st.error();
    const int k = std::clamp(static_cast<int>(std::lround((z - stem.z0_mm) / stem.dz_mm)), 0,
                             stem.slice_count() - 1);
    const auto& row = stem.radius[static_cast<size_t>(k)];
    const double rmax = row.empty() ? 0.0 : *std::max_element(row.begin(), row.end());
    v.keep(i, s, stem.pith_at(z), rmax + margin_mm);
  }
  return v;
}

}  // namespace sawyer::ct
