// The shared text and number helpers of text_parse.h: trimming, case, key/value header lines,
// the strict (from_chars) and lenient (strtod) number parsers, and number formatting.
#include "text_parse.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <system_error>

namespace sawyer::ct::detail {

std::string trim(std::string_view s, std::string_view pad) {
  const size_t b = s.find_first_not_of(pad);
  if (b == std::string_view::npos) return std::string();
  const size_t e = s.find_last_not_of(pad);
  return std::string(s.substr(b, e - b + 1));
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::optional<std::pair<std::string, std::string>> split_key_value(const std::string& line,
                                                                   std::string_view separator) {
  const size_t at = line.find(separator);
  if (at == std::string::npos) return std::nullopt;
  return std::pair{line.substr(0, at), line.substr(at + separator.size())};
}

std::optional<double> parse_double(std::string s, std::string_view pad) {
  s = trim(s, pad);
  if (!s.empty() && s[0] == '+') s.erase(0, 1);
  if (s.empty()) return std::nullopt;
  double v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<long long> parse_int(std::string s, std::string_view pad) {
  s = trim(s, pad);
  if (!s.empty() && s[0] == '+') s.erase(0, 1);
  long long v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

std::optional<std::vector<double>> parse_number_list(const std::string& s, char separator, size_t n,
                                                     std::string_view pad) {
  std::vector<double> out;
  size_t start = 0;
  while (true) {
    const size_t end = s.find(separator, start);
    const auto v = parse_double(s.substr(start, end == std::string::npos ? end : end - start), pad);
    if (!v) return std::nullopt;
    out.push_back(*v);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  if (out.size() != n) return std::nullopt;
  return out;
}

bool parse_numbers(const std::string& text, std::vector<double>& out) {
  out.clear();
  std::istringstream in(text);
  std::string tok;
  while (in >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end != tok.c_str() + tok.size() || !std::isfinite(v)) return false;
    out.push_back(v);
  }
  return true;
}

std::optional<double> parse_leading_double(const std::string& s) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

std::string num6(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace sawyer::ct::detail
