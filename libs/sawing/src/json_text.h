// JSON text to a document for the sawing file readers: every way the parser can refuse a text
// (malformed, a number out of range) becomes one error naming the line, never an exception.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "sawyer/core/result.h"

namespace sawyer::sawing {

Result<nlohmann::ordered_json> parse_json_text(const std::string& text);

// The same for a sawing file: a JSON object whose "format" is `format_tag`, else an error naming
// the top level or the format key.
Result<nlohmann::ordered_json> parse_format_json(const std::string& text, const char* format_tag);

}  // namespace sawyer::sawing
