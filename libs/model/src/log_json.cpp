#include "sawyer/model/log_json.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "sawyer/core/file_util.h"

namespace sawyer {
namespace {

using Json = nlohmann::ordered_json;

// ---- writing ---------------------------------------------------------------------------------

Json rows_to_json(const std::vector<std::vector<double>>& rows) {
  Json out = Json::array();
  for (const auto& row : rows) out.push_back(row);
  return out;
}

// ---- reading: every accessor names the key path of the first problem -------------------------

const char* type_name(const Json& j) { return j.type_name(); }

Result<const Json*> member(const Json& obj, const std::string& path, const char* key,
                           bool required = true) {
  auto it = obj.find(key);
  if (it == obj.end()) {
    if (!required) return static_cast<const Json*>(nullptr);
    return Error(path + key, "missing key");
  }
  return &*it;
}

Result<double> number_at(const Json& obj, const std::string& path, const char* key) {
  Result<const Json*> m = member(obj, path, key);
  if (!m) return m.error();
  const Json& v = *m.value();
  if (!v.is_number()) return Error(path + key, std::string("expected a number, got ") + type_name(v));
  const double d = v.get<double>();
  if (!std::isfinite(d)) return Error(path + key, "not a finite number");
  return d;
}

Result<std::string> string_at(const Json& obj, const std::string& path, const char* key,
                              bool required) {
  Result<const Json*> m = member(obj, path, key, required);
  if (!m) return m.error();
  if (!m.value()) return std::string();
  if (!m.value()->is_string())
    return Error(path + key, std::string("expected a string, got ") + type_name(*m.value()));
  return m.value()->get<std::string>();
}

Result<std::vector<double>> number_list(const Json& v, const std::string& where) {
  if (!v.is_array()) return Error(where, std::string("expected an array of numbers, got ") + type_name(v));
  std::vector<double> out;
  out.reserve(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    if (!v[i].is_number())
      return Error(where + "[" + std::to_string(i) + "]",
                   std::string("expected a number, got ") + type_name(v[i]));
    const double d = v[i].get<double>();
    if (!std::isfinite(d)) return Error(where + "[" + std::to_string(i) + "]", "not a finite number");
    out.push_back(d);
  }
  return out;
}

Result<std::vector<std::vector<double>>> rows_at(const Json& v, const std::string& where,
                                                 size_t rows, size_t cols) {
  if (!v.is_array()) return Error(where, std::string("expected an array of rows, got ") + type_name(v));
  if (v.size() != rows)
    return Error(where, "has " + std::to_string(v.size()) + " rows, expected " +
                            std::to_string(rows) + " (one per pith sample)");
  std::vector<std::vector<double>> out;
  out.reserve(rows);
  for (size_t i = 0; i < rows; ++i) {
    const std::string w = where + "[" + std::to_string(i) + "]";
    Result<std::vector<double>> row = number_list(v[i], w);
    if (!row) return row.error();
    if (row.value().size() != cols)
      return Error(w, "has " + std::to_string(row.value().size()) + " values, expected " +
                          std::to_string(cols) + " (n_angles)");
    out.push_back(std::move(row).value());
  }
  return out;
}

Result<Stem> parse_stem(const Json& j) {
  const std::string p = "stem.";
  if (!j.is_object()) return Error("stem", std::string("expected an object, got ") + type_name(j));
  Stem s;
  Result<double> z0 = number_at(j, p, "z0_mm");
  if (!z0) return z0.error();
  Result<double> dz = number_at(j, p, "dz_mm");
  if (!dz) return dz.error();
  s.z0_mm = z0.value();
  s.dz_mm = dz.value();
  Result<const Json*> pith = member(j, p, "pith");
  if (!pith) return pith.error();
  const Json& pj = *pith.value();
  if (!pj.is_array()) return Error("stem.pith", std::string("expected an array of [x, y], got ") + type_name(pj));
  for (size_t i = 0; i < pj.size(); ++i) {
    const std::string w = "stem.pith[" + std::to_string(i) + "]";
    Result<std::vector<double>> xy = number_list(pj[i], w);
    if (!xy) return xy.error();
    if (xy.value().size() != 2) return Error(w, "expected [x, y]");
    s.pith.push_back({xy.value()[0], xy.value()[1]});
  }
  Result<const Json*> radius = member(j, p, "radius");
  if (!radius) return radius.error();
  const Json& rj = *radius.value();
  // n_angles is optional: it defaults to the length of the first radius row.
  Result<const Json*> na = member(j, p, "n_angles", false);
  if (!na) return na.error();
  if (na.value()) {
    if (!na.value()->is_number_integer())
      return Error("stem.n_angles", std::string("expected an integer, got ") + type_name(*na.value()));
    s.n_angles = na.value()->get<int>();
  } else if (rj.is_array() && !rj.empty() && rj[0].is_array()) {
    s.n_angles = static_cast<int>(rj[0].size());
  }
  if (s.n_angles < 3) return Error("stem.n_angles", "must be at least 3");
  Result<std::vector<std::vector<double>>> rad = rows_at(rj, "stem.radius", s.pith.size(), s.n_angles);
  if (!rad) return rad.error();
  s.radius = std::move(rad).value();
  Result<const Json*> hw = member(j, p, "heartwood", false);
  if (!hw) return hw.error();
  if (hw.value()) {
    Result<std::vector<std::vector<double>>> h = rows_at(*hw.value(), "stem.heartwood", s.pith.size(), s.n_angles);
    if (!h) return h.error();
    s.heartwood = std::move(h).value();
  }
  Result<const Json*> bark = member(j, p, "bark_mm", false);
  if (!bark) return bark.error();
  if (bark.value()) {
    Result<std::vector<double>> b = number_list(*bark.value(), "stem.bark_mm");
    if (!b) return b.error();
    if (b.value().size() != s.pith.size())
      return Error("stem.bark_mm", "has " + std::to_string(b.value().size()) +
                                       " values, expected one per pith sample");
    s.bark_mm = std::move(b).value();
  }
  return s;
}

Result<Knot> parse_knot(const Json& j, size_t index) {
  const std::string p = "knots[" + std::to_string(index) + "].";
  if (!j.is_object()) return Error(p.substr(0, p.size() - 1), "expected an object");
  Knot k;
  k.id = static_cast<int>(index);
  Result<const Json*> id = member(j, p, "id", false);
  if (!id) return id.error();
  if (id.value()) {
    if (!id.value()->is_number_integer()) return Error(p + "id", "expected an integer");
    k.id = id.value()->get<int>();
  }
  struct Field {
    const char* key;
    double* dst;
  };
  const Field fields[] = {{"z0", &k.z0},         {"a", &k.a},
                          {"b", &k.b},           {"omega0", &k.omega0},
                          {"twist", &k.twist},   {"r_dead", &k.r_dead},
                          {"r_end", &k.r_end},   {"d_dead", &k.diameter.d_dead},
                          {"d_exp", &k.diameter.exponent}};
  for (const Field& f : fields) {
    Result<double> v = number_at(j, p, f.key);
    if (!v) return v.error();
    *f.dst = v.value();
  }
  if (j.contains("fit_rms_mm")) {
    Result<double> v = number_at(j, p, "fit_rms_mm");
    if (!v) return v.error();
    k.fit_rms_mm = v.value();
  }
  if (j.contains("support")) {
    if (!j["support"].is_number_integer()) return Error(p + "support", "expected an integer");
    k.support = j["support"].get<int>();
  }
  return k;
}

}  // namespace

std::string log_to_json(const LogModel& log) {
  Json j;
  j["format"] = kLogFormatTag;
  j["id"] = log.id;
  j["species"] = log.species;
  j["source"] = log.source;
  Json stem;
  stem["z0_mm"] = log.stem.z0_mm;
  stem["dz_mm"] = log.stem.dz_mm;
  stem["n_angles"] = log.stem.n_angles;
  Json pith = Json::array();
  for (const Vec2& p : log.stem.pith) pith.push_back({p.x, p.y});
  stem["pith"] = std::move(pith);
  stem["radius"] = rows_to_json(log.stem.radius);
  if (log.stem.has_heartwood()) stem["heartwood"] = rows_to_json(log.stem.heartwood);
  if (!log.stem.bark_mm.empty()) stem["bark_mm"] = log.stem.bark_mm;
  j["stem"] = std::move(stem);
  Json knots = Json::array();
  for (const Knot& k : log.knots) {
    Json kj;
    kj["id"] = k.id;
    kj["z0"] = k.z0;
    kj["a"] = k.a;
    kj["b"] = k.b;
    kj["omega0"] = k.omega0;
    kj["twist"] = k.twist;
    kj["r_dead"] = k.r_dead;
    kj["r_end"] = k.r_end;
    kj["d_dead"] = k.diameter.d_dead;
    kj["d_exp"] = k.diameter.exponent;
    kj["fit_rms_mm"] = k.fit_rms_mm;
    kj["support"] = k.support;
    knots.push_back(std::move(kj));
  }
  j["knots"] = std::move(knots);
  // One stem row or knot per line keeps the file diff-able and compact.
  std::ostringstream os;
  os << "{\n";
  bool first = true;
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (!first) os << ",\n";
    first = false;
    os << "  " << Json(it.key()).dump() << ": ";
    if (it.key() == "stem") {
      os << "{\n";
      bool f2 = true;
      for (auto s = it->begin(); s != it->end(); ++s) {
        if (!f2) os << ",\n";
        f2 = false;
        os << "    " << Json(s.key()).dump() << ": ";
        if (s->is_array() && !s->empty() && (*s)[0].is_array()) {
          os << "[\n";
          for (size_t i = 0; i < s->size(); ++i)
            os << "      " << (*s)[i].dump() << (i + 1 < s->size() ? ",\n" : "\n");
          os << "    ]";
        } else {
          os << s->dump();
        }
      }
      os << "\n  }";
    } else if (it.key() == "knots") {
      os << "[\n";
      for (size_t i = 0; i < it->size(); ++i)
        os << "    " << (*it)[i].dump() << (i + 1 < it->size() ? ",\n" : "\n");
      os << "  ]";
    } else {
      os << it->dump();
    }
  }
  os << "\n}\n";
  return os.str();
}

Result<LogModel> log_from_json(const std::string& text) {
  Json j;
  try {
    j = Json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is the 1-based offset of the problem.
    size_t line = 1;
    for (size_t i = 0; i + 1 < e.byte && i < text.size(); ++i)
      if (text[i] == '\n') ++line;
    return Error("line " + std::to_string(line), "malformed JSON");
  }
  if (!j.is_object()) return Error("top level", "expected a JSON object");
  Result<std::string> fmt = string_at(j, "", "format", true);
  if (!fmt) return fmt.error();
  if (fmt.value() != kLogFormatTag)
    return Error("format", "is \"" + fmt.value() + "\", expected \"" + kLogFormatTag + "\"");
  LogModel log;
  for (auto [key, dst] : {std::pair{"id", &log.id}, std::pair{"species", &log.species},
                          std::pair{"source", &log.source}}) {
    Result<std::string> s = string_at(j, "", key, false);
    if (!s) return s.error();
    *dst = s.value();
  }
  Result<const Json*> stem = member(j, "", "stem");
  if (!stem) return stem.error();
  Result<Stem> s = parse_stem(*stem.value());
  if (!s) return s.error();
  log.stem = std::move(s).value();
  Result<const Json*> knots = member(j, "", "knots");
  if (!knots) return knots.error();
  if (!knots.value()->is_array()) return Error("knots", "expected an array");
  for (size_t i = 0; i < knots.value()->size(); ++i) {
    Result<Knot> k = parse_knot((*knots.value())[i], i);
    if (!k) return k.error();
    log.knots.push_back(std::move(k).value());
  }
  Status v = validate(log);
  if (!v) return v.error();
  return log;
}

Status validate(const LogModel& log) {
  const Stem& s = log.stem;
  if (!(s.dz_mm > 0)) return Error("stem.dz_mm", "must be positive");
  if (s.pith.empty()) return Error("stem.pith", "is empty: a log needs at least one stem sample");
  if (s.n_angles < 3) return Error("stem.n_angles", "must be at least 3");
  if (s.radius.size() != s.pith.size())
    return Error("stem.radius", "needs one row per pith sample");
  for (size_t i = 0; i < s.radius.size(); ++i) {
    if (static_cast<int>(s.radius[i].size()) != s.n_angles)
      return Error("stem.radius[" + std::to_string(i) + "]", "needs n_angles values");
    for (size_t k = 0; k < s.radius[i].size(); ++k)
      if (!(s.radius[i][k] > 0) || !std::isfinite(s.radius[i][k]))
        return Error("stem.radius[" + std::to_string(i) + "][" + std::to_string(k) + "]",
                     "radius must be a positive finite number");
  }
  if (s.has_heartwood()) {
    if (s.heartwood.size() != s.pith.size())
      return Error("stem.heartwood", "needs one row per pith sample");
    for (size_t i = 0; i < s.heartwood.size(); ++i)
      for (size_t k = 0; k < s.heartwood[i].size(); ++k)
        if (s.heartwood[i][k] < 0)
          return Error("stem.heartwood[" + std::to_string(i) + "][" + std::to_string(k) + "]",
                       "must not be negative");
  }
  for (size_t i = 0; i < log.knots.size(); ++i) {
    const Knot& k = log.knots[i];
    const std::string w = "knots[" + std::to_string(i) + "]";
    for (double v : {k.z0, k.a, k.b, k.omega0, k.twist, k.r_dead, k.r_end, k.diameter.d_dead,
                     k.diameter.exponent})
      if (!std::isfinite(v)) return Error(w, "has a non-finite parameter");
    if (!(k.r_end > 0)) return Error(w + ".r_end", "must be positive (the knot's length from the pith)");
    if (k.r_dead < 0) return Error(w + ".r_dead", "must not be negative");
    if (k.diameter.d_dead < 0) return Error(w + ".d_dead", "must not be negative");
    if (!(k.diameter.exponent > 0)) return Error(w + ".d_exp", "must be positive");
  }
  return Status::Ok();
}

Result<LogModel> read_log_json(const std::filesystem::path& path) {
  Result<std::string> text = read_text_file(path);
  if (!text) return text.error();
  Result<LogModel> log = log_from_json(text.value());
  if (!log) return log.error().with_context(path.string());
  return log;
}

Status write_log_json(const LogModel& log, const std::filesystem::path& path) {
  Status v = validate(log);
  if (!v) return v.error().with_context(path.string());
  return write_text_file_atomic(path, log_to_json(log));
}

}  // namespace sawyer
