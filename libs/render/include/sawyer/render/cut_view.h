// The cut view: a sawn log in 3D for the cutting report. The boards are solid blocks in their
// knotted wood (the WoodRenderer's board faces), the knots cones along their axes (green where
// sound, red where dead, lit), and the log a translucent lit shell over its bark, so the boards
// show through it; the camera looks from above the top end, so the cut shows.
//
//   auto ctx = create_headless_context();                    // gl_context.h
//   auto r = WoodRenderer::create(log, {});
//   CutViewOptions o;                                         // 1200 x 600, white background
//   Camera cam = cut_view_camera(*r.value(), o.width, o.height);
//   Result<Image> img = render_cut_view(*r.value(), boards, cam, o);   // boards: BoardBox
//
// Needs the renderer's context current. Not thread safe (OpenGL).
#pragma once

#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/model/board_box.h"
#include "sawyer/render/camera.h"
#include "sawyer/render/image.h"
#include "sawyer/render/mesh.h"
#include "sawyer/render/wood_renderer.h"

namespace sawyer::render {

struct CutViewOptions {
  int width = 1200, height = 600;  // pixels (64..4096)
  int supersample = 2;             // n x n samples per pixel, averaged (1..4)
  float background[4] = {1.0f, 1.0f, 1.0f, 1.0f};
  // The shell over the bark: opacity facing the camera, added opacity at the silhouette, and a
  // highlight (MeshStyle, gl_layers.h). Its colour is the look's outer bark (WoodLook).
  float shell_alpha = 0.16f, shell_rim = 0.6f, shell_specular = 0.18f;
  double default_bark_mm = 8.0;  // where the model has no bark thickness
  bool knots = true;
  Rgb sound_color{0.15f, 0.62f, 0.22f};
  Rgb dead_color{0.86f, 0.14f, 0.10f};
  double knot_min_diameter_mm = 3.0;  // thinner knot parts drawn this thick
  ShadeOptions shade;                 // the boards' wood

  // Sizes within 64..4096 px, supersample 1..4, opacities within 0..1.
  Status validate() const;
};

// From above and beyond the log's top end, at an angle to its axis, framing the whole log (its
// bark included) in a width x height image with a small margin.
Camera cut_view_camera(const WoodRenderer& renderer, int width, int height,
                       double default_bark_mm = 8.0);

// The boards (log frame, as BoardBox) inside the renderer's log, seen by `camera`. RGBA8 image,
// rows top to bottom; pixels that show neither log, board nor knot are `background`.
Result<Image> render_cut_view(WoodRenderer& renderer, const std::vector<BoardBox>& boards,
                              const Camera& camera, const CutViewOptions& options = {});

}  // namespace sawyer::render
