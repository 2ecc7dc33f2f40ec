// The log's voxels for the knot pass (issue 5): every slice of a scan cropped to the log's
// outline (plus a margin) and stored as 16-bit HU, so a 4 m log at 5 mm (800 slices, 300 x 300
// pixels each) takes about 150 MB instead of 800 MB of float slices.
//
//   LogVolume v = LogVolume::empty_like(geometry);
//   for each slice i: v.keep(i, slice, stem);         // any order, any thread (distinct i)
//   float hu = v.at(i, x_mm, y_mm);                    // bilinear, air outside the crop
//
// Frames: scanner frame, mm (docs/architecture.md 3); slice i lies at geometry.z[i].
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/core/vec.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/model/log_model.h"

namespace sawyer::ct {

// HU as the knot pass keeps it: clamped to [-1024, 32767] and rounded half away from zero (like
// lround, but inline: it runs per voxel).
inline std::int16_t quantise_hu(float v) {
  v = v < -1024.f ? -1024.f : (v > 32767.f ? 32767.f : v);
  return static_cast<std::int16_t>(v >= 0.f ? v + 0.5f : v - 0.5f);
}

// Bilinear HU at pixel (c, r) (column, row; fractional) of a width x height image whose pixel
// k is value(k), rounded as quantise_hu; -1000 (air) outside it. LogVolume::at on a kept plane,
// and the same on a slice read again.
template <class Value>
float bilinear_hu(const Value& value, int width, int height, double c, double r) {
  if (!(c >= 0.0 && r >= 0.0 && c <= width - 1 && r <= height - 1) || width < 2 || height < 2)
    return -1000.f;
  const int c0 = c < width - 2 ? static_cast<int>(c) : width - 2;
  const int r0 = r < height - 2 ? static_cast<int>(r) : height - 2;
  const float fc = static_cast<float>(c - c0), fr = static_cast<float>(r - r0);
  const std::size_t k = static_cast<std::size_t>(r0) * width + c0;
  const float q00 = value(k), q01 = value(k + 1);
  const float q10 = value(k + width), q11 = value(k + width + 1);
  const float a = q00 + fc * (q01 - q00);
  const float b = q10 + fc * (q11 - q10);
  return a + fr * (b - a);
}

struct LogPlane {
  int x0 = 0, y0 = 0;            // pixel (x0, y0) of the slice is the plane's (0, 0)
  int width = 0, height = 0;     // 0: nothing kept (no log in this slice)
  std::vector<std::int16_t> hu;  // HU, clamped to [-1024, 32767]
};

class LogVolume {
 public:
  static LogVolume empty_like(const VolumeGeometry& geometry);
  const VolumeGeometry& geometry() const { return geometry_; }
  int slice_count() const { return static_cast<int>(planes_.size()); }
  const LogPlane& plane(int i) const { return planes_[static_cast<size_t>(i)]; }

  // Keeps the part of `slice` (slice i of the geometry) within `reach_mm` of `centre`
  // (scanner mm). Thread-safe for distinct i.
  void keep(int i, const Slice& slice, Vec2 centre, double reach_mm);
  // Bilinear HU at scanner (x, y) mm on slice i; -1000 (air) outside the kept crop.
  float at(int i, double x_mm, double y_mm) const;
  // Bytes held by the voxels.
  std::size_t bytes() const;

 private:
  VolumeGeometry geometry_;
  std::vector<LogPlane> planes_;
};

// Reads every slice of `source` and keeps, for each, the disc of the stem's largest outer
// radius at that height plus `margin_mm` around its pith (slices outside the stem keep
// nothing). For tests, benches and tools that have a Stem already; `sawyer scan` fills the
// volume during its stem pass instead of reading twice.
Result<LogVolume> read_log_volume(SliceSource& source, const Stem& stem, double margin_mm = 15.0);

}  // namespace sawyer::ct
