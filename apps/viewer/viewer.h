// The interactive viewer's state, UI and drawing (Dear ImGui on top of sawyer::render): the log's
// outer surface semi-transparent with the knots inside, a cross-section and a longitudinal
// section, a board with its four long faces. main.cpp owns the window, the ImGui back-ends and
// the loop; each frame it calls frame() between ImGui::NewFrame() and ImGui::Render().
//
//   auto v = Viewer::create(std::move(log), path);         // the window's context current
//   while (...) {
//     new ImGui frame;  v.value()->frame(request);  ImGui::Render();
//     clear the window;  v.value()->draw_background();  draw ImGui's data;  swap;
//   }
//
// Not thread safe (OpenGL, ImGui). Errors from opening files and writing screenshots are
// shown in the UI and returned; nothing here exits.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"
#include "sawyer/render/gl_layers.h"
#include "sawyer/render/mesh.h"
#include "sawyer/render/orbit_camera.h"
#include "sawyer/render/scene.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/sawing/sawing_session.h"

namespace sawyer::view {

// The pieces the viewer is built from (libs/render, libs/sawing), by their short names.
using render::GlTarget;
using render::GpuMesh;
using render::Mesh;
using render::MeshPainter;
using render::OrbitCamera;
using render::Rgb;
using sawing::SawingChoice;
using sawing::SawingSession;

// What is shown; the UI and the keys change it, main.cpp may preset it from the command line.
struct ViewState {
  bool show_surface = true;
  float surface_opacity = 0.28f;  // 0 = invisible, 1 = opaque
  bool cut_at_section = false;    // draw the surface only above the cross-section
  bool show_knots = true;
  bool show_section = true;        // the cross-section in the 3D view
  bool show_longitudinal = false;  // the longitudinal section in the 3D view
  bool show_board = true;
  bool show_pith = false;
  // Speed: the translucent surface at half resolution (it is smooth and faint), and the 3D view
  // progressive: smaller while the camera moves (sized to keep about 30 frames a second), at full
  // size with anti-aliased wood once it stops.
  bool surface_half_res = true;
  bool progressive = true;
  // The surface shaded by the knotted-wood renderer (the rings and the knots where they reach
  // the surface) or a plain light mesh (much cheaper on a software renderer, where
  // Viewer::create makes it the default).
  bool wood_surface = true;
  double section_z = 0;            // mm
  double longitudinal_deg = 0;     // azimuth of the longitudinal section, degrees
  double longitudinal_offset = 0;  // mm along its normal
  BoardBox board;
};

// Milliseconds spent in each part of the last frame (with finish_rendering() between parts when
// timing is on; 0 for a part that was not redrawn).
struct FrameTimes {
  double view3d = 0, cross_section = 0, longitudinal = 0, faces = 0, ui_build = 0;
};

// A key press (or auto-repeat) since the last frame, GLFW key codes. The window's callback
// queues them, so presses quicker than a frame are not lost.
struct KeyPress {
  int key = 0;
  bool shift = false, ctrl = false;
};

struct FrameRequest {
  int fb_width = 0, fb_height = 0;  // the window's framebuffer, pixels
  std::vector<KeyPress> keys;
  double last_frame_ms = 0;  // shown in the UI
  // Redraw every view even when nothing changed (the benchmark's typical frame).
  bool force_redraw = false;
  // Wait for the GPU after each part, so that FrameTimes measure it.
  bool timing = false;
};

class SawingPanel;

class Viewer {
 public:
  // Takes the log, uploads it and compiles the shaders (the window's context current). Errors
  // name the file or the shader.
  static Result<std::unique_ptr<Viewer>> create(std::unique_ptr<LogModel> log,
                                                const std::filesystem::path& path);
  ~Viewer();

  // Replaces the log (File/Open); on failure keeps the current one and returns the error.
  Status open(const std::filesystem::path& path);

  // Builds this frame's UI, handles the mouse and keys in the 3D view, and renders the views
  // that changed into their textures (shown through the UI's draw lists).
  void frame(const FrameRequest& request);

  // Copies the 3D view's opaque layer into the window's bound default framebuffer: main.cpp
  // calls it after clearing the window and before drawing the UI (cheaper than a textured quad).
  void draw_background() const;

  ViewState& state() { return state_; }
  OrbitCamera& orbit() { return orbit_; }
  const LogModel& log() const { return *log_; }
  const FrameTimes& times() const { return times_; }
  // The sizes of the views drawn in the last frame, "960 x 800" etc., for the benchmark.
  std::string view_sizes() const;

  // A screenshot the UI or F12 asked for: main.cpp reads the window after drawing the UI and
  // calls screenshot_done() with the result.
  std::optional<std::filesystem::path> take_screenshot_request();
  void screenshot_done(const std::filesystem::path& path, const Status& status);
  // Esc / Q in the 3D view, or the Quit button.
  bool quit_requested() const { return quit_; }
  // Puts the camera back to the whole-log view (R, Home, double-click).
  void reset_view();
  // Turns the sawing mode on with `choice` at `pos`; `optimise`: runs the optimiser to the end
  // first (for --screenshot). On failure the mode stays off and the error is returned.
  Status start_sawing(const SawingChoice& choice, const sawing::LogPosition& pos, bool optimise);
  bool sawing_mode() const { return sawing_mode_; }
  // The last 3D view was drawn small while the camera moved: the loop should draw the next
  // frame at once (the full-size image) instead of waiting for input.
  bool refine_pending() const { return refine_pending_; }
  // The 3D view's scale while the camera moves (1 = full size).
  double motion_scale() const { return motion_scale_; }

 private:
  Viewer() = default;
  Status load(std::unique_ptr<LogModel> log, const std::filesystem::path& path);
  void defaults_for_log();
  void handle_input(float x0, float y0, float w, float h, const std::vector<KeyPress>& keys);
  void handle_key(const KeyPress& k);
  void ui_controls(float x, float y, float w, float h);
  void ui_panels(float x, float y, float w, float h);
  void draw_3d(bool force, bool timing);
  void draw_cross_section(bool force, bool timing);
  void draw_longitudinal(bool force, bool timing);
  void draw_faces(bool force, bool timing);
  void step_section(double mm);
  void frame_board();
  // A named view (OrbitCamera::view_side etc.) with the whole log fitted in.
  void view_preset(void (OrbitCamera::*preset)());
  void request_screenshot();
  void ui_sawing(float x, float y, float w, float h);

  std::unique_ptr<LogModel> log_;
  std::unique_ptr<render::WoodRenderer> renderer_;
  std::filesystem::path path_;
  ViewState state_;
  OrbitCamera orbit_;
  MeshPainter painter_;
  GpuMesh knots_, board_box_, pith_, surface_;
  GlTarget opaque_, overlay_, section_tex_, long_tex_, faces_tex_;

  // Layout of this frame, framebuffer pixels.
  int view_w_ = 0, view_h_ = 0, section_px_ = 0, long_w_ = 0, long_h_ = 0, faces_w_ = 0,
      faces_h_ = 0;
  std::array<int, 4> face_y_{}, face_h_{};  // tiles in faces_tex_, GL rows from the bottom
  double face_stretch_ = 1;
  double long_stretch_ = 1;
  float scale_ = 1;             // framebuffer pixels per UI unit
  render::Viewport view_rect_;  // the 3D view in the window, GL pixels from the bottom left

  // What each texture shows now (redrawn when it changes).
  std::string key_3d_, key_section_, key_long_, key_faces_, key_board_mesh_;
  // The progressive 3D view (draw_3d): the camera of the last frame, whether that frame moved,
  // the scale while moving, and the frame time it aims at.
  static constexpr double kMovingFrameMs = 30.0;
  std::string camera_key_;
  bool was_moving_ = false, refine_pending_ = false;
  double motion_scale_ = 0.6;
  FrameTimes times_;

  bool dragging_ = false, panning_ = false, quit_ = false;
  bool reset_pending_ = true;  // frame the log once the 3D view's size is known
  std::string open_text_, screenshot_text_, status_line_;
  std::string run_choice_line_;  // the run's pattern choice (sawing::run_pattern_choice_line)
  bool status_error_ = false;
  std::optional<std::filesystem::path> screenshot_request_, open_request_;
  float aspect_3d_ = 1.5f;
  double last_frame_ms_ = 0;
  // The sawing mode (sawing_panel.h); the panel refers to log_ and goes before it.
  std::unique_ptr<SawingPanel> sawing_;
  bool sawing_mode_ = false;
};

}  // namespace sawyer::view
