// See json_text.h.
#include "json_text.h"

#include "sawyer/core/file_util.h"

namespace sawyer::sawing {
Result<std::string> read_data_file(const std::filesystem::path& path) {
  return read_text_file(path, kMaxDataFileBytes);
}

Result<nlohmann::ordered_json> parse_json_text(const std::string& text) {
  try {
    return nlohmann::ordered_json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    return Error(line_of(text, e.byte), "malformed JSON");
  } catch (const nlohmann::json::out_of_range&) {
    return Error("JSON", "a number out of range");
  } catch (const nlohmann::json::exception& e) {
    return Error("JSON", std::string("not readable: ") + e.what());
  }
}

Result<nlohmann::ordered_json> parse_format_json(const std::string& text, const char* format_tag) {
  Result<nlohmann::ordered_json> parsed = parse_json_text(text);
  if (!parsed) return parsed.error();
  const nlohmann::ordered_json& j = parsed.value();
  if (!j.is_object()) return Error("top level", "expected a JSON object");
  auto fmt = j.find("format");
  if (fmt == j.end() || !fmt->is_string())
    return Error("format", std::string("missing (expected \"") + format_tag + "\")");
  if (fmt->get<std::string>() != format_tag)
    return Error("format",
                 "is \"" + fmt->get<std::string>() + "\", expected \"" + format_tag + "\"");
  return parsed;
}

}  // namespace sawyer::sawing
