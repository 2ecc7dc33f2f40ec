// See json_text.h.
#include "json_text.h"

namespace sawyer::sawing {
namespace {

// The 1-based line of byte offset `byte` (nlohmann counts bytes from 1).
std::string line_of(const std::string& text, size_t byte) {
  size_t line = 1;
  for (size_t i = 0; i + 1 < byte && i < text.size(); ++i)
    if (text[i] == '\n') ++line;
  return "line " + std::to_string(line);
}

}  // namespace

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

}  // namespace sawyer::sawing
