// What `sawyer render` draws, as one call: a board's faces, a cross-section, a longitudinal
// section or a 3D view of a log model, on a headless context (EGL). The front end parses its
// options into a RenderJob, checks it, calls run_render_job and writes the image.
//
//   RenderJob job;
//   job.boards.push_back(BoardBox::from_string("0,30,150,50,0,0,4000").value());
//   job.size = {1200, 0};
//   if (Status st = check_render_job(job); !st) ...        // before the log is loaded
//   if (Status st = check_render_job(job, log); !st) ...   // the sections and boards in the log
//   Result<RenderedImage> img = run_render_job(log, job);
//
// Messages name the job's fields ("RenderJob::section_z", "RenderJob::boards", ...) and the job
// itself ("RenderJob"); a front end puts its own names in (option_names.h).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/model/board_box.h"
#include "sawyer/model/log_model.h"
#include "sawyer/render/image.h"
#include "sawyer/render/scene.h"
#include "sawyer/render/views.h"
#include "sawyer/render/wood_renderer.h"

namespace sawyer::render {

struct RenderJob {
  // Exactly one of: boards (one board's faces, or several with `view`), section_z,
  // longitudinal_deg, view.
  std::vector<BoardBox> boards;
  // Board centres are scanner-frame coordinates; else offsets from the log's mean pith line.
  bool boards_in_scanner_frame = false;
  unsigned faces = kLongFaces;             // a board's faces to draw (Face bits)
  std::optional<double> section_z;         // cross-section height, mm
  std::optional<double> longitudinal_deg;  // longitudinal section's azimuth, degrees
  double offset_mm = 0;                    // the longitudinal section's shift off the pith
  // The 3D view: the log's outer surface (unless !surface) with the boards and sections.
  bool view = false;
  double yaw_deg = 20, pitch_deg = 17;
  double distance_mm = 0;           // 0: 1.25 × the log's length
  std::optional<double> look_at_z;  // default: mid-log
  bool surface = true;
  ImageSize size;
  ShadeOptions shade;
  FaceLayout layout;
  RenderOptions renderer;
};

// The job on its own: one mode, one board without a view, the knot noise and every angle and
// length within range.
Status check_render_job(const RenderJob& job);
// The job against the log: the cross-section and the boards within its length.
Status check_render_job(const RenderJob& job, const LogModel& log);

struct RenderedImage {
  Image image;
  std::string what;     // "3D view", "board faces top,bottom", "cross-section z = 1500 mm", ...
  std::string context;  // the GL context's description (renderer, version)
};

// Renders the job (checked as above) on a new headless context. Errors name the colour strips or
// the shader file that failed, or the image size.
Result<RenderedImage> run_render_job(const LogModel& log, const RenderJob& job);

}  // namespace sawyer::render
