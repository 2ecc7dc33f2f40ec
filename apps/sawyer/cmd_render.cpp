// `sawyer render`: parses the options into a render job (libs/render/render_job.h), loads the
// log, renders it headless (EGL) and writes the image atomically (nothing is left under the
// output name on failure).
#include "cmd_render.h"
#include "cli_checks.h"
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
#include "sawyer/render/render_job.h"

namespace sawyer::app {
namespace {

namespace fs = std::filesystem;
using namespace sawyer::render;

struct RenderCli {
  std::string input, output, size = "1200", faces = "long", color_maps, species;
  std::vector<std::string> boards;
  std::optional<double> section_z, longitudinal_deg;
  double offset_mm = 0, yaw_deg = 20, pitch_deg = 17, distance_mm = 0, knot_noise = 0.05;
  int supersample = 2;
  std::optional<double> look_at_z;
  bool view = false, stretch = false, no_surface = false, no_index = false, field = false,
       no_lighting = false, quiet = false, scanner_frame = false, bark = false,
       supersample_all = false;
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

int run(const RenderCli& c) {
  // Everything that can be checked before the (slower) context and load comes first.
  if (!is_image_extension(c.output))
    return fail(Error(c.output, "unknown image type (use .png, .tif, .exr or .jpg)"));
  if (c.field && fs::path(c.output).extension() != ".exr")
    return fail(Error(c.output, "--field writes float values: use an .exr output"));
  RenderJob job;
  for (const std::string& b : c.boards) {
    Result<BoardBox> board = BoardBox::from_string(b);
    if (!board) return fail(board.error());
    job.boards.push_back(board.value());
  }
  job.boards_in_scanner_frame = c.scanner_frame;
  job.section_z = c.section_z;
  job.longitudinal_deg = c.longitudinal_deg;
  job.offset_mm = c.offset_mm;
  job.view = c.view;
  job.yaw_deg = c.yaw_deg;
  job.pitch_deg = c.pitch_deg;
  job.distance_mm = c.distance_mm;
  job.look_at_z = c.look_at_z;
  job.surface = !c.no_surface;
  job.shade.mode = c.field ? ShadeMode::kTimeField : ShadeMode::kWood;
  job.shade.lighting = !c.no_lighting;
  job.layout.stretch = c.stretch;
  job.layout.supersample = c.supersample;
  job.layout.adaptive = !c.supersample_all;
  job.shade.bark = c.bark;
  job.renderer.species = c.species;
  job.renderer.color_maps = c.color_maps;
  job.renderer.knot_index = !c.no_index;
  job.renderer.field.knot_noise = c.knot_noise;
  if (Status st = check_render_job(job); !st) return fail(st.error());
  Result<ImageSize> size = parse_size(c.size);
  if (!size) return fail(size.error());
  job.size = size.value();
  Result<OutputLock> lock =
      OutputLock::acquire({c.output, OutputKind::kFile, {c.input, c.color_maps}, "-o"});
  if (!lock) return fail(lock.error());
  // The memory budget as far as the size is known before the content (a missing height follows
  // the content's aspect ratio; the renderer checks the whole size again).
  const bool whole_framebuffer = c.view || c.supersample_all;  // else samples in the shader
  if (Status st = check_image_size(job.size.width, std::max(1, job.size.height),
                                   c.field || !whole_framebuffer ? 1 : c.supersample, c.field);
      !st)
    return fail(st.error());
  Result<unsigned> faces = parse_faces(c.faces);
  if (!faces) return fail(faces.error());
  job.faces = faces.value();

  std::error_code ec;
  if (!fs::exists(c.input, ec)) return fail(Error(c.input, "no such file or folder"));
  Result<LogModel> log = maps::open_log(c.input);
  if (!log) return fail(log.error());
  const LogModel& model = log.value();
  if (Status st = check_render_job(job, model); !st) return fail(st.error());

  const auto t0 = std::chrono::steady_clock::now();
  Result<RenderedImage> img = run_render_job(model, job);
  if (!img) return fail(img.error());
  Status st = write_image(c.output, img.value().image);
  if (!st) return fail(st.error());
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!c.quiet)
    std::cout << "wrote " << c.output << " (" << img.value().image.width << " x "
              << img.value().image.height << ", " << img.value().what << ", " << model.knots.size()
              << " knots, " << static_cast<int>(s * 1000) << " ms; " << img.value().context
              << ")\n";
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
                  "n x n samples per pixel against aliasing, taken only where the wood changes "
                  "within a pixel (knot edges, bark rings, crowded rings) on faces and sections "
                  "(1..4; 1 is fastest)")
      ->check(whole_number_in(1, 4))
      ->capture_default_str();
  cmd->add_flag("--supersample-all", c->supersample_all,
                "take the n x n samples in every pixel (slower; the reference for the above)");
  cmd->add_flag("--bark", c->bark,
                "draw the bark outside the wood (the model's bark thickness, else the species' "
                "default): on wane, sections and the 3D view's surface");
  cmd->add_option("--species", c->species,
                  "the look: spruce or pine (knot, heartwood and bark colours; default: the "
                  "log's species)");
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
