#include "sawyer/render/gl_layers.h"

#include <algorithm>
#include <cstddef>
#include <vector>

#include "gl.h"

namespace sawyer::render {
GlTarget::~GlTarget() { release(); }

void GlTarget::release() {
  if (fbo_) glDeleteFramebuffers(1, &fbo_);
  if (color_) glDeleteTextures(1, &color_);
  if (own_depth_ && depth_) glDeleteTextures(1, &depth_);
  fbo_ = color_ = depth_ = 0;
  own_depth_ = false;
  width_ = height_ = 0;
}

Status GlTarget::resize(int width, int height, Depth depth, const GlTarget* share) {
  const bool same =
      fbo_ && width == width_ && height == height_ && own_depth_ == (depth == Depth::kOwn) &&
      (depth != Depth::kShared || (share == share_ && share && depth_ == share->depth_));
  if (same) return Status::Ok();
  release();
  const std::string size = std::to_string(width) + " x " + std::to_string(height);
  if (width < 1 || height < 1) return Error("view target", "size " + size + " is empty");
  if (depth == Depth::kShared &&
      (!share || share->width_ != width || share->height_ != height || !share->depth_))
    return Error("view target", "no depth texture of size " + size + " to share");
  width_ = width;
  height_ = height;
  share_ = share;
  glGenTextures(1, &color_);
  glBindTexture(GL_TEXTURE_2D, color_);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  if (depth == Depth::kOwn) {
    own_depth_ = true;
    glGenTextures(1, &depth_);
    glBindTexture(GL_TEXTURE_2D, depth_);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, width, height, 0, GL_DEPTH_COMPONENT,
                 GL_UNSIGNED_INT, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  } else if (depth == Depth::kShared) {
    depth_ = share->depth_;
  }
  glBindTexture(GL_TEXTURE_2D, 0);
  glGenFramebuffers(1, &fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color_, 0);
  if (depth_) glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_, 0);
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    release();
    return Error("view target",
                 "framebuffer incomplete at " + size + " (status " + std::to_string(status) + ")");
  }
  return Status::Ok();
}

void GlTarget::bind(const float clear[4], bool clear_depth) const {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
  glClearColor(clear[0], clear[1], clear[2], clear[3]);
  GLbitfield bits = GL_COLOR_BUFFER_BIT;
  if (clear_depth && depth_) {
    glDepthMask(GL_TRUE);
    glClearDepth(1.0);
    bits |= GL_DEPTH_BUFFER_BIT;
  }
  glClear(bits);
}

void GlTarget::copy_depth_from(const GlTarget& source) const {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, source.fbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo_);
  glBlitFramebuffer(0, 0, source.width_, source.height_, 0, 0, width_, height_, GL_DEPTH_BUFFER_BIT,
                    GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
}

void GlTarget::blit_to_window(const Viewport& r) const {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  const bool same = r.width == width_ && r.height == height_;
  glBlitFramebuffer(0, 0, width_, height_, r.x, r.y, r.x + r.width, r.y + r.height,
                    GL_COLOR_BUFFER_BIT, same ? GL_NEAREST : GL_LINEAR);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

GpuMesh::~GpuMesh() {
  if (vbo_) glDeleteBuffers(1, &vbo_);
  if (vao_) glDeleteVertexArrays(1, &vao_);
}

void GpuMesh::upload(const Mesh& mesh) {
  if (!vao_) {
    glGenVertexArrays(1, &vao_);
    glGenBuffers(1, &vbo_);
    glBindVertexArray(vao_);
    glBindBuffer(GL_ARRAY_BUFFER, vbo_);
    const GLsizei stride = sizeof(MeshVertex);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride,
                          reinterpret_cast<const void*>(offsetof(MeshVertex, normal)));
    glEnableVertexAttribArray(2);
    glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride,
                          reinterpret_cast<const void*>(offsetof(MeshVertex, color)));
    glBindVertexArray(0);
  }
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.vertices.size() * sizeof(MeshVertex)),
               mesh.vertices.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  count_ = static_cast<int>(mesh.vertices.size());
  lines_ = mesh.lines;
}

Status MeshPainter::init() {
  const std::string vs = embedded_shader("mesh.vert"), fs = embedded_shader("mesh.frag");
  if (vs.empty() || fs.empty()) return Error("MeshPainter::init", "mesh shaders not embedded");
  Result<ShaderProgram> p = ShaderProgram::build_from_text("mesh.vert", vs, "mesh.frag", fs);
  if (!p) return p.error();
  program_ = std::move(p).value();
  return Status::Ok();
}

void MeshPainter::draw(const GpuMesh& mesh, const Camera& camera, const Viewport& vp,
                       double clip_z0, const MeshStyle& style) const {
  if (mesh.count() == 0) return;
  glUseProgram(program_.id());
  const render::Mat4 m = camera.view_projection(vp.aspect());
  glUniformMatrix4fv(program_.uniform("u_view_proj"), 1, GL_FALSE, m.m.data());
  Vec3 right, up, back;
  camera.axes(&right, &up, &back);
  const Vec3 l = (-0.3 * right + 0.45 * up + 0.85 * back).normalized();
  glUniform3f(program_.uniform("u_light_dir"), static_cast<float>(l.x), static_cast<float>(l.y),
              static_cast<float>(l.z));
  glUniform1i(program_.uniform("u_lit"), mesh.lines() ? 0 : 1);
  glUniform1f(program_.uniform("u_clip_z0"), static_cast<float>(std::max(clip_z0, -1e30)));
  const Vec3 eye = camera.eye();
  glUniform3f(program_.uniform("u_eye"), static_cast<float>(eye.x), static_cast<float>(eye.y),
              static_cast<float>(eye.z));
  glUniform1f(program_.uniform("u_alpha"), style.alpha);
  glUniform1f(program_.uniform("u_rim"), style.rim);
  glUniform1f(program_.uniform("u_specular"), style.specular);
  const bool translucent = style.alpha < 1.0f || style.rim > 0.0f;
  glViewport(vp.x, vp.y, vp.width, vp.height);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(translucent ? GL_FALSE : GL_TRUE);
  glDisable(GL_CULL_FACE);
  if (translucent) {
    glEnable(GL_BLEND);
    // Colour blended over what is there; the target's alpha kept opaque where it was.
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  } else {
    glDisable(GL_BLEND);
  }
  glBindVertexArray(mesh.vao());
  glDrawArrays(mesh.lines() ? GL_LINES : GL_TRIANGLES, 0, mesh.count());
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glUseProgram(0);
}

Image read_window(int width, int height) {
  const size_t row = static_cast<size_t>(width) * 4;
  std::vector<std::uint8_t> raw(row * height);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  glReadBuffer(GL_BACK);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, raw.data());
  // RGB, rows top to bottom (OpenGL's run bottom to top); the window has no meaningful alpha.
  Image img;
  img.width = width;
  img.height = height;
  img.channels = 3;
  img.u8.resize(static_cast<size_t>(width) * height * 3);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* src = &raw[(height - 1 - y) * row];
    std::uint8_t* dst = &img.u8[static_cast<size_t>(y) * width * 3];
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c) dst[3 * x + c] = src[4 * x + c];
  }
  return img;
}

}  // namespace sawyer::render
