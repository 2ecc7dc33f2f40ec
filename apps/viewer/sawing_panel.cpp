#include "sawing_panel.h"

#include <imgui_stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "sawyer/sawing/sawing_job.h"

namespace sawyer::view {
namespace {

namespace fs = std::filesystem;
using namespace sawyer::sawing;

const char* const kPatterns[] = {"2ex", "4ex", "tt (through-and-through)", "pattern file"};
const char* const kPatternKeys[] = {"2ex", "4ex", "tt", ""};
const char* const kGradings[] = {"nordic", "gost"};

ImU32 colour(const std::array<unsigned char, 3>& c, int alpha = 255) {
  return IM_COL32(c[0], c[1], c[2], alpha);
}

// -180..180 degrees.
double wrap_deg(double d) {
  d = std::fmod(d + 180.0, 360.0);
  if (d < 0) d += 360.0;
  return d - 180.0;
}

}  // namespace

SawingPanel::SawingPanel(const LogModel& log, const fs::path& log_path)
    : log_(log), log_path_(log_path) {
  save_path_ = (log_path.parent_path() / "sawing_position.json").string();
}

SawingPanel::~SawingPanel() {
  if (worker_.joinable()) worker_.join();
}

Status SawingPanel::start(const SawingChoice& choice, const LogPosition& pos) {
  if (running_) return Error("sawing", "the optimiser is running");
  if (worker_.joinable()) worker_.join();
  Result<std::unique_ptr<SawingSession>> s = SawingSession::create(log_, choice);
  if (!s) {
    message_ = s.error().message();
    message_error_ = true;
    return s.error();
  }
  session_ = std::move(s).value();
  choice_ = choice;
  pattern_item_ = 3;
  for (int i = 0; i < 3; ++i)
    if (choice.pattern == kPatternKeys[i]) pattern_item_ = i;
  if (pattern_item_ == 3) pattern_file_ = choice.pattern;
  grading_item_ = choice.grading == "gost" ? 1 : 0;
  prices_file_ = choice.prices;
  surface_.reset();
  selected_ = 0;
  set_position(pos);
  message_ = "loaded " + session_->pattern().name + ", " + session_->rules().name;
  message_error_ = false;
  return Status::Ok();
}

void SawingPanel::set_position(const LogPosition& pos) {
  LogPosition p = pos;
  p.rotation_deg = wrap_deg(p.rotation_deg);
  session_->set_position(p);
  if (selected_ >= static_cast<int>(session_->sawn().boards.size())) selected_ = 0;
  changed_ = true;
}

std::optional<BoardBox> SawingPanel::selected_board() const {
  if (!session_ || session_->sawn().boards.empty()) return std::nullopt;
  return session_->board_in_scanner(static_cast<size_t>(selected_));
}

void SawingPanel::optimise(bool wait) {
  if (!session_ || running_) return;
  if (worker_.joinable()) worker_.join();
  OptimiseOptions o;
  o.offset_x_max_mm = std::round(offsets_max_ / 2.0) * 2.0;
  o.offset_x_step_mm = 2.0;
  o.threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) - 1);
  done_ = 0;
  total_ = 1;
  running_ = true;
  surface_.reset();
  const SawingSession* s = session_.get();
  worker_ = std::thread([this, s, o]() {
    Result<OptimiseResult> r = optimise_position(s->saw_log(), s->pattern(), s->rules(),
                                                 s->prices(), o, [this](int done, int total) {
                                                   done_ = done;
                                                   total_ = total;
                                                 });
    {
      std::lock_guard<std::mutex> lock(result_mutex_);
      pending_ = std::move(r);
    }
    running_ = false;
  });
  if (wait) {
    worker_.join();
    poll_optimiser();
  }
}

void SawingPanel::poll_optimiser() {
  std::optional<Result<OptimiseResult>> r;
  {
    std::lock_guard<std::mutex> lock(result_mutex_);
    r = std::exchange(pending_, std::nullopt);
  }
  if (!r) return;
  if (worker_.joinable() && !running_) worker_.join();
  if (!r->ok()) {
    message_ = r->error().message();
    message_error_ = true;
    return;
  }
  surface_ = std::move(*r).value();
  char line[160];
  std::snprintf(line, sizeof line,
                "optimised %d positions in %.1f s; best %+.1f %% over horns-down",
                surface_->positions, surface_->seconds, 100.0 * surface_->gain_over_horns_down);
  message_ = line;
  message_error_ = false;
}

void SawingPanel::ui() {
  poll_optimiser();
  const bool busy = running_;

  // What to saw with.
  ImGui::SetNextItemWidth(150);
  ImGui::Combo("pattern", &pattern_item_, kPatterns, 4);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90);
  ImGui::Combo("grading", &grading_item_, kGradings, 2);
  if (pattern_item_ == 3) {
    ImGui::SetNextItemWidth(-90);
    ImGui::InputTextWithHint("##patfile", "sawyer-pattern/1 file", &pattern_file_);
  }
  ImGui::SetNextItemWidth(-90);
  ImGui::InputTextWithHint("##prices", "prices: default (example_prices.json)", &prices_file_);
  ImGui::SameLine();
  ImGui::BeginDisabled(busy);
  if (ImGui::Button("Load")) {
    SawingChoice c;
    c.pattern = pattern_item_ == 3 ? pattern_file_ : kPatternKeys[pattern_item_];
    c.grading = kGradings[grading_item_];
    c.prices = prices_file_;
    (void)start(c, session_ ? session_->position() : LogPosition{});
  }
  ImGui::EndDisabled();
  if (!session_) {
    if (!message_.empty())
      ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.4f, 1.0f), "%s", message_.c_str());
    return;
  }

  // The position.
  LogPosition p = session_->position();
  float rot = static_cast<float>(p.rotation_deg), x = static_cast<float>(p.offset_x_mm),
        y = static_cast<float>(p.offset_y_mm);
  bool moved = false;
  ImGui::SetNextItemWidth(-1);
  moved |= ImGui::SliderFloat("##rot", &rot, -180.0f, 180.0f, "rotation %.1f deg (0: horns down)");
  ImGui::SetNextItemWidth(-1);
  moved |= ImGui::SliderFloat("##ox", &x, -40.0f, 40.0f, "offset x %.1f mm");
  ImGui::SetNextItemWidth(-1);
  moved |= ImGui::SliderFloat("##oy", &y, -40.0f, 40.0f, "offset y %.1f mm");
  if (ImGui::Button("Horns down")) {
    rot = x = y = 0;
    moved = true;
  }
  ImGui::SameLine();
  if (ImGui::Button("-5 deg")) {
    rot -= 5;
    moved = true;
  }
  ImGui::SameLine();
  if (ImGui::Button("+5 deg")) {
    rot += 5;
    moved = true;
  }
  ImGui::SameLine();
  ImGui::TextDisabled("drag on the section: offset");
  if (moved) set_position({rot, x, y});

  // The boards at this position.
  const SawResult& sawn = session_->sawn();
  const LogValue& v = session_->value();
  const GradingRules& rules = session_->rules();
  const std::string& cur = session_->prices().currency;
  ImGui::Text("value %.2f %s, horns-down %.2f, gain %+.1f %%", v.value, cur.c_str(),
              session_->horns_down_value(), 100.0 * session_->gain_over_horns_down());
  // What the log turner and the set-works execute, and how horns-down was found.
  ImGui::TextWrapped("saw set-up: %s",
                     sawing::saw_setup_line(session_->saw_log(), session_->position()).c_str());
  ImGui::TextDisabled("%s", sawing::bow_line(session_->saw_log().bow()).c_str());
  const ImGuiTableFlags tf = ImGuiTableFlags_RowBg | ImGuiTableFlags_BordersInnerV |
                             ImGuiTableFlags_SizingFixedFit | ImGuiTableFlags_ScrollY;
  const float rows_h =
      ImGui::GetTextLineHeightWithSpacing() * (std::min<size_t>(sawn.boards.size(), 8) + 1.5f);
  if (ImGui::BeginTable("boards", 6, tf, ImVec2(0, rows_h))) {
    ImGui::TableSetupScrollFreeze(0, 1);
    ImGui::TableSetupColumn("board");
    ImGui::TableSetupColumn("mm");
    ImGui::TableSetupColumn("m");
    ImGui::TableSetupColumn("grade");
    ImGui::TableSetupColumn(cur.c_str());
    ImGui::TableSetupColumn("limited by", ImGuiTableColumnFlags_WidthStretch);
    ImGui::TableHeadersRow();
    for (size_t i = 0; i < sawn.boards.size(); ++i) {
      const Board& b = sawn.boards[i];
      const BoardValue& bv = v.boards[i];
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      char label[64];
      std::snprintf(label, sizeof label, "%s##b%zu", b.name.c_str(), i);
      if (ImGui::Selectable(label, selected_ == static_cast<int>(i),
                            ImGuiSelectableFlags_SpanAllColumns)) {
        selected_ = static_cast<int>(i);
        changed_ = true;
      }
      ImGui::TableNextColumn();
      ImGui::Text("%.0fx%.0f", b.thickness_mm, b.width_mm);
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", b.length_mm() * 1e-3);
      ImGui::TableNextColumn();
      const auto c = grade_colour(bv.grade.grade, rules.reject());
      ImGui::TextColored(ImVec4(c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f, 1.0f), "%s",
                         rules.grade_name(bv.grade.grade).c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%.2f", bv.value);
      ImGui::TableNextColumn();
      const std::string why = describe(bv.grade.limit, rules);
      ImGui::TextUnformatted(why.c_str());
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", why.c_str());
    }
    ImGui::EndTable();
  }
  for (const DroppedBoard& d : sawn.dropped)
    ImGui::TextDisabled("dropped %s: %s",
                        session_->pattern().boards[static_cast<size_t>(d.spec)].name.c_str(),
                        d.reason.c_str());

  // The optimiser.
  ImGui::BeginDisabled(busy);
  if (ImGui::Button("Optimise")) optimise(false);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(-1);
  ImGui::SliderFloat("##omax", &offsets_max_, 0.0f, 30.0f, "offsets x +-%.0f mm");
  ImGui::EndDisabled();
  if (busy) {
    const int t = std::max(1, total_.load());
    char over[48];
    std::snprintf(over, sizeof over, "%d / %d positions", done_.load(), t);
    ImGui::ProgressBar(static_cast<float>(done_.load()) / t, ImVec2(-1, 0), over);
  }
  if (surface_) heat_map();

  // Save.
  ImGui::SetNextItemWidth(-60);
  ImGui::InputText("##save", &save_path_);
  ImGui::SameLine();
  if (ImGui::Button("Save")) {
    Status s = session_->save(save_path_, log_.id);
    message_error_ = !s;
    message_ = s ? "saved " + save_path_ : s.error().message();
  }
  if (!message_.empty()) {
    if (message_error_)
      ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.4f, 1.0f), "%s", message_.c_str());
    else
      ImGui::TextWrapped("%s", message_.c_str());
  }
}

// The smoothed value surface at y offset 0 (the grid has no y offsets): rotation across,
// offset x down; the best position ringed, the current one crossed. Click: go there.
void SawingPanel::heat_map() {
  const OptimiseResult& r = *surface_;
  const size_t nr = r.rotations_deg.size(), nx = r.offsets_x_mm.size(), ny = r.offsets_y_mm.size();
  if (nr == 0 || nx == 0 || ny == 0) return;
  const size_t iy = ny / 2;
  double lo = 1e300, hi = -1e300;
  for (size_t ir = 0; ir < nr; ++ir)
    for (size_t ix = 0; ix < nx; ++ix) {
      const double s = r.smoothed[r.index(ir, ix, iy)];
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
  ImGui::Text("expected value: rotation %.0f..%.0f deg across, offset x down",
              r.rotations_deg.front(), r.rotations_deg.back());
  const float w = std::max(60.0f, ImGui::GetContentRegionAvail().x);
  // Fits the window above the lines below it where it can (a scroll bar otherwise).
  const float below = 3.0f * ImGui::GetFrameHeightWithSpacing();
  const float h =
      std::clamp(std::min(w * 0.3f, ImGui::GetContentRegionAvail().y - below), 40.0f, 140.0f);
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  ImGui::InvisibleButton("##heat", ImVec2(w, h));
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const float cw = w / nr, ch = h / nx;
  for (size_t ir = 0; ir < nr; ++ir)
    for (size_t ix = 0; ix < nx; ++ix) {
      const double s = r.smoothed[r.index(ir, ix, iy)];
      const double t = hi > lo ? (s - lo) / (hi - lo) : 0.5;
      dl->AddRectFilled(ImVec2(p0.x + ir * cw, p0.y + ix * ch),
                        ImVec2(p0.x + (ir + 1) * cw + 0.5f, p0.y + (ix + 1) * ch + 0.5f),
                        colour(heat_colour(t)));
    }
  auto cell_centre = [&](const LogPosition& p) {
    const double r0 = r.rotations_deg.front(), r1 = r.rotations_deg.back();
    const double x0 = r.offsets_x_mm.front(), x1 = r.offsets_x_mm.back();
    // Into the grid's range; with a 180° range each half turn mirrors the offset (optimise.h).
    double rot = p.rotation_deg, ox = p.offset_x_mm;
    const double half_step = 0.5 * (r1 - r0) / std::max<size_t>(nr - 1, 1);
    const bool mirror = r.rot_range_deg < 359.0;
    while (rot < r0 - half_step) {
      rot += r.rot_range_deg;
      if (mirror) ox = -ox;
    }
    while (rot >= r0 + r.rot_range_deg - half_step) {
      rot -= r.rot_range_deg;
      if (mirror) ox = -ox;
    }
    const float fx = nr > 1 ? static_cast<float>((rot - r0) / (r1 - r0)) : 0.0f;
    const float fy = nx > 1 ? static_cast<float>((ox - x0) / (x1 - x0)) : 0.0f;
    return ImVec2(p0.x + (fx * (nr - 1) + 0.5f) * cw, p0.y + (fy * (nx - 1) + 0.5f) * ch);
  };
  const ImVec2 b = cell_centre(r.best.pos);
  dl->AddCircle(b, std::max(5.0f, 0.8f * std::max(cw, ch)), IM_COL32(255, 255, 255, 255), 0, 2.0f);
  const ImVec2 c = cell_centre(session_->position());
  dl->AddLine(ImVec2(c.x - 4, c.y - 4), ImVec2(c.x + 4, c.y + 4), IM_COL32(80, 220, 255, 255),
              1.5f);
  dl->AddLine(ImVec2(c.x - 4, c.y + 4), ImVec2(c.x + 4, c.y - 4), IM_COL32(80, 220, 255, 255),
              1.5f);
  if (ImGui::IsItemHovered() || ImGui::IsItemActive()) {
    const ImVec2 m = ImGui::GetIO().MousePos;
    const size_t ir = std::min(nr - 1, static_cast<size_t>(std::max(0.0f, (m.x - p0.x) / cw)));
    const size_t ix = std::min(nx - 1, static_cast<size_t>(std::max(0.0f, (m.y - p0.y) / ch)));
    const size_t at = r.index(ir, ix, iy);
    ImGui::SetTooltip("rot %.0f deg, x %+.0f mm: %.2f (expected %.2f)", r.rotations_deg[ir],
                      r.offsets_x_mm[ix], r.value[at], r.smoothed[at]);
    if (ImGui::IsItemActive())
      set_position({r.rotations_deg[ir], r.offsets_x_mm[ix], r.offsets_y_mm[iy]});
  }
  if (ImGui::Button("Go to the best")) set_position(r.best.pos);
  ImGui::SameLine();
  ImGui::Text("best rot %.0f, x %+.0f: %.2f expected, %+.1f %%", r.best.pos.rotation_deg,
              r.best.pos.offset_x_mm, r.best.smoothed, 100.0 * r.gain_over_horns_down);
}

void SawingPanel::draw_on_section(ImDrawList* dl, double z,
                                  const std::function<ImVec2(double, double)>& to_px,
                                  double mm_per_px, bool image_hovered) {
  if (!session_) return;
  // Drag on the section: the pattern follows the mouse.
  if (image_hovered && ImGui::IsMouseClicked(0)) dragging_ = true;
  if (dragging_ && !ImGui::IsMouseDown(0)) dragging_ = false;
  const ImVec2 d = ImGui::GetIO().MouseDelta;
  if (dragging_ && (d.x != 0 || d.y != 0)) {
    const Vec2 dp = session_->scanner_to_pattern_delta(d.x * mm_per_px, -d.y * mm_per_px);
    LogPosition p = session_->position();
    p.offset_x_mm = std::clamp(p.offset_x_mm + dp.x, -40.0, 40.0);
    p.offset_y_mm = std::clamp(p.offset_y_mm + dp.y, -40.0, 40.0);
    set_position(p);
  }
  auto poly = [&](const std::array<Vec2, 4>& c, ImU32 col, float thick, bool fill) {
    ImVec2 pts[4];
    for (int i = 0; i < 4; ++i)
      pts[i] = to_px(c[static_cast<size_t>(i)].x, c[static_cast<size_t>(i)].y);
    if (fill) dl->AddConvexPolyFilled(pts, 4, (col & ~IM_COL32_A_MASK) | (60u << IM_COL32_A_SHIFT));
    dl->AddPolyline(pts, 4, col, ImDrawFlags_Closed, thick);
  };
  const Pattern& pat = session_->pattern();
  // Every board of the pattern, nominal size, faint; the sawn ones over them by grade.
  for (const BoardSpec& b : pat.boards) {
    const bool along_u = b.thickness_axis == ThicknessAxis::kU;
    poly(session_->rect_in_scanner(b.u_mm, b.v_mm, along_u ? b.thickness_mm : b.width_mm,
                                   along_u ? b.width_mm : b.thickness_mm, z),
         IM_COL32(200, 200, 200, 110), 1.0f, false);
  }
  const SawResult& sawn = session_->sawn();
  for (size_t i = 0; i < sawn.boards.size(); ++i) {
    const Board& b = sawn.boards[i];
    const bool along_u = b.thickness_axis == ThicknessAxis::kU;
    const int g = session_->value().boards[i].grade.grade;
    const bool here = z >= b.z_begin && z <= b.z_end;
    const ImU32 col = colour(grade_colour(g, session_->rules().reject()), here ? 255 : 140);
    poly(session_->rect_in_scanner(b.u_mm, b.v_mm, along_u ? b.thickness_mm : b.width_mm,
                                   along_u ? b.width_mm : b.thickness_mm, z),
         col, static_cast<int>(i) == selected_ ? 3.0f : 2.0f, true);
  }
}

}  // namespace sawyer::view
