// The sawing file, "sawyer-sawing/1": its writer and its reader (see sawing_file.h).
#include "sawyer/sawing/sawing_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "fit_text.h"
#include "pattern_json.h"
#include "sawyer/core/file_util.h"
#include "sawyer/model/log_json.h"
#include "sawyer/sawing/placement.h"

namespace sawyer::sawing {

namespace {

using Json = nlohmann::ordered_json;

// ---- writing ----

Json position_json(const LogPosition& p) {
  return {{"rotation_deg", p.rotation_deg},
          {"offset_x_mm", p.offset_x_mm},
          {"offset_y_mm", p.offset_y_mm}};
}

Json boards_json(const SawResult& sawn, const LogValue& v, const GradingRules& rules,
                 bool details) {
  Json out = Json::array();
  for (size_t i = 0; i < sawn.boards.size(); ++i) {
    const Board& b = sawn.boards[i];
    const BoardValue& bv = v.boards[i];
    Json board = {{"name", b.name},
                  {"thickness_mm", b.thickness_mm},
                  {"width_mm", b.width_mm},
                  {"thickness_axis", b.thickness_axis == ThicknessAxis::kU ? "u" : "v"},
                  {"u_mm", b.u_mm},
                  {"v_mm", b.v_mm},
                  {"z_begin_mm", b.z_begin},
                  {"z_end_mm", b.z_end},
                  {"volume_m3", b.volume_m3},
                  {"grade", rules.grade_name(bv.grade.grade)},
                  {"limited_by", describe(bv.grade.limit, rules)},
                  {"price_per_m3", bv.price_per_m3},
                  {"value", bv.value}};
    if (b.trimmed()) {
      // Cross-cut to value (trim_to_value): the sawn length and the offcuts at either end.
      board["sawn_begin_mm"] = b.sawn_begin;
      board["sawn_end_mm"] = b.sawn_end;
      board["offcuts_mm"] = {b.z_begin - b.sawn_begin, b.sawn_end - b.z_end};
    }
    if (details) {
      Json wane = Json::array();
      for (const SideWane& w : b.wane)
        wane.push_back({{"max_mm", w.max_mm}, {"length_mm", w.length_mm}});
      Json knots = Json::array();
      for (const KnotOnSide& k : b.knots)
        knots.push_back({{"knot_id", k.knot_id},
                         {"side", side_name(k.side)},
                         {"kind", knot_kind_name(k.kind)},
                         {"along_mm", k.along_mm},
                         {"across_mm", k.across_mm},
                         {"width_mm", k.width_mm},
                         {"minor_mm", k.minor_mm},
                         {"major_mm", k.major_mm},
                         {"dead", k.dead}});
      board["wane"] = std::move(wane);
      board["knots"] = std::move(knots);
    }
    out.push_back(std::move(board));
  }
  return out;
}

// The position as the saw executes it: the turn from the log's orientation in the scanner and
// the pattern centre at the log's two ends, in scanner x, y, z (docs/sawing.md, "Frames").
Json scanner_json(const SawLog& log, const LogPosition& pos) {
  Json ends = Json::array();
  for (const Vec3& c : pattern_centre_at_ends(log, pos)) ends.push_back({c.x, c.y, c.z});
  return {{"turn_deg", scanner_position(log, pos).turn_deg}, {"pattern_centre_at_ends_mm", ends}};
}

Json ranked_json(const SawLog& log, const RankedPosition& r) {
  Json j = position_json(r.pos);
  j["value"] = r.value;
  j["smoothed_value"] = r.smoothed;
  j["scanner"] = scanner_json(log, r.pos);
  return j;
}

Json bow_json(const BowInfo& b) {
  return {{"method",
           "arc fitted to the outline's centre line (area centroids per height); the horns point "
           "along its curvature"},
          {"arc_sagitta_mm", b.height_mm},
          {"chord_sweep_mm", b.chord_mm},
          {"min_bow_mm", kMinBowMm},
          {"straight", b.straight},
          {"horns_azimuth_deg", b.horns_azimuth * 180.0 / kPi},
          {"horns_down", b.straight
                             ? "convention: the log as it lay in the scanner (bow below min_bow_mm)"
                             : "from the bow"}};
}

// Which frame the positions and coordinates are in: offsets and rotation are relative to the
// log (its mean pith line and horns), the log's x, y are the scanner's when the model came from
// a CT scan (its scanner_frame, recorded here so a saw can be set from it).
Json frame_json(const LogModel& log) {
  Json j;
  j["position"] =
      "rotation_deg from horns down about the mean pith line; offset_x_mm, offset_y_mm from the "
      "mean pith line in the turned cross-section (docs/sawing.md); \"scanner\": the same "
      "position as executed: turn_deg from the log's orientation in the scanner, counter-"
      "clockwise in the scanner's x-y plane, and the pattern centre at the log's two ends";
  j["coordinates"] = log.scanner_frame ? "scanner" : "log model";
  if (log.scanner_frame)
    j["scanner_frame"] = Json::parse(scanner_frame_json_text(*log.scanner_frame));
  return j;
}

Json candidate_json(const PatternCandidateResult& r) {
  Json j = {{"name", r.name},
            {"class", r.class_label},
            {"own_class", r.own_class},
            {"needed_diameter_mm", r.needed_diameter_mm},
            {"fits", r.fits}};
  if (r.fits) {
    j["value"] = r.value;
    if (r.has_expected) j["expected_value"] = r.expected_value;
  }
  return j;
}

// How the pattern was chosen from a set: the set, the log's class, the chosen and the next best
// pattern with their values, every candidate, and the chosen pattern whole.
Json pattern_choice_json(const PatternChoice& c, const Pattern& chosen) {
  Json j;
  j["set"] = c.set;
  j["class"] = c.class_label;
  j["usable_diameter_mm"] = c.usable_diameter_mm;
  j["ranked_by"] = c.at_given_position ? "value at the given position"
                                       : "expected value at each pattern's best position";
  j["chosen"] = candidate_json(c.candidates[static_cast<size_t>(c.chosen)]);
  j["next_best"] =
      c.next_best < 0 ? Json() : candidate_json(c.candidates[static_cast<size_t>(c.next_best)]);
  Json all = Json::array();
  for (const PatternCandidateResult& r : c.candidates) all.push_back(candidate_json(r));
  j["candidates"] = std::move(all);
  j["pattern"] = pattern_file_json(chosen);
  return j;
}

}  // namespace

Json pattern_candidate_value_json(const PatternChoice& c, int i) {
  if (i < 0) return Json();
  const PatternCandidateResult& r = c.candidates[static_cast<size_t>(i)];
  Json j = {{"name", r.name}, {"class", r.class_label}, {"value", r.value}};
  if (r.has_expected) j["expected_value"] = r.expected_value;
  return j;
}

std::string pattern_choice_line(const PatternChoice& c, const std::string& currency) {
  const PatternCandidateResult& chosen = c.candidates[static_cast<size_t>(c.chosen)];
  const std::string what = c.at_given_position ? "at the given position " : "expected ";
  const std::string unit = currency.empty() ? "" : " " + currency;
  std::string line = "pattern '" + chosen.name + "' chosen from set '" + c.set + "' (class " +
                     c.class_label + ", usable diameter " + fmt("%.1f", c.usable_diameter_mm) +
                     " mm), " + what + fmt("%.2f", chosen.rank_value()) + unit;
  if (c.next_best >= 0) {
    const PatternCandidateResult& next = c.candidates[static_cast<size_t>(c.next_best)];
    const double best = chosen.rank_value();
    line += "; next best '" + next.name + "', " + what + fmt("%.2f", next.rank_value()) + unit +
            " (" + fmt("%+.1f", best > 0 ? 100 * (next.rank_value() / best - 1) : 0.0) + " %)";
  } else {
    line += "; no other candidate fits";
  }
  int fit = 0;
  for (const PatternCandidateResult& r : c.candidates) fit += r.fits;
  const size_t n = c.candidates.size();
  return line + "; " + std::to_string(n) + (n == 1 ? " candidate, " : " candidates, ") +
         std::to_string(fit) + (fit == 1 ? " fits" : " fit");
}

Json sawing_file_json(const LogModel& log, const SawSetup& setup, const SawingOutcome& out) {
  const OptimiseResult& r = out.opt;
  const OptimiseOptions& o = setup.options;
  Json j;
  j["format"] = kSawingFormatTag;
  j["log"] = log.id;
  j["pattern"] = out.pattern.name;
  j["grading"] = setup.rules.name;
  j["prices"] = setup.prices.name;
  j["currency"] = setup.prices.currency;
  j["inputs"] = {{"pattern", setup.pattern_set ? "" : setup.names.pattern},
                 {"grading", setup.names.grading},
                 {"prices", setup.prices_path.string()}};
  if (setup.pattern_set) j["inputs"]["pattern_set"] = setup.names.pattern_set;
  if (out.choice) j["pattern_choice"] = pattern_choice_json(*out.choice, out.pattern);
  j["options"] = {{"rot_step_deg", o.rot_step_deg},       {"rot_range_deg", r.rot_range_deg},
                  {"offset_x_max_mm", o.offset_x_max_mm}, {"offset_x_step_mm", o.offset_x_step_mm},
                  {"offset_y_max_mm", o.offset_y_max_mm}, {"offset_y_step_mm", o.offset_y_step_mm},
                  {"sigma_rot_deg", o.sigma_rot_deg},     {"sigma_offset_mm", o.sigma_offset_mm},
                  {"model_draws", r.model_draws}};
  if (r.model_draws > 0) j["options"]["scan_spread"] = r.spread_note;
  j["frame"] = frame_json(log);
  j["bow"] = bow_json(out.saw_log.bow());
  j["pattern_point_symmetric"] = r.symmetric;
  j["chosen"] = out.chosen_is_given() ? "given" : "best";
  j["best"] = ranked_json(out.saw_log, r.best);
  j["horns_down"] = ranked_json(out.saw_log, r.horns_down);
  j["horns_up"] = ranked_json(out.saw_log, r.horns_up);
  j["gain_over_horns_down"] = r.gain_over_horns_down;
  j["gain_over_horns_up"] = r.gain_over_horns_up;
  if (r.claim.groups > 0)
    j["claim"] = {{"gain_over_horns_down", r.claim.gain},
                  {"low", r.claim.low},
                  {"high", r.claim.high},
                  {"groups", r.claim.groups},
                  {"range", "90 % prediction range over the scan's uncertainty draws"}};
  Json ranked = Json::array();
  for (const RankedPosition& p : r.ranked) ranked.push_back(ranked_json(out.saw_log, p));
  j["ranked"] = ranked;
  j["boards"] = boards_json(out.best_sawn, out.best_value, setup.rules, true);
  if (out.given_sawn) {
    j["given_position"] = position_json(*setup.position);
    j["given_position"]["value"] = out.given_value->value;
    j["given_position"]["scanner"] = scanner_json(out.saw_log, *setup.position);
    // Raw over raw: a position off the grid has no smoothed value.
    j["given_position"]["gain_over_horns_down"] =
        r.horns_down.value > 0 ? out.given_value->value / r.horns_down.value - 1 : 0.0;
    j["given_position"]["boards"] =
        boards_json(*out.given_sawn, *out.given_value, setup.rules, true);
  }
  j["surface"] = {{"index", "(rotation × offsets_x + x) × offsets_y + y"},
                  {"rotations_deg", r.rotations_deg},
                  {"offsets_x_mm", r.offsets_x_mm},
                  {"offsets_y_mm", r.offsets_y_mm},
                  {"value", r.value},
                  {"smoothed_value", r.smoothed}};
  return j;
}

Json position_file_json(const SavedPosition& p) {
  Json j;
  j["format"] = kSawingFormatTag;
  j["log"] = p.log_id;
  j["pattern"] = p.pattern->name;
  j["grading"] = p.rules->name;
  j["prices"] = p.prices->name;
  j["currency"] = p.prices->currency;
  j["horns_down"] = position_json({});
  j["horns_down"]["value"] = p.horns_down_value;
  j["given_position"] = position_json(p.pos);
  j["given_position"]["value"] = p.value->value;
  j["given_position"]["gain_over_horns_down"] = p.gain_over_horns_down;
  j["given_position"]["boards"] = boards_json(*p.sawn, *p.value, *p.rules, false);
  return j;
}

// ---- reading ----

Board BoardRecord::board(int spec) const {
  Board b;
  b.spec = spec;
  b.name = name;
  b.thickness_mm = thickness_mm;
  b.width_mm = width_mm;
  b.thickness_axis = thickness_axis;
  b.u_mm = u_mm;
  b.v_mm = v_mm;
  b.z_begin = z_begin_mm;
  b.z_end = z_end_mm;
  return b;
}

std::string BoardRecord::limit_and_offcuts() const {
  if (offcut_begin_mm <= 0 && offcut_end_mm <= 0) return limited_by;
  return limited_by + sawing::offcut_note(z_begin_mm - offcut_begin_mm, z_end_mm + offcut_end_mm,
                                          z_begin_mm, z_end_mm);
}

namespace {

// Typed access to optional and required keys; errors carry the key path.
std::string opt_string(const Json& j, const char* key) {
  auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

Result<double> number(const Json& j, const std::string& key, const std::string& where) {
  auto it = j.find(key);
  if (it == j.end()) return Error(where + key, "missing");
  if (!it->is_number() || !std::isfinite(it->get<double>()))
    return Error(where + key, "expected a finite number");
  return it->get<double>();
}

Result<std::vector<double>> numbers(const Json& j, const std::string& key,
                                    const std::string& where) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_array()) return Error(where + key, "expected an array of numbers");
  std::vector<double> out;
  out.reserve(it->size());
  for (const Json& v : *it) {
    if (!v.is_number()) return Error(where + key, "expected an array of numbers");
    out.push_back(v.get<double>());
  }
  return out;
}

Result<PositionValue> position(const Json& j, const std::string& key) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_object()) return Error(key, "missing");
  const std::string w = key + ".";
  PositionValue p;
  p.present = true;
  Result<double> rot = number(*it, "rotation_deg", w), x = number(*it, "offset_x_mm", w),
                 y = number(*it, "offset_y_mm", w), v = number(*it, "value", w);
  for (const Result<double>* r : {&rot, &x, &y, &v})
    if (!*r) return r->error();
  p.pos = {rot.value(), x.value(), y.value()};
  p.value = v.value();
  if (Result<double> s = number(*it, "smoothed_value", w)) {
    p.smoothed_value = s.value();
    p.has_smoothed = true;
  }
  auto sc = it->find("scanner");
  if (sc != it->end()) {
    if (!sc->is_object()) return Error(w + "scanner", "expected an object");
    Result<double> turn = number(*sc, "turn_deg", w + "scanner.");
    if (!turn) return turn.error();
    auto ends = sc->find("pattern_centre_at_ends_mm");
    const std::string we = w + "scanner.pattern_centre_at_ends_mm";
    if (ends == sc->end() || !ends->is_array() || ends->size() != 2)
      return Error(we, "expected two [x, y, z] points");
    for (size_t e = 0; e < 2; ++e) {
      const Json& q = (*ends)[e];
      if (!q.is_array() || q.size() != 3 || !q[0].is_number() || !q[1].is_number() ||
          !q[2].is_number())
        return Error(we, "expected two [x, y, z] points");
      p.centre_at_ends[e] = {q[0].get<double>(), q[1].get<double>(), q[2].get<double>()};
    }
    p.turn_deg = turn.value();
    p.has_scanner = true;
  }
  return p;
}

Result<BoardRecord> board(const Json& j, const std::string& where) {
  if (!j.is_object()) return Error(where, "expected an object");
  const std::string w = where + ".";
  BoardRecord b;
  b.name = opt_string(j, "name");
  if (b.name.empty()) return Error(w + "name", "missing");
  struct Field {
    const char* key;
    double* out;
  };
  const Field fields[] = {{"thickness_mm", &b.thickness_mm},
                          {"width_mm", &b.width_mm},
                          {"u_mm", &b.u_mm},
                          {"v_mm", &b.v_mm},
                          {"z_begin_mm", &b.z_begin_mm},
                          {"z_end_mm", &b.z_end_mm},
                          {"volume_m3", &b.volume_m3},
                          {"price_per_m3", &b.price_per_m3},
                          {"value", &b.value}};
  for (const Field& f : fields) {
    Result<double> v = number(j, f.key, w);
    if (!v) return v.error();
    *f.out = v.value();
  }
  if (b.thickness_mm <= 0 || b.width_mm <= 0 || b.z_end_mm <= b.z_begin_mm)
    return Error(where, "bad size or z range");
  const std::string axis = opt_string(j, "thickness_axis");
  if (axis != "u" && axis != "v") return Error(w + "thickness_axis", "expected \"u\" or \"v\"");
  b.thickness_axis = axis == "u" ? ThicknessAxis::kU : ThicknessAxis::kV;
  b.grade = opt_string(j, "grade");
  b.limited_by = opt_string(j, "limited_by");
  if (auto k = j.find("knots"); k != j.end() && k->is_array())
    for (const Json& kn : *k) {
      ++b.knots;
      if (kn.is_object() && kn.value("dead", false)) ++b.dead_knots;
    }
  if (auto oc = j.find("offcuts_mm"); oc != j.end()) {
    if (!oc->is_array() || oc->size() != 2 || !(*oc)[0].is_number() || !(*oc)[1].is_number() ||
        (*oc)[0].get<double>() < 0 || (*oc)[1].get<double>() < 0)
      return Error(w + "offcuts_mm", "expected two lengths >= 0");
    b.offcut_begin_mm = (*oc)[0].get<double>();
    b.offcut_end_mm = (*oc)[1].get<double>();
  }
  if (auto wn = j.find("wane"); wn != j.end() && wn->is_array())
    for (const Json& s : *wn)
      if (s.is_object() && s.contains("max_mm") && s["max_mm"].is_number())
        b.max_wane_mm = std::max(b.max_wane_mm, s["max_mm"].get<double>());
  return b;
}

Result<std::vector<BoardRecord>> boards(const Json& j, const std::string& where) {
  if (!j.is_array()) return Error(where, "expected an array of boards");
  std::vector<BoardRecord> out;
  for (size_t i = 0; i < j.size(); ++i) {
    Result<BoardRecord> b = board(j[i], where + "[" + std::to_string(i) + "]");
    if (!b) return b.error();
    out.push_back(std::move(b).value());
  }
  return out;
}

// The grid is optional (a hand-made sawing.json may leave it out) but must be whole if present.
Result<ValueSurface> surface(const Json& j) {
  ValueSurface s;
  auto it = j.find("surface");
  if (it == j.end()) return s;
  const std::string w = "surface.";
  Result<std::vector<double>> rot = numbers(*it, "rotations_deg", w),
                              ox = numbers(*it, "offsets_x_mm", w),
                              oy = numbers(*it, "offsets_y_mm", w), v = numbers(*it, "value", w),
                              sv = numbers(*it, "smoothed_value", w);
  for (const auto* r : {&rot, &ox, &oy, &v, &sv})
    if (!*r) return r->error();
  s.rotations_deg = rot.value();
  s.offsets_x_mm = ox.value();
  s.offsets_y_mm = oy.value();
  s.value = v.value();
  s.smoothed_value = sv.value();
  const size_t n = s.rotations_deg.size() * s.offsets_x_mm.size() * s.offsets_y_mm.size();
  if (n == 0 || s.value.size() != n || s.smoothed_value.size() != n)
    return Error("surface", "value arrays do not match the axes (" + std::to_string(n) + " cells)");
  return s;
}

Result<PatternCandidateResult> candidate(const Json& j, const std::string& where) {
  if (!j.is_object()) return Error(where, "expected an object");
  const std::string w = where + ".";
  PatternCandidateResult r;
  r.name = opt_string(j, "name");
  if (r.name.empty()) return Error(w + "name", "missing");
  r.class_label = opt_string(j, "class");
  r.own_class = j.value("own_class", false);
  Result<double> need = number(j, "needed_diameter_mm", w);
  if (!need) return need.error();
  r.needed_diameter_mm = need.value();
  auto fits = j.find("fits");
  if (fits == j.end() || !fits->is_boolean()) return Error(w + "fits", "expected true or false");
  r.fits = fits->get<bool>();
  if (r.fits) {
    Result<double> v = number(j, "value", w);
    if (!v) return v.error();
    r.value = v.value();
    if (j.contains("expected_value")) {
      Result<double> e = number(j, "expected_value", w);
      if (!e) return e.error();
      r.expected_value = e.value();
      r.has_expected = true;
    }
  }
  return r;
}

// "pattern_choice" (pattern_choice_json): the choice and the chosen pattern.
Status parse_pattern_choice(const Json& j, SawingRecord& s) {
  const std::string w = "pattern_choice.";
  if (!j.is_object()) return Error("pattern_choice", "expected an object");
  PatternChoice c;
  c.set = opt_string(j, "set");
  c.class_label = opt_string(j, "class");
  Result<double> usable = number(j, "usable_diameter_mm", w);
  if (!usable) return usable.error();
  c.usable_diameter_mm = usable.value();
  c.at_given_position = opt_string(j, "ranked_by") == "value at the given position";
  auto all = j.find("candidates");
  if (all == j.end() || !all->is_array() || all->empty())
    return Error(w + "candidates", "expected an array of candidates");
  for (size_t i = 0; i < all->size(); ++i) {
    Result<PatternCandidateResult> r =
        candidate((*all)[i], w + "candidates[" + std::to_string(i) + "]");
    if (!r) return r.error();
    c.candidates.push_back(std::move(r).value());
  }
  // "chosen" and "next_best" name a fitting candidate (next_best may be null).
  auto index_of = [&](const char* key, bool required, int* out) -> Status {
    auto it = j.find(key);
    if (it == j.end() || it->is_null()) {
      if (required) return Error(w + key, "missing");
      return Status::Ok();
    }
    const std::string name = it->is_object() ? opt_string(*it, "name") : std::string();
    for (size_t i = 0; i < c.candidates.size(); ++i)
      if (c.candidates[i].name == name && c.candidates[i].fits) *out = static_cast<int>(i);
    if (*out < 0) return Error(w + key, "names no candidate that fits");
    return Status::Ok();
  };
  if (Status st = index_of("chosen", true, &c.chosen); !st) return st;
  if (Status st = index_of("next_best", false, &c.next_best); !st) return st;
  auto p = j.find("pattern");
  if (p == j.end() || !p->is_object()) return Error(w + "pattern", "missing");
  Result<Pattern> pattern = pattern_from_json_object(*p);
  if (!pattern) return pattern.error().with_context(w + "pattern");
  if (pattern.value().name != c.candidates[static_cast<size_t>(c.chosen)].name)
    return Error(w + "pattern", "is '" + pattern.value().name + "', not the chosen pattern");
  s.pattern_choice = std::move(c);
  s.chosen_pattern = std::move(pattern).value();
  return Status::Ok();
}

Result<SawingRecord> parse_sawing(const Json& j) {
  if (opt_string(j, "format") != kSawingFormatTag)
    return Error("format", std::string("expected \"") + kSawingFormatTag + "\"");
  SawingRecord s;
  s.log_id = opt_string(j, "log");
  s.pattern = opt_string(j, "pattern");
  s.grading = opt_string(j, "grading");
  s.prices = opt_string(j, "prices");
  s.currency = opt_string(j, "currency");
  if (auto pc = j.find("pattern_choice"); pc != j.end())
    if (Status st = parse_pattern_choice(*pc, s); !st) return st.error();
  // A position the viewer saved holds horns-down and the given position only.
  const bool whole = j.contains("best") || !j.contains("given_position");
  Result<PositionValue> hd = position(j, "horns_down");
  if (!hd) return hd.error();
  s.horns_down = hd.value();
  if (whole) {
    Result<PositionValue> best = position(j, "best"), hu = position(j, "horns_up");
    for (const auto* r : {&best, &hu})
      if (!*r) return r->error();
    s.best = best.value();
    s.horns_up = hu.value();
  }
  s.gain_over_horns_down = j.value("gain_over_horns_down", 0.0);
  s.gain_over_horns_up = j.value("gain_over_horns_up", 0.0);
  if (auto c = j.find("claim"); c != j.end()) {
    if (!c->is_object()) return Error("claim", "expected an object");
    Result<double> g = number(*c, "gain_over_horns_down", "claim."),
                   lo = number(*c, "low", "claim."), hi = number(*c, "high", "claim.");
    for (const auto* r : {&g, &lo, &hi})
      if (!*r) return r->error();
    if (!(lo.value() <= g.value() && g.value() <= hi.value()))
      return Error("claim", "low <= gain_over_horns_down <= high does not hold");
    int groups = 0;
    if (auto n = c->find("groups"); n != c->end() && n->is_number_integer()) groups = n->get<int>();
    s.claim = ClaimRange{g.value(), lo.value(), hi.value(), groups};
  }
  if (auto bw = j.find("bow"); bw != j.end()) {
    if (!bw->is_object()) return Error("bow", "expected an object");
    Result<double> h = number(*bw, "arc_sagitta_mm", "bow."),
                   c = number(*bw, "chord_sweep_mm", "bow."), m = number(*bw, "min_bow_mm", "bow.");
    for (const auto* r : {&h, &c, &m})
      if (!*r) return r->error();
    auto st = bw->find("straight");
    if (st == bw->end() || !st->is_boolean())
      return Error("bow.straight", "expected true or false");
    s.bow = {true, h.value(), c.value(), m.value(), st->get<bool>()};
  }
  const std::string chosen =
      j.contains("chosen") ? opt_string(j, "chosen") : (whole ? "best" : "given");
  if (chosen != "best" && chosen != "given")
    return Error("chosen", "expected \"best\" or \"given\"");
  s.chosen_given = chosen == "given";
  Result<std::vector<BoardRecord>> b = std::vector<BoardRecord>{};
  if (s.chosen_given) {
    Result<PositionValue> g = position(j, "given_position");
    if (!g) return g.error();
    s.chosen = g.value();
    auto it = j["given_position"].find("boards");
    if (it == j["given_position"].end()) return Error("given_position.boards", "missing");
    b = boards(*it, "given_position.boards");
  } else {
    s.chosen = s.best;
    if (!j.contains("boards")) return Error("boards", "missing");
    b = boards(j["boards"], "boards");
  }
  if (!b) return b.error();
  s.boards = std::move(b).value();
  Result<ValueSurface> surf = surface(j);
  if (!surf) return surf.error();
  s.surface = std::move(surf).value();
  return s;
}

}  // namespace

Result<SawingRecord> sawing_record_from_json(const std::string& text) {
  const Json j = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Error("", "not valid JSON");
  if (!j.is_object()) return Error("", "expected a JSON object");
  return parse_sawing(j);
}

Result<SawingRecord> read_sawing_file(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) return Error(path.string(), "missing");
  Result<std::string> text = read_text_file(path);
  if (!text) return text.error();
  Result<SawingRecord> r = sawing_record_from_json(text.value());
  if (!r) return r.error().with_context(path.string());
  return r;
}

std::string run_pattern_choice_line(const std::filesystem::path& log_json) {
  const std::filesystem::path scan = log_json.parent_path();
  if (scan.filename() != "scan") return "";
  const std::filesystem::path file = scan.parent_path() / "sawing.json";
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return "";
  Result<SawingRecord> r = read_sawing_file(file);
  if (!r || !r.value().pattern_choice) return "";
  return pattern_choice_line(*r.value().pattern_choice, r.value().currency);
}

}  // namespace sawyer::sawing
