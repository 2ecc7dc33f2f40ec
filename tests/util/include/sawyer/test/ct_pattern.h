// Test fixtures shared by the CT reader suites (stacks, volumes): a deterministic HU pattern,
// a geometry with unequal x/y spacing and a rotated orientation, and the checks that a scan read
// back holds exactly that pattern and geometry.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct {

namespace fs = std::filesystem;

// A test pattern in HU covering air to dense knots, different in every slice, row and column.
inline float pattern_hu(int c, int r, int i) {
  return static_cast<float>(-1000 + (c * 37 + r * 101 + i * 211) % 3000) + 0.25f * (c % 3);
}

inline VolumeGeometry test_geometry(int w, int h, int n) {
  VolumeGeometry g;
  g.width = w;
  g.height = h;
  g.spacing_x = 0.4;
  g.spacing_y = 0.65;
  for (int i = 0; i < n; ++i) g.z.push_back(2.5 * i);
  g.origin = {-12.5, 30.25, 1000.0};
  g.orientation = {0, 1, 0, -1, 0, 0};
  return g;
}

inline Slice pattern_slice(const VolumeGeometry& g, int i) {
  Slice s;
  s.index = i;
  s.z = g.z[i];
  s.width = g.width;
  s.height = g.height;
  s.hu.resize(static_cast<size_t>(g.width) * g.height);
  for (int r = 0; r < g.height; ++r)
    for (int c = 0; c < g.width; ++c)
      s.hu[static_cast<size_t>(r) * g.width + c] = pattern_hu(c, r, i);
  return s;
}

inline void write_volume(const fs::path& out, const VolumeGeometry& g, const WriteOptions& o) {
  auto sink = create_ct_writer(out, g, o);
  ASSERT_TRUE(sink.ok()) << sink.error().message();
  for (int i = 0; i < g.slice_count(); ++i) {
    Status st = sink.value()->write(pattern_slice(g, i));
    ASSERT_TRUE(st.ok()) << st.error().message();
  }
  Status st = sink.value()->finish();
  ASSERT_TRUE(st.ok()) << st.error().message();
}

inline std::unique_ptr<SliceSource> open_ok(const fs::path& p, const OpenOptions& o = {}) {
  auto r = open_ct(p, o);
  EXPECT_TRUE(r.ok()) << r.error().message();
  return r.ok() ? std::move(r).value() : nullptr;
}

// Every slice matches the pattern within `tol` HU.
inline void expect_pattern(SliceSource& src, double tol) {
  const VolumeGeometry& g = src.geometry();
  Slice s;
  for (int i = 0; i < g.slice_count(); ++i) {
    Status st = src.read(i, s);
    ASSERT_TRUE(st.ok()) << st.error().message();
    ASSERT_EQ(s.width, g.width);
    ASSERT_EQ(s.height, g.height);
    ASSERT_EQ(s.index, i);
    double worst = 0;
    for (int r = 0; r < g.height; ++r)
      for (int c = 0; c < g.width; ++c)
        worst = std::max(worst, std::abs(double(s.at(c, r)) - pattern_hu(c, r, i)));
    EXPECT_LE(worst, tol) << "slice " << i;
  }
}

inline void expect_geometry(const VolumeGeometry& got, const VolumeGeometry& want) {
  EXPECT_EQ(got.width, want.width);
  EXPECT_EQ(got.height, want.height);
  EXPECT_DOUBLE_EQ(got.spacing_x, want.spacing_x);
  EXPECT_DOUBLE_EQ(got.spacing_y, want.spacing_y);
  ASSERT_EQ(got.slice_count(), want.slice_count());
  for (int i = 0; i < want.slice_count(); ++i) EXPECT_NEAR(got.z[i], want.z[i], 1e-9) << i;
  EXPECT_NEAR(got.origin.x, want.origin.x, 1e-9);
  EXPECT_NEAR(got.origin.y, want.origin.y, 1e-9);
  EXPECT_NEAR(got.origin.z, want.origin.z, 1e-9);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(got.orientation[k], want.orientation[k], 1e-12);
}

}  // namespace sawyer::ct
