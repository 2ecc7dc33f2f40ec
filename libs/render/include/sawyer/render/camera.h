// Cameras and 4x4 matrices for the renderer, in the log frame (docs/architecture.md 3: mm, z along
// the log).
//
//   Camera c = Camera::orbit({0, 0, 2000}, 3000.0, 0.3, 0.4);   // perspective, looks at the target
//   Camera f = Camera::plane_view(face);                          // ortho, a plane filling the
//   view Mat4 vp = c.view_projection(aspect);
#pragma once

#include <array>

#include "sawyer/core/vec.h"

namespace sawyer::render {

// Column-major 4x4 matrix of floats, as OpenGL takes it.
struct Mat4 {
  std::array<float, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  float& at(int row, int col) { return m[col * 4 + row]; }
  float at(int row, int col) const { return m[col * 4 + row]; }
  friend Mat4 operator*(const Mat4& a, const Mat4& b);
  // Applies the matrix to (p, 1), including the perspective division.
  Vec3 transform_point(const Vec3& p) const;
};

// A rectangle in 3D: origin + s·u·width + t·v·height for s, t in [0, 1]; u, v unit and
// perpendicular; normal = u × v points towards the viewer.
struct PlaneRect {
  Vec3 origin;
  Vec3 u{0, 0, 1};
  Vec3 v{1, 0, 0};
  double width = 1;   // mm along u
  double height = 1;  // mm along v
  Vec3 normal() const { return cross(u, v); }
  Vec3 at(double s, double t) const { return origin + (s * width) * u + (t * height) * v; }
};

class Camera {
 public:
  enum class Projection { kPerspective, kOrthographic };

  // Looks at `target` from `distance` mm away; yaw turns about the log's y axis (0 = looking along
  // -x, the log's z axis to the right), pitch lifts the eye towards +y. Radians.
  static Camera orbit(const Vec3& target, double distance, double yaw, double pitch,
                      Projection projection = Projection::kPerspective);
  static Camera look_at(const Vec3& eye, const Vec3& target, const Vec3& up,
                        Projection projection = Projection::kPerspective);
  // Orthographic view straight at `rect` (from its normal side), the rect filling the viewport
  // exactly: image x along u, image y along v (bottom to top). Ignores the aspect ratio.
  static Camera plane_view(const PlaneRect& rect);

  Mat4 view() const;
  Mat4 projection(double aspect) const;
  Mat4 view_projection(double aspect) const { return projection(aspect) * view(); }
  Vec3 eye() const { return eye_; }
  // Direction the camera looks along (unit).
  Vec3 forward() const;
  // The camera's axes in the log frame: image right, image up, and back (towards the viewer).
  void axes(Vec3* right, Vec3* up, Vec3* back) const;

  Projection projection_type = Projection::kPerspective;
  double fov_y = 0.6;           // perspective: vertical field of view, rad
  double ortho_height = 500.0;  // orthographic: visible height, mm
  double near_mm = 10.0, far_mm = 20000.0;

 private:
  Vec3 eye_{-3000, 0, 0}, target_{0, 0, 0}, up_{0, 1, 0};
  bool plane_ = false;
  PlaneRect rect_;
};

}  // namespace sawyer::render
