// Reading a run folder back (see run_folder.h). Every check names the file and the key.
#include "sawyer/report/run_folder.h"

#include <nlohmann/json.hpp>

#include <cmath>

#include "sawyer/core/file_util.h"
#include "sawyer/model/log_json.h"
#include "sawyer/sawing/sawing_job.h"

namespace sawyer::report {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

Result<Json> read_json(const fs::path& path) {
  if (!fs::exists(path)) return Error(path.string(), "missing");
  Result<std::string> text = read_text_file(path);
  if (!text) return text.error();
  Json j = Json::parse(text.value(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Error(path.string(), "not valid JSON");
  if (!j.is_object()) return Error(path.string(), "expected a JSON object");
  return j;
}

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
  b.thickness_axis = axis == "u" ? sawing::ThicknessAxis::kU : sawing::ThicknessAxis::kV;
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

}  // namespace

std::string BoardRecord::limit_and_offcuts() const {
  if (offcut_begin_mm <= 0 && offcut_end_mm <= 0) return limited_by;
  return limited_by + sawing::offcut_note(z_begin_mm - offcut_begin_mm, z_end_mm + offcut_end_mm,
                                          z_begin_mm, z_end_mm);
}

namespace {

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

Result<SawingRecord> parse_sawing(const Json& j) {
  if (opt_string(j, "format") != "sawyer-sawing/1")
    return Error("format", "expected \"sawyer-sawing/1\"");
  SawingRecord s;
  s.log_id = opt_string(j, "log");
  s.pattern = opt_string(j, "pattern");
  s.grading = opt_string(j, "grading");
  s.prices = opt_string(j, "prices");
  s.currency = opt_string(j, "currency");
  Result<PositionValue> best = position(j, "best"), hd = position(j, "horns_down"),
                        hu = position(j, "horns_up");
  for (const auto* r : {&best, &hd, &hu})
    if (!*r) return r->error();
  s.best = best.value();
  s.horns_down = hd.value();
  s.horns_up = hu.value();
  s.gain_over_horns_down = j.value("gain_over_horns_down", 0.0);
  s.gain_over_horns_up = j.value("gain_over_horns_up", 0.0);
  if (auto bw = j.find("bow"); bw != j.end()) {
    if (!bw->is_object()) return Error("bow", "expected an object");
    Result<double> h = number(*bw, "arc_sagitta_mm", "bow."), c = number(*bw, "chord_sweep_mm", "bow."),
                   m = number(*bw, "min_bow_mm", "bow.");
    for (const auto* r : {&h, &c, &m})
      if (!*r) return r->error();
    auto st = bw->find("straight");
    if (st == bw->end() || !st->is_boolean()) return Error("bow.straight", "expected true or false");
    s.bow = {true, h.value(), c.value(), m.value(), st->get<bool>()};
  }
  const std::string chosen = j.contains("chosen") ? opt_string(j, "chosen") : "best";
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

Result<RunInfo> parse_run(const Json& j) {
  if (opt_string(j, "format") != "sawyer-run/1")
    return Error("format", "expected \"sawyer-run/1\"");
  RunInfo r;
  r.present = true;
  r.log_id = opt_string(j, "log_id");
  r.species = opt_string(j, "species");
  r.scan_source = opt_string(j, "scan_source");
  r.scan_description = opt_string(j, "scan_description");
  r.scan_checksum = opt_string(j, "scan_checksum");
  r.date = opt_string(j, "date");
  r.sawyer_version = opt_string(j, "sawyer_version");
  if (auto n = j.find("scan_notes"); n != j.end() && n->is_array())
    for (const Json& s : *n)
      if (s.is_string()) r.scan_notes.push_back(s.get<std::string>());
  if (auto o = j.find("options"); o != j.end() && o->is_object()) {
    r.pattern = opt_string(*o, "pattern");
    r.grading = opt_string(*o, "grading");
    r.prices = opt_string(*o, "prices");
    r.position = opt_string(*o, "position");
  }
  if (auto st = j.find("stages"); st != j.end() && st->is_array())
    for (const Json& s : *st)
      if (s.is_object())
        r.stages.push_back({opt_string(s, "name"), s.contains("seconds") && s["seconds"].is_number()
                                                       ? s["seconds"].get<double>()
                                                       : -1.0});
  return r;
}

}  // namespace

Result<RunFolder> load_run_folder(const fs::path& out) {
  if (!fs::is_directory(out)) return Error(out.string(), "not a run folder (no such folder)");
  RunFolder f;
  f.dir = out;
  const fs::path log_path = out / "scan" / "log.json";
  if (!fs::exists(log_path)) return Error(log_path.string(), "missing");
  Result<LogModel> log = read_log_json(log_path);
  if (!log) return log.error();
  f.log = std::move(log).value();

  const fs::path sawing_path = out / "sawing.json";
  Result<Json> sj = read_json(sawing_path);
  if (!sj) return sj.error();
  Result<SawingRecord> sawing = parse_sawing(sj.value());
  if (!sawing) return sawing.error().with_context(sawing_path.string());
  f.sawing = std::move(sawing).value();
  if (f.sawing.log_id != f.log.id)
    return Error(sawing_path.string(), "log '" + f.sawing.log_id + "' does not match " +
                                           log_path.string() + " (log '" + f.log.id + "')");

  const fs::path run_path = out / "run.json";
  if (fs::exists(run_path)) {
    Result<Json> rj = read_json(run_path);
    if (!rj) return rj.error();
    Result<RunInfo> run = parse_run(rj.value());
    if (!run) return run.error().with_context(run_path.string());
    f.run = std::move(run).value();
    if (!f.run.log_id.empty() && f.run.log_id != f.log.id)
      return Error(run_path.string(), "log_id '" + f.run.log_id + "' does not match " +
                                          log_path.string() + " (log '" + f.log.id + "')");
  }
  return f;
}

}  // namespace sawyer::report
