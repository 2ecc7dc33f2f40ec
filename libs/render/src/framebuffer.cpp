#include "sawyer/render/framebuffer.h"

#include <cstring>
#include <utility>

#include "gl.h"

namespace sawyer::render {

Result<Framebuffer> Framebuffer::create(int width, int height, Format format) {
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
  const std::string size = std::to_string(width) + " x " + std::to_string(height);
  if (width <= 0 || height <= 0 || width > max_size || height > max_size)
    return Error("framebuffer", "size " + size + " outside 1.." + std::to_string(max_size));
  Framebuffer fb;
  fb.width_ = width;
  fb.height_ = height;
  fb.format_ = format;
  glGenFramebuffers(1, &fb.fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, fb.fbo_);
  glGenRenderbuffers(1, &fb.color_);
  glBindRenderbuffer(GL_RENDERBUFFER, fb.color_);
  glRenderbufferStorage(GL_RENDERBUFFER, format == Format::kRgba8 ? GL_RGBA8 : GL_RGBA32F, width,
                        height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, fb.color_);
  glGenRenderbuffers(1, &fb.depth_);
  glBindRenderbuffer(GL_RENDERBUFFER, fb.depth_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, fb.depth_);
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE)
    return Error("framebuffer",
                 "incomplete at " + size + " (status " + std::to_string(status) + ")");
  return fb;
}

Framebuffer::Framebuffer(Framebuffer&& o) noexcept
    : fbo_(std::exchange(o.fbo_, 0)),
      color_(std::exchange(o.color_, 0)),
      depth_(std::exchange(o.depth_, 0)),
      width_(o.width_),
      height_(o.height_),
      format_(o.format_) {}

Framebuffer& Framebuffer::operator=(Framebuffer&& o) noexcept {
  if (this != &o) {
    this->~Framebuffer();
    new (this) Framebuffer(std::move(o));
  }
  return *this;
}

Framebuffer::~Framebuffer() {
  if (fbo_) glDeleteFramebuffers(1, &fbo_);
  if (color_) glDeleteRenderbuffers(1, &color_);
  if (depth_) glDeleteRenderbuffers(1, &depth_);
  fbo_ = color_ = depth_ = 0;
}

void Framebuffer::bind(const float clear[4]) {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
  if (clear)
    glClearColor(clear[0], clear[1], clear[2], clear[3]);
  else
    glClearColor(0, 0, 0, 0);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
}

Image Framebuffer::read() const {
  Image img;
  img.width = width_;
  img.height = height_;
  img.channels = 4;
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  const size_t row = static_cast<size_t>(width_) * 4;
  if (format_ == Format::kRgba8) {
    std::vector<std::uint8_t> raw(row * height_);
    glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, raw.data());
    img.u8.resize(raw.size());
    for (int y = 0; y < height_; ++y)  // OpenGL's rows run bottom to top
      std::memcpy(&img.u8[y * row], &raw[(height_ - 1 - y) * row], row);
  } else {
    std::vector<float> raw(row * height_);
    glReadPixels(0, 0, width_, height_, GL_RGBA, GL_FLOAT, raw.data());
    img.f32.resize(raw.size());
    for (int y = 0; y < height_; ++y)
      std::memcpy(&img.f32[y * row], &raw[(height_ - 1 - y) * row], row * sizeof(float));
  }
  return img;
}

void bind_default_framebuffer(const Viewport& viewport) {
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(viewport.x, viewport.y, viewport.width, viewport.height);
}

void clear_default_framebuffer(const Viewport& viewport, const float rgba[4]) {
  bind_default_framebuffer(viewport);
  glDisable(GL_SCISSOR_TEST);
  glClearColor(rgba[0], rgba[1], rgba[2], rgba[3]);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
}

Image read_pixels(const Viewport& vp) {
  Image img;
  img.width = vp.width;
  img.height = vp.height;
  const size_t row = static_cast<size_t>(vp.width) * 4;
  std::vector<std::uint8_t> raw(row * vp.height);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(vp.x, vp.y, vp.width, vp.height, GL_RGBA, GL_UNSIGNED_BYTE, raw.data());
  img.u8.resize(raw.size());
  for (int y = 0; y < vp.height; ++y)
    std::memcpy(&img.u8[y * row], &raw[(vp.height - 1 - y) * row], row);
  return img;
}

void finish_rendering() { glFinish(); }

}  // namespace sawyer::render
