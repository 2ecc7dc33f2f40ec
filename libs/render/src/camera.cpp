#include "sawyer/render/camera.h"

#include <cmath>

namespace sawyer::render {

Mat4 operator*(const Mat4& a, const Mat4& b) {
  Mat4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      float s = 0;
      for (int k = 0; k < 4; ++k) s += a.at(i, k) * b.at(k, j);
      r.at(i, j) = s;
    }
  return r;
}

Vec3 Mat4::transform_point(const Vec3& p) const {
  double o[4];
  for (int i = 0; i < 4; ++i) o[i] = at(i, 0) * p.x + at(i, 1) * p.y + at(i, 2) * p.z + at(i, 3);
  const double w = std::abs(o[3]) > 1e-30 ? o[3] : 1.0;
  return {o[0] / w, o[1] / w, o[2] / w};
}

namespace {

// A view matrix whose rows are the camera axes (right, up, back) through `eye`.
Mat4 view_from_axes(const Vec3& right, const Vec3& up, const Vec3& back, const Vec3& eye) {
  Mat4 m;
  const Vec3 axes[3] = {right, up, back};
  for (int r = 0; r < 3; ++r) {
    m.at(r, 0) = static_cast<float>(axes[r].x);
    m.at(r, 1) = static_cast<float>(axes[r].y);
    m.at(r, 2) = static_cast<float>(axes[r].z);
    m.at(r, 3) = static_cast<float>(-dot(axes[r], eye));
  }
  return m;
}

}  // namespace

Camera Camera::orbit(const Vec3& target, double distance, double yaw, double pitch,
                     Projection projection) {
  // yaw 0: the eye on the -x side looking along +x, so the log's z axis runs to the right.
  const Vec3 dir{-std::cos(pitch) * std::cos(yaw), std::sin(pitch),
                 -std::cos(pitch) * std::sin(yaw)};
  Camera c = look_at(target + distance * dir, target, {0, 1, 0}, projection);
  c.ortho_height = distance * 0.5;
  c.far_mm = std::max(c.far_mm, 4.0 * distance);
  return c;
}

Camera Camera::look_at(const Vec3& eye, const Vec3& target, const Vec3& up, Projection projection) {
  Camera c;
  c.eye_ = eye;
  c.target_ = target;
  c.up_ = up;
  c.projection_type = projection;
  return c;
}

Camera Camera::plane_view(const PlaneRect& rect) {
  Camera c;
  c.plane_ = true;
  c.rect_ = rect;
  c.projection_type = Projection::kOrthographic;
  const Vec3 n = rect.normal();
  c.target_ = rect.at(0.5, 0.5);
  c.eye_ = c.target_ + 1000.0 * n;
  c.up_ = rect.v;
  return c;
}

Vec3 Camera::forward() const { return (target_ - eye_).normalized(); }

void Camera::axes(Vec3* right, Vec3* up, Vec3* back) const {
  if (plane_) {
    *right = rect_.u;
    *up = rect_.v;
    *back = rect_.normal();
    return;
  }
  *back = (eye_ - target_).normalized();
  Vec3 r = cross(up_, *back);
  if (r.norm() < 1e-9) r = cross(Vec3{1, 0, 0}, *back);
  *right = r.normalized();
  *up = cross(*back, *right);
}

Mat4 Camera::view() const {
  Vec3 right, up, back;
  axes(&right, &up, &back);
  // A plane view maps the rect's origin to (0, 0, 0).
  return view_from_axes(right, up, back, plane_ ? rect_.origin : eye_);
}

Mat4 Camera::projection(double aspect) const {
  Mat4 p;
  if (plane_) {
    // x in [0, width] → [-1, 1], y in [0, height] → [-1, 1]; depth ±1000 mm about the plane.
    p.at(0, 0) = static_cast<float>(2.0 / rect_.width);
    p.at(0, 3) = -1.0f;
    p.at(1, 1) = static_cast<float>(2.0 / rect_.height);
    p.at(1, 3) = -1.0f;
    p.at(2, 2) = -1.0f / 1000.0f;
    return p;
  }
  const double n = near_mm, f = far_mm;
  if (projection_type == Projection::kOrthographic) {
    const double h = 0.5 * ortho_height, w = h * aspect;
    p.at(0, 0) = static_cast<float>(1.0 / w);
    p.at(1, 1) = static_cast<float>(1.0 / h);
    p.at(2, 2) = static_cast<float>(-2.0 / (f - n));
    p.at(2, 3) = static_cast<float>(-(f + n) / (f - n));
    return p;
  }
  const double t = 1.0 / std::tan(0.5 * fov_y);
  p.at(0, 0) = static_cast<float>(t / aspect);
  p.at(1, 1) = static_cast<float>(t);
  p.at(2, 2) = static_cast<float>(-(f + n) / (f - n));
  p.at(2, 3) = static_cast<float>(-2.0 * f * n / (f - n));
  p.at(3, 2) = -1.0f;
  p.at(3, 3) = 0.0f;
  return p;
}

}  // namespace sawyer::render
