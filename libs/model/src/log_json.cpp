#include "sawyer/model/log_json.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "sawyer/core/file_util.h"
#include "sawyer/core/stats.h"

namespace sawyer {
namespace {

using Json = nlohmann::ordered_json;
namespace lim = log_limits;

// A number for messages: "1e+12", "0.25".
std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// "<value> mm is outside <lo>-<hi> mm" (or "<lo> to <hi>" when lo is negative).
std::string outside(double v, double lo, double hi, const char* unit) {
  const std::string u = *unit ? std::string(" ") + unit : std::string();
  return num(v) + u + " is outside " + num(lo) + (lo < 0 ? " to " : "-") + num(hi) + u;
}

// check_range's test alone, for loops over many values (the name is built only on failure).
bool in_range(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

// The first value of `v` outside [lo, hi] (or not finite), as an error naming `where`.
Status check_range(double v, const std::string& where, double lo, double hi, const char* unit) {
  if (!std::isfinite(v)) return Error(where, "not a finite number");
  if (v < lo || v > hi) return Error(where, outside(v, lo, hi, unit));
  return Status::Ok();
}

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
  if (!v.is_number())
    return Error(path + key, std::string("expected a number, got ") + type_name(v));
  const double d = v.get<double>();
  if (!std::isfinite(d)) return Error(path + key, "not a finite number");
  return d;
}

// A JSON integer within [lo, hi], checked before it is narrowed (a huge integer would wrap).
Result<int> int_in_range(const Json& v, const std::string& where, long long lo, long long hi) {
  if (!v.is_number_integer())
    return Error(where, std::string("expected an integer, got ") + type_name(v));
  const bool too_big =
      v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(hi);
  const long long x = too_big ? hi + 1 : v.get<long long>();
  if (too_big || x < lo || x > hi)
    return Error(where, (too_big ? v.dump() : std::to_string(x)) + " is outside " +
                            std::to_string(lo) + "-" + std::to_string(hi));
  return static_cast<int>(x);
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
  if (!v.is_array())
    return Error(where, std::string("expected an array of numbers, got ") + type_name(v));
  std::vector<double> out;
  out.reserve(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    if (!v[i].is_number())
      return Error(where + "[" + std::to_string(i) + "]",
                   std::string("expected a number, got ") + type_name(v[i]));
    const double d = v[i].get<double>();
    if (!std::isfinite(d))
      return Error(where + "[" + std::to_string(i) + "]", "not a finite number");
    out.push_back(d);
  }
  return out;
}

Result<std::vector<std::vector<double>>> rows_at(const Json& v, const std::string& where,
                                                 size_t rows, size_t cols) {
  if (!v.is_array())
    return Error(where, std::string("expected an array of rows, got ") + type_name(v));
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
  if (!pj.is_array())
    return Error("stem.pith", std::string("expected an array of [x, y], got ") + type_name(pj));
  if (pj.size() > static_cast<size_t>(lim::kMaxSlices))
    return Error("stem.pith", "has " + std::to_string(pj.size()) + " samples, more than the " +
                                  std::to_string(lim::kMaxSlices) + " allowed");
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
    Result<int> n = int_in_range(*na.value(), "stem.n_angles", std::numeric_limits<int>::min(),
                                 std::numeric_limits<int>::max());
    if (!n) return n.error();
    s.n_angles = n.value();
  } else if (rj.is_array() && !rj.empty() && rj[0].is_array()) {
    s.n_angles = static_cast<int>(rj[0].size());
  }
  if (s.n_angles < 3) return Error("stem.n_angles", "must be at least 3");
  if (s.n_angles > lim::kMaxAngles)
    return Error("stem.n_angles", std::to_string(s.n_angles) + " is outside " +
                                      std::to_string(lim::kMinAngles) + "-" +
                                      std::to_string(lim::kMaxAngles));
  Result<std::vector<std::vector<double>>> rad =
      rows_at(rj, "stem.radius", s.pith.size(), s.n_angles);
  if (!rad) return rad.error();
  s.radius = std::move(rad).value();
  Result<const Json*> hw = member(j, p, "heartwood", false);
  if (!hw) return hw.error();
  if (hw.value()) {
    Result<std::vector<std::vector<double>>> h =
        rows_at(*hw.value(), "stem.heartwood", s.pith.size(), s.n_angles);
    if (!h) return h.error();
    s.heartwood = std::move(h).value();
  }
  Result<const Json*> bark = member(j, p, "bark_mm", false);
  if (!bark) return bark.error();
  if (bark.value()) {
    const Json& bj = *bark.value();
    if (bj.is_array() && !bj.empty() && bj.front().is_array()) {
      // A row per sample: the bark at every angle (Stem::bark), each row's median its bark_mm.
      Result<std::vector<std::vector<double>>> rows =
          rows_at(bj, "stem.bark_mm", s.pith.size(), s.n_angles);
      if (!rows) return rows.error();
      s.bark = std::move(rows).value();
      for (const std::vector<double>& row : s.bark) s.bark_mm.push_back(median(row));
    } else {
      Result<std::vector<double>> b = number_list(bj, "stem.bark_mm");
      if (!b) return b.error();
      if (b.value().size() != s.pith.size())
        return Error("stem.bark_mm", "has " + std::to_string(b.value().size()) +
                                         " values, expected one per pith sample");
      s.bark_mm = std::move(b).value();
    }
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
    Result<int> v = int_in_range(*id.value(), p + "id", std::numeric_limits<int>::min(),
                                 std::numeric_limits<int>::max());
    if (!v) return v.error();
    k.id = v.value();
  }
  struct Field {
    const char* key;
    double* dst;
  };
  const Field fields[] = {{"z0", &k.z0},
                          {"a", &k.a},
                          {"b", &k.b},
                          {"omega0", &k.omega0},
                          {"twist", &k.twist},
                          {"r_dead", &k.r_dead},
                          {"r_end", &k.r_end},
                          {"d_dead", &k.diameter.d_dead},
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
    Result<int> v = int_in_range(j["support"], p + "support", 0, std::numeric_limits<int>::max());
    if (!v) return v.error();
    k.support = v.value();
  }
  return k;
}

// "scanner_frame": {"origin_mm": [x, y, z], "row_dir": [..], "col_dir": [..], "slice_dir": [..],
// "z0_mm": z, "z_dir": 1}; slice_dir is written for coronal and sagittal scans only, so that an
// axial scan's file stays as it was before the key existed; absent, it reads as (0, 0, z_dir).
// The values are range-checked by validate().
Result<ScannerFrame> parse_scanner_frame(const Json& j) {
  const std::string p = "scanner_frame.";
  if (!j.is_object())
    return Error("scanner_frame", std::string("expected an object, got ") + type_name(j));
  ScannerFrame f;
  bool has_slice_dir = false;
  for (auto [key, dst] : {std::pair{"origin_mm", &f.origin_mm}, std::pair{"row_dir", &f.row_dir},
                          std::pair{"col_dir", &f.col_dir}, std::pair{"slice_dir", &f.slice_dir}}) {
    const bool optional = dst == &f.slice_dir;
    Result<const Json*> m = member(j, p, key, !optional);
    if (!m) return m.error();
    if (m.value() == nullptr) continue;
    has_slice_dir = has_slice_dir || optional;
    Result<std::vector<double>> v = number_list(*m.value(), p + key);
    if (!v) return v.error();
    if (v.value().size() != 3)
      return Error(p + key, "has " + std::to_string(v.value().size()) + " values, expected 3");
    *dst = Vec3{v.value()[0], v.value()[1], v.value()[2]};
  }
  Result<double> z0 = number_at(j, p, "z0_mm");
  if (!z0) return z0.error();
  f.z0_mm = z0.value();
  Result<double> zd = number_at(j, p, "z_dir");
  if (!zd) return zd.error();
  f.z_dir = zd.value();
  if (!has_slice_dir) f.slice_dir = {0, 0, f.z_dir < 0 ? -1.0 : 1.0};  // z_dir checked later
  return f;
}

// A list of at most kMaxQaLines strings of at most kMaxQaLineChars each.
Result<std::vector<std::string>> qa_lines(const Json& obj, const std::string& path,
                                          const char* key) {
  std::vector<std::string> out;
  Result<const Json*> m = member(obj, path, key, false);
  if (!m) return m.error();
  if (!m.value()) return out;
  const Json& a = *m.value();
  if (!a.is_array())
    return Error(path + key, std::string("expected an array, got ") + type_name(a));
  if (a.size() > static_cast<size_t>(lim::kMaxQaLines))
    return Error(path + key, "has " + std::to_string(a.size()) + " lines, more than the " +
                                 std::to_string(lim::kMaxQaLines) + " allowed");
  for (size_t i = 0; i < a.size(); ++i) {
    const std::string w = path + key + "[" + std::to_string(i) + "]";
    if (!a[i].is_string())
      return Error(w, std::string("expected a string, got ") + type_name(a[i]));
    std::string s = a[i].get<std::string>();
    if (s.size() > lim::kMaxQaLineChars)
      return Error(w, "longer than " + std::to_string(lim::kMaxQaLineChars) + " characters");
    out.push_back(std::move(s));
  }
  return out;
}

// "qa": {"trusted": true, "warnings": [...], "stages": [{"stage": "pith", "ok": true,
// "confidence": 0.93, "notes": [...]}, ...]}.
Result<ScanQa> parse_qa(const Json& j) {
  const std::string p = "qa.";
  if (!j.is_object()) return Error("qa", std::string("expected an object, got ") + type_name(j));
  ScanQa q;
  Result<const Json*> t = member(j, p, "trusted");
  if (!t) return t.error();
  if (!t.value()->is_boolean())
    return Error(p + "trusted",
                 std::string("expected true or false, got ") + type_name(*t.value()));
  q.trusted = t.value()->get<bool>();
  if (auto c = j.find("scan_class"); c != j.end()) {
    if (!c->is_string() || (c->get<std::string>() != "fine" && c->get<std::string>() != "coarse"))
      return Error(p + "scan_class", "expected \"fine\" or \"coarse\"");
    q.scan_class = c->get<std::string>();
  }
  Result<std::vector<std::string>> w = qa_lines(j, p, "warnings");
  if (!w) return w.error();
  q.warnings = std::move(w).value();
  Result<const Json*> st = member(j, p, "stages", false);
  if (!st) return st.error();
  if (st.value()) {
    const Json& a = *st.value();
    if (!a.is_array()) return Error(p + "stages", "expected an array");
    if (a.size() > static_cast<size_t>(lim::kMaxQaStages))
      return Error(p + "stages", "has " + std::to_string(a.size()) + " stages, more than the " +
                                     std::to_string(lim::kMaxQaStages) + " allowed");
    for (size_t i = 0; i < a.size(); ++i) {
      const std::string sp = p + "stages[" + std::to_string(i) + "].";
      if (!a[i].is_object()) return Error(sp.substr(0, sp.size() - 1), "expected an object");
      ScanQa::Stage s;
      Result<std::string> name = string_at(a[i], sp, "stage", true);
      if (!name) return name.error();
      if (name.value().size() > lim::kMaxQaLineChars) return Error(sp + "stage", "too long");
      s.name = name.value();
      Result<const Json*> ok = member(a[i], sp, "ok");
      if (!ok) return ok.error();
      if (!ok.value()->is_boolean()) return Error(sp + "ok", "expected true or false");
      s.ok = ok.value()->get<bool>();
      Result<double> c = number_at(a[i], sp, "confidence");
      if (!c) return c.error();
      if (Status r = check_range(c.value(), sp + "confidence", 0.0, 1.0, ""); !r) return r.error();
      s.confidence = c.value();
      Result<std::vector<std::string>> n = qa_lines(a[i], sp, "notes");
      if (!n) return n.error();
      s.notes = std::move(n).value();
      q.stages.push_back(std::move(s));
    }
  }
  return q;
}

}  // namespace

static Json qa_to_json(const ScanQa& q) {
  Json j;
  j["trusted"] = q.trusted;
  if (!q.scan_class.empty()) j["scan_class"] = q.scan_class;
  j["warnings"] = q.warnings;
  Json st = Json::array();
  for (const ScanQa::Stage& s : q.stages)
    st.push_back(
        {{"stage", s.name}, {"ok", s.ok}, {"confidence", s.confidence}, {"notes", s.notes}});
  j["stages"] = std::move(st);
  return j;
}

std::string qa_json_text(const ScanQa& qa) { return qa_to_json(qa).dump(); }

Result<ScanQa> qa_from_json_text(const std::string& text) {
  try {
    return parse_qa(Json::parse(text));
  } catch (const nlohmann::json::exception& e) {
    return Error("qa", std::string("not readable: ") + e.what());
  }
}

namespace {

Json frame_to_json(const ScannerFrame& f) {
  Json fj;
  fj["origin_mm"] = {f.origin_mm.x, f.origin_mm.y, f.origin_mm.z};
  fj["row_dir"] = {f.row_dir.x, f.row_dir.y, f.row_dir.z};
  fj["col_dir"] = {f.col_dir.x, f.col_dir.y, f.col_dir.z};
  if (!f.axial()) fj["slice_dir"] = {f.slice_dir.x, f.slice_dir.y, f.slice_dir.z};
  fj["z0_mm"] = f.z0_mm;
  fj["z_dir"] = f.z_dir;
  return fj;
}

}  // namespace

std::string scanner_frame_json_text(const ScannerFrame& f) { return frame_to_json(f).dump(); }

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
  // The bark at every angle where it is known (a row per sample, like radius), else one figure
  // per sample.
  if (!log.stem.bark.empty())
    stem["bark_mm"] = rows_to_json(log.stem.bark);
  else if (!log.stem.bark_mm.empty())
    stem["bark_mm"] = log.stem.bark_mm;
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
  if (log.scanner_frame) j["scanner_frame"] = frame_to_json(*log.scanner_frame);
  if (log.qa) j["qa"] = qa_to_json(*log.qa);
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

namespace {

// nlohmann reports a number too large for a double ("number overflow parsing '1e999'") without
// its offset: the line is found from the token it quotes.
Error overflow_error(const std::string& text, const std::string& what) {
  const size_t a = what.find('\''), b = what.rfind('\'');
  const std::string token = a != std::string::npos && b > a ? what.substr(a + 1, b - a - 1) : "";
  const size_t at = token.empty() ? std::string::npos : text.find(token);
  const std::string where = at == std::string::npos ? "JSON" : line_of(text, at + 1);
  return Error(where, "the number " + (token.empty() ? std::string() : token + " ") +
                          "does not fit a double");
}

Result<LogModel> model_from_json(const Json& j);

}  // namespace

Result<LogModel> log_from_json(const std::string& text) {
  Json j;
  try {
    j = Json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is the 1-based offset of the problem.
    return Error(line_of(text, e.byte), "malformed JSON");
  } catch (const nlohmann::json::out_of_range& e) {
    return overflow_error(text, e.what());
  } catch (const nlohmann::json::exception& e) {
    return Error("JSON", std::string("not readable: ") + e.what());
  }
  // The accessors check types before they convert; this is the net under them, so that no
  // document can end a command with an uncaught exception.
  try {
    return model_from_json(j);
  } catch (const nlohmann::json::exception& e) {
    return Error("JSON", std::string("not readable: ") + e.what());
  }
}

namespace {

Result<LogModel> model_from_json(const Json& j) {
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
  if (knots.value()->size() > static_cast<size_t>(lim::kMaxKnots))
    return Error("knots", "has " + std::to_string(knots.value()->size()) +
                              " knots, more than the " + std::to_string(lim::kMaxKnots) +
                              " allowed (a real log has at most a few hundred)");
  for (size_t i = 0; i < knots.value()->size(); ++i) {
    Result<Knot> k = parse_knot((*knots.value())[i], i);
    if (!k) return k.error();
    log.knots.push_back(std::move(k).value());
  }
  Result<const Json*> frame = member(j, "", "scanner_frame", false);
  if (!frame) return frame.error();
  if (frame.value()) {
    Result<ScannerFrame> f = parse_scanner_frame(*frame.value());
    if (!f) return f.error();
    log.scanner_frame = f.value();
  }
  Result<const Json*> qa = member(j, "", "qa", false);
  if (!qa) return qa.error();
  if (qa.value()) {
    Result<ScanQa> q = parse_qa(*qa.value());
    if (!q) return q.error();
    log.qa = std::move(q).value();
  }
  Status v = validate(log);
  if (!v) return v.error();
  return log;
}

}  // namespace

namespace {

std::string at(const std::string& key, size_t i) { return key + "[" + std::to_string(i) + "]"; }
std::string at(const std::string& key, size_t i, size_t k) { return at(at(key, i), k); }

// Sample counts first: they bound every loop below and every grid a user of the model allocates.
Status validate_extent(const Stem& s) {
  if (!(s.dz_mm > 0)) return Error("stem.dz_mm", "must be positive");
  if (Status st = check_range(s.dz_mm, "stem.dz_mm", lim::kMinDzMm, lim::kMaxDzMm, "mm"); !st)
    return st;
  if (Status st = check_range(s.z0_mm, "stem.z0_mm", -lim::kMaxAbsZMm, lim::kMaxAbsZMm, "mm"); !st)
    return st;
  if (s.pith.empty()) return Error("stem.pith", "is empty: a log needs at least one stem sample");
  if (s.pith.size() > static_cast<size_t>(lim::kMaxSlices))
    return Error("stem.pith", "has " + std::to_string(s.pith.size()) + " samples, more than the " +
                                  std::to_string(lim::kMaxSlices) + " allowed");
  if (s.length_mm() > lim::kMaxLengthMm)
    return Error("stem", "length " + num(s.length_mm()) + " mm (" + std::to_string(s.pith.size()) +
                             " samples × dz_mm " + num(s.dz_mm) + ") is outside 0-" +
                             num(lim::kMaxLengthMm) + " mm");
  if (s.n_angles < 3) return Error("stem.n_angles", "must be at least 3");
  if (s.n_angles > lim::kMaxAngles)
    return Error("stem.n_angles", std::to_string(s.n_angles) + " is outside " +
                                      std::to_string(lim::kMinAngles) + "-" +
                                      std::to_string(lim::kMaxAngles));
  const long long values = static_cast<long long>(s.pith.size()) * s.n_angles;
  if (values > lim::kMaxStemValues)
    return Error("stem", std::to_string(s.pith.size()) + " samples × " +
                             std::to_string(s.n_angles) + " angles = " + std::to_string(values) +
                             " radii, more than the " + std::to_string(lim::kMaxStemValues) +
                             " allowed");
  return Status::Ok();
}

Status validate_stem(const Stem& s) {
  if (Status st = validate_extent(s); !st) return st;
  for (size_t i = 0; i < s.pith.size(); ++i) {
    const Vec2 p = s.pith[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y))
      return Error(at("stem.pith", i), "not a finite position");
    for (double v : {p.x, p.y})
      if (std::abs(v) > lim::kMaxAbsPithMm)
        return Error(at("stem.pith", i), outside(v, -lim::kMaxAbsPithMm, lim::kMaxAbsPithMm, "mm"));
  }
  if (s.radius.size() != s.pith.size())
    return Error("stem.radius", "needs one row per pith sample");
  for (size_t i = 0; i < s.radius.size(); ++i) {
    if (static_cast<int>(s.radius[i].size()) != s.n_angles)
      return Error(at("stem.radius", i), "needs n_angles values");
    for (size_t k = 0; k < s.radius[i].size(); ++k) {
      const double r = s.radius[i][k];
      if (!(r > 0) || !std::isfinite(r))
        return Error(at("stem.radius", i, k), "radius must be a positive finite number");
      if (r > lim::kMaxRadiusMm)
        return Error(at("stem.radius", i, k), outside(r, 0, lim::kMaxRadiusMm, "mm"));
    }
  }
  if (s.has_heartwood()) {
    if (s.heartwood.size() != s.pith.size())
      return Error("stem.heartwood", "needs one row per pith sample");
    for (size_t i = 0; i < s.heartwood.size(); ++i)
      for (size_t k = 0; k < s.heartwood[i].size(); ++k) {
        const double h = s.heartwood[i][k];
        if (h < 0) return Error(at("stem.heartwood", i, k), "must not be negative");
        // The value's name only for a message: building it for every value cost more than the
        // rest of the check (a 4 m log's 290 000 values on every read and write of log.json).
        if (!in_range(h, 0, lim::kMaxRadiusMm))
          return check_range(h, at("stem.heartwood", i, k), 0, lim::kMaxRadiusMm, "mm");
      }
  }
  if (!s.bark_mm.empty() && s.bark_mm.size() != s.pith.size())
    return Error("stem.bark_mm", "needs one value per pith sample");
  for (size_t i = 0; i < s.bark_mm.size(); ++i)
    if (!in_range(s.bark_mm[i], 0, lim::kMaxBarkMm))
      return check_range(s.bark_mm[i], at("stem.bark_mm", i), 0, lim::kMaxBarkMm, "mm");
  if (!s.bark.empty()) {
    if (s.bark.size() != s.pith.size())
      return Error("stem.bark_mm", "needs one row per pith sample");
    for (size_t i = 0; i < s.bark.size(); ++i) {
      if (static_cast<int>(s.bark[i].size()) != s.n_angles)
        return Error(at("stem.bark_mm", i), "needs n_angles values");
      for (size_t k = 0; k < s.bark[i].size(); ++k)
        if (!in_range(s.bark[i][k], 0, lim::kMaxBarkMm))
          return check_range(s.bark[i][k], at("stem.bark_mm", i, k), 0, lim::kMaxBarkMm, "mm");
    }
  }
  return Status::Ok();
}

Status validate_knot(const Knot& k, const std::string& w) {
  for (double v : {k.z0, k.a, k.b, k.omega0, k.twist, k.r_dead, k.r_end, k.diameter.d_dead,
                   k.diameter.exponent})
    if (!std::isfinite(v)) return Error(w, "has a non-finite parameter");
  if (!(k.r_end > 0))
    return Error(w + ".r_end", "must be positive (the knot's length from the pith)");
  if (k.r_dead < 0) return Error(w + ".r_dead", "must not be negative");
  if (k.diameter.d_dead < 0) return Error(w + ".d_dead", "must not be negative");
  if (!(k.diameter.exponent > 0)) return Error(w + ".d_exp", "must be positive");
  struct Bound {
    const char* key;
    double v, lo, hi;
    const char* unit;
  };
  const Bound bounds[] = {
      {"z0", k.z0, -lim::kMaxAbsZMm, lim::kMaxAbsZMm, "mm"},
      {"a", k.a, -lim::kMaxAbsA, lim::kMaxAbsA, "mm/√mm"},
      {"b", k.b, -lim::kMaxAbsB, lim::kMaxAbsB, "mm/mm"},
      {"omega0", k.omega0, -lim::kMaxAbsOmegaRad, lim::kMaxAbsOmegaRad, "rad"},
      {"twist", k.twist, -lim::kMaxAbsTwist, lim::kMaxAbsTwist, "rad per ln(mm)"},
      {"r_dead", k.r_dead, 0, lim::kMaxKnotLengthMm, "mm"},
      {"r_end", k.r_end, 0, lim::kMaxKnotLengthMm, "mm"},
      {"d_dead", k.diameter.d_dead, 0, lim::kMaxKnotDiameterMm, "mm"},
      {"d_exp", k.diameter.exponent, 0, lim::kMaxExponent, ""},
      {"fit_rms_mm", k.fit_rms_mm, 0, lim::kMaxFitRmsMm, "mm"},
  };
  for (const Bound& b : bounds)
    if (Status st = check_range(b.v, w + "." + b.key, b.lo, b.hi, b.unit); !st) return st;
  if (k.support < 0) return Error(w + ".support", "must not be negative");
  return Status::Ok();
}

// The frame's origin lies where heights may (the scanner's origin is metres from the log at
// most); its directions are unit vectors at right angles, as a CT file's direction cosines are
// (to the 1e-3 scanners round them to), and z_dir is a sign. For a coronal or sagittal frame it
// is slice_dir's sign along the scanner axis slice_dir runs along: the two say the same, and a
// file that disagrees with itself is refused rather than one of them believed (an axial frame's
// z is z_dir alone; its slice_dir is not written).
Status validate_frame(const ScannerFrame& f) {
  const std::string w = "scanner_frame.";
  for (double v : {f.origin_mm.x, f.origin_mm.y, f.origin_mm.z})
    if (Status st = check_range(v, w + "origin_mm", -lim::kMaxAbsZMm, lim::kMaxAbsZMm, "mm"); !st)
      return st;
  if (Status st = check_range(f.z0_mm, w + "z0_mm", -lim::kMaxAbsZMm, lim::kMaxAbsZMm, "mm"); !st)
    return st;
  for (auto [key, d] : {std::pair{"row_dir", f.row_dir}, std::pair{"col_dir", f.col_dir},
                        std::pair{"slice_dir", f.slice_dir}}) {
    if (!std::isfinite(d.norm()) || std::abs(d.norm() - 1) > 1e-3)
      return Error(w + key,
                   "(" + num(d.x) + ", " + num(d.y) + ", " + num(d.z) + ") is not a unit vector");
  }
  if (std::abs(dot(f.row_dir, f.col_dir)) > 1e-3)
    return Error(w + "col_dir", "is not perpendicular to row_dir");
  if (std::abs(dot(f.slice_dir, f.row_dir)) > 1e-3 || std::abs(dot(f.slice_dir, f.col_dir)) > 1e-3)
    return Error(w + "slice_dir", "is not perpendicular to row_dir and col_dir");
  if (f.z_dir != 1.0 && f.z_dir != -1.0)
    return Error(w + "z_dir", num(f.z_dir) + " must be 1 or -1");
  const double along = f.slice_axis() == 0   ? f.slice_dir.x
                       : f.slice_axis() == 1 ? f.slice_dir.y
                                             : f.slice_dir.z;
  if (!f.axial() && along * f.z_dir < 0)
    return Error(w + "z_dir", num(f.z_dir) + " points against slice_dir (" + num(f.slice_dir.x) +
                                  ", " + num(f.slice_dir.y) + ", " + num(f.slice_dir.z) + ")");
  return Status::Ok();
}

}  // namespace

Status validate(const LogModel& log) {
  if (Status st = validate_stem(log.stem); !st) return st;
  if (log.scanner_frame)
    if (Status st = validate_frame(*log.scanner_frame); !st) return st;
  if (log.knots.size() > static_cast<size_t>(lim::kMaxKnots))
    return Error("knots", std::to_string(log.knots.size()) + " knots, more than the " +
                              std::to_string(lim::kMaxKnots) +
                              " allowed (a real log has at most a few hundred)");
  for (size_t i = 0; i < log.knots.size(); ++i)
    if (Status st = validate_knot(log.knots[i], at("knots", i)); !st) return st;
  return Status::Ok();
}

Result<LogModel> read_log_json(const std::filesystem::path& path) {
  Result<std::string> text = read_text_file(path, lim::kMaxFileBytes);
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
