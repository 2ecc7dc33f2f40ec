// The viewer's camera control: a turntable orbit around a target point, in the log frame
// (docs/architecture.md 3: mm, z along the log, y up on screen). Pure arithmetic, no OpenGL: mouse
// drags, wheel steps and keys change the state, camera() turns it into a sawyer::render::Camera.
//
//   OrbitCamera orbit;
//   orbit.frame_log(log, aspect);             // the whole log from the side, slightly above
//   orbit.rotate(dx_px, dy_px);                // left drag
//   orbit.pan(dx_px, dy_px, viewport_height);  // middle drag or shift + left drag
//   orbit.zoom(wheel_steps);                   // wheel
//   render::Camera cam = orbit.camera();
#pragma once

#include <vector>

#include "sawyer/core/vec.h"
#include "sawyer/model/log_model.h"
#include "sawyer/render/camera.h"

namespace sawyer::render {

class OrbitCamera {
 public:
  // Radians per pixel of drag, and the distance factor per wheel step.
  static constexpr double kRadiansPerPixel = 0.006;
  static constexpr double kZoomPerStep = 0.88;
  // Pitch stays this far from straight up or down (the turntable's up axis is +y).
  static constexpr double kPitchLimit = 1.55;

  // Looks at the middle of the log's pith from the side (yaw 0.35, pitch 0.3 rad, like
  // render::default_log_camera), at the distance where the whole log just fits the view
  // (`aspect` = width / height), keeping the projection type.
  void frame_log(const LogModel& log, double aspect);
  // The same fit from the current direction (after view_side() and the like); also sets the
  // zoom range and the far plane from the log's size.
  void fit_log(const LogModel& log, double aspect);
  // Keeps the direction, moves the target to the middle of `points` and sets the distance at
  // which they all fit in the view, `margin` (< 1) of the way to its edges.
  void frame_points(const std::vector<Vec3>& points, double aspect, double margin = 0.9);

  // Left drag: dx turns about the vertical (+y) axis, dy lifts or lowers the eye.
  void rotate(double dx_px, double dy_px);
  // Moves the target in the view plane so that the point under the cursor follows it.
  void pan(double dx_px, double dy_px, double viewport_height_px);
  // Positive steps come closer (each step multiplies the distance by kZoomPerStep).
  void zoom(double steps);
  // Named views: from the side (-x, the log's z to the right), from the top end (+z), from above.
  void view_side();
  void view_end();
  void view_top();
  void toggle_projection();

  Camera camera() const;
  // Visible height at the target's distance, mm (pan and scale bars).
  double visible_height() const;

  Vec3 target{0, 0, 0};
  double distance = 3000;  // mm from the target
  double yaw = 0.35;       // rad, see Camera::orbit
  double pitch = 0.3;      // rad
  double fov_y = 0.6;      // rad, vertical
  bool orthographic = false;
  // Set by frame_log from the log's size: the zoom range and the scene's extent (far plane), mm.
  double min_distance = 50, max_distance = 50000;
  double extent = 5000;
};

}  // namespace sawyer::render
