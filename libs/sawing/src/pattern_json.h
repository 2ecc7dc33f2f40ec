// A pattern as a JSON object, without the file's "format" key: the body of a sawyer-pattern/1
// file, and of each inline pattern of a sawyer-pattern-set/1 file (docs/sawing.md). Errors name
// the key ("boards[2].thickness_mm: expected a number") or the pattern's board (validate()).
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "sawyer/core/result.h"
#include "sawyer/sawing/pattern.h"

namespace sawyer::sawing {

// Reads the pattern's keys (name, kerf_mm, wane, standard_widths_mm, boards) and validates it.
Result<Pattern> pattern_from_json_object(const nlohmann::ordered_json& j);
// Every key of the pattern, in the file's order.
nlohmann::ordered_json pattern_json_object(const Pattern& p);
// The whole sawyer-pattern/1 file: "format", then pattern_json_object's keys.
nlohmann::ordered_json pattern_file_json(const Pattern& p);

// Reads the number at obj[key] into *dst when it is there (missing: an error when `required`);
// errors name "<where>.<key>" (`where` empty: the key alone) and say a number was expected or
// that it is not finite.
Status number_at(const nlohmann::ordered_json& obj, const std::string& where, const char* key,
                 bool required, double* dst);

}  // namespace sawyer::sawing
