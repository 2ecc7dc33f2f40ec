#include "sawyer/sawing/pattern.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "fit_text.h"

namespace sawyer::sawing {

namespace {

struct Rect {
  double u0, u1, v0, v1;
};

Rect rect_of(const BoardSpec& b) {
  const double hu = 0.5 * (b.thickness_axis == ThicknessAxis::kU ? b.thickness_mm : b.width_mm);
  const double hv = 0.5 * (b.thickness_axis == ThicknessAxis::kU ? b.width_mm : b.thickness_mm);
  return {b.u_mm - hu, b.u_mm + hu, b.v_mm - hv, b.v_mm + hv};
}

}  // namespace

std::string fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string usable_diameter_text(double usable_diameter_mm) {
  return "the log's usable diameter is " + fmt("%.1f", usable_diameter_mm) +
         " mm (inscribed in the top end, under bark)";
}

Status Pattern::validate() const {
  const std::string where = name.empty() ? "pattern" : "pattern '" + name + "'";
  if (!(kerf_mm >= 0)) return Error(where, "kerf_mm must be ≥ 0");
  if (boards.empty()) return Error(where, "has no boards");
  if (boards.size() > static_cast<size_t>(kMaxPatternBoards))
    return Error(where, "has " + std::to_string(boards.size()) + " boards, more than the " +
                            std::to_string(kMaxPatternBoards) +
                            " allowed (a real pattern has a few dozen)");
  if (standard_widths_mm.size() > static_cast<size_t>(kMaxStandardWidths))
    return Error(where, "has " + std::to_string(standard_widths_mm.size()) +
                            " standard widths, more than the " +
                            std::to_string(kMaxStandardWidths) + " allowed");
  if (!(wane.max_face_fraction >= 0 && wane.max_face_fraction <= 1) ||
      !(wane.max_edge_fraction >= 0 && wane.max_edge_fraction <= 1))
    return Error(where, "wane fractions must lie in [0, 1]");
  if (!(wane.min_length_mm >= 0) || !(wane.length_step_mm >= 0))
    return Error(where, "min_length_mm and length_step_mm must be ≥ 0");
  for (double w : standard_widths_mm)
    if (!(w > 0 && w <= kMaxBoardSizeMm))
      return Error(where, "standard widths must be > 0 and at most " +
                              std::to_string(static_cast<int>(kMaxBoardSizeMm)) + " mm");
  for (size_t i = 0; i < boards.size(); ++i) {
    const BoardSpec& b = boards[i];
    const std::string bw =
        where + ", board " + std::to_string(i) + (b.name.empty() ? "" : " '" + b.name + "'");
    if (!(b.thickness_mm > 0) || !(b.width_mm > 0) || !(b.thickness_mm <= kMaxBoardSizeMm) ||
        !(b.width_mm <= kMaxBoardSizeMm))
      return Error(bw, "thickness and width must be > 0 and at most " +
                           std::to_string(static_cast<int>(kMaxBoardSizeMm)) + " mm");
    if (!std::isfinite(b.u_mm) || !std::isfinite(b.v_mm))
      return Error(bw, "position is not finite");
    const Rect r = rect_of(b);
    for (size_t j = 0; j < i; ++j) {
      const Rect s = rect_of(boards[j]);
      const double eps = 1e-6;
      if (r.u0 < s.u1 - eps && s.u0 < r.u1 - eps && r.v0 < s.v1 - eps && s.v0 < r.v1 - eps)
        return Error(bw, "overlaps board " + std::to_string(j));
    }
  }
  return Status::Ok();
}

double Pattern::required_diameter_mm() const {
  double r2 = 0;
  for (const BoardSpec& b : boards) {
    if (b.edged) continue;
    const Rect r = rect_of(b);
    for (double u : {r.u0, r.u1})
      for (double v : {r.v0, r.v1}) r2 = std::max(r2, u * u + v * v);
  }
  return 2.0 * std::sqrt(r2);
}

Pattern cant_pattern(const CantOptions& o) {
  Pattern p;
  p.kerf_mm = o.kerf_mm;
  char name[96];
  std::snprintf(name, sizeof name, "%dex %gx%g", o.centre_boards, o.centre_thickness_mm,
                o.centre_width_mm);
  p.name = name;
  if (o.side_boards_per_side > 0) {
    std::snprintf(name, sizeof name, " + %d×%gx%g sides", 2 * o.side_boards_per_side,
                  o.side_thickness_mm, o.side_width_mm);
    p.name += name;
  }
  const int n = o.centre_boards;
  const double t = o.centre_thickness_mm, k = o.kerf_mm;
  // Centre boards side by side, symmetric about u = 0: centres at (i − (n−1)/2)·(t + k).
  for (int i = 0; i < n; ++i) {
    BoardSpec b;
    b.name = "centre " + std::to_string(i + 1);
    b.u_mm = (i - 0.5 * (n - 1)) * (t + k);
    b.thickness_mm = t;
    b.width_mm = o.centre_width_mm;
    p.boards.push_back(b);
  }
  const double outer = 0.5 * n * t + 0.5 * (n - 1) * k;  // |u| of the centre boards' outer faces
  int side = 0;
  for (int s = 0; s < o.side_boards_per_side; ++s) {
    const double u = outer + k + s * (o.side_thickness_mm + k) + 0.5 * o.side_thickness_mm;
    for (double sign : {-1.0, 1.0}) {
      BoardSpec b;
      b.name = "side " + std::to_string(++side);
      b.u_mm = sign * u;
      b.thickness_mm = o.side_thickness_mm;
      b.width_mm = o.side_width_mm;
      b.edged = true;
      p.boards.push_back(b);
    }
  }
  return p;
}

Pattern two_ex_pattern(CantOptions o) {
  o.centre_boards = 2;
  return cant_pattern(o);
}

Pattern four_ex_pattern(CantOptions o) {
  o.centre_boards = 4;
  return cant_pattern(o);
}

CantOptions four_ex_options() {
  CantOptions c;
  c.centre_boards = 4;
  c.centre_thickness_mm = 38;
  c.centre_width_mm = 100;
  return c;
}

Pattern through_and_through_pattern(int boards, double thickness_mm, double max_width_mm,
                                    double kerf_mm) {
  Pattern p;
  char name[64];
  std::snprintf(name, sizeof name, "through-and-through %d×%g", boards, thickness_mm);
  p.name = name;
  p.kerf_mm = kerf_mm;
  for (int i = 0; i < boards; ++i) {
    BoardSpec b;
    b.name = "board " + std::to_string(i + 1);
    b.u_mm = (i - 0.5 * (boards - 1)) * (thickness_mm + kerf_mm);
    b.thickness_mm = thickness_mm;
    b.width_mm = max_width_mm;
    b.edged = true;
    p.boards.push_back(b);
  }
  return p;
}

Status check_pattern_fits(const Pattern& p, double usable_diameter_mm, const std::string& log_id) {
  const double need = p.required_diameter_mm();
  if (need <= usable_diameter_mm) return Status::Ok();
  return Error("log '" + log_id + "'",
               "pattern '" + p.name + "' does not fit: it needs a diameter of " +
                   fmt("%.1f", need) + " mm, " + usable_diameter_text(usable_diameter_mm));
}

}  // namespace sawyer::sawing
