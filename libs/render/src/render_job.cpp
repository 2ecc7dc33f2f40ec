// `sawyer render`'s work (see render_job.h): the job's checks, then one image on a headless
// context.
#include "sawyer/render/render_job.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

#include "sawyer/model/log_json.h"
#include "sawyer/render/gl_context.h"

namespace sawyer::render {
namespace {

// A length for messages: "1500", "232.5".
std::string mm(double v) {
  std::ostringstream os;
  os << std::round(v * 10.0) / 10.0;
  return os.str();
}

std::string face_list(unsigned mask) {
  std::string s;
  for (unsigned bit = 1; bit <= 32; bit <<= 1)
    if (mask & bit) s += std::string(s.empty() ? "" : ",") + face_name(static_cast<Face>(bit));
  return s;
}

}  // namespace

Status check_render_job(const RenderJob& j) {
  const int modes = (j.view ? 1 : 0) + (!j.view && !j.boards.empty() ? 1 : 0) +
                    (!j.view && j.section_z ? 1 : 0) + (!j.view && j.longitudinal_deg ? 1 : 0);
  if (modes != 1)
    return Error("RenderJob",
                 "give exactly one of RenderJob::boards, RenderJob::section_z, "
                 "RenderJob::longitudinal_deg, or RenderJob::view (which may add boards and "
                 "sections)");
  if (!j.view && j.boards.size() > 1)
    return Error("RenderJob::boards",
                 "several boards need RenderJob::view; render one board's faces at a time");
  const double noise = j.renderer.field.knot_noise;
  if (!(noise >= 0 && noise <= 0.5))
    return Error("WoodFieldParams::knot_noise", "must be in [0, 0.5]");
  // Angles a turn either way; lengths within the log model's own limits (log_json.h).
  const double reach = log_limits::kMaxAbsPithMm + log_limits::kMaxRadiusMm;
  const double zmax = log_limits::kMaxAbsZMm;
  struct Bound {
    const char* option;
    std::optional<double> v;
    double lo, hi;
  };
  for (const Bound& b : {Bound{"RenderJob::longitudinal_deg", j.longitudinal_deg, -360, 360},
                         Bound{"RenderJob::offset_mm", j.offset_mm, -reach, reach},
                         Bound{"RenderJob::yaw_deg", j.yaw_deg, -360, 360},
                         Bound{"RenderJob::pitch_deg", j.pitch_deg, -90, 90},
                         Bound{"RenderJob::distance_mm", j.distance_mm, 0, 1e6},
                         Bound{"RenderJob::section_z", j.section_z, -zmax, zmax},
                         Bound{"RenderJob::look_at_z", j.look_at_z, -zmax, zmax}})
    if (b.v && !(*b.v >= b.lo && *b.v <= b.hi))
      return Error(b.option, mm(*b.v) + " is outside " + mm(b.lo) + " to " + mm(b.hi));
  return Status::Ok();
}

Status check_render_job(const RenderJob& j, const LogModel& model) {
  const double z0 = model.stem.z_begin(), z1 = model.stem.z_end();
  if (j.section_z && (*j.section_z < z0 || *j.section_z > z1))
    return Error("RenderJob::section_z", "z = " + mm(*j.section_z) + " mm is outside the log (" +
                                             mm(z0) + " to " + mm(z1) + " mm)");
  // A board that misses the log would render as an empty image: refuse it instead.
  for (const BoardBox& b : j.boards)
    if (b.z1 <= z0 || b.z0 >= z1)
      return Error("RenderJob::boards", "z " + mm(b.z0) + " to " + mm(b.z1) +
                                            " mm misses the log, which runs from " + mm(z0) +
                                            " to " + mm(z1) + " mm");
  return Status::Ok();
}

Result<RenderedImage> run_render_job(const LogModel& model, const RenderJob& j) {
  Result<std::unique_ptr<GlContext>> ctx = create_headless_context();
  if (!ctx) return ctx.error();
  Result<std::unique_ptr<WoodRenderer>> r = WoodRenderer::create(model, j.renderer);
  if (!r) return r.error();  // names the colour strip or shader file
  WoodRenderer& renderer = *r.value();
  std::vector<BoardBox> boards = j.boards;
  if (!j.boards_in_scanner_frame) {
    const Vec3 centre = renderer.pith_point(0.0);
    for (BoardBox& b : boards) {
      b.cx += centre.x;
      b.cy += centre.y;
    }
  }
  RenderedImage out;
  Result<Image> img = Error("nothing rendered");
  if (j.view) {
    Scene scene;
    scene.boards = boards;
    scene.log_surface = j.surface;
    if (j.section_z && !scene.log_surface) scene.cross_sections.push_back(*j.section_z);
    if (j.longitudinal_deg)
      scene.longitudinal_sections.push_back({*j.longitudinal_deg * kPi / 180.0, j.offset_mm});
    if (scene.log_surface) {
      // The boards are sawn out of the log: the surface stops where the first one starts, with
      // a cross-section there; the log's ends are cross-sections too.
      double cut = model.stem.z_end();
      for (const BoardBox& b : boards) cut = std::min(cut, std::max(b.z0, model.stem.z_begin()));
      if (j.section_z) cut = std::min(cut, *j.section_z);
      scene.surface_z1 = cut;
      scene.cross_sections.push_back(model.stem.z_begin() + 0.01);
      scene.cross_sections.push_back(cut - 0.01);
    }
    const Stem& st = model.stem;
    const double dist = j.distance_mm > 0 ? j.distance_mm : 1.25 * st.length_mm();
    const double target_z = j.look_at_z ? *j.look_at_z : 0.5 * (st.z_begin() + st.z_end());
    Camera cam = Camera::orbit(renderer.pith_point(target_z), dist, j.yaw_deg * kPi / 180.0,
                               j.pitch_deg * kPi / 180.0);
    cam.near_mm = std::max(1.0, 0.02 * dist);
    cam.far_mm = 4.0 * dist + st.length_mm();
    img = render_view(renderer, scene, cam, j.size, j.shade, j.layout);
    out.what = "3D view";
  } else if (!boards.empty()) {
    img = render_board_faces(renderer, boards[0], j.faces, j.size, j.shade, j.layout);
    out.what = "board faces " + face_list(j.faces);
  } else if (j.section_z) {
    img = render_cross_section(renderer, *j.section_z, j.size, j.shade, j.layout);
    out.what = "cross-section z = " + mm(*j.section_z) + " mm";
  } else {
    img = render_longitudinal_section(renderer, {*j.longitudinal_deg * kPi / 180.0, j.offset_mm},
                                      j.size, j.shade, j.layout);
    out.what = "longitudinal section";
  }
  if (!img) return img.error();
  out.image = std::move(img).value();
  out.context = ctx.value()->description();
  return out;
}

}  // namespace sawyer::render
