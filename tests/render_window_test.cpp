// The window back-end (GLFW): a window's OpenGL context runs the same renderer, drawing into the
// window's own framebuffer as the viewer will. Needs a display: skipped without one (run under
// `xvfb-run` to exercise it on a machine with no screen).
#include <gtest/gtest.h>

#include <cstdlib>

#include "sawyer/render/glfw_window.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/test/test_util.h"

namespace sawyer::render {
namespace {

TEST(RenderWindow, DrawsABoardIntoTheWindowFramebuffer) {
  if (!std::getenv("DISPLAY") && !std::getenv("WAYLAND_DISPLAY"))
    GTEST_SKIP() << "no display (run under xvfb-run)";
  WindowOptions o;
  o.width = 320;
  o.height = 200;
  o.visible = false;
  auto win = GlfwWindow::create(o);
  ASSERT_TRUE(win.ok()) << win.error().message();
  EXPECT_NE(win.value()->description().find("OpenGL 4."), std::string::npos);
  const LogModel& log = test::sample_model("gran1_spruce");
  auto r = WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  const Vec3 c = r.value()->pith_point(0);
  BoardBox b;
  b.cx = c.x;
  b.cy = c.y + 40;
  b.width = 150;
  b.thickness = 40;
  b.z0 = 1000;
  b.z1 = 1600;
  const Viewport vp = win.value()->framebuffer_viewport();
  ASSERT_GT(vp.width, 0);
  bind_default_framebuffer(vp);
  r.value()->draw_plane(board_face(b, Face::kTop), vp);
  const Image img = read_pixels(vp);
  win.value()->swap_buffers();
  int wood = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) wood += img.value(x, y, 0) > 0.3f;
  EXPECT_GT(wood, img.width * img.height * 9 / 10) << "the face fills the window";
}

}  // namespace
}  // namespace sawyer::render
