// Prices per grade and dimension, board and log value, and the "sawyer-prices/1" reader.
#include "sawyer/sawing/value.h"
#include "json_text.h"

#include <nlohmann/json.hpp>

#include <cmath>

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
