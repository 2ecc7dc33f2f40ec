// OpenGL pieces for an interactive view on top of the wood renderer (sawyer-view uses them):
// textures to render into (the 3D view's opaque and translucent layers, the section and face
// panels, shown through Dear ImGui), the plain-mesh painter for knot tubes and outlines
// (mesh.h), and reading the window back for screenshots.
// Everything needs the window's context current; destroy while it is current.
//
//   GlTarget opaque, overlay;
//   opaque.resize(w, h, GlTarget::Depth::kOwn);
//   overlay.resize(w, h, GlTarget::Depth::kShared, &opaque);   // same depth: occluded by opaque
//   opaque.bind(kBackground, true);  renderer.draw(solid, cam, opaque.viewport());
//   painter.draw(tubes, cam, opaque.viewport());
//   overlay.bind(kTransparent, false);  renderer.draw(surface, cam, overlay.viewport());
#pragma once

#include <string>

#include "sawyer/core/result.h"
#include "sawyer/render/camera.h"
#include "sawyer/render/framebuffer.h"
#include "sawyer/render/image.h"
#include "sawyer/render/mesh.h"
#include "sawyer/render/shader_program.h"

namespace sawyer::render {

// An RGBA8 colour texture behind a framebuffer object, with an optional depth texture.
class GlTarget {
 public:
  enum class Depth { kNone, kOwn, kShared };

  GlTarget() = default;
  GlTarget(const GlTarget&) = delete;
  GlTarget& operator=(const GlTarget&) = delete;
  ~GlTarget();

  // Allocates the textures at w x h, or keeps them when the size and depth choice are unchanged.
  // kShared attaches `share`'s depth texture (resize `share` first, to the same size). Fails
  // (naming the size) when the driver cannot make a complete framebuffer.
  Status resize(int width, int height, Depth depth, const GlTarget* share = nullptr);
  // Binds the framebuffer, sets the viewport to all of it and clears the colour to `clear`
  // (RGBA) and, when asked, the depth.
  void bind(const float clear[4], bool clear_depth) const;
  // Copies `source`'s depth into this target's own depth texture, scaled to this size (nearest
  // sample): a smaller translucent layer depth-tested against a full-size opaque one.
  void copy_depth_from(const GlTarget& source) const;
  // Copies the colour into `rect` of the window's default framebuffer (scaled, linear).
  void blit_to_window(const Viewport& rect) const;
  Viewport viewport() const { return {0, 0, width_, height_}; }
  int width() const { return width_; }
  int height() const { return height_; }
  unsigned texture() const { return color_; }
  bool ready() const { return fbo_ != 0; }

 private:
  void release();
  unsigned fbo_ = 0, color_ = 0, depth_ = 0;
  bool own_depth_ = false;
  const GlTarget* share_ = nullptr;
  int width_ = 0, height_ = 0;
};

// A Mesh uploaded to the GPU.
class GpuMesh {
 public:
  GpuMesh() = default;
  GpuMesh(const GpuMesh&) = delete;
  GpuMesh& operator=(const GpuMesh&) = delete;
  ~GpuMesh();
  void upload(const Mesh& mesh);
  int count() const { return count_; }
  bool lines() const { return lines_; }
  unsigned vao() const { return vao_; }

 private:
  unsigned vao_ = 0, vbo_ = 0;
  int count_ = 0;
  bool lines_ = false;
};

// How a mesh is drawn. The default is opaque, diffuse-lit (the viewer's knot tubes). A
// translucent style (alpha < 1 or rim > 0) is blended over what is drawn (src-alpha over) with the
// depth test on and depth writes off, so draw it after the opaque meshes.
struct MeshStyle {
  float alpha = 1.0f;     // opacity where the surface faces the camera
  float rim = 0.0f;       // added opacity towards the silhouette: alpha + rim·(1 − |n·view|)²
  float specular = 0.0f;  // strength of a highlight from the light (0: none)
};

// Draws GpuMeshes with depth test, lit by a light that moves with the camera.
class MeshPainter {
 public:
  // Compiles the viewer's mesh shaders (shaders/mesh.vert and mesh.frag, embedded at build time).
  Status init();
  // Lines are one pixel wide (core profiles refuse wider ones). Nothing below `clip_z0` (mm
  // along the log) is drawn.
  void draw(const GpuMesh& mesh, const Camera& camera, const Viewport& viewport,
            double clip_z0 = -1e30, const MeshStyle& style = {}) const;

 private:
  ShaderProgram program_;
};

// The window's back buffer (what the next swap shows) as RGB, rows top to bottom.
Image read_window(int width, int height);

}  // namespace sawyer::render
