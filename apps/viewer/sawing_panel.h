// The viewer's sawing mode (Dear ImGui): pattern, grading and prices chosen as in `sawyer saw`;
// rotation and offsets by sliders or by dragging on the cross-section; the pattern's boards drawn
// on the cross-section coloured by grade; the boards listed with grade, limiting feature and
// value, updated on every change; the optimiser run in a background thread with its smoothed
// value surface shown as a heat map (click: jump there); the position saved as JSON.
//
// Not thread safe (ImGui); the optimiser's thread only reads the session, which is not replaced
// while it runs.
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <imgui.h>

#include "sawyer/sawing/optimise.h"
#include "sawyer/sawing/sawing_session.h"

namespace sawyer::view {

using sawing::SawingChoice;
using sawing::SawingSession;

class SawingPanel {
 public:
  // `log` must outlive the panel; `log_path` names the default file for Save.
  SawingPanel(const LogModel& log, const std::filesystem::path& log_path);
  ~SawingPanel();  // waits for the optimiser

  // Loads `choice` and saws at `pos`; on failure keeps what was loaded and returns the error.
  Status start(const SawingChoice& choice, const sawing::LogPosition& pos);
  bool ready() const { return session_ != nullptr; }
  // Starts the optimiser in the background; `wait`: returns when it has finished.
  void optimise(bool wait);

  // The controls, table and heat map in the current ImGui window.
  void ui();
  // Over the cross-section at height z: the boards of the pattern at the current position.
  // `to_px` maps scanner (x, y) mm to screen; `mm_per_px` for dragging (item = the image, hovered).
  void draw_on_section(ImDrawList* dl, double z, const std::function<ImVec2(double, double)>& to_px,
                       double mm_per_px, bool image_hovered);
  // The board picked in the table, in the scanner frame (for the faces panel), if any.
  std::optional<BoardBox> selected_board() const;
  // Changes since the last call (the faces panel follows the selection).
  bool take_changed() { return std::exchange(changed_, false); }

 private:
  void set_position(const sawing::LogPosition& pos);
  void poll_optimiser();
  void heat_map();

  const LogModel& log_;
  std::filesystem::path log_path_;
  std::unique_ptr<SawingSession> session_;
  SawingChoice choice_;
  int pattern_item_ = 0, grading_item_ = 0;
  std::string pattern_file_, prices_file_, save_path_, message_;
  bool message_error_ = false;
  int selected_ = 0;
  bool changed_ = true, dragging_ = false;

  // The optimiser.
  std::thread worker_;
  std::atomic<int> done_{0}, total_{0};
  std::atomic<bool> running_{false};
  std::mutex result_mutex_;
  std::optional<Result<sawing::OptimiseResult>> pending_;
  std::optional<sawing::OptimiseResult> surface_;
  float offsets_max_ = 10.0f;
};

}  // namespace sawyer::view
