// The text and number helpers every CT reader and writer shares: trimming, lower case, header
// lines split into key and value, number parsing, and the number formats of messages. Internal.
//
// The number parsers are not interchangeable; each reader keeps the one it has always used:
//  - parse_double / parse_int: the whole text, after trimming `pad` and one leading '+', through
//    std::from_chars: no hex, no inf or nan, no trailing text, out of range refused. DICOM's DS
//    and IS values (with kBlanksAndNul).
//  - parse_numbers: whitespace-separated tokens, each wholly one finite std::strtod number, so
//    hex floats (0x1p3) pass and out of range is refused as not finite. MetaImage, NRRD, .vti.
//  - parse_leading_double: std::strtod from the start of the text: leading whitespace and any
//    trailing text pass. ImageJ descriptions.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace sawyer::ct::detail {

// What text headers pad values with: space, tab, CR, LF.
inline constexpr std::string_view kBlanks = " \t\r\n";
// The same and NUL, which DICOM pads UIDs (and some writers other strings) with.
inline constexpr std::string_view kBlanksAndNul{" \t\r\n\0", 5};

// `s` without the characters of `pad` at either end.
std::string trim(std::string_view s, std::string_view pad = kBlanks);

// ASCII lower case (std::tolower per byte).
std::string lower(std::string s);

// `line` split at the first `separator` into the text before and after it, neither trimmed;
// nothing when the separator is absent.
std::optional<std::pair<std::string, std::string>> split_key_value(const std::string& line,
                                                                   std::string_view separator);

// Strict parsers (see above); nothing unless all of `s` but the padding is the number.
std::optional<double> parse_double(std::string s, std::string_view pad = kBlanks);
std::optional<long long> parse_int(std::string s, std::string_view pad = kBlanks);

// Exactly n strict numbers (parse_double) separated by `separator`, or nothing.
std::optional<std::vector<double>> parse_number_list(const std::string& s, char separator, size_t n,
                                                     std::string_view pad = kBlanks);

// Whitespace-separated numbers (see above) into `out`; false on anything else.
bool parse_numbers(const std::string& text, std::vector<double>& out);

// The number `s` starts with (see above), when there is one and it is finite.
std::optional<double> parse_leading_double(const std::string& s);

// Numbers in messages. num: up to 10 significant digits (0.5, 1e+300, nan); num6: up to 6
// (printf %.6g: 0.4, 1e+300, nan); fixed: `decimals` digits after the point (printf %.*f).
std::string num(double v);
std::string num6(double v);
std::string fixed(double v, int decimals);

}  // namespace sawyer::ct::detail
