// OpenGL contexts for the renderer: a headless one (EGL, no display needed: Mesa's software
// renderer llvmpipe or a GPU) and, in sawyer::render_glfw, a window (glfw_window.h). Everything
// in sawyer::render draws with whichever context is current on the calling thread.
//
//   Result<std::unique_ptr<GlContext>> ctx = create_headless_context();
//   if (!ctx) { std::cerr << ctx.error().message() << "\n"; return 1; }
//   // ctx is current on this thread: create a WoodRenderer, draw, read back.
//
// Contexts are OpenGL 4.5 core (4.3 accepted: SSBOs are the floor). Thread safety: a context is
// current on one thread at a time; make_current() moves it.
#pragma once

#include <memory>
#include <string>

#include "sawyer/core/result.h"

namespace sawyer::render {

class GlContext {
 public:
  virtual ~GlContext() = default;
  // Makes the context current on the calling thread. False when the driver refuses.
  virtual bool make_current() = 0;
  // "OpenGL 4.5 (Core Profile) Mesa 22.3.6, llvmpipe (LLVM 15.0.6, 256 bits), EGL surfaceless".
  virtual std::string description() const = 0;
};

struct HeadlessContextOptions {
  // EGL platforms tried in order: Mesa's surfaceless platform, then the device platform (one
  // EGLDevice per GPU or software device), then the default display.
  bool try_surfaceless = true;
  bool try_device = true;
  // Debug output from the driver to stderr (GL_KHR_debug), for development.
  bool debug = false;
};

// A headless OpenGL context, current on the calling thread when it returns. Renders only into
// framebuffer objects (no pbuffer or window). The error says which EGL steps failed.
Result<std::unique_ptr<GlContext>> create_headless_context(
    const HeadlessContextOptions& options = {});

// Starts making a headless context (default options) on a thread of its own, for the next
// create_headless_context() with default options to take instead of making one: loading the GL
// driver (Mesa's, with LLVM: ~0.3 s of the dynamic loader on two cores) then overlaps earlier
// work (`sawyer run` calls this once the decision is printed, while it writes the files). Calling
// it again while one waits does nothing. A context made ahead and not taken must be dropped before
// the process ends (drop_prewarmed_headless_context: the GL driver's own exit handlers run before
// static destructors).
void prewarm_headless_context();
void drop_prewarmed_headless_context();

// Describes the current context (version, renderer); empty when none is current.
std::string describe_current_context();

}  // namespace sawyer::render
