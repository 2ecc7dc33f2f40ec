// JSON text to a document for the sawing file readers: every way the parser can refuse a text
// (malformed, a number out of range) becomes one error naming the line, never an exception.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <string>

#include "sawyer/core/result.h"

namespace sawyer::sawing {

// Pattern, grading and price files are a few kB (the bundled ones 1-4 kB); 1 MiB holds any
// hand-written table many times over.
inline constexpr std::uintmax_t kMaxDataFileBytes = std::uintmax_t{1} << 20;

// The text of a pattern, grading or price file: a regular file (not a FIFO, a device or a
// folder) of at most kMaxDataFileBytes, checked before it is read; else one error naming it.
Result<std::string> read_data_file(const std::filesystem::path& path);

Result<nlohmann::ordered_json> parse_json_text(const std::string& text);

// The same for a sawing file: a JSON object whose "format" is `format_tag`, else an error naming
// the top level or the format key.
Result<nlohmann::ordered_json> parse_format_json(const std::string& text, const char* format_tag);

}  // namespace sawyer::sawing
