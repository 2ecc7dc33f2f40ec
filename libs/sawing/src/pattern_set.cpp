// Pattern sets and their file, "sawyer-pattern-set/1" (see pattern_set.h, docs/sawing.md).
#include "sawyer/sawing/pattern_set.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "fit_text.h"
#include "json_text.h"
#include "pattern_json.h"
#include "sawyer/core/file_util.h"

namespace sawyer::sawing {

namespace {

using Json = nlohmann::ordered_json;
constexpr const char* kPatternSetFormatTag = "sawyer-pattern-set/1";

std::string set_where(const std::string& name) {
  return name.empty() ? "pattern set" : "pattern set '" + name + "'";
}

std::string class_where(const std::string& set_name, size_t i, const DiameterClass& c) {
  return set_where(set_name) + ", class " + std::to_string(i) + " '" + c.label() + "'";
}

// Refuses a key of `obj` that is not in `allowed`; `where` names the object.
Status only_keys(const Json& obj, const std::string& where,
                 std::initializer_list<const char*> allowed) {
  for (const auto& [key, value] : obj.items()) {
    bool known = false;
    for (const char* a : allowed) known = known || key == a;
    if (!known) {
      std::string list;
      for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
      return Error(where.empty() ? key : where + "." + key, "unknown key (expected " + list + ")");
    }
  }
  return Status::Ok();
}

// A whole number at obj[key] within [lo, hi] into *dst when it is there.
Status count_at(const Json& obj, const char* key, int lo, int hi, int* dst) {
  auto it = obj.find(key);
  if (it == obj.end()) return Status::Ok();
  if (!it->is_number_integer())
    return Error(
        key, "expected a whole number from " + std::to_string(lo) + " to " + std::to_string(hi));
  const long long v = it->get<long long>();
  if (v < lo || v > hi)
    return Error(
        key, std::to_string(v) + " is outside " + std::to_string(lo) + " to " + std::to_string(hi));
  *dst = static_cast<int>(v);
  return Status::Ok();
}

// The keys every pattern entry may have besides its boards or preset parameters; copied into a
// preset's pattern after it is made.
Status common_keys(const Json& o, Pattern* p) {
  // The preset's name and boards, written out, with the entry's own keys over them: read as one
  // pattern, so the keys are checked as a pattern file's are.
  Json body = Json::object();
  body["name"] = p->name;
  for (const char* key : {"name", "kerf_mm", "wane", "standard_widths_mm"})
    if (auto it = o.find(key); it != o.end()) body[key] = *it;
  body["boards"] = pattern_json_object(*p)["boards"];
  Result<Pattern> read = pattern_from_json_object(body);
  if (!read) return read.error();
  *p = std::move(read).value();
  return Status::Ok();
}

// One pattern of a class: written out, or a bundled preset with its parameters.
Result<Pattern> pattern_entry(const Json& o) {
  if (!o.is_object()) return Error("", "expected an object (a pattern, or {\"preset\": ...})");
  auto preset = o.find("preset");
  if (preset == o.end()) {
    if (Status s =
            only_keys(o, "", {"format", "name", "kerf_mm", "wane", "standard_widths_mm", "boards"});
        !s)
      return s.error();
    if (auto f = o.find("format"); f != o.end() && *f != "sawyer-pattern/1")
      return Error("format", "expected \"sawyer-pattern/1\" or none");
    return pattern_from_json_object(o);
  }
  if (!preset->is_string() || (*preset != "2ex" && *preset != "4ex" && *preset != "tt"))
    return Error("preset", "expected \"2ex\", \"4ex\" or \"tt\"");
  Pattern p;
  double kerf = 3.0;
  if (Status s = number_at(o, "", "kerf_mm", false, &kerf); !s) return s.error();
  if (*preset == "tt") {
    if (Status s = only_keys(o, "",
                             {"preset", "name", "kerf_mm", "wane", "standard_widths_mm",
                              "board_count", "thickness_mm", "max_width_mm"});
        !s)
      return s.error();
    ThroughAndThroughOptions t;
    t.kerf_mm = kerf;
    if (Status s = count_at(o, "board_count", 1, kMaxPatternBoards, &t.boards); !s)
      return s.error();
    for (auto [key, dst] :
         {std::pair{"thickness_mm", &t.thickness_mm}, std::pair{"max_width_mm", &t.max_width_mm}})
      if (Status s = number_at(o, "", key, false, dst); !s) return s.error();
    p = through_and_through_pattern(t.boards, t.thickness_mm, t.max_width_mm, t.kerf_mm);
  } else {
    if (Status s = only_keys(
            o, "",
            {"preset", "name", "kerf_mm", "wane", "standard_widths_mm", "centre_thickness_mm",
             "centre_width_mm", "side_boards_per_side", "side_thickness_mm", "side_width_mm"});
        !s)
      return s.error();
    CantOptions c = *preset == "2ex" ? CantOptions{} : four_ex_options();
    c.kerf_mm = kerf;
    if (Status s =
            count_at(o, "side_boards_per_side", 0, kMaxPatternBoards / 2, &c.side_boards_per_side);
        !s)
      return s.error();
    for (auto [key, dst] : {std::pair{"centre_thickness_mm", &c.centre_thickness_mm},
                            std::pair{"centre_width_mm", &c.centre_width_mm},
                            std::pair{"side_thickness_mm", &c.side_thickness_mm},
                            std::pair{"side_width_mm", &c.side_width_mm}})
      if (Status s = number_at(o, "", key, false, dst); !s) return s.error();
    p = cant_pattern(c);
  }
  if (Status s = common_keys(o, &p); !s) return s.error();
  return p;
}

}  // namespace

std::string DiameterClass::label() const {
  if (!name.empty()) return name;
  return fmt("%g", min_diameter_mm) + "-" + fmt("%g", max_diameter_mm) + " mm";
}

Status PatternSet::validate() const {
  const std::string where = set_where(name);
  if (neighbour_classes < 0 || neighbour_classes > kMaxNeighbourClasses)
    return Error(where, "neighbour_classes must be 0 to " + std::to_string(kMaxNeighbourClasses));
  if (classes.empty()) return Error(where, "has no classes");
  if (classes.size() > static_cast<size_t>(kMaxPatternSetClasses))
    return Error(where, "has " + std::to_string(classes.size()) + " classes, more than the " +
                            std::to_string(kMaxPatternSetClasses) + " allowed");
  // Each name's first pattern, written out once, and where it is: a file may repeat one pattern
  // in every class (2 000 entries of 200 boards), and comparing every pair took minutes.
  struct First {
    Json written;
    std::string where;
  };
  std::map<std::string, First> seen;
  for (size_t i = 0; i < classes.size(); ++i) {
    const DiameterClass& c = classes[i];
    const std::string cw = class_where(name, i, c);
    if (!(c.min_diameter_mm >= 0) || !(c.max_diameter_mm > c.min_diameter_mm) ||
        !(c.max_diameter_mm <= kMaxBoardSizeMm))
      return Error(cw, "needs 0 <= min_diameter_mm < max_diameter_mm <= " +
                           fmt("%g", kMaxBoardSizeMm) + " mm");
    if (i > 0 && c.min_diameter_mm != classes[i - 1].max_diameter_mm)
      return Error(cw, "starts at " + fmt("%g", c.min_diameter_mm) +
                           " mm, but the class before "
                           "ends at " +
                           fmt("%g", classes[i - 1].max_diameter_mm) +
                           " mm: classes must follow each other in ascending order, without a "
                           "gap or an overlap");
    if (c.patterns.empty()) return Error(cw, "has no patterns");
    if (c.patterns.size() > static_cast<size_t>(kMaxClassPatterns))
      return Error(cw, "has " + std::to_string(c.patterns.size()) + " patterns, more than the " +
                           std::to_string(kMaxClassPatterns) + " allowed");
    for (size_t k = 0; k < c.patterns.size(); ++k) {
      const Pattern& p = c.patterns[k];
      const std::string pw = cw + ", pattern " + std::to_string(k);
      if (p.name.empty()) return Error(pw, "has no name (the files name the chosen pattern)");
      if (Status s = p.validate(); !s) return s.error().with_context(pw);
      Json written = pattern_json_object(p);
      if (auto q = seen.find(p.name); q != seen.end()) {
        if (q->second.written != written)
          return Error(pw, "'" + p.name + "' is also the name of " + q->second.where +
                               ", which saws other boards; give it another name");
        continue;
      }
      seen.emplace(p.name, First{std::move(written),
                                 "class " + std::to_string(i) + "'s pattern " + std::to_string(k)});
    }
  }
  return Status::Ok();
}

int PatternSet::class_of(double d) const {
  if (classes.empty() || !(d >= classes.front().min_diameter_mm)) return -1;
  for (size_t i = 0; i < classes.size(); ++i)
    if (d < classes[i].max_diameter_mm) return static_cast<int>(i);
  return static_cast<int>(classes.size()) - 1;
}

std::vector<PatternCandidate> PatternSet::candidates(double d) const {
  std::vector<PatternCandidate> out;
  const int own = class_of(d);
  if (own < 0) return out;
  const int n = static_cast<int>(classes.size());
  std::set<std::string> names;
  for (int i = std::max(0, own - neighbour_classes); i <= std::min(n - 1, own + neighbour_classes);
       ++i)
    for (const Pattern& p : classes[static_cast<size_t>(i)].patterns)
      if (names.insert(p.name).second) out.push_back({&p, i, i == own});
  return out;
}

std::vector<const Pattern*> PatternSet::patterns() const {
  std::vector<const Pattern*> out;
  std::set<std::string> names;
  for (const DiameterClass& c : classes)
    for (const Pattern& p : c.patterns)
      if (names.insert(p.name).second) out.push_back(&p);
  return out;
}

Result<PatternSet> pattern_set_from_json(const std::string& text) {
  Result<Json> parsed = parse_format_json(text, kPatternSetFormatTag);
  if (!parsed) return parsed.error();
  const Json& j = parsed.value();
  if (Status s = only_keys(j, "top level",
                           {"format", "name", "description", "neighbour_classes", "classes"});
      !s)
    return s.error();
  PatternSet set;
  for (auto [key, dst] :
       {std::pair{"name", &set.name}, std::pair{"description", &set.description}}) {
    auto it = j.find(key);
    if (it == j.end()) continue;
    if (!it->is_string()) return Error(key, "expected a string");
    *dst = it->get<std::string>();
  }
  const std::string where = set_where(set.name);
  if (Status s = count_at(j, "neighbour_classes", 0, kMaxNeighbourClasses, &set.neighbour_classes);
      !s)
    return s.error().with_context(where);
  auto classes = j.find("classes");
  if (classes == j.end()) return Error(where, "classes: missing");
  if (!classes->is_array()) return Error(where, "classes: expected an array");
  if (classes->size() > static_cast<size_t>(kMaxPatternSetClasses))
    return Error(where, "classes: has " + std::to_string(classes->size()) +
                            " classes, more than the " + std::to_string(kMaxPatternSetClasses) +
                            " allowed");
  for (size_t i = 0; i < classes->size(); ++i) {
    const Json& o = (*classes)[i];
    const std::string cw0 = where + ", class " + std::to_string(i);
    if (!o.is_object()) return Error(cw0, "expected an object");
    DiameterClass c;
    if (auto it = o.find("name"); it != o.end()) {
      if (!it->is_string()) return Error(cw0, "name: expected a string");
      c.name = it->get<std::string>();
    }
    if (Status s = only_keys(o, "", {"name", "min_diameter_mm", "max_diameter_mm", "patterns"}); !s)
      return s.error().with_context(cw0);
    for (auto [key, dst] : {std::pair{"min_diameter_mm", &c.min_diameter_mm},
                            std::pair{"max_diameter_mm", &c.max_diameter_mm}})
      if (Status s = number_at(o, "", key, true, dst); !s) return s.error().with_context(cw0);
    const std::string cw = class_where(set.name, i, c);
    auto patterns = o.find("patterns");
    if (patterns == o.end()) return Error(cw, "patterns: missing");
    if (!patterns->is_array()) return Error(cw, "patterns: expected an array");
    if (patterns->size() > static_cast<size_t>(kMaxClassPatterns))
      return Error(cw, "patterns: has " + std::to_string(patterns->size()) +
                           " patterns, more than the " + std::to_string(kMaxClassPatterns) +
                           " allowed");
    for (size_t k = 0; k < patterns->size(); ++k) {
      Result<Pattern> p = pattern_entry((*patterns)[k]);
      if (!p) return p.error().with_context(cw + ", pattern " + std::to_string(k));
      c.patterns.push_back(std::move(p).value());
    }
    set.classes.push_back(std::move(c));
  }
  if (Status s = set.validate(); !s) return s.error();
  return set;
}

std::string pattern_set_to_json(const PatternSet& set) {
  Json j;
  j["format"] = kPatternSetFormatTag;
  j["name"] = set.name;
  if (!set.description.empty()) j["description"] = set.description;
  j["neighbour_classes"] = set.neighbour_classes;
  Json classes = Json::array();
  for (const DiameterClass& c : set.classes) {
    Json o;
    if (!c.name.empty()) o["name"] = c.name;
    o["min_diameter_mm"] = c.min_diameter_mm;
    o["max_diameter_mm"] = c.max_diameter_mm;
    Json patterns = Json::array();
    for (const Pattern& p : c.patterns) patterns.push_back(pattern_json_object(p));
    o["patterns"] = std::move(patterns);
    classes.push_back(std::move(o));
  }
  j["classes"] = std::move(classes);
  return j.dump(2) + "\n";
}

Result<PatternSet> read_pattern_set_file(const std::filesystem::path& path) {
  Result<std::string> text = read_data_file(path);
  if (!text) return text.error();
  Result<PatternSet> s = pattern_set_from_json(text.value());
  if (!s) return s.error().with_context(path.string());
  return s;
}

Status write_pattern_set_file(const std::filesystem::path& path, const PatternSet& set) {
  return write_text_file_atomic(path, pattern_set_to_json(set));
}

}  // namespace sawyer::sawing
