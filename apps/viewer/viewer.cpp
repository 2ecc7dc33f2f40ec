#include "viewer.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>  // key codes only (KeyPress)
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <sstream>
#include <utility>

#include "sawing_panel.h"
#include "sawyer/maps/open_log.h"
#include "sawyer/model/log_json.h"
#include "sawyer/render/framebuffer.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/render/views.h"
#include "sawyer/sawing/sawing_file.h"

namespace sawyer::view {
namespace {

namespace fs = std::filesystem;
using render::board_outline;
using render::Face;
using render::knot_tubes;
using render::log_surface;
using render::pith_line;

constexpr float kBackground[4] = {0.15f, 0.16f, 0.18f, 1.0f};
constexpr float kPanelBackground[4] = {0.10f, 0.10f, 0.11f, 1.0f};
constexpr float kTransparent[4] = {0, 0, 0, 0};
constexpr Rgb kBoardColor{1.0f, 0.85f, 0.25f};
constexpr Rgb kPithColor{0.9f, 0.2f, 0.2f};
constexpr Rgb kSurfaceColor{0.86f, 0.70f, 0.50f};
constexpr double kDeg = kPi / 180.0;
const Face kLongFaceOrder[4] = {Face::kTop, Face::kBottom, Face::kLeft, Face::kRight};

double now_ms() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double, std::milli>(clock::now().time_since_epoch()).count();
}

// Times one part of the frame: waits for the GPU at the end when timing.
class PartTimer {
 public:
  PartTimer(bool timing, double* out) : timing_(timing), out_(out), t0_(now_ms()) {}
  ~PartTimer() {
    if (!timing_) return;
    render::finish_rendering();
    *out_ = now_ms() - t0_;
  }

 private:
  bool timing_;
  double* out_;
  double t0_;
};

std::string key_of(std::initializer_list<double> values) {
  std::ostringstream s;
  s.precision(9);
  for (double v : values) s << v << ',';
  return s.str();
}

double max_radius(const Stem& st) {
  double r = 0;
  for (const auto& row : st.radius)
    for (double x : row) r = std::max(r, x);
  return r;
}

double mean_radius(const Stem& st) {
  double sum = 0;
  for (int i = 0; i < st.slice_count(); ++i) sum += st.mean_radius(i);
  return st.slice_count() ? sum / st.slice_count() : 0;
}

ImTextureID tex_id(unsigned tex) {
  return reinterpret_cast<ImTextureID>(static_cast<std::intptr_t>(tex));
}

// ImGui::Image of a whole GL texture (rows bottom to top) or of GL rows [y0, y0 + h).
void gl_image(unsigned tex, ImVec2 size, int tex_h = 0, int y0 = 0, int h = 0) {
  float v_top = 1.0f, v_bottom = 0.0f;
  if (tex_h > 0 && h > 0) {
    v_top = static_cast<float>(y0 + h) / tex_h;
    v_bottom = static_cast<float>(y0) / tex_h;
  }
  ImGui::Image(tex_id(tex), size, ImVec2(0, v_top), ImVec2(1, v_bottom));
}

// `path` when no file has that name, else the first of name-1.ext, name-2.ext, ... that is free
// (a trailing -N of `path` itself is replaced).
fs::path free_name(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return path;
  std::string stem = path.stem().string();
  const size_t dash = stem.rfind('-');
  if (dash != std::string::npos && dash + 1 < stem.size() &&
      stem.find_first_not_of("0123456789", dash + 1) == std::string::npos)
    stem.resize(dash);
  for (int i = 1;; ++i) {
    fs::path p = path;
    p.replace_filename(stem + "-" + std::to_string(i) + path.extension().string());
    if (!fs::exists(p, ec)) return p;
  }
}

}  // namespace

Result<std::unique_ptr<Viewer>> Viewer::create(std::unique_ptr<LogModel> log,
                                               const fs::path& path) {
  std::unique_ptr<Viewer> v(new Viewer());
  if (Status st = v->painter_.init(); !st) return st.error();
  if (Status st = v->load(std::move(log), path); !st) return st.error();
  v->screenshot_text_ = free_name("sawyer-view.png").string();
  // Software renderers draw the wood-shaded surface (every stem sample x 360 angles, each
  // fragment through the whole wood field) slowly: start them with the plain one (docs/viewer.md).
  const std::string gl = render::describe_current_context();
  if (gl.find("llvmpipe") != std::string::npos || gl.find("softpipe") != std::string::npos)
    v->state_.wood_surface = false;
  return v;
}

Viewer::~Viewer() {
  sawing_.reset();    // waits for the optimiser, which reads the log
  renderer_.reset();  // before the log it points to
}

Status Viewer::load(std::unique_ptr<LogModel> log, const fs::path& path) {
  Result<std::unique_ptr<render::WoodRenderer>> r = render::WoodRenderer::create(*log);
  if (!r) return r.error().with_context(path.string());
  sawing_.reset();  // it refers to the old log
  sawing_mode_ = false;
  renderer_ = std::move(r).value();  // the old renderer goes before the old log
  log_ = std::move(log);
  path_ = path;
  open_text_ = path.string();
  // A run folder's log: the pattern its run chose from a pattern set, if it did.
  run_choice_line_ = sawing::run_pattern_choice_line(path);
  knots_.upload(knot_tubes(*log_));
  pith_.upload(pith_line(log_->stem, kPithColor));
  surface_.upload(log_surface(log_->stem, kSurfaceColor));
  key_3d_.clear();
  key_section_.clear();
  key_long_.clear();
  key_faces_.clear();
  key_board_mesh_.clear();
  defaults_for_log();
  return Status::Ok();
}

Status Viewer::open(const fs::path& path) {
  Result<LogModel> log = maps::open_log(path);
  Status st =
      log ? load(std::make_unique<LogModel>(std::move(log).value()), path) : Status(log.error());
  status_error_ = !st;
  status_line_ = st ? "opened " + path.string() : st.error().message();
  if (!st) std::cerr << "sawyer-view: " << st.error().message() << "\n";
  return st;
}

void Viewer::defaults_for_log() {
  const Stem& st = log_->stem;
  const double zmid = 0.5 * (st.z_begin() + st.z_end());
  const double len = st.length_mm();
  const double R = mean_radius(st);
  const Vec2 c = st.pith_at(zmid);
  state_.section_z = zmid;
  state_.longitudinal_deg = 0;
  state_.longitudinal_offset = 0;
  // A side board off the pith, through the middle of the log: its faces meet the knots at an
  // angle, as most boards do.
  BoardBox& b = state_.board;
  b.cx = c.x;
  b.cy = c.y + 0.45 * R;
  b.width = std::round(std::min(0.9 * R, 150.0));
  b.thickness = std::round(std::min(0.3 * R, 50.0));
  b.rotation = 0;
  b.z0 = std::round(std::max(st.z_begin(), zmid - 0.25 * len));
  b.z1 = std::round(std::min(st.z_end(), zmid + 0.25 * len));
  reset_pending_ = true;
}

void Viewer::reset_view() {
  const bool ortho = orbit_.orthographic;
  orbit_.frame_log(*log_, aspect_3d_);
  orbit_.orthographic = ortho;
}

void Viewer::frame_board() {
  const BoardBox& b = state_.board;
  std::vector<Vec3> corners;
  for (double z : {b.z0, b.z1})
    for (double su : {-0.5, 0.5})
      for (double sv : {-0.5, 0.5})
        corners.push_back(Vec3{b.cx, b.cy, z} + (su * b.width) * b.u() +
                          (sv * b.thickness) * b.v());
  orbit_.frame_points(corners, aspect_3d_);
}

void Viewer::view_preset(void (OrbitCamera::*preset)()) {
  (orbit_.*preset)();
  orbit_.fit_log(*log_, aspect_3d_);
}

void Viewer::step_section(double mm) {
  const Stem& st = log_->stem;
  state_.section_z = std::clamp(state_.section_z + mm, st.z_begin(), st.z_end());
}

Status Viewer::start_sawing(const SawingChoice& choice, const sawing::LogPosition& pos,
                            bool optimise) {
  auto panel = std::make_unique<SawingPanel>(*log_, path_);
  if (Status s = panel->start(choice, pos); !s) return s;
  if (optimise) panel->optimise(true);
  sawing_ = std::move(panel);
  sawing_mode_ = true;
  return Status::Ok();
}

// The sawing window over the right of the 3D view.
void Viewer::ui_sawing(float x, float y, float w, float h) {
  if (!sawing_mode_) return;
  if (!sawing_) {
    sawing_ = std::make_unique<SawingPanel>(*log_, path_);
    (void)sawing_->start({}, {});
  }
  ImGui::SetNextWindowPos(ImVec2(x, y), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(w, h), ImGuiCond_Always);
  ImGui::SetNextWindowBgAlpha(0.92f);
  ImGui::Begin("Sawing", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  sawing_->ui();
  ImGui::End();
  if (sawing_->take_changed()) {
    if (std::optional<BoardBox> b = sawing_->selected_board()) {
      state_.board = *b;
      const double zc = 0.5 * (b->z0 + b->z1);
      if (state_.section_z < b->z0 || state_.section_z > b->z1) state_.section_z = zc;
    }
  }
}

void Viewer::request_screenshot() {
  fs::path p = screenshot_text_.empty() ? fs::path("sawyer-view.png") : fs::path(screenshot_text_);
  screenshot_request_ = p;
}

std::optional<fs::path> Viewer::take_screenshot_request() {
  return std::exchange(screenshot_request_, std::nullopt);
}

void Viewer::screenshot_done(const fs::path& path, const Status& status) {
  status_error_ = !status;
  status_line_ = status ? "saved " + path.string() : status.error().message();
  if (status) screenshot_text_ = free_name(path).string();
}

std::string Viewer::view_sizes() const {
  std::ostringstream s;
  s << "3D " << view_w_ << "x" << view_h_ << ", section " << section_px_ << "x" << section_px_
    << ", longitudinal " << long_w_ << "x" << long_h_ << ", faces " << faces_w_ << "x" << faces_h_;
  return s.str();
}

void Viewer::frame(const FrameRequest& req) {
  ImGuiIO& io = ImGui::GetIO();
  const double t0 = now_ms();
  times_ = {};
  scale_ = io.DisplayFramebufferScale.x > 0 ? io.DisplayFramebufferScale.x : 1.0f;
  const float W = io.DisplaySize.x, H = io.DisplaySize.y;
  // Layout: controls on the left; on the right the 3D view above a strip with the 2D views
  // (the cross-section, then the longitudinal section and the board faces beside it).
  const float left_w = std::clamp(0.22f * W, 280.0f, 330.0f);
  const float main_w = std::max(1.0f, W - left_w);
  const float strip_h = std::clamp(0.40f * H, 200.0f, 520.0f);
  const float view_h = std::max(1.0f, H - strip_h);
  view_w_ = std::max(1, static_cast<int>(main_w * scale_));
  view_h_ = std::max(1, static_cast<int>(view_h * scale_));
  aspect_3d_ = static_cast<float>(view_w_) / view_h_;
  last_frame_ms_ = req.last_frame_ms;
  if (std::optional<fs::path> p = std::exchange(open_request_, std::nullopt)) (void)open(*p);
  if (std::exchange(reset_pending_, false)) reset_view();

  handle_input(left_w, 0, main_w, view_h, req.keys);
  ui_controls(0, 0, left_w, H);
  const float saw_w = std::min(main_w, 470.0f);
  ui_sawing(left_w + main_w - saw_w, 0, saw_w, view_h);
  ui_panels(left_w, view_h, main_w, strip_h);
  times_.ui_build = now_ms() - t0;

  draw_3d(req.force_redraw, req.timing);
  ImDrawList* bg = ImGui::GetBackgroundDrawList();
  const ImVec2 a(left_w, 0), b(left_w + main_w, view_h);
  // The opaque layer is copied into the window by draw_background(); the UI blends the surface
  // layer over it.
  view_rect_ = {static_cast<int>(left_w * scale_), static_cast<int>((H - view_h) * scale_), view_w_,
                view_h_};
  if (state_.show_surface && state_.surface_opacity > 0) {
    const int alpha = static_cast<int>(std::lround(255.0 * state_.surface_opacity));
    bg->AddImage(tex_id(overlay_.texture()), a, b, ImVec2(0, 1), ImVec2(1, 0),
                 IM_COL32(255, 255, 255, alpha));
  }
  draw_cross_section(req.force_redraw, req.timing);
  draw_longitudinal(req.force_redraw, req.timing);
  draw_faces(req.force_redraw, req.timing);
  render::bind_default_framebuffer(
      {0, 0, static_cast<int>(W * scale_), static_cast<int>(H * scale_)});
}

void Viewer::draw_background() const {
  if (opaque_.ready()) opaque_.blit_to_window(view_rect_);
}

void Viewer::handle_input(float x0, float y0, float w, float h, const std::vector<KeyPress>& keys) {
  ImGuiIO& io = ImGui::GetIO();
  const ImVec2 m = io.MousePos;
  const bool in_view = m.x >= x0 && m.x < x0 + w && m.y >= y0 && m.y < y0 + h;
  const bool mouse_free = !io.WantCaptureMouse && in_view;
  if (mouse_free && (ImGui::IsMouseClicked(0) || ImGui::IsMouseClicked(2))) {
    dragging_ = true;
    panning_ = ImGui::IsMouseClicked(2) || io.KeyShift;
  }
  if (dragging_ && !ImGui::IsMouseDown(0) && !ImGui::IsMouseDown(2)) dragging_ = false;
  if (dragging_ && (io.MouseDelta.x != 0 || io.MouseDelta.y != 0)) {
    if (panning_)
      orbit_.pan(io.MouseDelta.x, io.MouseDelta.y, h);
    else
      orbit_.rotate(io.MouseDelta.x, io.MouseDelta.y);
  }
  if (mouse_free && ImGui::IsMouseDragging(1) && io.MouseDelta.y != 0)
    orbit_.zoom(-io.MouseDelta.y / 40.0);  // right drag: zoom
  if (mouse_free && io.MouseWheel != 0) orbit_.zoom(io.MouseWheel);
  if (mouse_free && ImGui::IsMouseDoubleClicked(0)) reset_view();

  if (io.WantCaptureKeyboard) return;
  for (const KeyPress& k : keys) handle_key(k);
}

void Viewer::handle_key(const KeyPress& k) {
  const double step = k.shift ? 100.0 : 10.0;
  const double turn = 15.0 * kDeg / OrbitCamera::kRadiansPerPixel;  // 15° in pixels of drag
  switch (k.key) {
    case GLFW_KEY_R:
    case GLFW_KEY_HOME:
      reset_view();
      break;
    case GLFW_KEY_F:
      frame_board();
      break;
    case GLFW_KEY_1:
    case GLFW_KEY_KP_1:
      view_preset(&OrbitCamera::view_side);
      break;
    case GLFW_KEY_3:
    case GLFW_KEY_KP_3:
      view_preset(&OrbitCamera::view_end);
      break;
    case GLFW_KEY_7:
    case GLFW_KEY_KP_7:
      view_preset(&OrbitCamera::view_top);
      break;
    case GLFW_KEY_5:
    case GLFW_KEY_KP_5:
    case GLFW_KEY_O:
      orbit_.toggle_projection();
      break;
    case GLFW_KEY_LEFT:
      orbit_.rotate(-turn, 0);
      break;
    case GLFW_KEY_RIGHT:
      orbit_.rotate(turn, 0);
      break;
    case GLFW_KEY_UP:
      orbit_.rotate(0, turn);
      break;
    case GLFW_KEY_DOWN:
      orbit_.rotate(0, -turn);
      break;
    case GLFW_KEY_EQUAL:
    case GLFW_KEY_KP_ADD:
      orbit_.zoom(1);
      break;
    case GLFW_KEY_MINUS:
    case GLFW_KEY_KP_SUBTRACT:
      orbit_.zoom(-1);
      break;
    case GLFW_KEY_PAGE_UP:
      step_section(step);
      break;
    case GLFW_KEY_PAGE_DOWN:
      step_section(-step);
      break;
    case GLFW_KEY_LEFT_BRACKET:
      state_.longitudinal_deg = std::fmod(state_.longitudinal_deg + 355.0, 360.0);
      break;
    case GLFW_KEY_RIGHT_BRACKET:
      state_.longitudinal_deg = std::fmod(state_.longitudinal_deg + 5.0, 360.0);
      break;
    case GLFW_KEY_S:
      if (!k.ctrl) state_.show_surface = !state_.show_surface;
      break;
    case GLFW_KEY_K:
      state_.show_knots = !state_.show_knots;
      break;
    case GLFW_KEY_C:
      state_.cut_at_section = !state_.cut_at_section;
      break;
    case GLFW_KEY_F12:
    case GLFW_KEY_P:
      request_screenshot();
      break;
    case GLFW_KEY_ESCAPE:
    case GLFW_KEY_Q:
      quit_ = true;
      break;
    default:
      break;
  }
}

void Viewer::ui_controls(float x, float y, float w, float h) {
  ImGui::SetNextWindowPos(ImVec2(x, y), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(w, h), ImGuiCond_Always);
  ImGui::Begin("Sawyer viewer", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse);
  const Stem& st = log_->stem;
  const float R = static_cast<float>(max_radius(st));

  if (ImGui::CollapsingHeader("File", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::SetNextItemWidth(-60);
    const bool enter =
        ImGui::InputText("##open", &open_text_, ImGuiInputTextFlags_EnterReturnsTrue);
    ImGui::SameLine();
    // Opened at the start of the next frame: this frame's UI still refers to the current log.
    if (ImGui::Button("Open") || enter) open_request_ = open_text_;
    ImGui::Text("%s  %s", log_->id.c_str(), log_->species.c_str());
    int dead = 0;
    for (const Knot& k : log_->knots) dead += k.has_dead_part() ? 1 : 0;
    ImGui::Text("%.2f m, mean diameter %.0f mm", st.length_mm() / 1000.0, 2.0 * mean_radius(st));
    ImGui::Text("%d knots, %d with a dead part", static_cast<int>(log_->knots.size()), dead);
    // The scan's own QA verdict (log.json "qa"), so that an operator sees an uncertain model
    // before sawing it.
    if (const auto& qa = log_->qa) {
      if (qa->trusted) {
        ImGui::TextDisabled("scan QA: passed");
      } else {
        ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.4f, 1.0f), "scan QA: NOT TO BE TRUSTED");
        for (const std::string& line : qa->warnings) ImGui::TextWrapped("  %s", line.c_str());
      }
    }
  }

  if (ImGui::CollapsingHeader("Show", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::Checkbox("log surface (S)", &state_.show_surface);
    ImGui::SetNextItemWidth(-1);
    ImGui::SliderFloat("##opacity", &state_.surface_opacity, 0.0f, 1.0f, "opacity %.2f");
    ImGui::Checkbox("cut at the section (C)", &state_.cut_at_section);
    ImGui::Checkbox("knots (K)", &state_.show_knots);
    ImGui::SameLine();
    ImGui::TextDisabled("sound brown, dead black");
    ImGui::Checkbox("cross-section", &state_.show_section);
    ImGui::SameLine();
    ImGui::Checkbox("longitudinal", &state_.show_longitudinal);
    ImGui::Checkbox("board", &state_.show_board);
    ImGui::SameLine();
    ImGui::Checkbox("pith", &state_.show_pith);
  }

  if (ImGui::CollapsingHeader("Sections", ImGuiTreeNodeFlags_DefaultOpen)) {
    float z = static_cast<float>(state_.section_z);
    ImGui::SetNextItemWidth(-1);
    if (ImGui::SliderFloat("##z", &z, static_cast<float>(st.z_begin()),
                           static_cast<float>(st.z_end()), "height z %.0f mm"))
      state_.section_z = z;
    float a = static_cast<float>(state_.longitudinal_deg);
    ImGui::SetNextItemWidth(-1);
    if (ImGui::SliderFloat("##angle", &a, 0.0f, 360.0f, "longitudinal %.0f deg"))
      state_.longitudinal_deg = a;
    float off = static_cast<float>(state_.longitudinal_offset);
    ImGui::SetNextItemWidth(-1);
    if (ImGui::SliderFloat("##offset", &off, -R, R, "offset from pith %.0f mm"))
      state_.longitudinal_offset = off;
  }

  if (ImGui::CollapsingHeader("Board", ImGuiTreeNodeFlags_DefaultOpen)) {
    BoardBox& b = state_.board;
    const Vec2 c = st.pith_at(0.5 * (st.z_begin() + st.z_end()));
    auto slider = [&](const char* id, double* v, float lo, float hi, const char* fmt) {
      float f = static_cast<float>(*v);
      ImGui::SetNextItemWidth(-1);
      if (ImGui::SliderFloat(id, &f, lo, hi, fmt)) *v = f;
    };
    slider("##cx", &b.cx, static_cast<float>(c.x) - R, static_cast<float>(c.x) + R,
           "centre x %.0f mm");
    slider("##cy", &b.cy, static_cast<float>(c.y) - R, static_cast<float>(c.y) + R,
           "centre y %.0f mm");
    double deg = b.rotation / kDeg;
    slider("##rot", &deg, -90.0f, 90.0f, "rotation %.0f deg");
    b.rotation = deg * kDeg;
    slider("##w", &b.width, 10.0f, 2.0f * R, "width %.0f mm");
    slider("##t", &b.thickness, 5.0f, R, "thickness %.0f mm");
    float z0 = static_cast<float>(b.z0), z1 = static_cast<float>(b.z1);
    ImGui::SetNextItemWidth(-1);
    if (ImGui::DragFloatRange2("##zr", &z0, &z1, 5.0f, static_cast<float>(st.z_begin()),
                               static_cast<float>(st.z_end()), "z0 %.0f", "z1 %.0f mm")) {
      b.z0 = z0;
      b.z1 = std::max(z1, z0 + 10.0f);
    }
    if (ImGui::Button("Frame the board (F)")) frame_board();
  }

  if (ImGui::CollapsingHeader("Sawing", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::Checkbox("sawing mode", &sawing_mode_);
    ImGui::SameLine();
    ImGui::TextDisabled("pattern, grades, value");
    if (!run_choice_line_.empty()) ImGui::TextWrapped("run: %s", run_choice_line_.c_str());
  }

  if (ImGui::CollapsingHeader("View", ImGuiTreeNodeFlags_DefaultOpen)) {
    if (ImGui::Button("Reset R")) reset_view();
    ImGui::SameLine();
    if (ImGui::Button("Side 1")) view_preset(&OrbitCamera::view_side);
    ImGui::SameLine();
    if (ImGui::Button("End 3")) view_preset(&OrbitCamera::view_end);
    ImGui::SameLine();
    if (ImGui::Button("Top 7")) view_preset(&OrbitCamera::view_top);
    ImGui::Checkbox("orthographic (5)", &orbit_.orthographic);
    ImGui::SetNextItemWidth(-90);
    ImGui::InputText("##shot", &screenshot_text_);
    ImGui::SameLine();
    if (ImGui::Button("Screenshot")) request_screenshot();
  }

  if (ImGui::CollapsingHeader("Speed")) {
    ImGui::Checkbox("wood-shaded surface", &state_.wood_surface);
    ImGui::Checkbox("surface at half resolution", &state_.surface_half_res);
    ImGui::Checkbox("progressive: smaller while the camera moves", &state_.progressive);
  }
  if (ImGui::CollapsingHeader("Controls")) {
    ImGui::TextWrapped(
        "Left drag: orbit. Middle drag or Shift+left drag: pan. Wheel or right drag: zoom. "
        "Double-click, R or Home: reset. F: frame the board. 1 / 3 / 7: side, end, top. "
        "5 or O: orthographic. Arrows: turn 15 deg. + / -: zoom. PageUp / PageDown: section "
        "10 mm (Shift: 100 mm). [ / ]: longitudinal angle 5 deg. S, K, C: surface, knots, cut. "
        "F12 or P: screenshot. Esc or Q: quit.");
  }
  if (!status_line_.empty()) {
    if (status_error_)
      ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.4f, 1.0f), "%s", status_line_.c_str());
    else
      ImGui::TextWrapped("%s", status_line_.c_str());
  }
  if (last_frame_ms_ > 0) ImGui::TextDisabled("last frame %.0f ms", last_frame_ms_);
  ImGui::End();
}

void Viewer::ui_panels(float x, float y, float w, float h) {
  ImGui::SetNextWindowPos(ImVec2(x, y), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(w, h), ImGuiCond_Always);
  ImGui::Begin("Sections and board", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                   ImGuiWindowFlags_NoTitleBar);
  const Stem& st = log_->stem;
  const ImGuiStyle& style = ImGui::GetStyle();
  const float line = ImGui::GetTextLineHeightWithSpacing();
  const float inner_h = std::max(32.0f, h - 2.0f * style.WindowPadding.y);
  const double len = st.length_mm();

  // Cross-section: square, the board and the longitudinal section's trace drawn over it.
  const float side = std::max(32.0f, std::min(inner_h - line, 0.45f * w));
  section_px_ = std::max(1, static_cast<int>(side * scale_));
  ImGui::BeginGroup();
  ImGui::Text("Section z = %.0f mm", state_.section_z);
  const ImVec2 s0 = ImGui::GetCursorScreenPos();
  gl_image(section_tex_.texture(), ImVec2(side, side));
  const bool section_hovered = ImGui::IsItemHovered();
  {
    const render::PlaneRect rect = render::cross_section_rect(*renderer_, state_.section_z);
    auto to_px = [&](double px, double py) {
      return ImVec2(s0.x + static_cast<float>((px - rect.origin.x) / rect.width * side),
                    s0.y + static_cast<float>((1.0 - (py - rect.origin.y) / rect.height) * side));
    };
    ImDrawList* dl = ImGui::GetWindowDrawList();
    dl->PushClipRect(s0, ImVec2(s0.x + side, s0.y + side), true);
    const BoardBox& b = state_.board;
    if (sawing_mode_ && sawing_) {
      sawing_->draw_on_section(
          dl, state_.section_z, [&](double px, double py) { return to_px(px, py); },
          rect.width / side, section_hovered);
    } else if (state_.show_board && state_.section_z >= b.z0 && state_.section_z <= b.z1) {
      const Vec3 u = b.u(), v = b.v();
      ImVec2 pts[4];
      const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
      for (int i = 0; i < 4; ++i)
        pts[i] = to_px(b.cx + 0.5 * (su[i] * b.width * u.x + sv[i] * b.thickness * v.x),
                       b.cy + 0.5 * (su[i] * b.width * u.y + sv[i] * b.thickness * v.y));
      dl->AddPolyline(pts, 4, IM_COL32(255, 215, 64, 255), ImDrawFlags_Closed, 1.5f);
    }
    const Vec3 p = renderer_->pith_point(state_.section_z);
    const double a = state_.longitudinal_deg * kDeg, R = rect.width;
    const double ox = p.x - state_.longitudinal_offset * std::sin(a),
                 oy = p.y + state_.longitudinal_offset * std::cos(a);
    dl->AddLine(to_px(ox - R * std::cos(a), oy - R * std::sin(a)),
                to_px(ox + R * std::cos(a), oy + R * std::sin(a)), IM_COL32(90, 200, 255, 200),
                1.0f);
    dl->PopClipRect();
  }
  ImGui::EndGroup();
  ImGui::SameLine();

  // Beside it: the longitudinal section of the whole log and the board's four long faces, z to
  // the right; heights stretched across when the strips would be too thin to read.
  ImGui::BeginGroup();
  const float inner = std::max(32.0f, ImGui::GetContentRegionAvail().x);
  const float strips_h = std::max(40.0f, inner_h - 6.0f * line - 8.0f);
  ImGui::Text("Longitudinal, %.0f deg", state_.longitudinal_deg);
  const render::PlaneRect lrect = render::longitudinal_rect(
      *renderer_, {state_.longitudinal_deg * kDeg, state_.longitudinal_offset});
  const float natural = static_cast<float>(inner * lrect.height / lrect.width);
  const float lh = std::clamp(natural, std::min(36.0f, 0.25f * strips_h), 0.3f * strips_h);
  long_stretch_ = lh / std::max(natural, 1e-3f);
  long_w_ = std::max(1, static_cast<int>(inner * scale_));
  long_h_ = std::max(1, static_cast<int>(lh * scale_));
  if (long_stretch_ > 1.05) {
    ImGui::SameLine();
    ImGui::TextDisabled("(across x%.1f)", long_stretch_);
  }
  const ImVec2 l0 = ImGui::GetCursorScreenPos();
  gl_image(long_tex_.texture(), ImVec2(inner, lh));
  {
    ImDrawList* dl = ImGui::GetWindowDrawList();
    const float xs = l0.x + static_cast<float>((state_.section_z - st.z_begin()) / len * inner);
    dl->AddLine(ImVec2(xs, l0.y), ImVec2(xs, l0.y + lh), IM_COL32(90, 200, 255, 220), 1.0f);
    if (state_.show_board) {
      const BoardBox& b = state_.board;
      const float xa = l0.x + static_cast<float>((b.z0 - st.z_begin()) / len * inner);
      const float xb = l0.x + static_cast<float>((b.z1 - st.z_begin()) / len * inner);
      dl->AddLine(ImVec2(xa, l0.y + lh + 2), ImVec2(xb, l0.y + lh + 2), IM_COL32(255, 215, 64, 255),
                  2.0f);
    }
    ImGui::Dummy(ImVec2(inner, 2));
  }

  const BoardBox& b = state_.board;
  ImGui::Text("Faces top, bottom, left, right; z %.0f-%.0f", b.z0, b.z1);
  const double px_per_mm = inner / std::max(b.z1 - b.z0, 1.0);
  // The space left for the four faces, shared in proportion to their widths in mm.
  const float faces_avail = std::max(24.0f, strips_h - lh - 4.0f * 3.0f);
  const double mm_sum = 2.0 * (b.width + b.thickness);
  const double natural_sum = mm_sum * px_per_mm;
  face_stretch_ = std::max(1.0, std::min(faces_avail / std::max(natural_sum, 1e-6), 8.0));
  const double across = std::min(px_per_mm * face_stretch_, faces_avail / mm_sum);
  if (face_stretch_ > 1.05) {
    ImGui::SameLine();
    ImGui::TextDisabled("(across x%.1f)", across / px_per_mm);
  }
  faces_w_ = std::max(1, static_cast<int>(inner * scale_));
  float face_ui_h[4];
  int total = 0;
  for (int i = 0; i < 4; ++i) {
    const double mm = i < 2 ? b.width : b.thickness;
    face_ui_h[i] = static_cast<float>(std::max(4.0, mm * across));
    face_h_[i] = std::max(1, static_cast<int>(face_ui_h[i] * scale_));
    total += face_h_[i];
  }
  faces_h_ = total;
  int y_gl = total;  // tiles stacked top to bottom: GL rows count from the bottom
  for (int i = 0; i < 4; ++i) {
    y_gl -= face_h_[i];
    face_y_[i] = y_gl;
  }
  if (state_.show_board) {
    ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(style.ItemSpacing.x, 3.0f));
    for (int i = 0; i < 4; ++i)
      gl_image(faces_tex_.texture(), ImVec2(inner, face_ui_h[i]), faces_h_, face_y_[i], face_h_[i]);
    ImGui::PopStyleVar();
  } else {
    ImGui::TextDisabled("(board hidden)");
  }
  ImGui::EndGroup();
  ImGui::End();
}

void Viewer::draw_3d(bool force, bool timing) {
  const render::Camera cam = orbit_.camera();
  const BoardBox& b = state_.board;
  const ViewState& s = state_;
  // The progressive image: while the camera moves (it differs from the last frame's), the view
  // is drawn smaller, at a scale that follows the frame time towards kMovingFrameMs, one sample
  // per pixel, and scaled up into the window; the first frame after it stops is drawn at full
  // size with the wood's 2 x 2 samples where it changes within a pixel (refine_pending() asks the
  // loop for that frame at once).
  const std::string camera_key =
      key_of({orbit_.target.x, orbit_.target.y, orbit_.target.z, orbit_.distance, orbit_.yaw,
              orbit_.pitch, orbit_.orthographic ? 1.0 : 0.0});
  const bool moving = s.progressive && !camera_key_.empty() && camera_key != camera_key_;
  camera_key_ = camera_key;
  if (moving && last_frame_ms_ > 0 && was_moving_) {
    // Frame time grows with the pixels: the side scales by the root of the time ratio, damped.
    const double ratio = std::sqrt(kMovingFrameMs / last_frame_ms_);
    motion_scale_ = std::clamp(motion_scale_ * std::clamp(ratio, 0.8, 1.15), 0.3, 1.0);
  }
  was_moving_ = moving;
  refine_pending_ = moving;
  std::ostringstream k;
  k << key_of({static_cast<double>(view_w_),
               static_cast<double>(view_h_),
               orbit_.target.x,
               orbit_.target.y,
               orbit_.target.z,
               orbit_.distance,
               orbit_.yaw,
               orbit_.pitch,
               orbit_.orthographic ? 1.0 : 0.0,
               moving ? motion_scale_ : 1.0,
               moving ? 1.0 : 0.0,  // one sample while moving, the refined wood once still
               s.show_surface ? 1.0 : 0.0,
               s.cut_at_section ? 1.0 : 0.0,
               s.show_knots ? 1.0 : 0.0,
               s.show_section ? 1.0 : 0.0,
               s.show_longitudinal ? 1.0 : 0.0,
               s.show_board ? 1.0 : 0.0,
               s.show_pith ? 1.0 : 0.0,
               s.section_z,
               s.longitudinal_deg,
               s.longitudinal_offset,
               s.wood_surface ? 1.0 : 0.0})
    << key_of({b.cx, b.cy, b.width, b.thickness, b.rotation, b.z0, b.z1});
  const double drag_scale = moving ? motion_scale_ : 1.0;
  const int w = std::max(1, static_cast<int>(view_w_ * drag_scale));
  const int h = std::max(1, static_cast<int>(view_h_ * drag_scale));
  const double surface_scale = s.surface_half_res ? 0.5 : 1.0;
  const int sw = std::max(1, static_cast<int>(w * surface_scale));
  const int sh = std::max(1, static_cast<int>(h * surface_scale));
  k << key_of({static_cast<double>(w), static_cast<double>(sw)});
  if (!force && k.str() == key_3d_ && opaque_.ready()) return;
  key_3d_ = k.str();
  PartTimer timer(timing, &times_.view3d);

  const std::string board_key = key_of({b.cx, b.cy, b.width, b.thickness, b.rotation, b.z0, b.z1});
  if (board_key != key_board_mesh_) {
    board_box_.upload(board_outline(b, kBoardColor));
    key_board_mesh_ = board_key;
  }
  const bool shared_depth = sw == w && sh == h;
  Status st = opaque_.resize(w, h, GlTarget::Depth::kOwn);
  if (st) {
    st = shared_depth ? overlay_.resize(w, h, GlTarget::Depth::kShared, &opaque_)
                      : overlay_.resize(sw, sh, GlTarget::Depth::kOwn);
  }
  if (!st) {
    status_line_ = st.error().message();
    status_error_ = true;
    return;
  }

  // Opaque layer: sections, the board, the knot tubes.
  render::Scene solid;
  if (s.show_board) solid.boards.push_back(b);
  if (s.show_section) solid.cross_sections.push_back(s.section_z);
  if (s.show_longitudinal)
    solid.longitudinal_sections.push_back({s.longitudinal_deg * kDeg, s.longitudinal_offset});
  const render::Viewport vp = opaque_.viewport();
  opaque_.bind(kBackground, true);
  render::ShadeOptions quality;
  quality.supersample = moving ? 1 : 2;
  renderer_->draw(solid, cam, vp, quality);
  if (s.show_knots) painter_.draw(knots_, cam, vp);
  if (s.show_board) painter_.draw(board_box_, cam, vp);
  if (s.show_pith) painter_.draw(pith_, cam, vp);

  // Translucent layer: the outer surface, depth-tested against the opaque layer, blended over it
  // by the UI's draw list at the chosen opacity.
  overlay_.bind(kTransparent, false);
  if (!shared_depth) overlay_.copy_depth_from(opaque_);
  if (s.show_surface && s.surface_opacity > 0) {
    if (s.wood_surface) {
      render::Scene surface;
      surface.log_surface = true;
      if (s.cut_at_section) surface.surface_z0 = s.section_z;
      renderer_->draw(surface, cam, overlay_.viewport());
    } else {
      painter_.draw(surface_, cam, overlay_.viewport(), s.cut_at_section ? s.section_z : -1e30);
    }
  }
}

void Viewer::draw_cross_section(bool force, bool timing) {
  const std::string k = key_of({static_cast<double>(section_px_), state_.section_z});
  if (!force && k == key_section_ && section_tex_.ready()) return;
  key_section_ = k;
  PartTimer timer(timing, &times_.cross_section);
  if (!section_tex_.resize(section_px_, section_px_, GlTarget::Depth::kNone)) return;
  section_tex_.bind(kPanelBackground, false);
  renderer_->draw_plane(render::cross_section_rect(*renderer_, state_.section_z),
                        section_tex_.viewport());
}

void Viewer::draw_longitudinal(bool force, bool timing) {
  const std::string k = key_of({static_cast<double>(long_w_), static_cast<double>(long_h_),
                                state_.longitudinal_deg, state_.longitudinal_offset});
  if (!force && k == key_long_ && long_tex_.ready()) return;
  key_long_ = k;
  PartTimer timer(timing, &times_.longitudinal);
  if (!long_tex_.resize(long_w_, long_h_, GlTarget::Depth::kNone)) return;
  long_tex_.bind(kPanelBackground, false);
  renderer_->draw_plane(render::longitudinal_rect(*renderer_, {state_.longitudinal_deg * kDeg,
                                                               state_.longitudinal_offset}),
                        long_tex_.viewport());
}

void Viewer::draw_faces(bool force, bool timing) {
  const BoardBox& b = state_.board;
  if (!state_.show_board) return;
  const std::string k = key_of({static_cast<double>(faces_w_), static_cast<double>(faces_h_), b.cx,
                                b.cy, b.width, b.thickness, b.rotation, b.z0, b.z1,
                                static_cast<double>(face_h_[0]), static_cast<double>(face_h_[2])});
  if (!force && k == key_faces_ && faces_tex_.ready()) return;
  key_faces_ = k;
  PartTimer timer(timing, &times_.faces);
  if (!faces_tex_.resize(faces_w_, faces_h_, GlTarget::Depth::kNone)) return;
  faces_tex_.bind(kPanelBackground, false);
  for (int i = 0; i < 4; ++i)
    renderer_->draw_plane(board_face(b, kLongFaceOrder[i]), {0, face_y_[i], faces_w_, face_h_[i]});
}

}  // namespace sawyer::view
