// sawyer-view: the interactive viewer (GLFW window + Dear ImGui on sawyer::render). Parses the
// options, loads the log (bad input: one line on stderr, exit 1, before any window opens), runs
// the loop; --screenshot saves the window after a few frames and exits, --bench-frames times
// the typical frame and prints a table.
#include <CLI/CLI.hpp>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "sawyer/core/option_names.h"
#include "sawyer/maps/open_log.h"
#include "sawyer/model/log_json.h"
#include "sawyer/render/framebuffer.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/render/glfw_window.h"
#include "sawyer/render/image.h"
#include "sawyer/render/scene.h"
#include "sawyer/sawing/setup.h"
#include "viewer.h"

namespace fs = std::filesystem;
using namespace sawyer;

namespace {

// The libraries' option names (docs/style.md 6) as the viewer's flags.
constexpr OptionName kFlags[] = {{"SawNames::position", "--position"},
                                 {"BoardBox::from_string", "--board"},
                                 {"ImageSize", "--size"}};

int fail(const std::string& message) {
  std::cerr << "sawyer-view: " << with_option_names(message, kFlags) << "\n";
  return 1;
}

// Key presses queued by the window's callback (ImGui's GLFW back-end calls it before its own),
// handed to the viewer with the next frame.
std::vector<view::KeyPress> g_keys;

void on_key(GLFWwindow*, int key, int, int action, int mods) {
  if (action == GLFW_PRESS || action == GLFW_REPEAT)
    g_keys.push_back({key, (mods & GLFW_MOD_SHIFT) != 0, (mods & GLFW_MOD_CONTROL) != 0});
}

double now_ms() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double, std::milli>(clock::now().time_since_epoch()).count();
}

struct Cli {
  std::string log_path, screenshot, size = "1280x800", board, hide, show, surface = "auto";
  std::string saw, grading = "nordic", prices, position;
  bool optimise = false;
  int frames = 3, bench_frames = 0;
  std::optional<double> section_z, longitudinal_deg, opacity;
  bool cut = false, hidden = false;
};

Status parse_size(const std::string& s, int* w, int* h) {
  const size_t x = s.find_first_of("xX");
  try {
    if (x == std::string::npos) throw std::invalid_argument(s);
    size_t a = 0, b = 0;
    *w = std::stoi(s.substr(0, x), &a);
    const std::string hs = s.substr(x + 1);
    *h = std::stoi(hs, &b);
    if (a != x || b != hs.size()) throw std::invalid_argument(s);
  } catch (const std::exception&) {
    return Error("--size", "'" + s + "' is not WxH (pixels)");
  }
  if (*w < 320 || *h < 240 || *w > 8192 || *h > 8192)
    return Error("--size", "'" + s + "': width 320..8192 and height 240..8192 pixels");
  return Status::Ok();
}

// One frame: ImGui frame, the viewer's UI and views, the UI drawn into the window. The swap is
// the caller's, so a screenshot can read the back buffer first.
void run_frame(view::Viewer& v, render::GlfwWindow& win, const view::FrameRequest& req,
               double* ui_draw_ms) {
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  v.frame(req);
  ImGui::Render();
  const double t0 = now_ms();
  const render::Viewport vp = win.framebuffer_viewport();
  const float background[4] = {0.08f, 0.08f, 0.09f, 1.0f};
  render::clear_default_framebuffer(vp, background);
  v.draw_background();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  if (req.timing) {
    render::finish_rendering();
    if (ui_draw_ms) *ui_draw_ms = now_ms() - t0;
  }
}

view::FrameRequest request_for(const render::Viewport& vp) {
  view::FrameRequest r;
  r.fb_width = vp.width;
  r.fb_height = vp.height;
  return r;
}

Status save_window(render::GlfwWindow& win, const fs::path& path) {
  const render::Viewport vp = win.framebuffer_viewport();
  return render::write_image(path, render::read_window(vp.width, vp.height));
}

struct BenchRow {
  double view3d = 0, section = 0, longitudinal = 0, faces = 0, ui_build = 0, ui_draw = 0, swap = 0;
};

// Times `frames` typical frames (every view redrawn) twice: once waiting for the GPU after each
// part (the parts' shares), once with a single wait at the end of the frame (the frame rate).
int bench(view::Viewer& v, render::GlfwWindow& win, int frames, const std::string& log_path) {
  const render::Viewport vp = win.framebuffer_viewport();
  view::FrameRequest req = request_for(vp);
  req.force_redraw = true;
  req.timing = true;
  for (int i = 0; i < 3; ++i) {  // warm-up: shaders, layout, textures
    win.poll_events();
    run_frame(v, win, req, nullptr);
    win.swap_buffers();
  }
  BenchRow parts;
  for (int i = 0; i < frames; ++i) {
    win.poll_events();
    v.orbit().rotate(2.0, 0.0);  // the camera moves as when orbiting
    double ui_draw = 0;
    run_frame(v, win, req, &ui_draw);
    const double t0 = now_ms();
    win.swap_buffers();
    render::finish_rendering();
    const view::FrameTimes& t = v.times();
    parts.view3d += t.view3d;
    parts.section += t.cross_section;
    parts.longitudinal += t.longitudinal;
    parts.faces += t.faces;
    parts.ui_build += t.ui_build;
    parts.ui_draw += ui_draw;
    parts.swap += now_ms() - t0;
  }
  // Frames with the camera turning: each request carries the last frame's time, as the
  // interactive loop's does (the progressive view sizes itself by it).
  auto frame_loop = [&](bool force) {
    view::FrameRequest plain = request_for(vp);
    plain.force_redraw = force;
    const double t0 = now_ms();
    double last = 0;
    for (int i = 0; i < frames; ++i) {
      const double f0 = now_ms();
      win.poll_events();
      v.orbit().rotate(2.0, 0.0);
      plain.last_frame_ms = last;
      run_frame(v, win, plain, nullptr);
      win.swap_buffers();
      render::finish_rendering();
      last = now_ms() - f0;
    }
    return (now_ms() - t0) / frames;
  };
  const double typical = frame_loop(true);
  const double orbiting = frame_loop(false);  // panels unchanged: only the 3D view redrawn
  const double moving_scale = v.motion_scale();
  // The camera stops: the next frame draws the full-size view with the anti-aliased wood.
  double still = 0;
  {
    view::FrameRequest plain = request_for(vp);
    const double t0 = now_ms();
    win.poll_events();
    run_frame(v, win, plain, nullptr);
    win.swap_buffers();
    render::finish_rendering();
    still = now_ms() - t0;
  }

  const double n = frames;
  std::printf("sawyer-view --bench-frames %d: %s, window %d x %d\n", frames, log_path.c_str(),
              vp.width, vp.height);
  std::printf("  %s\n", render::describe_current_context().c_str());
  std::printf("  views: %s; surface %s%s\n", v.view_sizes().c_str(),
              v.state().wood_surface ? "wood-shaded" : "plain mesh",
              v.state().surface_half_res ? " at half resolution" : "");
  std::printf("  %-44s %9s\n", "part of the typical frame (GPU waited)", "mean ms");
  std::printf("  %-44s %9.1f\n", "3D view (surface, knots, section, board)", parts.view3d / n);
  std::printf("  %-44s %9.1f\n", "cross-section panel", parts.section / n);
  std::printf("  %-44s %9.1f\n", "longitudinal section panel", parts.longitudinal / n);
  std::printf("  %-44s %9.1f\n", "board faces panel (4 faces)", parts.faces / n);
  std::printf("  %-44s %9.1f\n", "UI build (ImGui)", parts.ui_build / n);
  std::printf("  %-44s %9.1f\n", "window: 3D view copied in, UI drawn (ImGui)", parts.ui_draw / n);
  std::printf("  %-44s %9.1f\n", "swap", parts.swap / n);
  std::printf("  %-44s %9s %7s\n", "frame", "mean ms", "fps");
  std::printf("  %-44s %9.1f %7.2f\n", "typical: 3D view + section + board faces", typical,
              1000.0 / typical);
  std::printf("  %-44s %9.1f %7.2f\n", "orbiting: 3D view only (panels unchanged)", orbiting,
              1000.0 / orbiting);
  std::printf("  %-44s %9.1f %7.2f\n", "stopped: the full-size, anti-aliased 3D view", still,
              1000.0 / still);
  std::printf("  progressive 3D view while moving: %s, at %.0f %% of the view's side\n",
              v.state().progressive ? "on" : "off", 100.0 * moving_scale);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Cli cli;
  CLI::App app{
      "sawyer-view: look at a log model in 3D (the outer surface semi-transparent with "
      "the knots inside), scrub a cross-section and a longitudinal section, place a "
      "board and see its four faces. Mouse and keys: see docs/viewer.md or the "
      "Controls panel."};
  app.add_option("log", cli.log_path, "The log model (log.json)")->required();
  app.add_option("--size", cli.size, "Window size WxH in pixels")->capture_default_str();
  app.add_option("--screenshot", cli.screenshot,
                 "Render --frames frames, save the window as this image (PNG, TIFF, JPEG) and "
                 "exit");
  app.add_option("--frames", cli.frames, "Frames rendered before --screenshot saves")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_option("--bench-frames", cli.bench_frames,
                 "Time this many typical frames, print a table and exit")
      ->check(CLI::Range(1, 100000));
  app.add_option("--section-z", cli.section_z, "Cross-section height, mm");
  app.add_option("--longitudinal", cli.longitudinal_deg,
                 "Azimuth of the longitudinal section, degrees");
  app.add_option("--board", cli.board, "The board: x,y,width,thickness,rotation_deg,z0,z1 (mm)");
  app.add_option("--opacity", cli.opacity, "Opacity of the log's surface, 0..1")
      ->check(CLI::Range(0.0, 1.0));
  app.add_flag("--cut", cli.cut, "Draw the surface only above the cross-section");
  app.add_option("--surface", cli.surface,
                 "The log's surface: wood (shaded by the knotted-wood renderer), plain (a light "
                 "mesh), auto (plain on software renderers)")
      ->check(CLI::IsMember({"auto", "wood", "plain"}))
      ->capture_default_str();
  app.add_option("--hide", cli.hide,
                 "Hide parts of the 3D view, comma separated: surface, knots, section, board");
  app.add_option("--show", cli.show,
                 "Show more in the 3D view, comma separated: longitudinal, pith");
  app.add_option("--saw", cli.saw,
                 "Start in the sawing mode with this pattern: 2ex | 4ex | tt | a "
                 "sawyer-pattern/1 file");
  app.add_option("--grading", cli.grading, "Sawing mode: nordic | gost | a sawyer-grading/1 file")
      ->capture_default_str();
  app.add_option("--prices", cli.prices,
                 "Sawing mode: a sawyer-prices/1 file (default: data/prices/example_prices.json)");
  app.add_option("--position", cli.position,
                 "Sawing mode: the log's position rot[,x[,y]] (degrees, mm, mm)");
  app.add_flag("--optimise", cli.optimise,
               "Sawing mode: run the position optimiser at the start (waits for it)");
  app.add_flag("--hidden", cli.hidden,
               "Keep the window hidden (with --screenshot or --bench-frames; some drivers "
               "leave a hidden window's pixels undefined)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  int width = 0, height = 0;
  if (Status st = parse_size(cli.size, &width, &height); !st) return fail(st.error().message());
  std::optional<BoardBox> board;
  if (!cli.board.empty()) {
    Result<BoardBox> b = BoardBox::from_string(cli.board);
    if (!b) return fail(b.error().message());
    board = b.value();
  }
  view::ViewState shown;  // only the show_* flags are used
  std::stringstream hide(cli.hide);
  for (std::string part; std::getline(hide, part, ',');) {
    if (part == "surface")
      shown.show_surface = false;
    else if (part == "knots")
      shown.show_knots = false;
    else if (part == "section")
      shown.show_section = false;
    else if (part == "board")
      shown.show_board = false;
    else
      return fail("--hide: unknown part '" + part + "' (surface, knots, section, board)");
  }
  std::stringstream show(cli.show);
  for (std::string part; std::getline(show, part, ',');) {
    if (part == "longitudinal")
      shown.show_longitudinal = true;
    else if (part == "pith")
      shown.show_pith = true;
    else
      return fail("--show: unknown part '" + part + "' (longitudinal, pith)");
  }
  if (!cli.screenshot.empty() && !render::is_image_extension(cli.screenshot))
    return fail(cli.screenshot + ": unknown image extension (use .png, .tif, .jpg or .exr)");

  sawing::LogPosition saw_position;
  if (!cli.position.empty()) {
    Result<sawing::LogPosition> p = sawing::parse_position(cli.position);
    if (!p) return fail(p.error().message());
    saw_position = p.value();
  }
  if (cli.saw.empty() && (!cli.position.empty() || cli.optimise))
    return fail("--position and --optimise need --saw PATTERN");

  // The log first: a bad file is reported without needing a display.
  Result<LogModel> log = maps::open_log(cli.log_path);
  if (!log) return fail(log.error().message());

  render::WindowOptions wo;
  wo.width = width;
  wo.height = height;
  wo.title = "Sawyer - " + (log.value().id.empty() ? cli.log_path : log.value().id);
  wo.visible = !cli.hidden;
  wo.vsync = cli.bench_frames == 0 && cli.screenshot.empty();
  Result<std::unique_ptr<render::GlfwWindow>> window = render::GlfwWindow::create(wo);
  if (!window) return fail(window.error().message());
  render::GlfwWindow& win = *window.value();

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // the same layout every start, no file in the cwd
  ImGui::StyleColorsDark();
  ImGuiStyle& style = ImGui::GetStyle();
  style.WindowRounding = 0;
  style.FramePadding = ImVec2(6, 2);  // compact: the controls fit a 700-pixel-high window
  style.ItemSpacing = ImVec2(6, 3);
  glfwSetKeyCallback(win.handle(), on_key);  // before ImGui's back-end, which chains to it
  if (!ImGui_ImplGlfw_InitForOpenGL(win.handle(), true) || !ImGui_ImplOpenGL3_Init("#version 450"))
    return fail("window: Dear ImGui's GLFW or OpenGL 3 back-end failed to start");

  int rc = 0;
  {
    Result<std::unique_ptr<view::Viewer>> created =
        view::Viewer::create(std::make_unique<LogModel>(std::move(log).value()), cli.log_path);
    if (!created) {
      rc = fail(created.error().message());
    } else {
      view::Viewer& v = *created.value();
      view::ViewState& s = v.state();
      const Stem& st = v.log().stem;
      if (cli.section_z) s.section_z = std::clamp(*cli.section_z, st.z_begin(), st.z_end());
      if (cli.longitudinal_deg) s.longitudinal_deg = *cli.longitudinal_deg;
      if (cli.opacity) s.surface_opacity = static_cast<float>(*cli.opacity);
      if (board) s.board = *board;
      s.cut_at_section = cli.cut;
      s.show_surface = shown.show_surface;
      s.show_knots = shown.show_knots;
      s.show_section = shown.show_section;
      s.show_board = shown.show_board;
      s.show_longitudinal = shown.show_longitudinal;
      s.show_pith = shown.show_pith;
      if (cli.surface != "auto") s.wood_surface = cli.surface == "wood";
      if (!cli.saw.empty()) {
        if (Status saw =
                v.start_sawing({cli.saw, cli.grading, cli.prices}, saw_position, cli.optimise);
            !saw)
          rc = fail(saw.error().message());
      }

      if (rc != 0) {
        // --saw failed: reported above.
      } else if (cli.bench_frames > 0) {
        rc = bench(v, win, cli.bench_frames, cli.log_path);
      } else if (!cli.screenshot.empty()) {
        for (int i = 0; i < cli.frames; ++i) {
          win.poll_events();
          const render::Viewport vp = win.framebuffer_viewport();
          run_frame(v, win, request_for(vp), nullptr);
          if (i + 1 == cli.frames) {
            Status saved = save_window(win, cli.screenshot);
            if (!saved)
              rc = fail(saved.error().message());
            else
              std::cout << "sawyer-view: wrote " << cli.screenshot << " (" << vp.width << " x "
                        << vp.height << ")\n";
          }
          win.swap_buffers();
        }
      } else {
        // Interactive: draw when something happens (input, or twice a second for the UI).
        double last_ms = 0;
        while (!win.should_close() && !v.quit_requested()) {
          // Right after the camera stops, the full-size frame is drawn without waiting.
          if (v.refine_pending())
            glfwPollEvents();
          else
            glfwWaitEventsTimeout(0.5);
          const render::Viewport vp = win.framebuffer_viewport();
          if (vp.width <= 0 || vp.height <= 0) continue;  // minimised
          const double t0 = now_ms();
          view::FrameRequest req = request_for(vp);
          req.keys = std::exchange(g_keys, {});
          req.last_frame_ms = last_ms;
          run_frame(v, win, req, nullptr);
          if (std::optional<fs::path> shot = v.take_screenshot_request()) {
            Status saved = save_window(win, *shot);
            if (!saved) std::cerr << "sawyer-view: " << saved.error().message() << "\n";
            v.screenshot_done(*shot, saved);
          }
          win.swap_buffers();
          last_ms = now_ms() - t0;
        }
      }
    }
  }  // the viewer's GL objects go while the context is current

  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  return rc;
}
