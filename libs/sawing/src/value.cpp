// Prices per grade and dimension, board and log value, and the "sawyer-prices/1" reader.
#include "sawyer/sawing/value.h"
#include "json_text.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <vector>

#include "sawyer/core/file_util.h"

namespace sawyer::sawing {

namespace {

using Json = nlohmann::ordered_json;
constexpr const char* kPricesFormatTag = "sawyer-prices/1";

Status read_grade_prices(const Json& obj, const std::string& at,
                         std::map<std::string, double>* dst) {
  if (!obj.is_object()) return Error(at, "expected an object {grade: price per m³}");
  for (auto& [k, v] : obj.items()) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0)
      return Error(at + "." + k, "expected a price ≥ 0");
    (*dst)[k] = v.get<double>();
  }
  return Status::Ok();
}

}  // namespace

double PriceTable::price(const std::string& grade, double thickness_mm, double width_mm) const {
  auto near = [](double a, double b) { return std::abs(a - b) <= 0.5; };
  for (const Dimension& d : dimensions) {
    if ((near(d.thickness_mm, thickness_mm) && near(d.width_mm, width_mm)) ||
        (near(d.thickness_mm, width_mm) && near(d.width_mm, thickness_mm))) {
      auto it = d.per_m3.find(grade);
      if (it != d.per_m3.end()) return it->second;
      break;
    }
  }
  auto it = default_per_m3.find(grade);
  return it == default_per_m3.end() ? 0.0 : it->second;
}

Status PriceTable::check_covers(const GradingRules& rules) const {
  for (const GradeRule& g : rules.grades)
    if (!default_per_m3.count(g.name))
      return Error("default." + g.name, "no price for grade '" + g.name + "' of " + rules.name);
  return Status::Ok();
}

LogValue value_of(const SawResult& sawn, const GradingRules& rules, const PriceTable& prices) {
  LogValue out;
  out.boards.reserve(sawn.boards.size());
  for (const Board& b : sawn.boards) {
    BoardValue v;
    v.grade = grade_board(b, rules);
    v.price_per_m3 = prices.price(rules.grade_name(v.grade.grade), b.thickness_mm, b.width_mm);
    v.value = b.volume_m3 * v.price_per_m3;
    out.value += v.value;
    out.boards.push_back(std::move(v));
  }
  return out;
}

Board cut_board(const Board& b, double z0, double z1) {
  // Every field but the per-sample and per-knot lists, which are rebuilt for the piece.
  Board c;
  c.spec = b.spec;
  c.name = b.name;
  c.thickness_mm = b.thickness_mm, c.width_mm = b.width_mm;
  c.thickness_axis = b.thickness_axis;
  c.u_mm = b.u_mm, c.v_mm = b.v_mm;
  c.sawn_begin = b.sawn_begin, c.sawn_end = b.sawn_end;
  c.hidden_knots = b.hidden_knots;
  c.z_begin = z0;
  c.z_end = z1;
  c.box_volume_m3 = b.thickness_mm * b.width_mm * (z1 - z0) * 1e-9;
  c.knots.clear();
  for (const KnotOnSide& k : b.knots) {
    if (k.z_mm < z0 || k.z_mm > z1) continue;
    c.knots.push_back(k);
    c.knots.back().along_mm = k.z_mm - z0;
  }
  double missing = 0;
  for (const BoardSlab& s : b.slabs) {
    const double ov = std::min(s.z1, z1) - std::max(s.z0, z0);
    if (ov <= 0) continue;
    c.slabs.push_back({std::max(s.z0, z0), std::min(s.z1, z1), s.wane, s.missing_mm2});
    missing += s.missing_mm2 * ov;
    for (int k = 0; k < 4; ++k) {
      c.wane[k].max_mm = std::max(c.wane[k].max_mm, static_cast<double>(s.wane[k]));
      if (s.wane[k] > 0) c.wane[k].length_mm += ov;
    }
  }
  c.volume_m3 = c.box_volume_m3 - missing * 1e-9;
  return c;
}

namespace {

// The wane and missing area of any piece [A_i, B_j] of a board, where A_i = z_begin + i·step and
// B_j = z_end − j·step are the cross-cuts trim_to_value tries, from one pass over the board's
// slabs instead of one per piece. The cut points, sorted, split the board into at most 2·steps + 1
// intervals; per interval each side's largest wane, and at each point the running integrals of
// the missing area and of each side's wane length. A piece's largest wane is the largest over its
// intervals (a slab reaching into an interval counts there, as cut_board() counts every slab the
// piece overlaps), its sums the differences of the integrals.
class PieceWane {
 public:
  PieceWane(const Board& b, double step, int steps) {
    for (int i = 0; i <= steps; ++i) pts_.push_back(b.z_begin + i * step);
    for (int j = 0; j <= steps; ++j) pts_.push_back(b.z_end - j * step);
    std::sort(pts_.begin(), pts_.end());
    pts_.erase(std::unique(pts_.begin(), pts_.end()), pts_.end());
    const size_t m = pts_.size();
    runs_.assign(1, std::vector<std::array<double, 4>>(m, {0, 0, 0, 0}));
    std::vector<std::array<double, 4>>& each = runs_[0];
    sum_.assign(m, {0, 0, 0, 0, 0});  // at point p: ∫ from pts_[0] of missing, wane length ×4
    std::array<double, 5> run{0, 0, 0, 0, 0};
    size_t s = 0;
    for (size_t e = 0; e + 1 < m; ++e) {
      const double e0 = pts_[e], e1 = pts_[e + 1];
      while (s < b.slabs.size() && b.slabs[s].z1 <= e0) ++s;
      for (size_t t = s; t < b.slabs.size() && b.slabs[t].z0 < e1; ++t) {
        const BoardSlab& sl = b.slabs[t];
        const double ov = std::min(sl.z1, e1) - std::max(sl.z0, e0);
        if (ov <= 0) continue;
        run[0] += sl.missing_mm2 * ov;
        for (int k = 0; k < 4; ++k) {
          each[e][k] = std::max(each[e][k], static_cast<double>(sl.wane[k]));
          if (sl.wane[k] > 0) run[1 + k] += ov;
        }
      }
      sum_[e + 1] = run;
    }
    for (size_t l = 1; (size_t{1} << l) < m; ++l) {
      const std::vector<std::array<double, 4>>& below = runs_[l - 1];
      std::vector<std::array<double, 4>> level(m - (size_t{1} << l) + 1);
      const size_t half = size_t{1} << (l - 1);
      for (size_t e = 0; e < level.size(); ++e)
        for (int k = 0; k < 4; ++k) level[e][k] = std::max(below[e][k], below[e + half][k]);
      runs_.push_back(std::move(level));
    }
  }
  // Index of a cut point (one of the A_i or B_j it was built with).
  int at(double z) const {
    return static_cast<int>(std::lower_bound(pts_.begin(), pts_.end(), z) - pts_.begin());
  }
  // The piece between points p0 < p1: its wane per side and its missing area × length (mm³).
  // The largest wane over intervals [p0, p1) from two overlapping power-of-two runs (the same
  // maximum as a loop over them).
  double piece(int p0, int p1, std::array<SideWane, 4>* wane) const {
    if (p1 <= p0) {
      *wane = {};
      return 0;
    }
    const int l = std::bit_width(static_cast<unsigned>(p1 - p0)) - 1;
    const std::vector<std::array<double, 4>>& run = runs_[l];
    for (int k = 0; k < 4; ++k) {
      (*wane)[k].max_mm = std::max(run[p0][k], run[p1 - (1 << l)][k]);
      (*wane)[k].length_mm = sum_[p1][1 + k] - sum_[p0][1 + k];
    }
    return sum_[p1][0] - sum_[p0][0];
  }

 private:
  std::vector<double> pts_;
  // runs_[l][e]: per side the largest wane over intervals e .. e + 2^l − 1 (runs_[0]: each one).
  std::vector<std::vector<std::array<double, 4>>> runs_;
  std::vector<std::array<double, 5>> sum_;
};

}  // namespace

void trim_to_value(SawResult& sawn, const GradingRules& rules, const PriceTable& prices) {
  const double step = prices.length_step_mm;
  if (!(step > 0)) return;
  std::vector<double> price(rules.reject() + 1);
  sawn.volume_m3 = 0;
  for (Board& b : sawn.boards) {
    for (int g = 0; g <= rules.reject(); ++g)
      price[g] = prices.price(rules.grade_name(g), b.thickness_mm, b.width_mm);
    const BoardGrade g0 = grade_board(b, rules);
    double best = b.volume_m3 * price[g0.grade];
    // The best price any better grade of this size fetches bounds what a shorter piece can be
    // worth.
    double top = 0;
    for (int gi = 0; gi < g0.grade; ++gi) top = std::max(top, price[gi]);
    const double len = b.length_mm();
    const int steps = static_cast<int>(std::floor(len / step + 1e-9));
    const double min_len = std::max(prices.min_length_mm, step);
    double best_z0 = b.z_begin, best_z1 = b.z_end;
    if (g0.grade == 0 || steps < 1) {
      sawn.volume_m3 += b.volume_m3;
      continue;
    }
    // A step cut off that holds no knot crossing and no wane removes nothing the grade sees:
    // the piece one step longer is graded the same (or better: fewer knots per metre) and holds
    // more wood, so such cuts are not tried. has[0][i]: the i-th step from z_begin (1-based)
    // holds something; has[1][j] likewise from z_end.
    std::vector<char> has[2];
    has[0].assign(steps + 1, 0);
    has[1].assign(steps + 1, 0);
    auto mark = [&](double z0, double z1) {
      const int a0 = static_cast<int>(std::floor((z0 - b.z_begin) / step)) + 1;
      const int a1 = static_cast<int>(std::floor((z1 - b.z_begin) / step)) + 1;
      for (int a = std::max(a0, 1); a <= std::min(a1, steps); ++a) has[0][a] = 1;
      const int e0 = static_cast<int>(std::floor((b.z_end - z1) / step)) + 1;
      const int e1 = static_cast<int>(std::floor((b.z_end - z0) / step)) + 1;
      for (int e = std::max(e0, 1); e <= std::min(e1, steps); ++e) has[1][e] = 1;
    };
    for (const KnotOnSide& k : b.knots) mark(k.z_mm, k.z_mm);
    for (const BoardSlab& s : b.slabs)
      if (s.missing_mm2 > 0 || s.wane[0] > 0 || s.wane[1] > 0 || s.wane[2] > 0 || s.wane[3] > 0)
        mark(s.z0, s.z1);
    // A knot too big for the grade above must go: the piece keeps it otherwise, and with it the
    // grade (the grades are nested, each allowing what the one above allows).
    int need_i = 0, need_j = 0;
    if (g0.limit.kind == LimitKind::kSoundKnot || g0.limit.kind == LimitKind::kDeadKnot) {
      const double z = b.z_begin + g0.limit.along_mm;
      need_i = static_cast<int>(std::floor((z - b.z_begin) / step)) + 1;
      need_j = static_cast<int>(std::floor((b.z_end - z) / step)) + 1;
    }
    const PieceWane pieces(b, step, steps);
    const std::vector<int> counted = counted_knots(b, rules);
    std::array<SideWane, 4> wane;
    for (int i = 0; i <= steps; ++i) {
      if (i > 0 && !has[0][i]) continue;
      const double z0 = b.z_begin + i * step;
      const int p0 = pieces.at(z0);
      for (int j = 0; i + j <= steps; ++j) {
        if (i + j == 0 || (j > 0 && !has[1][j])) continue;
        if (i < need_i && j < need_j) continue;
        const double z1 = b.z_end - j * step;
        if (z1 - z0 < min_len - 1e-9) break;
        // Worth trying only if even the best grade could beat the best so far.
        if (top * b.volume_m3 * (z1 - z0) / len <= best) break;
        const double missing = pieces.piece(p0, pieces.at(z1), &wane);
        const double volume = b.thickness_mm * b.width_mm * (z1 - z0) * 1e-9 - missing * 1e-9;
        const double v = volume * price[piece_grade(b, z0, z1, wane, rules, counted)];
        if (v > best + 1e-12) best = v, best_z0 = z0, best_z1 = z1;
      }
    }
    if (best_z0 != b.z_begin || best_z1 != b.z_end) b = cut_board(b, best_z0, best_z1);
    sawn.volume_m3 += b.volume_m3;
  }
}

SawResult saw_for_sale(const SawLog& log, const Pattern& pattern, const LogPosition& pos,
                       const GradingRules& rules, const PriceTable& prices) {
  SawResult r = saw(log, pattern, pos);
  trim_to_value(r, rules, prices);
  return r;
}

Result<PriceTable> prices_from_json(const std::string& text) {
  Result<Json> parsed = parse_format_json(text, kPricesFormatTag);
  if (!parsed) return parsed.error();
  const Json& j = parsed.value();
  PriceTable t;
  for (auto [key, dst] : {std::pair{"name", &t.name}, std::pair{"currency", &t.currency}})
    if (auto it = j.find(key); it != j.end()) {
      if (!it->is_string()) return Error(key, "expected a string");
      *dst = it->get<std::string>();
    }
  auto def = j.find("default");
  if (def == j.end()) return Error("default", "missing (prices for dimensions not listed)");
  if (Status s = read_grade_prices(*def, "default", &t.default_per_m3); !s) return s.error();
  if (auto dims = j.find("dimensions"); dims != j.end()) {
    if (!dims->is_array()) return Error("dimensions", "expected an array");
    for (size_t i = 0; i < dims->size(); ++i) {
      const Json& d = (*dims)[i];
      const std::string at = "dimensions[" + std::to_string(i) + "]";
      if (!d.is_object()) return Error(at, "expected an object");
      PriceTable::Dimension dim;
      for (auto [key, dst] :
           {std::pair{"thickness_mm", &dim.thickness_mm}, std::pair{"width_mm", &dim.width_mm}}) {
        auto it = d.find(key);
        if (it == d.end() || !it->is_number() || !(it->get<double>() > 0))
          return Error(at + "." + key, "missing or not a size > 0");
        *dst = it->get<double>();
      }
      auto p = d.find("prices");
      if (p == d.end()) return Error(at + ".prices", "missing");
      if (Status s = read_grade_prices(*p, at + ".prices", &dim.per_m3); !s) return s.error();
      t.dimensions.push_back(dim);
    }
  }
  if (auto lengths = j.find("lengths"); lengths != j.end()) {
    if (!lengths->is_object()) return Error("lengths", "expected an object {step_mm, min_mm}");
    for (auto [key, dst] :
         {std::pair{"step_mm", &t.length_step_mm}, std::pair{"min_mm", &t.min_length_mm}}) {
      auto it = lengths->find(key);
      if (it == lengths->end()) continue;
      if (!it->is_number() || !(it->get<double>() >= 0) || it->get<double>() > 12000)
        return Error(std::string("lengths.") + key, "expected a length of 0-12000 mm");
      *dst = it->get<double>();
    }
    // Cross-cutting tries pieces a whole number of steps shorter at either end: a step of a few
    // millimetres would be millions of pieces per board. Mills cut in steps of 300 mm or a foot.
    if (t.length_step_mm > 0 && t.length_step_mm < kMinLengthStepMm) {
      char buf[120];
      std::snprintf(buf, sizeof buf,
                    "a step of %g mm is under the %g mm allowed (0: no cross-cutting)",
                    t.length_step_mm, kMinLengthStepMm);
      return Error("lengths.step_mm", buf);
    }
  }
  return t;
}

Result<PriceTable> read_price_file(const std::filesystem::path& path) {
  Result<std::string> text = read_data_file(path);
  if (!text) return text.error();
  Result<PriceTable> r = prices_from_json(text.value());
  if (!r) return r.error().with_context(path.string());
  return r;
}

}  // namespace sawyer::sawing
