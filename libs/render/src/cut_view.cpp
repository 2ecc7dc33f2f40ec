// The cut view (see cut_view.h): wood boards, knot cones and a translucent bark shell, drawn in
// that order into one framebuffer with depth.
#include "sawyer/render/cut_view.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "sawyer/render/framebuffer.h"
#include "sawyer/render/gl_layers.h"

namespace sawyer::render {

Status CutViewOptions::validate() const {
  if (width < 64 || width > 4096 || height < 64 || height > 4096)
    return Error("cut view", "image size must be 64..4096 px a side");
  if (supersample < 1 || supersample > 4) return Error("cut view", "supersample must be 1..4");
  for (float a : {shell_alpha, shell_rim, shell_specular})
    if (!(a >= 0.0f && a <= 1.0f)) return Error("cut view", "shell opacities must be 0..1");
  if (!(default_bark_mm >= 0 && default_bark_mm < 500))
    return Error("cut view", "default bark thickness must be 0..500 mm");
  return Status::Ok();
}

Camera cut_view_camera(const WoodRenderer& r, int width, int height, double default_bark_mm) {
  const Stem& st = r.log().stem;
  const double len = std::max(st.length_mm(), 1.0);
  const double aspect = static_cast<double>(width) / std::max(height, 1);
  // Points on the bark's outside: what must fit in the picture.
  std::vector<Vec3> pts;
  const double R = r.max_radius() + default_bark_mm;
  for (int i = 0; i <= 16; ++i) {
    const double z = st.z_begin() + len * i / 16.0;
    const Vec3 c = r.pith_point(z);
    for (int k = 0; k < 12; ++k) {
      const double a = kTwoPi * k / 12;
      pts.push_back({c.x + R * std::cos(a), c.y + R * std::sin(a), z});
    }
  }
  // Beyond the top end (yaw < 0 puts the eye on the +z side), from above, at an angle; a wide
  // lens, so the near (top) end, where the boards' ends show, is drawn large.
  const double yaw = -0.85, pitch = 0.32;
  Vec3 target = r.pith_point(st.z_begin() + 0.55 * len);
  auto camera_at = [&](const Vec3& t, double dist) {
    Camera c = Camera::orbit(t, dist, yaw, pitch);
    c.fov_y = 0.75;
    c.near_mm = std::max(1.0, 0.02 * dist);
    c.far_mm = 4.0 * dist + 2 * len;
    return c;
  };
  // The points' extent in normalised device coordinates; false when one is behind the eye.
  auto extent = [&](const Camera& c, double* x0, double* x1, double* y0, double* y1) {
    const Mat4 vp = c.view_projection(aspect);
    const Vec3 eye = c.eye(), fwd = c.forward();
    *x0 = *y0 = 1e300;
    *x1 = *y1 = -1e300;
    for (const Vec3& p : pts) {
      if (dot(p - eye, fwd) < 2 * c.near_mm) return false;
      const Vec3 n = vp.transform_point(p);
      *x0 = std::min(*x0, n.x), *x1 = std::max(*x1, n.x);
      *y0 = std::min(*y0, n.y), *y1 = std::max(*y1, n.y);
    }
    return true;
  };
  constexpr double kFill = 0.92;  // of the half-width or half-height, whichever is tighter
  double dist = 2.0 * len;
  for (int round = 0; round < 4; ++round) {
    // The nearest distance at which every point lies in front and within the frame.
    double lo = 0.05 * len, hi = 20.0 * len;
    for (int i = 0; i < 40; ++i) {
      const double mid = std::sqrt(lo * hi);
      double x0, x1, y0, y1;
      const bool in = extent(camera_at(target, mid), &x0, &x1, &y0, &y1) && x0 >= -kFill &&
                      x1 <= kFill && y0 >= -kFill && y1 <= kFill;
      (in ? hi : lo) = mid;
    }
    dist = hi;
    // Centre the extent: move the target by the offset of its middle, in view units.
    const Camera c = camera_at(target, dist);
    double x0, x1, y0, y1;
    if (!extent(c, &x0, &x1, &y0, &y1)) break;
    Vec3 right, up, back;
    c.axes(&right, &up, &back);
    const double half_h = dist * std::tan(0.5 * c.fov_y), half_w = half_h * aspect;
    target = target + (0.5 * (x0 + x1) * half_w) * right + (0.5 * (y0 + y1) * half_h) * up;
  }
  const Camera cam = camera_at(target, dist);
  return cam;
}

Result<Image> render_cut_view(WoodRenderer& r, const std::vector<BoardBox>& boards,
                              const Camera& camera, const CutViewOptions& o) {
  if (Status st = o.validate(); !st) return st.error();
  const int n = o.supersample;
  Result<Framebuffer> fb =
      Framebuffer::create(o.width * n, o.height * n, Framebuffer::Format::kRgba8);
  if (!fb) return fb.error();
  fb.value().bind(o.background);
  const Viewport vp = fb.value().viewport();
  // Boards: every face, in wood.
  Scene scene;
  scene.boards = boards;
  scene.board_faces = kAllFaces;
  r.draw(scene, camera, vp, o.shade);

  MeshPainter painter;
  if (Status st = painter.init(); !st) return st.error();
  const LogModel& log = r.log();
  if (o.knots) {
    KnotTubeOptions ko;
    ko.min_diameter_mm = o.knot_min_diameter_mm;
    ko.sound_color = o.sound_color;
    ko.dead_color = o.dead_color;
    ko.sides = 10;
    ko.rings = 16;
    GpuMesh knots;
    knots.upload(knot_tubes(log, ko));
    painter.draw(knots, camera, vp);
  }
  const WoodLook& look = r.look();
  GpuMesh shell;
  shell.upload(
      bark_surface(log.stem, look.bark_default_mm > 0 ? look.bark_default_mm : o.default_bark_mm,
                   {look.bark_outer[0], look.bark_outer[1], look.bark_outer[2]}, 96, 40.0));
  MeshStyle style;
  style.alpha = o.shell_alpha;
  style.rim = o.shell_rim;
  style.specular = o.shell_specular;
  painter.draw(shell, camera, vp, -1e30, style);
  Image img = downsample(fb.value().read(), n);
  return img;
}

}  // namespace sawyer::render
