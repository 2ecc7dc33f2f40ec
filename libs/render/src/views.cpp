#include "sawyer/render/views.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace sawyer::render {
namespace {

struct Tile {
  PlaneRect rect;
  Viewport vp;
};

// Samples per pixel side: the layout's, 1 for the raw field (its values must not be averaged).
int samples(const ShadeOptions& shade, const FaceLayout& layout) {
  return shade.mode == ShadeMode::kTimeField ? 1 : std::clamp(layout.supersample, 1, 4);
}

// Framebuffer pixels per image pixel side: 1 where the shader takes the samples itself.
int framebuffer_scale(const ShadeOptions& shade, const FaceLayout& layout, bool planes) {
  return planes && layout.adaptive ? 1 : samples(shade, layout);
}

// The size against the limits, for the shading and layout it is rendered with.
Status check_size(int w, int h, const ShadeOptions& shade, const FaceLayout& layout, bool planes) {
  return check_image_size(w, h, framebuffer_scale(shade, layout, planes),
                          shade.mode == ShadeMode::kTimeField);
}

// Renders tiles (each a rectangle filling its viewport) into one image.
Result<Image> render_tiles(WoodRenderer& r, const std::vector<Tile>& tiles, int w, int h,
                           const ShadeOptions& shade, const FaceLayout& layout) {
  if (Status st = check_size(w, h, shade, layout, true); !st) return st.error();
  const bool is_float = shade.mode == ShadeMode::kTimeField;
  const int n = framebuffer_scale(shade, layout, true);
  ShadeOptions sh = shade;
  sh.supersample = n == 1 ? samples(shade, layout) : 1;
  Result<Framebuffer> fb = Framebuffer::create(
      w * n, h * n, is_float ? Framebuffer::Format::kRgba32f : Framebuffer::Format::kRgba8);
  if (!fb) return fb.error();
  fb.value().bind(layout.background);
  for (const Tile& t : tiles)
    if (t.vp.width > 0 && t.vp.height > 0)
      r.draw_plane(t.rect, {t.vp.x * n, t.vp.y * n, t.vp.width * n, t.vp.height * n}, sh);
  return downsample(fb.value().read(), n);
}

// Places one rectangle of rw x rh mm in a w x h image (size.height 0: from the aspect ratio).
std::vector<Tile> single_tile(const PlaneRect& rect, ImageSize& size, const FaceLayout& layout) {
  if (size.height <= 0)
    size.height = std::max(1, static_cast<int>(std::lround(size.width * rect.height / rect.width)));
  Tile t{rect, {0, 0, size.width, size.height}};
  if (!layout.stretch) {
    const double s = std::min(size.width / rect.width, size.height / rect.height);
    const int w = std::max(1, static_cast<int>(std::lround(rect.width * s)));
    const int h = std::max(1, static_cast<int>(std::lround(rect.height * s)));
    t.vp = {(size.width - w) / 2, (size.height - h) / 2, w, h};
  }
  return {t};
}

}  // namespace

Status check_image_size(int w, int h, int n, bool float_field) {
  if (w < 1 || h < 1 || w > kMaxImageSide || h > kMaxImageSide)
    return Error("ImageSize", std::to_string(w) + "x" + std::to_string(h) + " outside 1.." +
                                  std::to_string(kMaxImageSide) + " pixels");
  const long long bytes = static_cast<long long>(w) * n * h * n * (float_field ? 16 : 4);
  if (bytes > kMaxFramebufferBytes) {
    const std::string samples =
        n > 1 ? " at " + std::to_string(n) + "x" + std::to_string(n) + " supersampling" : "";
    return Error("ImageSize",
                 std::to_string(w) + "x" + std::to_string(h) + samples + " needs " +
                     std::to_string(bytes >> 20) + " MiB of framebuffer, more than the " +
                     std::to_string(kMaxFramebufferBytes >> 20) + " MiB allowed (a smaller size" +
                     (n > 1 ? " or less FaceLayout::supersample" : "") + ")");
  }
  return Status::Ok();
}

Result<Image> render_board_faces(WoodRenderer& r, const BoardBox& board, unsigned faces,
                                 ImageSize size, const ShadeOptions& shade,
                                 const FaceLayout& layout) {
  if (Status st = board.validate(); !st) return st.error();
  std::vector<PlaneRect> rects;
  for (unsigned bit = 1; bit <= 32; bit <<= 1)
    if (faces & bit) rects.push_back(board_face(board, static_cast<Face>(bit)));
  if (rects.empty()) return Error("face_mask", "no face selected");
  if (size.width < 1) return Error("ImageSize", "width must be at least 1 pixel");
  double max_w = 0, sum_h = 0;
  for (const PlaneRect& p : rects) {
    max_w = std::max(max_w, p.width);
    sum_h += p.height;
  }
  const int gaps = layout.gap_px * static_cast<int>(rects.size() - 1);
  // Pixels per mm across and along: equal unless stretched to a given height.
  double sx = size.width / max_w, sy = sx;
  if (size.height <= 0) {
    size.height = std::max(1, static_cast<int>(std::lround(sum_h * sy)) + gaps);
  } else if (layout.stretch) {
    sy = std::max(1.0, static_cast<double>(size.height - gaps)) / sum_h;
  } else {
    sx = sy = std::min(sx, std::max(1.0, static_cast<double>(size.height - gaps)) / sum_h);
  }
  if (Status st = check_size(size.width, size.height, shade, layout, true); !st) return st.error();
  std::vector<Tile> tiles;
  double y = 0;  // from the top of the image
  for (const PlaneRect& p : rects) {
    const int h = std::max(1, static_cast<int>(std::lround(p.height * sy)));
    const int w = layout.stretch && rects.size() == 1
                      ? size.width
                      : std::max(1, static_cast<int>(std::lround(p.width * sx)));
    const int x = (size.width - w) / 2;
    const int top = static_cast<int>(std::lround(y));
    tiles.push_back({p, {x, size.height - top - h, w, h}});
    y += h + layout.gap_px;
  }
  return render_tiles(r, tiles, size.width, size.height, shade, layout);
}

PlaneRect cross_section_rect(const WoodRenderer& r, double z) {
  const double R = r.max_radius() * 1.03;
  const Vec2 c = r.log().stem.pith_at(z);
  PlaneRect p;
  p.origin = {c.x - R, c.y - R, z};
  p.u = {1, 0, 0};
  p.v = {0, 1, 0};
  p.width = p.height = 2 * R;
  return p;
}

PlaneRect longitudinal_rect(const WoodRenderer& r, const LongitudinalSection& s) {
  const Stem& st = r.log().stem;
  const double R = r.max_radius() * 1.03;
  const Vec3 dir{std::cos(s.angle), std::sin(s.angle), 0},
      nrm{-std::sin(s.angle), std::cos(s.angle), 0};
  const Vec3 c = r.pith_point(st.z_begin());
  PlaneRect p;
  p.origin = c + s.offset * nrm - R * dir;
  p.u = {0, 0, 1};
  p.v = dir;
  p.width = st.length_mm();
  p.height = 2 * R;
  return p;
}

Result<Image> render_cross_section(WoodRenderer& r, double z, ImageSize size,
                                   const ShadeOptions& shade, const FaceLayout& layout) {
  std::vector<Tile> tiles = single_tile(cross_section_rect(r, z), size, layout);
  return render_tiles(r, tiles, size.width, size.height, shade, layout);
}

Result<Image> render_longitudinal_section(WoodRenderer& r, const LongitudinalSection& s,
                                          ImageSize size, const ShadeOptions& shade,
                                          const FaceLayout& layout) {
  std::vector<Tile> tiles = single_tile(longitudinal_rect(r, s), size, layout);
  return render_tiles(r, tiles, size.width, size.height, shade, layout);
}

Result<Image> render_view(WoodRenderer& r, const Scene& scene, const Camera& camera, ImageSize size,
                          const ShadeOptions& shade, const FaceLayout& layout) {
  if (size.height <= 0) size.height = std::max(1, size.width * 3 / 4);
  if (Status st = check_size(size.width, size.height, shade, layout, false); !st) return st.error();
  const bool is_float = shade.mode == ShadeMode::kTimeField;
  const int n = samples(shade, layout);
  ShadeOptions sh = shade;
  sh.supersample = 1;
  Result<Framebuffer> fb =
      Framebuffer::create(size.width * n, size.height * n,
                          is_float ? Framebuffer::Format::kRgba32f : Framebuffer::Format::kRgba8);
  if (!fb) return fb.error();
  fb.value().bind(layout.background);
  r.draw(scene, camera, fb.value().viewport(), sh);
  return downsample(fb.value().read(), n);
}

Camera default_log_camera(const WoodRenderer& r) {
  const Stem& st = r.log().stem;
  const double zmid = 0.5 * (st.z_begin() + st.z_end());
  const double len = st.length_mm();
  Camera c = Camera::orbit(r.pith_point(zmid), 1.25 * len, 0.35, 0.3);
  c.fov_y = 0.6;
  c.near_mm = std::max(1.0, 0.05 * len);
  c.far_mm = 4.0 * len;
  return c;
}

}  // namespace sawyer::render
