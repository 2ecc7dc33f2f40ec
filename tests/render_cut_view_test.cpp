// The cut view of the cutting report (libs/render cut_view.h): the boards show through the
// translucent bark shell, the shell is translucent, knots are drawn in their colours, and what
// lies outside the log is background. On the bundled gran1 spruce, small images.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "sawyer/render/cut_view.h"
#include "sawyer/render/gl_layers.h"
#include "sawyer/render/image.h"
#include "sawyer/render/mesh.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/test/render_context.h"
#include "sawyer/test/test_util.h"

namespace sawyer::render {
namespace {

struct Rgb8 {
  double r = 0, g = 0, b = 0;
};

// Mean colour (0..255) of the 3 x 3 pixels around (x, y).
Rgb8 at(const Image& img, double x, double y) {
  Rgb8 c;
  int n = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int px = std::clamp(static_cast<int>(x) + dx, 0, img.width - 1);
      const int py = std::clamp(static_cast<int>(y) + dy, 0, img.height - 1);
      c.r += 255.0 * img.value(px, py, 0);
      c.g += 255.0 * img.value(px, py, 1);
      c.b += 255.0 * img.value(px, py, 2);
      ++n;
    }
  return {c.r / n, c.g / n, c.b / n};
}

double distance(const Rgb8& a, const Rgb8& b) {
  return std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b);
}

class RenderCutView : public ::testing::Test {
 protected:
  void SetUp() override {
    test::ensure_headless_context();
    auto r = WoodRenderer::create(test::sample_model("gran1_spruce"));
    ASSERT_TRUE(r.ok()) << r.error().message();
    renderer_ = std::move(r).value();
    const Stem& st = renderer_->log().stem;
    // Two boards on the pith line: a centre board and one beside it.
    const Vec3 c = renderer_->pith_point(st.z_begin() + 0.5 * st.length_mm());
    for (double dy : {0.0, -60.0}) {
      BoardBox b;
      b.cx = c.x;
      b.cy = c.y + dy;
      b.width = dy == 0 ? 150 : 100;
      b.thickness = dy == 0 ? 50 : 25;
      b.z0 = st.z_begin() + 200;
      b.z1 = st.z_end() - 300;
      boards_.push_back(b);
    }
    options_.width = 480;
    options_.height = 280;
    options_.supersample = 1;
    camera_ = cut_view_camera(*renderer_, options_.width, options_.height);
  }

  Image render(const std::vector<BoardBox>& boards, const CutViewOptions& o) {
    Result<Image> img = render_cut_view(*renderer_, boards, camera_, o);
    EXPECT_TRUE(img.ok()) << img.error().message();
    // SAWYER_TEST_IMAGES=<folder>: keep every image rendered here (cut_1.png, ...) to look at.
    if (const char* d = std::getenv("SAWYER_TEST_IMAGES"); d && img.ok())
      (void)write_image(std::string(d) + "/cut_" + std::to_string(++saved_) + ".png", img.value());
    return img.ok() ? img.value() : Image{};
  }
  Vec2 pixel(const Vec3& p) const {
    const Vec3 n = camera_.view_projection(static_cast<double>(options_.width) / options_.height)
                       .transform_point(p);
    return {(0.5 * n.x + 0.5) * options_.width, (0.5 - 0.5 * n.y) * options_.height};
  }

  std::unique_ptr<WoodRenderer> renderer_;
  static inline int saved_ = 0;
  std::vector<BoardBox> boards_;
  CutViewOptions options_;
  Camera camera_;
};

TEST_F(RenderCutView, BoardsShowThroughTheTranslucentShell) {
  CutViewOptions bare = options_;  // the boards alone: no shell, no knots
  bare.shell_alpha = bare.shell_rim = bare.shell_specular = 0;
  bare.knots = false;
  CutViewOptions shell_only = options_;
  shell_only.knots = false;
  CutViewOptions full = options_;
  full.knots = false;
  const Image with = render(boards_, full);
  const Image alone = render(boards_, bare);
  const Image shell = render({}, shell_only);
  ASSERT_GT(with.width, 0);
  const Rgb8 background{255, 255, 255};

  // Board pixels: the centre of each board's top end (the camera looks from beyond it) and of
  // its upper face at mid-length. Through the shell they keep the bare board's colour but for
  // less than half the way to the bark's (the shell is translucent over them), and stay warmer
  // than the shell alone is there (wood shows, not bark over background).
  const std::array<float, 3> bark = renderer_->look().bark_outer;
  const Rgb8 bark8{255.0 * bark[0], 255.0 * bark[1], 255.0 * bark[2]};
  int checked = 0;
  for (const BoardBox& b : boards_) {
    const Vec3 mid{b.cx, b.cy, 0.5 * (b.z0 + b.z1)};
    for (const Vec3& p : {Vec3{b.cx, b.cy, b.z1}, mid + (0.5 * b.thickness) * b.v()}) {
      const Vec2 q = pixel(p);
      ASSERT_TRUE(q.x > 2 && q.x < with.width - 3 && q.y > 2 && q.y < with.height - 3);
      const Rgb8 w = at(with, q.x, q.y), a = at(alone, q.x, q.y), s = at(shell, q.x, q.y);
      SCOPED_TRACE(testing::Message() << "pixel " << q.x << ", " << q.y);
      EXPECT_GT(distance(a, background), 60) << "the bare board is not drawn here";
      EXPECT_LT(distance(w, a), 0.5 * distance(a, bark8)) << "the shell hides the board";
      EXPECT_GT(w.r - w.b, s.r - s.b + 15) << "no wood under the shell";
      ++checked;
    }
  }
  EXPECT_EQ(checked, 4);

  // The shell is translucent: where it covers the pith line away from the boards (beyond their
  // top end) it is neither background nor opaque bark.
  const Stem& st = renderer_->log().stem;
  const Vec2 q = pixel(renderer_->pith_point(st.z_end() - 120));
  const Rgb8 s = at(shell, q.x, q.y);
  EXPECT_GT(distance(s, background), 15) << "no shell over the log";
  EXPECT_GT(distance(s, bark8), 60) << "the shell is opaque";

  // Outside the log: background, in every image.
  for (const Image* img : {&with, &alone, &shell})
    for (auto [x, y] : {std::pair{2, 2}, {img->width - 3, 2}}) {
      const Rgb8 c = at(*img, x, y);
      EXPECT_EQ(distance(c, background), 0) << "corner " << x << ", " << y;
    }
}

TEST_F(RenderCutView, KnotsAreGreenWhereSoundAndRedWhereDead) {
  CutViewOptions o = options_;
  o.shell_alpha = o.shell_rim = o.shell_specular = 0;
  const Image knots = render({}, o);
  CutViewOptions none = o;
  none.knots = false;
  const Image empty = render({}, none);
  int green = 0, red = 0, other = 0;
  for (int y = 0; y < knots.height; ++y)
    for (int x = 0; x < knots.width; ++x) {
      const Rgb8 c{255.0 * knots.value(x, y, 0), 255.0 * knots.value(x, y, 1),
                   255.0 * knots.value(x, y, 2)};
      EXPECT_EQ(distance(at(empty, x, y), {255, 255, 255}), 0) << x << ", " << y;
      if (distance(c, {255, 255, 255}) < 1) continue;
      if (c.g > c.r + 30 && c.g > c.b + 30)
        ++green;
      else if (c.r > c.g + 60 && c.r > c.b + 60)
        ++red;
      else
        ++other;
    }
  // gran1 has 108 knots, many with a dead part.
  EXPECT_GT(green, 200);
  EXPECT_GT(red, 50);
  EXPECT_LT(other, (green + red) / 4);  // edges only
}

TEST(RenderCutViewMesh, BarkSurfaceLiesTheBarkOutsideTheOutlineAndBlocksAreClosed) {
  Stem st;
  st.z0_mm = 5;
  st.dz_mm = 10;
  st.n_angles = 36;
  for (int i = 0; i < 50; ++i) {
    st.pith.push_back({0, 0});
    st.radius.push_back(std::vector<double>(36, 100.0));
    st.bark_mm.push_back(i < 25 ? 10.0 : 20.0);
  }
  const Mesh m = bark_surface(st, 5.0, {0.5f, 0.4f, 0.3f}, 48, 10.0);
  ASSERT_EQ(m.vertices.size() % 3, 0u);
  for (const MeshVertex& v : m.vertices) {
    const double r = std::hypot(v.pos[0], v.pos[1]);
    const bool end = v.pos[2] < st.z_begin() + 1e-3 || v.pos[2] > st.z_end() - 1e-3;
    if (!end) {  // on the side: 100 + bark, 10 below z = 240, 20 above z = 250
      EXPECT_GE(r, 110.0 - 1e-3);
      EXPECT_LE(r, 120.0 + 1e-3);
      if (v.pos[2] < 240) {
        EXPECT_NEAR(r, 110.0, 1e-3);
      }
      if (v.pos[2] > 250) {
        EXPECT_NEAR(r, 120.0, 1e-3);
      }
    } else {  // the end rings: between the wood and the bark's outside
      EXPECT_GE(r, 100.0 - 1e-3);
      EXPECT_LE(r, 120.0 + 1e-3);
    }
  }
  // No bark in the model: the default.
  st.bark_mm.clear();
  for (const MeshVertex& v : bark_surface(st, 5.0, {0.5f, 0.4f, 0.3f}, 48, 10.0).vertices) {
    if (v.pos[2] > st.z_begin() + 1e-3 && v.pos[2] < st.z_end() - 1e-3) {
      EXPECT_NEAR(std::hypot(v.pos[0], v.pos[1]), 105.0, 1e-3);
    }
  }

  // A board block: 12 triangles, normals outward (the centre lies behind every face).
  BoardBox b;
  b.cx = 10;
  b.cy = -5;
  b.rotation = 0.4;
  const Mesh box = board_block(b, {1, 1, 1});
  ASSERT_EQ(box.vertices.size(), 36u);
  const Vec3 centre{b.cx, b.cy, 0.5 * (b.z0 + b.z1)};
  for (size_t i = 0; i < box.vertices.size(); i += 3) {
    const auto p = [&](size_t k) {
      return Vec3{box.vertices[k].pos[0], box.vertices[k].pos[1], box.vertices[k].pos[2]};
    };
    const Vec3 n{box.vertices[i].normal[0], box.vertices[i].normal[1], box.vertices[i].normal[2]};
    EXPECT_GT(dot(p(i) - centre, n), 0);
    EXPECT_GT(dot(cross(p(i + 1) - p(i), p(i + 2) - p(i)), n), 0);  // counter-clockwise outside
  }
}

}  // namespace
}  // namespace sawyer::render
