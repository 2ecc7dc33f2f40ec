// The window back-end (sawyer::render_glfw): a GLFW window with an OpenGL 4.5 core context, for
// the interactive viewer. The viewer keeps its own loop and UI (e.g. Dear ImGui's GLFW backend,
// which takes handle()):
//
//   auto win = GlfwWindow::create({1280, 800, "Sawyer"});
//   auto renderer = WoodRenderer::create(log);        // with the window's context current
//   while (!win.value()->should_close()) {
//     win.value()->poll_events();
//     Viewport vp = win.value()->framebuffer_viewport();
//     bind_default_framebuffer(vp);  /* clear */  renderer.value()->draw(scene, camera, vp);
//     win.value()->swap_buffers();
//   }
//
// Needs a display (X11 or Wayland); create() fails with a one-line error without one.
#pragma once

#include <memory>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/render/framebuffer.h"
#include "sawyer/render/gl_context.h"

struct GLFWwindow;

namespace sawyer::render {

struct WindowOptions {
  int width = 1280, height = 800;
  std::string title = "Sawyer";
  bool visible = true;
  bool vsync = true;
};

class GlfwWindow final : public GlContext {
 public:
  static Result<std::unique_ptr<GlfwWindow>> create(const WindowOptions& options = {});
  ~GlfwWindow() override;
  bool make_current() override;
  std::string description() const override;

  bool should_close() const;
  void poll_events();
  void swap_buffers();
  // The window's framebuffer in pixels (differs from the window size on HiDPI screens).
  Viewport framebuffer_viewport() const;
  // For UI libraries (ImGui_ImplGlfw_InitForOpenGL) and input callbacks.
  GLFWwindow* handle() const { return window_; }

 private:
  explicit GlfwWindow(GLFWwindow* w) : window_(w) {}
  GLFWwindow* window_ = nullptr;
};

}  // namespace sawyer::render
