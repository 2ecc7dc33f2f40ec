#include "sawyer/render/orbit_camera.h"

#include <algorithm>
#include <cmath>

namespace sawyer::render {

void OrbitCamera::frame_log(const LogModel& log, double aspect) {
  yaw = 0.35;
  pitch = 0.3;
  fit_log(log, aspect);
}

void OrbitCamera::fit_log(const LogModel& log, double aspect) {
  const Stem& st = log.stem;
  const double zmid = 0.5 * (st.z_begin() + st.z_end());
  double rmax = 0;
  for (int i = 0; i < st.slice_count(); ++i)
    for (double r : st.radius[i]) rmax = std::max(rmax, r);
  const double len = std::max(st.length_mm(), 1.0);
  min_distance = std::max(10.0, 0.2 * rmax);
  max_distance = 20.0 * (len + rmax);
  extent = len + 2.0 * rmax;
  // The log's outline at both ends and in the middle.
  std::vector<Vec3> points;
  for (double z : {st.z_begin(), zmid, st.z_end()}) {
    const Vec2 c = st.pith_at(z);
    for (int k = 0; k < 16; ++k) {
      const double w = kTwoPi * k / 16;
      points.push_back({c.x + rmax * std::cos(w), c.y + rmax * std::sin(w), z});
    }
  }
  frame_points(points, aspect);
  const Vec2 c = st.pith_at(zmid);
  target = {c.x, c.y, zmid};
}

void OrbitCamera::frame_points(const std::vector<Vec3>& points, double aspect, double margin) {
  if (points.empty()) return;
  Vec3 lo = points[0], hi = points[0];
  for (const Vec3& p : points) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  target = 0.5 * (lo + hi);
  // How far the points reach into the view at a distance (2 when one is behind the near plane):
  // it only shrinks as the eye moves back along the view direction, so bisect for `margin`.
  auto reach_at = [&](double d) {
    distance = d;
    const Camera cam = camera();
    const render::Mat4 view = cam.view(), proj = cam.projection(std::max(aspect, 0.05));
    double reach = 0;
    for (const Vec3& p : points) {
      const Vec3 q = view.transform_point(p);
      if (-q.z < cam.near_mm) return 2.0;
      const Vec3 n = proj.transform_point(q);
      reach = std::max({reach, std::abs(n.x), std::abs(n.y)});
    }
    return reach;
  };
  double near = min_distance, far = max_distance;
  if (reach_at(far) > margin) {
    distance = far;
    return;
  }
  for (int it = 0; it < 60 && far - near > 1e-3 * near; ++it) {
    const double mid = std::sqrt(near * far);
    (reach_at(mid) > margin ? near : far) = mid;
  }
  distance = far;
}

void OrbitCamera::rotate(double dx_px, double dy_px) {
  yaw -= dx_px * kRadiansPerPixel;
  yaw = std::remainder(yaw, kTwoPi);
  pitch = std::clamp(pitch + dy_px * kRadiansPerPixel, -kPitchLimit, kPitchLimit);
}

double OrbitCamera::visible_height() const {
  // The orthographic view is sized to show what the perspective one shows at the target.
  return 2.0 * distance * std::tan(0.5 * fov_y);
}

void OrbitCamera::pan(double dx_px, double dy_px, double viewport_height_px) {
  if (viewport_height_px <= 0) return;
  const double mm_per_px = visible_height() / viewport_height_px;
  Vec3 right, up, back;
  camera().axes(&right, &up, &back);
  // Dragging right moves the scene right: the target moves left; screen y grows downwards.
  target = target - (dx_px * mm_per_px) * right + (dy_px * mm_per_px) * up;
}

void OrbitCamera::zoom(double steps) {
  distance = std::clamp(distance * std::pow(kZoomPerStep, steps), min_distance, max_distance);
}

void OrbitCamera::view_side() {
  yaw = 0;
  pitch = 0;
}

void OrbitCamera::view_end() {
  // From beyond the top end (+z) looking down the log towards the butt.
  yaw = -0.5 * kPi;
  pitch = 0;
}

void OrbitCamera::view_top() {
  yaw = 0;
  pitch = kPitchLimit;
}

void OrbitCamera::toggle_projection() { orthographic = !orthographic; }

Camera OrbitCamera::camera() const {
  Camera c = Camera::orbit(
      target, distance, yaw, pitch,
      orthographic ? Camera::Projection::kOrthographic : Camera::Projection::kPerspective);
  c.fov_y = fov_y;
  c.ortho_height = visible_height();
  c.near_mm = std::max(1.0, 0.02 * distance);
  c.far_mm = distance + 2.0 * extent;
  return c;
}

}  // namespace sawyer::render
