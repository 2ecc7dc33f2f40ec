// `sawyer render`: parses the options, loads the log, renders headless (EGL), writes the image
// atomically (nothing is left under the output name on failure).
#include "cmd_render.h"
#include "cli_error.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "sawyer/core/output_guard.h"
#include "sawyer/maps/open_log.h"
#include "sawyer/model/log_json.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/render/views.h"
#include "sawyer/render/wood_renderer.h"

namespace sawyer::app {
namespace {

namespace fs = std::filesystem;
using namespace sawyer::render;

struct RenderCli {
  std::string input, output, size = "1200", faces = "long", color_maps;
  std::vector<std::string> boards;
  std::optional<double> section_z, longitudinal_deg;
  double offset_mm = 0, yaw_deg = 20, pitch_deg = 17, distance_mm = 0, knot_noise = 0.05;
  int supersample = 2;
  std::optional<double> look_at_z;
  bool view = false, stretch = false, no_surface = false, no_index = false, field = false,
       no_lighting = false, quiet = false, scanner_frame = false;
};

Result<ImageSize> parse_size(const std::string& s) {
  ImageSize out;
  const size_t x = s.find_first_of("xX");
  try {
    size_t used = 0;
    out.width = std::stoi(s.substr(0, x), &used);
    if (used != (x == std::string::npos ? s.size() : x)) throw std::invalid_argument(s);
    if (x != std::string::npos) {
      const std::string h = s.substr(x + 1);
      out.height = std::stoi(h, &used);
      if (used != h.size()) throw std::invalid_argument(s);
    }
  } catch (const std::exception&) {
    return Error("--size", "'" + s + "' is not WxH or W (pixels)");
  }
  if (out.width < 1 || out.width > kMaxImageSide ||
      (x != std::string::npos && (out.height < 1 || out.height > kMaxImageSide)))
    return Error("--size",
                 "'" + s + "': sides must be 1.." + std::to_string(kMaxImageSide) + " pixels");
  return out;
}

Result<unsigned> parse_faces(const std::string& s) {
  unsigned mask = 0;
  std::stringstream ss(s);
  std::string f;
  while (std::getline(ss, f, ',')) {
    if (f == "top")
      mask |= static_cast<unsigned>(Face::kTop);
    else if (f == "bottom")
      mask |= static_cast<unsigned>(Face::kBottom);
    else if (f == "left")
      mask |= static_cast<unsigned>(Face::kLeft);
    else if (f == "right")
      mask |= static_cast<unsigned>(Face::kRight);
    else if (f == "butt")
      mask |= static_cast<unsigned>(Face::kButt);
    else if (f == "end")
      mask |= static_cast<unsigned>(Face::kTopEnd);
    else if (f == "long")
      mask |= kLongFaces;
    else if (f == "all")
      mask |= kAllFaces;
    else
      return Error("--face",
                   "unknown face '" + f +
                       "' (top, bottom, left, right, butt, end, long, all; comma-separated)");
  }
  if (!mask) return Error("--face", "no face given");
  return mask;
}

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

int run(const RenderCli& c) {
  // Everything that can be checked before the (slower) context and load comes first.
  if (!is_image_extension(c.output))
    return fail(Error(c.output, "unknown image type (use .png, .tif, .exr or .jpg)"));
  if (c.field && fs::path(c.output).extension() != ".exr")
    return fail(Error(c.output, "--field writes float values: use an .exr output"));
  const int modes = (c.view ? 1 : 0) + (!c.view && !c.boards.empty() ? 1 : 0) +
                    (!c.view && c.section_z ? 1 : 0) + (!c.view && c.longitudinal_deg ? 1 : 0);
  if (modes != 1)
    return fail(Error("sawyer render",
                      "give exactly one of --board, --section, --longitudinal, "
                      "or --view (which may add boards and sections)"));
  if (!c.view && c.boards.size() > 1)
    return fail(Error("--board", "several boards need --view; render one board's faces at a time"));
  Result<ImageSize> size = parse_size(c.size);
  if (!size) return fail(size.error());
  Result<OutputLock> lock =
      OutputLock::acquire({c.output, OutputKind::kFile, {c.input, c.color_maps}, "-o"});
  if (!lock) return fail(lock.error());
  // The memory budget as far as the size is known before the content (a missing height follows
  // the content's aspect ratio; the renderer checks the whole size again).
  if (Status st = check_image_size(size.value().width, std::max(1, size.value().height),
                                   c.field ? 1 : c.supersample, c.field);
      !st)
    return fail(st.error());
  Result<unsigned> faces = parse_faces(c.faces);
  if (!faces) return fail(faces.error());
  std::vector<BoardBox> boards;
  for (const std::string& b : c.boards) {
    Result<BoardBox> board = BoardBox::from_string(b);
    if (!board) return fail(board.error());
    boards.push_back(board.value());
  }
  if (!(c.knot_noise >= 0 && c.knot_noise <= 0.5))
    return fail(Error("--knot-noise", "must be in [0, 0.5]"));
  // Angles a turn either way; lengths within the log model's own limits (log_json.h).
  const double reach = log_limits::kMaxAbsPithMm + log_limits::kMaxRadiusMm;
  struct Bound {
    const char* option;
    std::optional<double> v;
    double lo, hi;
  };
  for (const Bound& b :
       {Bound{"--longitudinal", c.longitudinal_deg, -360, 360},
        Bound{"--offset", c.offset_mm, -reach, reach}, Bound{"--yaw", c.yaw_deg, -360, 360},
        Bound{"--pitch", c.pitch_deg, -90, 90}, Bound{"--distance", c.distance_mm, 0, 1e6},
        Bound{"--section", c.section_z, -log_limits::kMaxAbsZMm, log_limits::kMaxAbsZMm},
        Bound{"--look-at", c.look_at_z, -log_limits::kMaxAbsZMm, log_limits::kMaxAbsZMm}})
    if (b.v && !(*b.v >= b.lo && *b.v <= b.hi))
      return fail(Error(b.option, mm(*b.v) + " is outside " + mm(b.lo) + " to " + mm(b.hi)));

  std::error_code ec;
  if (!fs::exists(c.input, ec)) return fail(Error(c.input, "no such file or folder"));
  Result<LogModel> log = maps::open_log(c.input);
  if (!log) return fail(log.error());
  const LogModel& model = log.value();
  if (c.section_z && (*c.section_z < model.stem.z_begin() || *c.section_z > model.stem.z_end()))
    return fail(Error("--section", "z = " + mm(*c.section_z) + " mm is outside the log (" +
                                       mm(model.stem.z_begin()) + " to " + mm(model.stem.z_end()) +
                                       " mm)"));

  // A board that misses the log would render as an empty image: refuse it instead.
  for (const BoardBox& b : boards)
    if (b.z1 <= model.stem.z_begin() || b.z0 >= model.stem.z_end())
      return fail(Error(
          "--board", "z " + mm(b.z0) + " to " + mm(b.z1) + " mm misses the log, which runs from " +
                         mm(model.stem.z_begin()) + " to " + mm(model.stem.z_end()) + " mm"));

  const auto t0 = std::chrono::steady_clock::now();
  Result<std::unique_ptr<GlContext>> ctx = create_headless_context();
  if (!ctx) return fail(ctx.error());
  RenderOptions ro;
  ro.color_maps = c.color_maps;
  ro.knot_index = !c.no_index;
  ro.field.knot_noise = c.knot_noise;
  Result<std::unique_ptr<WoodRenderer>> r = WoodRenderer::create(model, ro);
  if (!r) return fail(r.error());  // names the colour strip or shader file
  WoodRenderer& renderer = *r.value();
  // Board centres are given from the log's mean pith line unless --scanner-frame says otherwise.
  if (!c.scanner_frame) {
    const Vec3 centre = renderer.pith_point(0.0);
    for (BoardBox& b : boards) {
      b.cx += centre.x;
      b.cy += centre.y;
    }
  }

  ShadeOptions shade;
  shade.mode = c.field ? ShadeMode::kTimeField : ShadeMode::kWood;
  shade.lighting = !c.no_lighting;
  FaceLayout layout;
  layout.stretch = c.stretch;
  layout.supersample = c.supersample;
  std::string what;
  Result<Image> img = Error("nothing rendered");
  if (c.view) {
    Scene scene;
    scene.boards = boards;
    scene.log_surface = !c.no_surface;
    if (c.section_z && !scene.log_surface) scene.cross_sections.push_back(*c.section_z);
    if (c.longitudinal_deg)
      scene.longitudinal_sections.push_back({*c.longitudinal_deg * kPi / 180.0, c.offset_mm});
    if (scene.log_surface) {
      // The boards are sawn out of the log: the surface stops where the first one starts, with
      // a cross-section there; the log's ends are cross-sections too.
      double cut = model.stem.z_end();
      for (const BoardBox& b : boards) cut = std::min(cut, std::max(b.z0, model.stem.z_begin()));
      if (c.section_z) cut = std::min(cut, *c.section_z);
      scene.surface_z1 = cut;
      scene.cross_sections.push_back(model.stem.z_begin() + 0.01);
      scene.cross_sections.push_back(cut - 0.01);
    }
    const Stem& st = model.stem;
    const double dist = c.distance_mm > 0 ? c.distance_mm : 1.25 * st.length_mm();
    const double target_z = c.look_at_z ? *c.look_at_z : 0.5 * (st.z_begin() + st.z_end());
    Camera cam = Camera::orbit(renderer.pith_point(target_z), dist, c.yaw_deg * kPi / 180.0,
                               c.pitch_deg * kPi / 180.0);
    cam.near_mm = std::max(1.0, 0.02 * dist);
    cam.far_mm = 4.0 * dist + st.length_mm();
    img = render_view(renderer, scene, cam, size.value(), shade, layout);
    what = "3D view";
  } else if (!boards.empty()) {
    img = render_board_faces(renderer, boards[0], faces.value(), size.value(), shade, layout);
    what = "board faces " + face_list(faces.value());
  } else if (c.section_z) {
    img = render_cross_section(renderer, *c.section_z, size.value(), shade, layout);
    what = "cross-section z = " + mm(*c.section_z) + " mm";
  } else {
    img = render_longitudinal_section(renderer, {*c.longitudinal_deg * kPi / 180.0, c.offset_mm},
                                      size.value(), shade, layout);
    what = "longitudinal section";
  }
  if (!img) return fail(img.error());
  Status st = write_image(c.output, img.value());
  if (!st) return fail(st.error());
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!c.quiet)
    std::cout << "wrote " << c.output << " (" << img.value().width << " x " << img.value().height
              << ", " << what << ", " << model.knots.size() << " knots, "
              << static_cast<int>(s * 1000) << " ms; " << ctx.value()->description() << ")\n";
  return 0;
}

}  // namespace

void add_render_command(CLI::App& app, std::function<int()>& run_out) {
  auto c = std::make_shared<RenderCli>();
  CLI::App* cmd = app.add_subcommand(
      "render",
      "Render a log model headless with the knotted-wood shader: a board's faces, a cross-section, "
      "a longitudinal section or a 3D view (docs/render.md)");
  cmd->add_option("input", c->input, "log.json (or a maps / stem-bank folder)")->required();
  cmd->add_option("-o,--output", c->output, "image to write: .png, .tif, .exr or .jpg")->required();
  cmd->add_option("--board", c->boards,
                  "a board as \"x,y,w,t,rot,z0,z1\": centre x, y (mm from the log's mean pith "
                  "line, scanner axes), width, "
                  "thickness (mm), rotation about the log axis (degrees), from z0 to z1 (mm)");
  cmd->add_flag("--scanner-frame", c->scanner_frame,
                "board centres are scanner-frame coordinates, not offsets from the mean pith");
  cmd->add_option("--face", c->faces,
                  "board faces: top, bottom, left, right, butt, end, long (= the four long faces), "
                  "all; comma-separated")
      ->capture_default_str();
  cmd->add_option("--section", c->section_z, "cross-section at height z (mm)");
  cmd->add_option("--longitudinal", c->longitudinal_deg,
                  "longitudinal section through the pith line at this azimuth (degrees)");
  cmd->add_option("--offset", c->offset_mm, "longitudinal section: shift off the pith (mm)")
      ->capture_default_str();
  cmd->add_flag("--view", c->view,
                "3D view of the log's outer surface with the given boards and sections");
  cmd->add_option("--yaw", c->yaw_deg, "view: camera turn about the log (degrees)")
      ->capture_default_str();
  cmd->add_option("--pitch", c->pitch_deg, "view: camera elevation (degrees)")
      ->capture_default_str();
  cmd->add_option("--distance", c->distance_mm,
                  "view: camera distance (mm; default from the log length)");
  cmd->add_option("--look-at", c->look_at_z,
                  "view: height the camera looks at (mm; default mid-log)");
  cmd->add_flag("--no-surface", c->no_surface, "view: leave out the log's outer surface");
  cmd->add_option("--size", c->size,
                  "image size WxH or W (pixels, 1..8192 a side; without H the height follows "
                  "the content)")
      ->capture_default_str();
  cmd->add_flag("--stretch", c->stretch, "fill the image even if that stretches the faces");
  cmd->add_option("--supersample", c->supersample,
                  "n x n samples per pixel against ring aliasing (1..4; 1 is fastest)")
      ->check(CLI::Range(1, 4))
      ->capture_default_str();
  cmd->add_option("--color-maps", c->color_maps,
                  "folder with wood_bar_color.bmp, wood_bar_normal.bmp, wood_bar_specular.bmp "
                  "(default: the bundled sample_logs/wood_color_maps)");
  cmd->add_option("--knot-noise", c->knot_noise, "knot outline noise (0: exact diameters)")
      ->capture_default_str();
  cmd->add_flag("--field", c->field,
                "write the raw time field (t, t_stem, t_knot, knot index) to a float .exr");
  cmd->add_flag("--no-lighting", c->no_lighting, "flat colour, no Phong lighting");
  cmd->add_flag("--no-index", c->no_index,
                "visit every knot per pixel (the published loop; slower)");
  cmd->add_flag("-q,--quiet", c->quiet, "no summary line");
  cmd->callback([c, &run_out]() { run_out = [c]() { return run(*c); }; });
}

}  // namespace sawyer::app
