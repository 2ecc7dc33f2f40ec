#include "sawyer/model/gran1_import.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "sawyer/core/file_util.h"
#include "sawyer/model/log_json.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

Result<Json> parse_file(const fs::path& path) {
  Result<std::string> text = read_text_file(path, log_limits::kMaxFileBytes);
  if (!text) return text.error();
  try {
    return Json::parse(text.value());
  } catch (const nlohmann::json::parse_error&) {
    return Error(path.string(), "malformed JSON");
  } catch (const nlohmann::json::exception&) {
    // out_of_range: a number such as 1e999 that does not fit a double.
    return Error(path.string(), "malformed JSON (a number out of range)");
  }
}

// Row i of a 2D numeric array, checked to hold `cols` finite numbers.
Result<std::vector<double>> numeric_row(const Json& rows, size_t i, size_t cols,
                                        const fs::path& file, const char* what) {
  const std::string where = file.string() + ": " + what + " " + std::to_string(i);
  const Json& r = rows[i];
  if (!r.is_array() || r.size() != cols)
    return Error(where, "expected " + std::to_string(cols) + " numbers");
  std::vector<double> out(cols);
  for (size_t k = 0; k < cols; ++k) {
    if (!r[k].is_number()) return Error(where, "value " + std::to_string(k) + " is not a number");
    out[k] = r[k].get<double>();
    if (!std::isfinite(out[k]))
      return Error(where, "value " + std::to_string(k) + " is not finite");
  }
  return out;
}

}  // namespace

double paper_knot_radius(double r, double R, double rmin) {
  return (0.2 * rmin - 0.1 * std::sqrt(std::max(r, 0.0) * rmin)) * r / R;
}

KnotDiameter fit_paper_diameter(double r_dead, double R, double rmin) {
  KnotDiameter d;
  if (!(r_dead > 0) || !(R > 0) || !(rmin > 0)) return d;
  d.d_dead = std::max(0.0, 2.0 * paper_knot_radius(r_dead, R, rmin));
  if (!(d.d_dead > 0)) return d;
  // Least squares in log-log through the fixed point (r_dead, d_dead):
  // log(d/d_dead) = p·log(r/r_dead) over r in (0.05·r_dead, r_dead].
  constexpr int kN = 64;
  double sxx = 0, sxy = 0;
  for (int i = 1; i <= kN; ++i) {
    const double r = r_dead * (0.05 + 0.95 * i / kN);
    const double rad = paper_knot_radius(r, R, rmin);
    if (rad <= 0) continue;
    const double x = std::log(r / r_dead), y = std::log(2.0 * rad / d.d_dead);
    sxx += x * x, sxy += x * y;
  }
  if (sxx > 0) d.exponent = std::max(0.05, sxy / sxx);
  return d;
}

Result<LogModel> import_gran1(const fs::path& folder, const std::string& name) {
  const fs::path pith_path = folder / (name + "_pith.json");
  const fs::path radii_path = folder / (name + "_radii.json");
  const fs::path knots_path = folder / (name + "_knots.json");

  Result<Json> pj = parse_file(pith_path);
  if (!pj) return pj.error();
  Result<Json> rj = parse_file(radii_path);
  if (!rj) return rj.error();
  Result<Json> kj = parse_file(knots_path);
  if (!kj) return kj.error();

  LogModel log;
  log.id = "gran1_spruce";
  log.species = "spruce";
  log.source =
      "Gran_1, Norway spruce measured from CT by Lulea University of Technology; published with "
      "Larsson et al. 2022 'Procedural Texturing of Solid Wood with Knots' (MIT licence, "
      "(c) 2022 Maria Larsson)";
  Stem& s = log.stem;

  // Pith: [x, y, z] per slice, z uniformly spaced.
  const Json& pith = pj.value();
  if (!pith.is_array() || pith.size() < 2)
    return Error(pith_path.string(), "expected an array of at least two [x, y, z] rows");
  std::vector<double> zs;
  for (size_t i = 0; i < pith.size(); ++i) {
    Result<std::vector<double>> row = numeric_row(pith, i, 3, pith_path, "row");
    if (!row) return row.error();
    s.pith.push_back({row.value()[0], row.value()[1]});
    zs.push_back(row.value()[2]);
  }
  s.z0_mm = zs[0];
  s.dz_mm = zs[1] - zs[0];
  if (!(s.dz_mm > 0)) return Error(pith_path.string(), "z does not increase between rows 0 and 1");
  for (size_t i = 1; i < zs.size(); ++i)
    if (std::abs(zs[i] - zs[0] - i * s.dz_mm) > 1e-3 * s.dz_mm)
      return Error(
          pith_path.string() + ": row " + std::to_string(i),
          "z is not uniformly spaced (expected " + std::to_string(zs[0] + i * s.dz_mm) + ")");

  // Radii: one row of 360 per slice; row value j is at the published map's azimuth j degrees,
  // measured from +y towards +x, i.e. at our ω = 90° − j.
  const Json& radii = rj.value();
  if (!radii.is_array() || radii.size() != s.pith.size())
    return Error(radii_path.string(),
                 "expected " + std::to_string(s.pith.size()) + " rows, one per pith row");
  s.n_angles = 360;
  if (radii.size() > static_cast<size_t>(log_limits::kMaxSlices))
    return Error(radii_path.string(), std::to_string(radii.size()) + " rows, more than the " +
                                          std::to_string(log_limits::kMaxSlices) + " allowed");
  double rmin = 1e300;
  for (size_t i = 0; i < radii.size(); ++i) {
    Result<std::vector<double>> row = numeric_row(radii, i, 360, radii_path, "row");
    if (!row) return row.error();
    std::vector<double> ours(360);
    for (int k = 0; k < 360; ++k) {
      const double v = row.value()[((90 - k) % 360 + 360) % 360];
      if (!(v > 0))
        return Error(radii_path.string() + ": row " + std::to_string(i), "radius must be positive");
      ours[k] = v;
      rmin = std::min(rmin, v);
    }
    s.radius.push_back(std::move(ours));
  }
  // The stem's numbers in range before the knots use them (the slice lookup below divides by dz).
  if (Status st = validate(log); !st) return st.error().with_context(folder.string());

  // Knots: [A, B, C, D, E, F, G, H, I].
  const Json& knots = kj.value();
  if (!knots.is_array()) return Error(knots_path.string(), "expected an array of knot rows");
  for (size_t i = 0; i < knots.size(); ++i) {
    Result<std::vector<double>> row = numeric_row(knots, i, 9, knots_path, "knot");
    if (!row) return row.error();
    const std::vector<double>& v = row.value();
    Knot k;
    k.id = static_cast<int>(i);
    k.z0 = v[2];
    k.a = -v[3];
    k.b = -v[4];
    k.omega0 = v[5];
    k.twist = -v[6];
    k.r_end = v[7];
    k.r_dead = v[8];
    if (!(k.r_end > 0))
      return Error(knots_path.string() + ": knot " + std::to_string(i),
                   "end distance H must be positive");
    if (std::abs(k.z0) > log_limits::kMaxAbsZMm)
      return Error(knots_path.string() + ": knot " + std::to_string(i),
                   "height C = " + std::to_string(k.z0) + " mm is outside ±" +
                       std::to_string(static_cast<int>(log_limits::kMaxAbsZMm)) + " mm");
    // Local stem radius at the knot's base height for the paper's growth rule.
    const int slice = std::clamp(static_cast<int>(std::lround((k.z0 - s.z0_mm) / s.dz_mm)), 0,
                                 s.slice_count() - 1);
    k.diameter = fit_paper_diameter(k.r_dead, s.mean_radius(slice), rmin);
    log.knots.push_back(k);
  }
  if (Status st = validate(log); !st) return st.error().with_context(folder.string());
  return log;
}

}  // namespace sawyer
