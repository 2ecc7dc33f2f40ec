// The viewer's geometry, now in libs/render: knot tubes on the knot formula, the light outer
// surface, a board's outline, and the orbit camera's framing, panning, rotation and zoom.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <string>

#include "sawyer/model/log_json.h"
#include "sawyer/render/mesh.h"
#include "sawyer/render/orbit_camera.h"
#include "sawyer/test/test_util.h"

namespace sawyer::render {
namespace {

// A straight log along z with one knot running along +x at z = 500: the axis is the x axis at
// that height, so a tube vertex at pith distance r has x = r and lies d(r)/2 from the axis.
LogModel straight_log_with_one_knot() {
  LogModel log;
  log.id = "straight";
  Stem& st = log.stem;
  st.z0_mm = 5;
  st.dz_mm = 10;
  st.n_angles = 36;
  for (int i = 0; i < 100; ++i) {
    st.pith.push_back({0, 0});
    st.radius.push_back(std::vector<double>(36, 150.0));
  }
  Knot k;
  k.z0 = 500;
  k.r_dead = 60;
  k.r_end = 100;
  k.diameter = {20.0, 1.0};  // d(r) = 20 r / 60 up to r_dead, 20 mm beyond
  log.knots.push_back(k);
  return log;
}

TEST(ViewerGeometry, KnotTubeLiesOnTheKnotSurfaceAndItsDeadPartIsDark) {
  const LogModel log = straight_log_with_one_knot();
  KnotTubeOptions o;
  o.min_diameter_mm = 2.0;
  const Mesh mesh = knot_tubes(log, o);
  ASSERT_FALSE(mesh.lines);
  ASSERT_GT(mesh.vertices.size(), 100u);
  ASSERT_EQ(mesh.vertices.size() % 3, 0u);
  int sound = 0, dead = 0;
  for (const MeshVertex& v : mesh.vertices) {
    const double x = v.pos[0], dist = std::hypot(v.pos[1], v.pos[2] - 500.0);
    const bool is_dead = v.color[0] == o.dead_color[0] && v.color[1] == o.dead_color[1];
    const bool is_sound = v.color[0] == o.sound_color[0] && v.color[1] == o.sound_color[1];
    ASSERT_TRUE(is_dead || is_sound);
    EXPECT_GE(x, -1e-3);
    EXPECT_LE(x, 100.0 + 1e-3);
    const double d = std::max(x <= 60 ? 20.0 * x / 60.0 : 20.0, o.min_diameter_mm);
    if (x < 100.0 - 1e-3) {  // the end cap's centre is on the axis
      EXPECT_NEAR(dist, 0.5 * d, 1e-3) << "x " << x;
    }
    if (is_dead) {
      ++dead;
      EXPECT_GE(x, 60.0 - 1e-3);  // dark only beyond the sound/dead border
    } else {
      ++sound;
      EXPECT_LE(x, 60.0 + 1e-3);
    }
  }
  EXPECT_GT(sound, 0);
  EXPECT_GT(dead, 0);
}

TEST(ViewerGeometry, EveryKnotOfTheSpruceLogGetsATube) {
  const LogModel& log = test::sample_model("gran1_spruce");
  ASSERT_FALSE(log.knots.empty());
  KnotTubeOptions o;
  const Mesh all = knot_tubes(log, o);
  LogModel one = log;
  one.knots.resize(1);
  const size_t per_knot = knot_tubes(one, o).vertices.size();
  ASSERT_GT(per_knot, 0u);
  // Each knot is rings x sides x 6 vertices plus a cap, plus one more ring with a dead part.
  EXPECT_GE(all.vertices.size(), log.knots.size() * static_cast<size_t>(o.rings * o.sides * 6));
  int dead_knots = 0;
  for (const Knot& k : log.knots) dead_knots += k.has_dead_part() ? 1 : 0;
  EXPECT_GT(dead_knots, 0);
}

TEST(ViewerGeometry, LightSurfaceLiesOnTheOuterRadiusFromEndToEnd) {
  LogModel log = straight_log_with_one_knot();
  // An elliptical outline: r = 150 + 30 cos 2w.
  for (auto& row : log.stem.radius)
    for (int k = 0; k < log.stem.n_angles; ++k)
      row[k] = 150.0 + 30.0 * std::cos(2.0 * kTwoPi * k / log.stem.n_angles);
  const Mesh m = log_surface(log.stem, {1, 1, 1}, 72, 20.0);
  ASSERT_FALSE(m.lines);
  ASSERT_EQ(m.vertices.size() % 6, 0u);
  double zmin = 1e9, zmax = -1e9;
  for (const MeshVertex& v : m.vertices) {
    const double w = std::atan2(v.pos[1], v.pos[0]);
    EXPECT_NEAR(std::hypot(v.pos[0], v.pos[1]), log.stem.radius_at(wrap_angle(w), v.pos[2]), 1e-3);
    // Normals point outwards.
    EXPECT_GT(v.normal[0] * v.pos[0] + v.normal[1] * v.pos[1], 0.0);
    zmin = std::min(zmin, static_cast<double>(v.pos[2]));
    zmax = std::max(zmax, static_cast<double>(v.pos[2]));
  }
  EXPECT_NEAR(zmin, log.stem.z_begin(), 1e-3);
  EXPECT_NEAR(zmax, log.stem.z_end(), 1e-3);
}

TEST(ViewerGeometry, BoardOutlineHasTwelveEdgesAtTheBoardsCorners) {
  BoardBox b;
  b.cx = 10;
  b.cy = -20;
  b.width = 100;
  b.thickness = 40;
  b.rotation = 0.3;
  b.z0 = 100;
  b.z1 = 900;
  const Mesh m = board_outline(b, {1, 1, 0});
  ASSERT_TRUE(m.lines);
  ASSERT_EQ(m.vertices.size(), 24u);
  for (const MeshVertex& v : m.vertices) {
    const Vec3 d = Vec3{v.pos[0], v.pos[1], 0} - Vec3{b.cx, b.cy, 0};
    EXPECT_NEAR(std::abs(dot(d, b.u())), 50.0, 1e-3);
    EXPECT_NEAR(std::abs(dot(d, b.v())), 20.0, 1e-3);
    EXPECT_TRUE(std::abs(v.pos[2] - 100.0) < 1e-3 || std::abs(v.pos[2] - 900.0) < 1e-3);
  }
}

// The largest |x| and |y| of the log's outline in normalised device coordinates.
std::array<double, 2> reach(const OrbitCamera& orbit, const LogModel& log, double aspect) {
  const render::Mat4 vp = orbit.camera().view_projection(aspect);
  std::array<double, 2> r{0, 0};
  const Stem& st = log.stem;
  for (int i = 0; i < st.slice_count(); i += 10)
    for (int k = 0; k < st.n_angles; k += 10) {
      const double w = kTwoPi * k / st.n_angles;
      const Vec2 c = st.pith[i];
      const Vec3 p{c.x + st.radius[i][k] * std::cos(w), c.y + st.radius[i][k] * std::sin(w),
                   st.z_at(i)};
      const Vec3 n = vp.transform_point(p);
      r[0] = std::max(r[0], std::abs(n.x));
      r[1] = std::max(r[1], std::abs(n.y));
    }
  return r;
}

TEST(ViewerGeometry, ResetViewFitsTheWholeLogAndFillsTheView) {
  const LogModel& log = test::sample_model("gran1_spruce");
  for (double aspect : {0.6, 1.0, 2.2}) {
    for (bool ortho : {false, true}) {
      OrbitCamera orbit;
      orbit.orthographic = ortho;
      orbit.frame_log(log, aspect);
      const std::array<double, 2> r = reach(orbit, log, aspect);
      EXPECT_LE(std::max(r[0], r[1]), 0.95) << "aspect " << aspect << " ortho " << ortho;
      EXPECT_GE(std::max(r[0], r[1]), 0.75) << "aspect " << aspect << " ortho " << ortho;
    }
  }
}

TEST(ViewerGeometry, PanKeepsThePointUnderTheCursorAndRotateStopsShortOfThePoles) {
  const LogModel& log = test::sample_model("gran1_spruce");
  const double aspect = 1.5, height_px = 600, width_px = aspect * height_px;
  for (bool ortho : {false, true}) {
    OrbitCamera orbit;
    orbit.orthographic = ortho;
    orbit.frame_log(log, aspect);
    const Vec3 target = orbit.target;
    orbit.pan(30, -20, height_px);  // 30 px right, 20 px up
    const Vec3 n = orbit.camera().view_projection(aspect).transform_point(target);
    EXPECT_NEAR(0.5 * n.x * width_px, 30.0, 0.5) << "ortho " << ortho;
    EXPECT_NEAR(0.5 * n.y * height_px, 20.0, 0.5) << "ortho " << ortho;
  }
  OrbitCamera orbit;
  orbit.frame_log(log, aspect);
  orbit.rotate(0, 1e6);
  EXPECT_LE(orbit.pitch, OrbitCamera::kPitchLimit);
  orbit.rotate(0, -1e6);
  EXPECT_GE(orbit.pitch, -OrbitCamera::kPitchLimit);
  const double d = orbit.distance;
  orbit.zoom(3);
  EXPECT_NEAR(orbit.distance, d * std::pow(OrbitCamera::kZoomPerStep, 3), 1e-6 * d);
  orbit.zoom(1e4);
  EXPECT_EQ(orbit.distance, orbit.min_distance);
}

}  // namespace
}  // namespace sawyer::render
