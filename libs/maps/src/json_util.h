// JSON helpers shared by the maps readers and writers: parse a file, fetch typed keys with
// errors that name the file and key, dump without letting nlohmann-json's exceptions escape.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sawyer/core/result.h"

namespace sawyer::maps_detail {

using Json = nlohmann::ordered_json;

// Reads and parses `path`. Errors: missing or unreadable file, malformed JSON (with the byte
// offset nlohmann-json reports).
Result<Json> read_json_file(const std::filesystem::path& path);

// Serialises `j` (indented by `indent`, or compact when negative) and writes it to `path`.
// Invalid UTF-8 in strings becomes an error naming `shown`, not an exception.
Status write_json_file(const std::filesystem::path& path, const Json& j, int indent,
                       const std::string& shown);

// Typed access to obj[key]; errors read "<file>: <key>: <what is wrong>". `file` is the path
// string shown to the user; `prefix` is a key path prefix such as "knots[3].".
class JsonReader {
 public:
  JsonReader(const Json& obj, std::string file, std::string prefix = {})
      : obj_(obj), file_(std::move(file)), prefix_(std::move(prefix)) {}

  bool has(const char* key) const { return obj_.is_object() && obj_.contains(key); }
  Result<double> number(const char* key) const;      // finite number
  Result<long long> integer(const char* key) const;  // integer-valued number
  Result<bool> boolean(const char* key) const;
  Result<std::string> string(const char* key) const;
  Result<std::vector<double>> numbers(const char* key) const;  // array of finite numbers
  Error error(const std::string& key, const std::string& what) const;

 private:
  Result<const Json*> member(const char* key) const;
  const Json& obj_;
  std::string file_, prefix_;
};

}  // namespace sawyer::maps_detail
