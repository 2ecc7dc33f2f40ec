#include "sawyer/render/glfw_window.h"

#include <GLFW/glfw3.h>

namespace sawyer::render {
namespace {

std::string g_last_error;
int g_windows = 0;

void on_error(int, const char* description) { g_last_error = description ? description : "?"; }

}  // namespace

Result<std::unique_ptr<GlfwWindow>> GlfwWindow::create(const WindowOptions& options) {
  glfwSetErrorCallback(on_error);
  if (g_windows == 0 && !glfwInit())
    return Error("window",
                 "GLFW cannot start (" + g_last_error + "); no display? use the headless renderer");
  glfwDefaultWindowHints();
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
  GLFWwindow* w =
      glfwCreateWindow(options.width, options.height, options.title.c_str(), nullptr, nullptr);
  if (!w) {
    if (g_windows == 0) glfwTerminate();
    return Error("window", "cannot create an OpenGL 4.5 core window (" + g_last_error + ")");
  }
  ++g_windows;
  glfwMakeContextCurrent(w);
  glfwSwapInterval(options.vsync ? 1 : 0);
  return std::unique_ptr<GlfwWindow>(new GlfwWindow(w));
}

GlfwWindow::~GlfwWindow() {
  glfwDestroyWindow(window_);
  if (--g_windows == 0) glfwTerminate();
}

bool GlfwWindow::make_current() {
  glfwMakeContextCurrent(window_);
  return true;
}

std::string GlfwWindow::description() const { return describe_current_context() + ", GLFW window"; }

bool GlfwWindow::should_close() const { return glfwWindowShouldClose(window_) != 0; }
void GlfwWindow::poll_events() { glfwPollEvents(); }
void GlfwWindow::swap_buffers() { glfwSwapBuffers(window_); }

Viewport GlfwWindow::framebuffer_viewport() const {
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  return {0, 0, w, h};
}

}  // namespace sawyer::render
