// Reads and writes sawyer_stack.json, the geometry sidecar of TIFF/PNG stacks.
#include "sidecar.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <set>

#include "sawyer/core/file_util.h"
#include "sawyer/ct/io/limits.h"
#include "text_parse.h"

namespace sawyer::ct::detail {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// The JSON as the user wrote it, shortened, for "got ..." in messages.
std::string shown(const Json& j) {
  std::string s = j.dump();
  if (s.size() > 40) s = s.substr(0, 37) + "...";
  return s;
}

Error key_error(const std::string& where, const std::string& key, const std::string& what) {
  return Error(where, "\"" + key + "\" " + what);
}

std::optional<double> finite_number(const Json& j) {
  if (!j.is_number()) return std::nullopt;
  const double v = j.get<double>();
  if (!std::isfinite(v)) return std::nullopt;
  return v;
}

Result<double> positive_number(const Json& j, const std::string& where, const std::string& key) {
  const std::optional<double> v = finite_number(j);
  if (!v) return key_error(where, key, "must be a number in mm, got " + shown(j));
  if (!(*v > 0)) return key_error(where, key, "must be positive, got " + num(*v));
  if (*v < kMinSpacingMm || *v > kMaxSpacingMm)
    return key_error(
        where, key,
        num(*v) + " mm is outside " + num(kMinSpacingMm) + "-" + num(kMaxSpacingMm) + " mm");
  return *v;
}

// Positions must increase, no closer than the smallest slice spacing and within a log's length
// of each other: the reader builds its z grid (and the resampler its slice count) from them.
Status check_z_mm(const std::vector<double>& z, const std::string& where) {
  const char* key = "z_mm";
  for (size_t i = 1; i < z.size(); ++i) {
    if (!(z[i] > z[i - 1])) {
      return key_error(where, key,
                       "must increase strictly, but element " + std::to_string(i) + " (" +
                           num(z[i]) + ") follows " + num(z[i - 1]));
    }
    if (z[i] - z[i - 1] < kMinSpacingMm) {
      return key_error(where, key,
                       "elements " + std::to_string(i - 1) + " and " + std::to_string(i) + " are " +
                           num(z[i] - z[i - 1]) + " mm apart; slice spacing must be " +
                           num(kMinSpacingMm) + "-" + num(kMaxSpacingMm) + " mm");
    }
  }
  if (!z.empty() && z.back() - z.front() > kMaxZExtentMm) {
    return key_error(where, key,
                     "spans " + num(z.back() - z.front()) + " mm (" + num(z.front()) + " to " +
                         num(z.back()) + "), more than " + num(kMaxZExtentMm) + " mm");
  }
  return Status::Ok();
}

Result<std::vector<double>> number_array(const Json& j, const std::string& where,
                                         const std::string& key, size_t want) {
  const std::string expected = want ? "must be an array of " + std::to_string(want) + " numbers"
                                    : "must be an array of numbers";
  if (!j.is_array() || (want && j.size() != want) || j.empty())
    return key_error(where, key, expected + ", got " + shown(j));
  std::vector<double> out;
  out.reserve(j.size());
  for (size_t i = 0; i < j.size(); ++i) {
    const std::optional<double> v = finite_number(j[i]);
    if (!v) {
      return key_error(where, key,
                       expected + ", but element " + std::to_string(i) + " is " + shown(j[i]));
    }
    out.push_back(*v);
  }
  return out;
}

Status parse_pixel_spacing(const Json& j, const std::string& where, StackSidecar& sc) {
  const char* key = "pixel_spacing_mm";
  if (j.is_number()) {
    auto v = positive_number(j, where, key);
    if (!v) return v.error();
    sc.pixel_spacing_x = sc.pixel_spacing_y = v.value();
    return Status::Ok();
  }
  if (j.is_array() && j.size() == 2) {
    for (int i = 0; i < 2; ++i) {
      auto v = positive_number(j[i], where, key);
      if (!v) return v.error();
      (i == 0 ? sc.pixel_spacing_x : sc.pixel_spacing_y) = v.value();
    }
    return Status::Ok();
  }
  return key_error(where, key, "must be a number or [x, y] in mm, got " + shown(j));
}

Status parse_orientation(const Json& j, const std::string& where, StackSidecar& sc) {
  auto v = number_array(j, where, "orientation", 6);
  if (!v) return v.error();
  const std::vector<double>& o = v.value();
  const Vec3 row{o[0], o[1], o[2]}, col{o[3], o[4], o[5]};
  // Direction cosines: two unit vectors at right angles (loose enough for printed decimals).
  if (std::abs(row.norm() - 1) > 1e-3 || std::abs(col.norm() - 1) > 1e-3 ||
      std::abs(dot(row, col)) > 1e-3) {
    return key_error(where, "orientation",
                     "must hold two perpendicular unit vectors (row and column direction "
                     "cosines), got " +
                         shown(j));
  }
  sc.orientation = std::array<double, 6>{o[0], o[1], o[2], o[3], o[4], o[5]};
  return Status::Ok();
}

Status parse_files(const Json& j, const std::string& where, StackSidecar& sc) {
  if (!j.is_array() || j.empty())
    return key_error(where, "files", "must be a non-empty array of file names, got " + shown(j));
  std::set<std::string> seen;
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string at = "element " + std::to_string(i);
    if (!j[i].is_string() || j[i].get<std::string>().empty())
      return key_error(where, "files", at + " must be a file name, got " + shown(j[i]));
    const std::string name = j[i].get<std::string>();
    const fs::path p(name);
    // Names are relative to the stack's folder; a path out of it is a mistake, not a feature.
    if (p.is_absolute() || name.find("..") != std::string::npos)
      return key_error(where, "files",
                       at + " (\"" + name + "\") must name a file in the stack's folder");
    if (!seen.insert(name).second) return key_error(where, "files", "lists \"" + name + "\" twice");
    sc.files.push_back(name);
  }
  return Status::Ok();
}

}  // namespace

Result<StackSidecar> parse_stack_sidecar(const std::string& text, const std::string& where) {
  Json j;
  try {
    j = Json::parse(text);
  } catch (const Json::exception& e) {
    std::string what = e.what();
    // "[json.exception.parse_error.101] parse error at line 1, ..." -> "parse error at line 1, ..."
    if (const size_t at = what.find("] "); what.starts_with("[json.") && at != std::string::npos)
      what = what.substr(at + 2);
    return Error(where, "not valid JSON (" + what + ")");
  }
  if (!j.is_object()) return Error(where, "expected a JSON object { ... }, got " + shown(j));

  StackSidecar sc;
  try {
    for (const auto& [key, value] : j.items()) {
      Status st;
      if (key == "format") {
        if (!value.is_string() || value.get<std::string>() != kStackFormatTag) {
          st = key_error(where, key,
                         std::string("must be \"") + kStackFormatTag + "\", got " + shown(value));
        }
      } else if (key == "pixel_spacing_mm") {
        st = parse_pixel_spacing(value, where, sc);
      } else if (key == "slice_spacing_mm") {
        auto v = positive_number(value, where, key);
        if (v)
          sc.slice_spacing = v.value();
        else
          st = v.error();
      } else if (key == "z_mm") {
        auto v = number_array(value, where, key, 0);
        if (!v) {
          st = v.error();
        } else {
          sc.z_mm = std::move(v).value();
          st = check_z_mm(sc.z_mm, where);
        }
      } else if (key == "rescale_slope") {
        const std::optional<double> v = finite_number(value);
        if (!v || *v == 0)
          st = key_error(where, key, "must be a non-zero number, got " + shown(value));
        else
          sc.rescale_slope = *v;
      } else if (key == "rescale_intercept") {
        const std::optional<double> v = finite_number(value);
        if (!v)
          st = key_error(where, key, "must be a number, got " + shown(value));
        else
          sc.rescale_intercept = *v;
      } else if (key == "origin_mm") {
        auto v = number_array(value, where, key, 3);
        if (v)
          sc.origin = Vec3{v.value()[0], v.value()[1], v.value()[2]};
        else
          st = v.error();
      } else if (key == "orientation") {
        st = parse_orientation(value, where, sc);
      } else if (key == "files") {
        st = parse_files(value, where, sc);
      } else {
        sc.unknown_keys.push_back(key);
      }
      if (!st) return st.error();
    }
  } catch (const Json::exception& e) {
    // get<>() on a value checked above cannot throw; this is a guard, not a path.
    return Error(where, std::string("unexpected JSON content (") + e.what() + ")");
  }
  if (!sc.z_mm.empty() && !sc.files.empty() && sc.z_mm.size() != sc.files.size()) {
    return key_error(where, "z_mm",
                     "has " + std::to_string(sc.z_mm.size()) + " positions but \"files\" lists " +
                         std::to_string(sc.files.size()) + " files");
  }
  return sc;
}

Result<StackSidecar> read_stack_sidecar(const fs::path& file) {
  Result<std::string> text = read_text_file(file, 64u << 20);
  // A sidecar is a few hundred bytes plus z_mm (64 MiB is millions of slices): anything bigger
  // is not one, and is refused before it is read.
  if (!text) return text.error();
  return parse_stack_sidecar(text.value(), file.string());
}

std::string format_stack_sidecar(const VolumeGeometry& g, double rescale_slope,
                                 double rescale_intercept, const std::vector<std::string>& files) {
  nlohmann::ordered_json j;
  j["format"] = kStackFormatTag;
  j["pixel_spacing_mm"] = {g.spacing_x, g.spacing_y};
  if (g.slice_count() >= 2) j["slice_spacing_mm"] = g.slice_spacing();
  j["z_mm"] = g.z;
  j["rescale_slope"] = rescale_slope;
  j["rescale_intercept"] = rescale_intercept;
  j["origin_mm"] = {g.origin.x, g.origin.y, g.origin.z};
  j["orientation"] = g.orientation;
  if (!files.empty()) j["files"] = files;
  return j.dump(2) + "\n";
}

}  // namespace sawyer::ct::detail
