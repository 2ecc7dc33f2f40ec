// The user pattern file, "sawyer-pattern/1" (docs/sawing.md).
#include "pattern_json.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <sstream>

#include "json_text.h"
#include "sawyer/core/file_util.h"
#include "sawyer/sawing/pattern.h"

namespace sawyer::sawing {

namespace {

using Json = nlohmann::ordered_json;
constexpr const char* kPatternFormatTag = "sawyer-pattern/1";

}  // namespace

Status number_at(const Json& obj, const std::string& where, const char* key, bool required,
                 double* dst) {
  const std::string at = where.empty() ? key : where + "." + key;
  auto it = obj.find(key);
  if (it == obj.end()) return required ? Status(Error(at, "missing")) : Status::Ok();
  if (!it->is_number()) return Error(at, "expected a number");
  const double v = it->get<double>();
  if (!std::isfinite(v)) return Error(at, "not finite");
  *dst = v;
  return Status::Ok();
}

Result<Pattern> pattern_from_json_object(const Json& j) {
  Pattern p;
  if (auto it = j.find("name"); it != j.end()) {
    if (!it->is_string()) return Error("name", "expected a string");
    p.name = it->get<std::string>();
  }
  if (Status s = number_at(j, "", "kerf_mm", false, &p.kerf_mm); !s) return s.error();
  if (auto it = j.find("wane"); it != j.end()) {
    if (!it->is_object()) return Error("wane", "expected an object");
    for (auto [key, dst] : {std::pair{"max_face_fraction", &p.wane.max_face_fraction},
                            std::pair{"max_edge_fraction", &p.wane.max_edge_fraction},
                            std::pair{"min_length_mm", &p.wane.min_length_mm},
                            std::pair{"length_step_mm", &p.wane.length_step_mm}})
      if (Status s = number_at(*it, "wane", key, false, dst); !s) return s.error();
  }
  if (auto it = j.find("standard_widths_mm"); it != j.end()) {
    if (!it->is_array()) return Error("standard_widths_mm", "expected an array of numbers");
    p.standard_widths_mm.clear();
    for (size_t i = 0; i < it->size(); ++i) {
      const Json& w = (*it)[i];
      if (!w.is_number())
        return Error("standard_widths_mm[" + std::to_string(i) + "]", "expected a number");
      p.standard_widths_mm.push_back(w.get<double>());
    }
  }
  auto boards = j.find("boards");
  if (boards == j.end()) return Error("boards", "missing");
  if (!boards->is_array()) return Error("boards", "expected an array");
  if (boards->size() > static_cast<size_t>(kMaxPatternBoards))
    return Error("boards", "has " + std::to_string(boards->size()) + " boards, more than the " +
                               std::to_string(kMaxPatternBoards) +
                               " allowed (a real pattern has a few dozen)");
  for (size_t i = 0; i < boards->size(); ++i) {
    const std::string where = "boards[" + std::to_string(i) + "]";
    const Json& o = (*boards)[i];
    if (!o.is_object()) return Error(where, "expected an object");
    BoardSpec b;
    if (auto it = o.find("name"); it != o.end()) {
      if (!it->is_string()) return Error(where + ".name", "expected a string");
      b.name = it->get<std::string>();
    }
    for (auto [key, dst, req] :
         {std::tuple{"u_mm", &b.u_mm, true}, std::tuple{"v_mm", &b.v_mm, true},
          std::tuple{"thickness_mm", &b.thickness_mm, true},
          std::tuple{"width_mm", &b.width_mm, true}})
      if (Status s = number_at(o, where, key, req, dst); !s) return s.error();
    if (auto it = o.find("thickness_axis"); it != o.end()) {
      if (!it->is_string() || (*it != "u" && *it != "v"))
        return Error(where + ".thickness_axis", "expected \"u\" or \"v\"");
      b.thickness_axis = *it == "u" ? ThicknessAxis::kU : ThicknessAxis::kV;
    }
    if (auto it = o.find("edged"); it != o.end()) {
      if (!it->is_boolean()) return Error(where + ".edged", "expected true or false");
      b.edged = it->get<bool>();
    }
    p.boards.push_back(b);
  }
  if (Status s = p.validate(); !s) return s.error();
  return p;
}

Json pattern_json_object(const Pattern& p) {
  Json j;
  j["name"] = p.name;
  j["kerf_mm"] = p.kerf_mm;
  j["wane"] = {{"max_face_fraction", p.wane.max_face_fraction},
               {"max_edge_fraction", p.wane.max_edge_fraction},
               {"min_length_mm", p.wane.min_length_mm},
               {"length_step_mm", p.wane.length_step_mm}};
  j["standard_widths_mm"] = p.standard_widths_mm;
  Json boards = Json::array();
  for (const BoardSpec& b : p.boards)
    boards.push_back({{"name", b.name},
                      {"u_mm", b.u_mm},
                      {"v_mm", b.v_mm},
                      {"thickness_mm", b.thickness_mm},
                      {"width_mm", b.width_mm},
                      {"thickness_axis", b.thickness_axis == ThicknessAxis::kU ? "u" : "v"},
                      {"edged", b.edged}});
  j["boards"] = std::move(boards);
  return j;
}

Result<Pattern> pattern_from_json(const std::string& text) {
  Result<Json> parsed = parse_format_json(text, kPatternFormatTag);
  if (!parsed) return parsed.error();
  return pattern_from_json_object(parsed.value());
}

Json pattern_file_json(const Pattern& p) {
  Json j;
  j["format"] = kPatternFormatTag;
  const Json body = pattern_json_object(p);  // items() refers to it: not a temporary
  for (const auto& [key, value] : body.items()) j[key] = value;
  return j;
}

std::string pattern_to_json(const Pattern& p) { return pattern_file_json(p).dump(2) + "\n"; }

Result<Pattern> read_pattern_file(const std::filesystem::path& path) {
  Result<std::string> text = read_data_file(path);
  if (!text) return text.error();
  Result<Pattern> p = pattern_from_json(text.value());
  if (!p) return p.error().with_context(path.string());
  return p;
}

Status write_pattern_file(const std::filesystem::path& path, const Pattern& p) {
  return write_text_file_atomic(path, pattern_to_json(p));
}

}  // namespace sawyer::sawing
