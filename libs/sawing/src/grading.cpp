// Board grading from rule tables, and the "sawyer-grading/1" reader.
#include "sawyer/sawing/grading.h"
#include "json_text.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <set>

#include "sawyer/core/file_util.h"

namespace sawyer::sawing {

namespace {

using Json = nlohmann::ordered_json;
constexpr const char* kGradingFormatTag = "sawyer-grading/1";

bool is_face(Side s) { return s == Side::kFacePlus || s == Side::kFaceMinus; }

// What one side holds, for the checks.
struct SideStats {
  int largest_sound = -1, largest_dead = -1;  // index into Board::knots
  double sound_mm = 0, dead_mm = 0;
  int count = 0, dead_count = 0;
};

bool limit_ok(double v) { return !std::isnan(v) && v >= 0; }

Status check_side(const SideRules& s, const std::string& at) {
  for (auto [key, v] : {std::pair{"sound_knot.mm", s.sound_knot.mm},
                        {"sound_knot.per_width", s.sound_knot.per_width},
                        {"dead_knot.mm", s.dead_knot.mm},
                        {"dead_knot.per_width", s.dead_knot.per_width},
                        {"knots_per_m", s.knots_per_m},
                        {"dead_knots_per_m", s.dead_knots_per_m},
                        {"knots_per_board", s.knots_per_board},
                        {"wane_fraction", s.wane_fraction}})
    if (!limit_ok(v)) return Error(at + "." + key, "must be a number ≥ 0");
  return Status::Ok();
}

Status read_number(const Json& obj, const std::string& at, const char* key, double* dst) {
  auto it = obj.find(key);
  if (it == obj.end()) return Status::Ok();
  const std::string here = at.empty() ? std::string(key) : at + "." + key;
  if (!it->is_number()) return Error(here, "expected a number");
  const double v = it->get<double>();
  if (!std::isfinite(v) || v < 0) return Error(here, "expected a finite number ≥ 0");
  *dst = v;
  return Status::Ok();
}

Status read_size(const Json& obj, const std::string& at, const char* key, SizeLimit* dst) {
  auto it = obj.find(key);
  if (it == obj.end()) return Status::Ok();
  const std::string here = at + "." + key;
  if (!it->is_object()) return Error(here, "expected an object {\"mm\", \"per_width\"}");
  for (auto& [k, v] : it->items())
    if (k != "mm" && k != "per_width") return Error(here + "." + k, "unknown key");
  dst->mm = 0;
  if (Status s = read_number(*it, here, "mm", &dst->mm); !s) return s;
  if (Status s = read_number(*it, here, "per_width", &dst->per_width); !s) return s;
  return Status::Ok();
}

Status read_side(const Json& obj, const std::string& at, SideRules* dst) {
  if (!obj.is_object()) return Error(at, "expected an object");
  static const std::set<std::string> kKeys = {"sound_knot",      "dead_knot",
                                              "knots_per_m",     "dead_knots_per_m",
                                              "knots_per_board", "wane_fraction"};
  for (auto& [k, v] : obj.items())
    if (!kKeys.count(k)) return Error(at + "." + k, "unknown key");
  if (Status s = read_size(obj, at, "sound_knot", &dst->sound_knot); !s) return s;
  if (Status s = read_size(obj, at, "dead_knot", &dst->dead_knot); !s) return s;
  for (auto [key, p] : {std::pair{"knots_per_m", &dst->knots_per_m},
                        {"dead_knots_per_m", &dst->dead_knots_per_m},
                        {"knots_per_board", &dst->knots_per_board},
                        {"wane_fraction", &dst->wane_fraction}})
    if (Status s = read_number(obj, at, key, p); !s) return s;
  return Status::Ok();
}

}  // namespace

Status GradingRules::validate() const {
  if (grades.empty()) return Error("grades", "no grade given");
  if (!limit_ok(min_knot_mm) || std::isinf(min_knot_mm))
    return Error("min_knot_mm", "must be a finite number ≥ 0");
  std::set<std::string> names;
  for (size_t i = 0; i < grades.size(); ++i) {
    const GradeRule& g = grades[i];
    const std::string at = "grades[" + std::to_string(i) + "]";
    if (g.name.empty() || g.name == "reject") return Error(at + ".name", "empty or \"reject\"");
    if (!names.insert(g.name).second) return Error(at + ".name", "'" + g.name + "' twice");
    if (Status s = check_side(g.face, at + ".face"); !s) return s;
    if (Status s = check_side(g.edge, at + ".edge"); !s) return s;
    if (!limit_ok(g.wane_length_fraction))
      return Error(at + ".wane_length_fraction", "must be a number ≥ 0");
  }
  return Status::Ok();
}

namespace {

// Everything the rules look at: per side its knot figures and wane, and the board's size.
struct GradeInput {
  std::array<SideStats, 4> st{};
  const SideWane* wane = nullptr;  // [4]
  double length_mm = 0, width_mm = 0, thickness_mm = 0;
};

void count_knot(const KnotOnSide& k, int index, const GradingRules& rules,
                std::array<SideStats, 4>* st) {
  if (k.width_mm < rules.min_knot_mm) return;
  SideStats& s = (*st)[static_cast<int>(k.side)];
  ++s.count;
  if (k.dead) {
    ++s.dead_count;
    if (k.width_mm > s.dead_mm || s.largest_dead < 0)
      s.dead_mm = k.width_mm, s.largest_dead = index;
  } else if (k.width_mm > s.sound_mm || s.largest_sound < 0) {
    s.sound_mm = k.width_mm, s.largest_sound = index;
  }
}

// `knots`: what SideStats' indices point into (for the limit's knot figures).
BoardGrade grade_input(const GradeInput& in, const std::vector<KnotOnSide>& knots,
                       const GradingRules& rules) {
  const double length_m = in.length_mm * 1e-3;
  double wane_length = 0;
  for (int k = 0; k < 4; ++k) wane_length = std::max(wane_length, in.wane[k].length_mm);
  const double wane_length_fraction = in.length_mm > 0 ? wane_length / in.length_mm : 0;

  BoardGrade out;
  GradeLimit last;
  for (int g = 0; g < rules.reject(); ++g) {
    const GradeRule& rule = rules.grades[g];
    GradeLimit fail;
    fail.grade = g;
    for (int si = 0; si < 4 && fail.kind == LimitKind::kNone; ++si) {
      const Side side = static_cast<Side>(si);
      const bool face = is_face(side);
      const SideRules& r = face ? rule.face : rule.edge;
      const double side_width = face ? in.width_mm : in.thickness_mm;
      const SideStats& s = in.st[si];
      fail.side = side;
      auto knot_fail = [&](LimitKind kind, int knot, double allowed) {
        fail.kind = kind;
        fail.knot = knot;
        fail.measured = knots[knot].width_mm;
        fail.allowed = allowed;
        fail.along_mm = knots[knot].along_mm;
      };
      auto count_fail = [&](LimitKind kind, double measured, double allowed) {
        fail.kind = kind;
        fail.measured = measured;
        fail.allowed = allowed;
      };
      const double sound_allowed = r.sound_knot.allowed(side_width);
      const double dead_allowed = r.dead_knot.allowed(side_width);
      // Per-metre counts allow floor(per_m × board length in m) knots on the side.
      const double per_m_allowed = std::floor(r.knots_per_m * length_m + 1e-9);
      const double dead_per_m_allowed = std::floor(r.dead_knots_per_m * length_m + 1e-9);
      if (s.largest_dead >= 0 && s.dead_mm > dead_allowed)
        knot_fail(LimitKind::kDeadKnot, s.largest_dead, dead_allowed);
      else if (s.largest_sound >= 0 && s.sound_mm > sound_allowed)
        knot_fail(LimitKind::kSoundKnot, s.largest_sound, sound_allowed);
      else if (s.dead_count > dead_per_m_allowed)
        count_fail(LimitKind::kDeadKnotCount, s.dead_count, dead_per_m_allowed);
      else if (s.count > per_m_allowed)
        count_fail(LimitKind::kKnotCount, s.count, per_m_allowed);
      else if (s.count > r.knots_per_board)
        count_fail(LimitKind::kKnotsPerBoard, s.count, r.knots_per_board);
      else if (side_width > 0 && in.wane[si].max_mm / side_width > r.wane_fraction)
        count_fail(LimitKind::kWane, in.wane[si].max_mm / side_width, r.wane_fraction);
    }
    if (fail.kind == LimitKind::kNone && wane_length_fraction > rule.wane_length_fraction) {
      fail.kind = LimitKind::kWaneLength;
      fail.measured = wane_length_fraction;
      fail.allowed = rule.wane_length_fraction;
    }
    if (fail.kind == LimitKind::kNone) {
      out.grade = g;
      out.limit = last;
      return out;
    }
    last = fail;
  }
  out.grade = rules.reject();
  out.limit = last;
  return out;
}

}  // namespace

BoardGrade grade_board(const Board& board, const GradingRules& rules) {
  GradeInput in;
  for (size_t i = 0; i < board.knots.size(); ++i)
    count_knot(board.knots[i], static_cast<int>(i), rules, &in.st);
  in.wane = board.wane.data();
  in.length_mm = board.length_mm();
  in.width_mm = board.width_mm;
  in.thickness_mm = board.thickness_mm;
  return grade_input(in, board.knots, rules);
}

std::vector<int> counted_knots(const Board& board, const GradingRules& rules) {
  std::vector<int> out;
  for (size_t i = 0; i < board.knots.size(); ++i)
    if (!(board.knots[i].width_mm < rules.min_knot_mm)) out.push_back(static_cast<int>(i));
  return out;
}

int piece_grade(const Board& board, double z0, double z1, const std::array<SideWane, 4>& wane,
                const GradingRules& rules, const std::vector<int>& counted) {
  GradeInput in;
  for (const int i : counted) {
    const KnotOnSide& k = board.knots[i];
    if (k.z_mm < z0 || k.z_mm > z1) continue;  // as cut_board() keeps them
    count_knot(k, i, rules, &in.st);
  }
  in.wane = wane.data();
  in.length_mm = z1 - z0;
  in.width_mm = board.width_mm;
  in.thickness_mm = board.thickness_mm;
  return grade_input(in, board.knots, rules).grade;
}

std::vector<LimitingKnot> limiting_knots(const Board& board, const GradingRules& rules, int grade) {
  std::vector<LimitingKnot> out;
  if (grade <= 0 || grade > rules.reject()) return out;
  const int above = grade - 1;
  const GradeRule& rule = rules.grades[above];
  for (size_t i = 0; i < board.knots.size(); ++i) {
    const KnotOnSide& k = board.knots[i];
    if (k.width_mm < rules.min_knot_mm) continue;  // not graded (count_knot)
    const bool face = is_face(k.side);
    const SideRules& r = face ? rule.face : rule.edge;
    const double side_width = face ? board.width_mm : board.thickness_mm;
    const double allowed =
        k.dead ? r.dead_knot.allowed(side_width) : r.sound_knot.allowed(side_width);
    if (!(k.width_mm > allowed)) continue;
    LimitingKnot l;
    l.index = static_cast<int>(i);
    l.knot_id = k.knot_id;
    l.side = k.side;
    l.z_mm = k.z_mm;
    l.along_mm = k.along_mm;
    l.across_mm = k.across_mm;
    l.width_mm = k.width_mm;
    l.dead = k.dead;
    l.grade = above;
    l.rule = k.dead ? LimitKind::kDeadKnot : LimitKind::kSoundKnot;
    l.allowed_mm = allowed;
    out.push_back(l);
  }
  std::stable_sort(out.begin(), out.end(), [](const LimitingKnot& a, const LimitingKnot& b) {
    return a.width_mm - a.allowed_mm > b.width_mm - b.allowed_mm;
  });
  return out;
}

std::string describe(const LimitingKnot& k, const GradingRules& rules) {
  // Whole millimetres unless they would print the size no larger than the limit.
  const int digits = std::lround(k.width_mm) > std::lround(k.allowed_mm) ? 0 : 1;
  char buf[200];
  std::snprintf(buf, sizeof buf, "knot %d, %s, %.*f mm on %s at %.2f m: over %.*f mm allowed in %s",
                k.knot_id, k.dead ? "dead" : "sound", digits, k.width_mm, side_name(k.side),
                k.along_mm * 1e-3, digits, k.allowed_mm, rules.grade_name(k.grade).c_str());
  return buf;
}

std::string describe(const GradeLimit& l, const GradingRules& rules) {
  if (l.kind == LimitKind::kNone) return "none";
  const std::string grade = rules.grade_name(l.grade);
  char buf[200];
  switch (l.kind) {
    case LimitKind::kSoundKnot:
    case LimitKind::kDeadKnot:
      std::snprintf(buf, sizeof buf, "%s knot %.1f mm on %s at %.2f m > %.1f mm allowed in %s",
                    l.kind == LimitKind::kDeadKnot ? "dead" : "sound", l.measured,
                    side_name(l.side), l.along_mm * 1e-3, l.allowed, grade.c_str());
      break;
    case LimitKind::kKnotCount:
    case LimitKind::kDeadKnotCount:
    case LimitKind::kKnotsPerBoard:
      std::snprintf(buf, sizeof buf, "%.0f %sknots on %s > %.0f allowed in %s", l.measured,
                    l.kind == LimitKind::kDeadKnotCount ? "dead " : "", side_name(l.side),
                    l.allowed, grade.c_str());
      break;
    case LimitKind::kWane:
      std::snprintf(buf, sizeof buf, "wane %.0f %% of %s > %.0f %% allowed in %s", 100 * l.measured,
                    side_name(l.side), 100 * l.allowed, grade.c_str());
      break;
    case LimitKind::kWaneLength:
      std::snprintf(buf, sizeof buf, "wane along %.0f %% of the length > %.0f %% allowed in %s",
                    100 * l.measured, 100 * l.allowed, grade.c_str());
      break;
    case LimitKind::kNone:
      break;
  }
  return buf;
}

Result<GradingRules> grading_from_json(const std::string& text) {
  Result<Json> parsed = parse_format_json(text, kGradingFormatTag);
  if (!parsed) return parsed.error();
  const Json& j = parsed.value();
  GradingRules rules;
  if (auto it = j.find("name"); it != j.end()) {
    if (!it->is_string()) return Error("name", "expected a string");
    rules.name = it->get<std::string>();
  }
  if (Status s = read_number(j, "", "min_knot_mm", &rules.min_knot_mm); !s) return s.error();
  auto grades = j.find("grades");
  if (grades == j.end() || !grades->is_array()) return Error("grades", "missing or not an array");
  for (size_t i = 0; i < grades->size(); ++i) {
    const Json& g = (*grades)[i];
    const std::string at = "grades[" + std::to_string(i) + "]";
    if (!g.is_object()) return Error(at, "expected an object");
    GradeRule rule;
    for (auto& [k, v] : g.items())
      if (k != "name" && k != "face" && k != "edge" && k != "wane_length_fraction")
        return Error(at + "." + k, "unknown key");
    auto name = g.find("name");
    if (name == g.end() || !name->is_string())
      return Error(at + ".name", "missing or not a string");
    rule.name = name->get<std::string>();
    if (auto it = g.find("face"); it != g.end())
      if (Status s = read_side(*it, at + ".face", &rule.face); !s) return s.error();
    if (auto it = g.find("edge"); it != g.end())
      if (Status s = read_side(*it, at + ".edge", &rule.edge); !s) return s.error();
    if (Status s = read_number(g, at, "wane_length_fraction", &rule.wane_length_fraction); !s)
      return s.error();
    rules.grades.push_back(rule);
  }
  if (Status s = rules.validate(); !s) return s.error();
  return rules;
}

Result<GradingRules> read_grading_file(const std::filesystem::path& path) {
  Result<std::string> text = read_data_file(path);
  if (!text) return text.error();
  Result<GradingRules> r = grading_from_json(text.value());
  if (!r) return r.error().with_context(path.string());
  return r;
}

}  // namespace sawyer::sawing
