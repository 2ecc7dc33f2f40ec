// An offscreen render target (framebuffer object with a depth buffer) and reading it back.
// Needs a current GL context (gl_context.h); destroy it while that context is current.
//
//   Result<Framebuffer> fb = Framebuffer::create(1200, 800, Framebuffer::Format::kRgba8);
//   fb.value().bind();                 // viewport set to the whole target, cleared
//   renderer.draw(scene, camera, fb.value().viewport());
//   Image img = fb.value().read();
#pragma once

#include "sawyer/core/result.h"
#include "sawyer/render/image.h"

namespace sawyer::render {

// A pixel rectangle of the bound framebuffer, origin at the bottom left (OpenGL's convention).
struct Viewport {
  int x = 0, y = 0, width = 0, height = 0;
  double aspect() const { return height > 0 ? static_cast<double>(width) / height : 1.0; }
};

class Framebuffer {
 public:
  enum class Format { kRgba8, kRgba32f };

  // Fails (naming the size) when the driver cannot make a complete framebuffer.
  static Result<Framebuffer> create(int width, int height, Format format);
  Framebuffer() = default;
  Framebuffer(Framebuffer&& other) noexcept;
  Framebuffer& operator=(Framebuffer&& other) noexcept;
  Framebuffer(const Framebuffer&) = delete;
  Framebuffer& operator=(const Framebuffer&) = delete;
  ~Framebuffer();

  // Binds it for drawing, sets the viewport to all of it and clears colour (to `clear`) and depth.
  void bind(const float clear[4] = nullptr);
  Viewport viewport() const { return {0, 0, width_, height_}; }
  int width() const { return width_; }
  int height() const { return height_; }
  // Reads the pixels (waits for drawing to finish), rows top to bottom.
  Image read() const;

 private:
  unsigned fbo_ = 0, color_ = 0, depth_ = 0;
  int width_ = 0, height_ = 0;
  Format format_ = Format::kRgba8;
};

// Binds the default framebuffer (a window's) and sets the viewport: what a viewer does before
// drawing into its own window each frame.
void bind_default_framebuffer(const Viewport& viewport);
// The same, then clears all of the window (no scissor) to `rgba` and its depth to far.
void clear_default_framebuffer(const Viewport& viewport, const float rgba[4]);

// Reads `viewport` of the bound read framebuffer (a window's: after drawing, before swapping)
// as 8-bit RGBA, rows top to bottom.
Image read_pixels(const Viewport& viewport);

// Waits until the current context has finished all drawing (glFinish): for timing.
void finish_rendering();

}  // namespace sawyer::render
