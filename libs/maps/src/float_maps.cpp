#include "sawyer/maps/float_maps.h"

#include <cmath>
#include <string>
#include <system_error>
#include <vector>

#include "image_io.h"
#include "json_util.h"
#include "model_checks.h"
#include "sawyer/core/file_util.h"
#include "sawyer/model/log_json.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;
using maps_detail::FloatImage;
using maps_detail::Json;
using maps_detail::JsonReader;

constexpr const char* kJsonFile = "float_maps.json";
constexpr const char* kStemFile = "stem.exr";
constexpr const char* kKnotsFile = "knots.exr";

const std::vector<std::string>& stem_channels() {
  static const std::vector<std::string> names = {"pith_x", "pith_y", "radius", "heartwood"};
  return names;
}
const std::vector<std::string>& knot_channels() {
  static const std::vector<std::string> names = {"R", "G", "B", "A"};
  return names;
}

// Largest integer below which every integer is a float32.
constexpr double kFloatExactInt = 16777216.0;  // 2^24

Json layout_json() {
  Json stem;
  stem["columns"] =
      "angle k of n_angles, at omega = 2*pi*k/n_angles (rad, from +x counter-clockwise)";
  stem["rows"] = "stem sample i of n_slices, at z = z0_mm + i*dz_mm; row 0 is the top scanline";
  stem["channels"] = stem_channels();
  stem["units"] =
      "mm; pith_x, pith_y in the scanner frame (same in every column); heartwood 0 "
      "when has_heartwood is false";
  Json knots;
  knots["columns"] = 3;
  knots["rows"] = "knot i of n_knots (file omitted when n_knots is 0)";
  knots["channels"] = knot_channels();
  knots["texels"] = Json::array({Json::array({"z0", "a", "b", "omega0"}),
                                 Json::array({"twist", "r_dead", "r_end", "d_dead"}),
                                 Json::array({"d_exp", "id", "fit_rms_mm", "support"})});
  knots["formula"] =
      "z(r) = z0 + a*sqrt(r) + b*r; omega(r) = omega0 + twist*ln(max(r, 1)); "
      "d(r) = d_dead*(min(r, r_dead)/r_dead)^d_exp";
  Json out;
  out[kStemFile] = std::move(stem);
  out[kKnotsFile] = std::move(knots);
  return out;
}

Json header_json(const LogModel& log) {
  const Stem& s = log.stem;
  Json j;
  j["format"] = kFloatMapsFormatTag;
  j["id"] = log.id;
  j["species"] = log.species;
  j["source"] = log.source;
  j["z0_mm"] = s.z0_mm;
  j["dz_mm"] = s.dz_mm;
  j["n_angles"] = s.n_angles;
  j["n_slices"] = s.slice_count();
  j["n_knots"] = log.knots.size();
  j["has_heartwood"] = s.has_heartwood();
  if (!s.bark_mm.empty()) j["bark_mm"] = s.bark_mm;
  j["layout"] = layout_json();
  return j;
}

FloatImage stem_image(const Stem& s) {
  FloatImage img(s.n_angles, s.slice_count(), stem_channels());
  for (int i = 0; i < s.slice_count(); ++i)
    for (int k = 0; k < s.n_angles; ++k) {
      img.at(k, i, 0) = static_cast<float>(s.pith[i].x);
      img.at(k, i, 1) = static_cast<float>(s.pith[i].y);
      img.at(k, i, 2) = static_cast<float>(s.radius[i][k]);
      img.at(k, i, 3) = s.has_heartwood() ? static_cast<float>(s.heartwood[i][k]) : 0.0f;
    }
  return img;
}

Result<FloatImage> knot_image(const LogModel& log, const std::string& shown) {
  FloatImage img(3, static_cast<int>(log.knots.size()), knot_channels());
  for (size_t i = 0; i < log.knots.size(); ++i) {
    const Knot& k = log.knots[i];
    if (std::abs(static_cast<double>(k.id)) > kFloatExactInt ||
        std::abs(static_cast<double>(k.support)) > kFloatExactInt)
      return Error(shown, "knot " + std::to_string(i) + " (id " + std::to_string(k.id) +
                              "): id and support must be at most 2^24 to be stored exactly");
    const double v[12] = {k.z0,
                          k.a,
                          k.b,
                          k.omega0,
                          k.twist,
                          k.r_dead,
                          k.r_end,
                          k.diameter.d_dead,
                          k.diameter.exponent,
                          static_cast<double>(k.id),
                          k.fit_rms_mm,
                          static_cast<double>(k.support)};
    for (int t = 0; t < 12; ++t)
      img.at(t / 4, static_cast<int>(i), t % 4) = static_cast<float>(v[t]);
  }
  return img;
}

Status check_image_size(const fs::path& path, const FloatImage& img, int columns, int rows) {
  if (img.width != columns)
    return Error(path.string(), "expected " + std::to_string(columns) + " columns, found " +
                                    std::to_string(img.width));
  if (img.height != rows)
    return Error(path.string(),
                 "expected " + std::to_string(rows) + " rows, found " + std::to_string(img.height));
  return Status::Ok();
}

// A count from the header, within [lo, hi].
Result<int> count_at(const JsonReader& r, const char* key, long long lo, long long hi) {
  Result<long long> v = r.integer(key);
  if (!v) return v.error();
  if (v.value() < lo || v.value() > hi)
    return r.error(key, "must be between " + std::to_string(lo) + " and " + std::to_string(hi) +
                            ", found " + std::to_string(v.value()));
  return static_cast<int>(v.value());
}

}  // namespace

Status export_float_maps(const LogModel& log, const fs::path& dir) {
  if (Status st = validate(log); !st) return st.error().with_context(dir.string());
  if (Status st = maps_detail::check_finite(log.stem); !st)
    return st.error().with_context(dir.string());
  const Stem& s = log.stem;
  for (size_t i = 0; i < s.heartwood.size(); ++i)
    if (static_cast<int>(s.heartwood[i].size()) != s.n_angles)
      return Error(dir.string() + ": stem.heartwood[" + std::to_string(i) + "]",
                   "needs n_angles values");
  if (!s.bark_mm.empty() && static_cast<int>(s.bark_mm.size()) != s.slice_count())
    return Error(dir.string() + ": stem.bark_mm", "needs one value per stem sample");

  return write_dir_atomic(dir, [&](const fs::path& tmp) -> Status {
    Status st =
        maps_detail::write_exr_float(tmp / kStemFile, stem_image(s), (dir / kStemFile).string());
    if (!st) return st;
    if (!log.knots.empty()) {
      Result<FloatImage> knots = knot_image(log, (dir / kKnotsFile).string());
      if (!knots) return knots.error();
      st = maps_detail::write_exr_float(tmp / kKnotsFile, knots.value(),
                                        (dir / kKnotsFile).string());
      if (!st) return st;
    }
    // The header last: a folder with float_maps.json in it is complete.
    return maps_detail::write_json_file(tmp / kJsonFile, header_json(log), 2,
                                        (dir / kJsonFile).string());
  });
}

Result<LogModel> import_float_maps(const fs::path& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return Error(dir.string(), "no such folder");
  if (!fs::is_directory(dir, ec))
    return Error(dir.string(), "is a file, expected a folder of maps");
  const fs::path json_path = dir / kJsonFile;
  Result<Json> parsed = maps_detail::read_json_file(json_path);
  if (!parsed) return parsed.error();
  const Json& j = parsed.value();
  if (!j.is_object()) return Error(json_path.string(), "expected a JSON object");
  JsonReader r(j, json_path.string());

  Result<std::string> tag = r.string("format");
  if (!tag) return tag.error();
  if (tag.value() != kFloatMapsFormatTag)
    return r.error("format", "is '" + tag.value() + "', expected '" + kFloatMapsFormatTag + "'");

  LogModel log;
  for (auto [key, dst] :
       {std::pair{"id", &log.id}, {"species", &log.species}, {"source", &log.source}}) {
    if (!r.has(key)) continue;
    Result<std::string> v = r.string(key);
    if (!v) return v.error();
    *dst = v.value();
  }
  Stem& s = log.stem;
  Result<double> z0 = r.number("z0_mm");
  if (!z0) return z0.error();
  Result<double> dz = r.number("dz_mm");
  if (!dz) return dz.error();
  if (!(dz.value() > 0)) return r.error("dz_mm", "must be positive");
  s.z0_mm = z0.value();
  s.dz_mm = dz.value();
  // The counts size the grids allocated below: the log model's limits, checked before the images
  // are read.
  Result<int> n_angles = count_at(r, "n_angles", log_limits::kMinAngles, log_limits::kMaxAngles);
  if (!n_angles) return n_angles.error();
  Result<int> n_slices = count_at(r, "n_slices", 1, log_limits::kMaxSlices);
  if (!n_slices) return n_slices.error();
  if (static_cast<long long>(n_angles.value()) * n_slices.value() > log_limits::kMaxStemValues)
    return r.error("n_slices", std::to_string(n_slices.value()) + " × n_angles " +
                                   std::to_string(n_angles.value()) + " radii, more than the " +
                                   std::to_string(log_limits::kMaxStemValues) + " allowed");
  Result<int> n_knots = count_at(r, "n_knots", 0, log_limits::kMaxKnots);
  if (!n_knots) return n_knots.error();
  Result<bool> has_hw = r.boolean("has_heartwood");
  if (!has_hw) return has_hw.error();
  s.n_angles = n_angles.value();
  const int n = n_slices.value();
  if (r.has("bark_mm")) {
    Result<std::vector<double>> bark = r.numbers("bark_mm");
    if (!bark) return bark.error();
    if (static_cast<int>(bark.value().size()) != n)
      return r.error("bark_mm", "has " + std::to_string(bark.value().size()) +
                                    " values, expected n_slices = " + std::to_string(n));
    s.bark_mm = std::move(bark).value();
  }

  const fs::path stem_path = dir / kStemFile;
  Result<FloatImage> stem = maps_detail::read_float_channels(stem_path, stem_channels());
  if (!stem) return stem.error();
  const FloatImage& si = stem.value();
  if (Status st = check_image_size(stem_path, si, s.n_angles, n); !st) return st.error();
  s.pith.resize(n);
  s.radius.assign(n, std::vector<double>(s.n_angles));
  if (has_hw.value()) s.heartwood.assign(n, std::vector<double>(s.n_angles));
  for (int i = 0; i < n; ++i) {
    s.pith[i] = {si.at(0, i, 0), si.at(0, i, 1)};
    if (!std::isfinite(s.pith[i].x) || !std::isfinite(s.pith[i].y))
      return Error(stem_path.string() + ": row " + std::to_string(i), "pith is not finite");
    for (int k = 0; k < s.n_angles; ++k) {
      s.radius[i][k] = si.at(k, i, 2);
      if (has_hw.value()) s.heartwood[i][k] = si.at(k, i, 3);
    }
  }

  if (n_knots.value() > 0) {
    const fs::path knots_path = dir / kKnotsFile;
    Result<FloatImage> knots = maps_detail::read_float_channels(knots_path, knot_channels());
    if (!knots) return knots.error();
    const FloatImage& ki = knots.value();
    if (Status st = check_image_size(knots_path, ki, 3, n_knots.value()); !st) return st.error();
    for (int i = 0; i < ki.height; ++i) {
      double v[12];
      for (int t = 0; t < 12; ++t) v[t] = ki.at(t / 4, i, t % 4);
      Knot k;
      k.z0 = v[0], k.a = v[1], k.b = v[2], k.omega0 = v[3];
      k.twist = v[4], k.r_dead = v[5], k.r_end = v[6], k.diameter.d_dead = v[7];
      k.diameter.exponent = v[8];
      k.fit_rms_mm = v[10];
      if (!std::isfinite(v[9]) || !std::isfinite(v[11]) || v[9] != std::floor(v[9]) ||
          v[11] != std::floor(v[11]) || std::abs(v[9]) > kFloatExactInt ||
          std::abs(v[11]) > kFloatExactInt)
        return Error(knots_path.string() + ": knot " + std::to_string(i),
                     "id and support must be whole numbers");
      k.id = static_cast<int>(v[9]);
      k.support = static_cast<int>(v[11]);
      log.knots.push_back(k);
    }
  }

  if (Status st = validate(log); !st) return st.error().with_context(dir.string());
  return log;
}

}  // namespace sawyer
