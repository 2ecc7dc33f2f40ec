// Library option names to a front end's names (see option_names.h).
#include "sawyer/core/option_names.h"

namespace sawyer {
namespace {

bool word_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

// Whether text[at, end) stands alone: not inside a longer identifier (letters, digits, '_', and
// "::" between parts; a single ':' as in "where: what" ends a word).
bool whole_word(const std::string& t, size_t at, size_t end) {
  if (at > 0 && (word_char(t[at - 1]) || (t[at - 1] == ':' && at > 1 && t[at - 2] == ':')))
    return false;
  if (end < t.size() &&
      (word_char(t[end]) || (t[end] == ':' && end + 1 < t.size() && t[end + 1] == ':')))
    return false;
  return true;
}

}  // namespace

std::string with_option_names(std::string text, std::span<const OptionName> names) {
  for (const OptionName& n : names) {
    if (n.option.empty()) continue;
    // A prefix rule takes the field name after the prefix with it, '_' turned to '-'.
    const bool prefix = n.option.size() > 2 && n.option.ends_with("::");
    size_t at = 0;
    while ((at = text.find(n.option, at)) != std::string::npos) {
      const size_t start = at + n.option.size();
      size_t end = start;
      if (prefix)
        while (end < text.size() && word_char(text[end])) ++end;
      if ((prefix && end == start) || !whole_word(text, at, end)) {
        at = end;
        continue;
      }
      std::string to(n.name);
      for (size_t i = start; i < end; ++i) to += text[i] == '_' ? '-' : text[i];
      text.replace(at, end - at, to);
      at += to.size();
    }
  }
  return text;
}

Error with_option_names(const Error& error, std::span<const OptionName> names) {
  return Error(with_option_names(error.message(), names));
}

}  // namespace sawyer
