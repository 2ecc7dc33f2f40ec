#include "json_util.h"

#include <cmath>
#include <exception>

#include "sawyer/core/file_util.h"

namespace sawyer::maps_detail {
namespace fs = std::filesystem;

// Map headers are a few kB; 16 MiB leaves room for any hand-edited or annotated one and keeps a
// FIFO, a device or a stray huge file from being read.
constexpr std::uintmax_t kMaxJsonBytes = std::uintmax_t{16} << 20;

Result<Json> read_json_file(const fs::path& path) {
  Result<std::string> text = read_text_file(path, kMaxJsonBytes);
  if (!text) return text.error();
  try {
    return Json::parse(text.value());
  } catch (const nlohmann::json::parse_error& e) {
    return Error(path.string(), "malformed JSON at byte " + std::to_string(e.byte));
  } catch (const std::exception& e) {
    return Error(path.string(), std::string("malformed JSON: ") + e.what());
  }
}

Status write_json_file(const fs::path& path, const Json& j, int indent, const std::string& shown) {
  std::string text;
  try {
    text = j.dump(indent);
  } catch (const nlohmann::json::type_error&) {
    return Error(shown, "a text field is not valid UTF-8");
  } catch (const std::exception& e) {
    return Error(shown, std::string("cannot serialise: ") + e.what());
  }
  text += "\n";
  Status st = write_text_file_atomic(path, text);
  if (!st) return Error(shown, "write failed");
  return Status::Ok();
}

Error JsonReader::error(const std::string& key, const std::string& what) const {
  return Error(file_ + ": " + prefix_ + key, what);
}

Result<const Json*> JsonReader::member(const char* key) const {
  if (!obj_.is_object())
    return Error(file_ + (prefix_.empty() ? "" : ": " + prefix_), "expected an object");
  auto it = obj_.find(key);
  if (it == obj_.end()) return error(key, "missing key");
  return &*it;
}

Result<double> JsonReader::number(const char* key) const {
  Result<const Json*> m = member(key);
  if (!m) return m.error();
  const Json& v = *m.value();
  if (!v.is_number()) return error(key, std::string("expected a number, got ") + v.type_name());
  const double d = v.get<double>();
  if (!std::isfinite(d)) return error(key, "not a finite number");
  return d;
}

Result<long long> JsonReader::integer(const char* key) const {
  Result<double> d = number(key);
  if (!d) return d.error();
  const double v = d.value();
  if (v != std::floor(v) || std::abs(v) > 9.0e15) return error(key, "expected an integer");
  return static_cast<long long>(v);
}

Result<bool> JsonReader::boolean(const char* key) const {
  Result<const Json*> m = member(key);
  if (!m) return m.error();
  if (!m.value()->is_boolean())
    return error(key, std::string("expected true or false, got ") + m.value()->type_name());
  return m.value()->get<bool>();
}

Result<std::string> JsonReader::string(const char* key) const {
  Result<const Json*> m = member(key);
  if (!m) return m.error();
  if (!m.value()->is_string())
    return error(key, std::string("expected a string, got ") + m.value()->type_name());
  return m.value()->get<std::string>();
}

Result<std::vector<double>> JsonReader::numbers(const char* key) const {
  Result<const Json*> m = member(key);
  if (!m) return m.error();
  const Json& v = *m.value();
  if (!v.is_array())
    return error(key, std::string("expected an array of numbers, got ") + v.type_name());
  std::vector<double> out;
  out.reserve(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    const std::string k = std::string(key) + "[" + std::to_string(i) + "]";
    if (!v[i].is_number())
      return error(k, std::string("expected a number, got ") + v[i].type_name());
    const double d = v[i].get<double>();
    if (!std::isfinite(d)) return error(k, "not a finite number");
    out.push_back(d);
  }
  return out;
}

}  // namespace sawyer::maps_detail
