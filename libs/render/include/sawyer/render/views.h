// Whole images of a log: board faces, sections and 3D views, rendered offscreen and read back.
// Used by `sawyer render`, the benchmark and the tests. Need a current context (gl_context.h).
//
//   Result<Image> img = render_board_faces(renderer, board, kLongFaces, {1200, 0});
//   if (img) write_image("board.png", img.value());
#pragma once

#include "sawyer/render/image.h"
#include "sawyer/render/wood_renderer.h"

namespace sawyer::render {

struct ImageSize {
  int width = 1200;
  int height = 0;  // 0: from the content's aspect ratio (board faces, sections)
};

// Image size limits. The image is rendered into a framebuffer of w × h pixels (board faces and
// sections, whose n × n samples are taken inside the shader where needed), or (w·n) × (h·n)
// for 3D views and FaceLayout::adaptive off; 4 bytes a sample (16 for the float time field),
// and
// read back to the host, where it is held twice while its rows are flipped: at most
// kMaxFramebufferBytes (512 MiB, so about 1 GiB of host memory at the peak and the same on the
// GPU). 8192 per side is a 68-megapixel print; GPUs' renderbuffers stop at 16384 or 32768.
inline constexpr int kMaxImageSide = 8192;
inline constexpr long long kMaxFramebufferBytes = 512LL << 20;

// Checks a w × h image at n × n samples per pixel (`float_field`: 16-byte samples) against the
// limits above; the error names --size with the size, the samples and the limit.
Status check_image_size(int width, int height, int supersample, bool float_field);

struct FaceLayout {
  // Fill the image exactly even when that stretches the faces (else keep millimetres square and
  // pad with the background).
  bool stretch = false;
  int gap_px = 8;  // between stacked faces
  // Supersampling: n x n samples per pixel, averaged (anti-aliasing of knot edges, bark rings
  // and crowded rings). 1 = one sample per pixel.
  int supersample = 1;
  // Board faces and sections: the n x n samples only in pixels where the field changes within
  // the pixel (ShadeOptions::supersample, wood.frag), one elsewhere. Off: every pixel, in a
  // framebuffer n times the size (the reference the adaptive image is checked against). 3D
  // views always take every pixel's samples.
  bool adaptive = true;
  float background[4] = {0.12f, 0.12f, 0.13f, 1.0f};
};

// The board's faces in `faces` (Face bits), stacked top to bottom in the order top, bottom,
// left, right, butt, end; long faces run left (z0) to right (z1).
Result<Image> render_board_faces(WoodRenderer& renderer, const BoardBox& board, unsigned faces,
                                 ImageSize size, const ShadeOptions& shade = {},
                                 const FaceLayout& layout = {});

// The cross-section at height z, seen from the top end (+z), x to the right, y up.
Result<Image> render_cross_section(WoodRenderer& renderer, double z, ImageSize size,
                                   const ShadeOptions& shade = {}, const FaceLayout& layout = {});

// A longitudinal section of the whole log, z to the right.
Result<Image> render_longitudinal_section(WoodRenderer& renderer, const LongitudinalSection& s,
                                          ImageSize size, const ShadeOptions& shade = {},
                                          const FaceLayout& layout = {});

// A 3D view of `scene` (size.height 0 means 3:4 of the width).
Result<Image> render_view(WoodRenderer& renderer, const Scene& scene, const Camera& camera,
                          ImageSize size, const ShadeOptions& shade = {},
                          const FaceLayout& layout = {});

// The rectangle of a cross-section at z (square around the pith, covering the log) and of a
// longitudinal section, as drawn by the functions above.
PlaneRect cross_section_rect(const WoodRenderer& renderer, double z);
PlaneRect longitudinal_rect(const WoodRenderer& renderer, const LongitudinalSection& s);

// A camera that shows the whole log from the side, slightly from above (the viewer's default).
Camera default_log_camera(const WoodRenderer& renderer);

}  // namespace sawyer::render
