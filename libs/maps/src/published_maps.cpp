// The published map format (docs/maps.md). The encoder and decoder below follow the published
// renderer's sampling rules:
//   - texel centres: column c of an image W wide is read at texture u = (c + 0.5)/W, row i of H
//     at v = (i + 0.5)/H; row 0 is the top row of the image file;
//   - stem map: u = φ/2π with φ = atan2(dx, dy) (from +y towards +x), v = h/hmax;
//   - knot maps: u = r/rmin (pith distance in units of rmin, clamped to the last column),
//     v = (knot + 0.5)/N;
//   - the renderer subtracts the green and adds the blue channel of the height and orientation
//     maps, so green holds the negative part of a term and blue the positive part.
#include "sawyer/maps/published_maps.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <ostream>
#include <sstream>
#include <system_error>

#include "image_io.h"
#include "json_util.h"
#include "model_checks.h"
#include "sawyer/core/file_util.h"
#include "sawyer/model/gran1_import.h"
#include "sawyer/model/log_json.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;
using maps_detail::Json;
using maps_detail::JsonReader;
using maps_detail::Rgb8Image;

constexpr const char* kParamsFile = "map_params.json";
constexpr const char* kPithMapFile = "pith_and_radius_map.bmp";
constexpr const char* kHeightMapFile = "knot_height_map.bmp";
constexpr const char* kOrientMapFile = "knot_orientation_map.bmp";
constexpr const char* kStateMapFile = "knot_state_map.bmp";
constexpr const char* kSidecarFile = "sawyer_maps.json";

constexpr double kHalfPi = 0.5 * kPi;
// Smallest rmax − rmin the exporter writes (a perfectly round, constant stem has none).
constexpr double kMinRadiusSpanMm = 1e-3;
// The stem grid the importer gives a model when no sidecar says otherwise.
constexpr int kDefaultAngles = 360;

std::string num(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

// ---- shared rules ------------------------------------------------------------------------------

// Pith distance (mm) at which the renderer reads knot-map column j of `columns`.
double knot_column_r(int j, int columns, double rmin) { return (j + 0.5) * rmin / columns; }

// Our azimuth ω (from +x counter-clockwise) of stem-map column c of `columns`: the column's
// centre is at the renderer's φ = 2π(c + 0.5)/W, measured from +y towards +x, so ω = π/2 − φ.
double stem_column_omega(int c, int columns) {
  return wrap_angle(kHalfPi - kTwoPi * (c + 0.5) / columns);
}

// ln r as the knot formula takes it (Knot::azimuth_at).
double log_r(double r) { return std::log(std::max(r, 1.0)); }

// 8-bit encoding of v in [0, 1], rounding to nearest; counts a clamp when v is out of range.
std::uint8_t encode_unit(double v, int* clamped) {
  constexpr double kSlack = 1e-9;
  if (v < -kSlack || v > 1.0 + kSlack) {
    if (clamped) ++*clamped;
  }
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
}

double decode_unit(double byte) { return byte / 255.0; }

// Catmull-Rom interpolation of periodic samples v[k] at fractional index x (v[k] at x = k).
double periodic_catmull_rom(const std::vector<double>& v, double x) {
  const int n = static_cast<int>(v.size());
  const int k = static_cast<int>(std::floor(x));
  const double t = x - k, t2 = t * t, t3 = t2 * t;
  const double w[4] = {0.5 * (-t3 + 2 * t2 - t), 0.5 * (3 * t3 - 5 * t2 + 2),
                       0.5 * (-3 * t3 + 4 * t2 + t), 0.5 * (t3 - t2)};
  double acc = 0;
  for (int d = 0; d < 4; ++d) acc += w[d] * v[((k - 1 + d) % n + n) % n];
  return acc;
}

// ---- sidecar -----------------------------------------------------------------------------------

struct SidecarKnot {
  int id = 0;
  double d_dead = 0, d_exp = 1, r_end = 0, r_dead = 0, fit_rms_mm = 0;
  int support = 0;
};

struct Sidecar {
  std::string id, species, source;
  double z_origin_mm = 0;
  Vec2 pith_mid;
  int n_angles = kDefaultAngles;
  // Map sizes as written; -1 where the sidecar does not say.
  int stem_columns = -1, stem_rows = -1, knot_columns = -1, rows_per_knot = -1;
  std::vector<SidecarKnot> knots;
};

Json sidecar_to_json(const LogModel& log, double z_origin, Vec2 pith_mid, int stem_columns,
                     int knot_columns, int rows_per_knot) {
  Json j;
  j["format"] = kPublishedMapsSidecarTag;
  j["id"] = log.id;
  j["species"] = log.species;
  j["source"] = log.source;
  j["z_origin_mm"] = z_origin;
  j["pith_mid"] = {pith_mid.x, pith_mid.y};
  j["n_angles"] = log.stem.n_angles;
  j["stem_columns"] = stem_columns;
  j["stem_rows"] = log.stem.slice_count();
  j["knot_columns"] = knot_columns;
  j["rows_per_knot"] = rows_per_knot;
  Json knots = Json::array();
  for (const Knot& k : log.knots) {
    Json o;
    o["id"] = k.id;
    o["d_dead"] = k.diameter.d_dead;
    o["d_exp"] = k.diameter.exponent;
    o["r_end"] = k.r_end;
    o["r_dead"] = k.r_dead;
    o["fit_rms_mm"] = k.fit_rms_mm;
    o["support"] = k.support;
    knots.push_back(std::move(o));
  }
  j["knots"] = std::move(knots);
  return j;
}

// Optional integer key: -1 when absent.
Result<int> optional_int(const JsonReader& r, const char* key, int lo, int hi) {
  if (!r.has(key)) return -1;
  Result<long long> v = r.integer(key);
  if (!v) return v.error();
  if (v.value() < lo || v.value() > hi)
    return r.error(key, "out of range (" + std::to_string(v.value()) + ")");
  return static_cast<int>(v.value());
}

Result<Sidecar> read_sidecar(const fs::path& path) {
  Result<Json> parsed = maps_detail::read_json_file(path);
  if (!parsed) return parsed.error();
  const Json& j = parsed.value();
  const std::string file = path.string();
  if (!j.is_object()) return Error(file, "expected a JSON object");
  JsonReader r(j, file);
  Sidecar s;
  Result<std::string> tag = r.string("format");
  if (!tag) return tag.error();
  if (tag.value() != kPublishedMapsSidecarTag)
    return r.error("format",
                   "is '" + tag.value() + "', expected '" + kPublishedMapsSidecarTag + "'");
  for (auto [key, dst] : {std::pair{"id", &s.id}, {"species", &s.species}, {"source", &s.source}}) {
    if (!r.has(key)) continue;
    Result<std::string> v = r.string(key);
    if (!v) return v.error();
    *dst = v.value();
  }
  Result<double> zo = r.number("z_origin_mm");
  if (!zo) return zo.error();
  s.z_origin_mm = zo.value();
  Result<std::vector<double>> mid = r.numbers("pith_mid");
  if (!mid) return mid.error();
  if (mid.value().size() != 2) return r.error("pith_mid", "expected [x, y]");
  s.pith_mid = {mid.value()[0], mid.value()[1]};
  Result<long long> na = r.integer("n_angles");
  if (!na) return na.error();
  if (na.value() < log_limits::kMinAngles || na.value() > log_limits::kMaxAngles)
    return r.error("n_angles", "must be between " + std::to_string(log_limits::kMinAngles) +
                                   " and " + std::to_string(log_limits::kMaxAngles) + ", found " +
                                   std::to_string(na.value()));
  s.n_angles = static_cast<int>(na.value());
  for (auto [key, dst] : {std::pair{"stem_columns", &s.stem_columns},
                          {"stem_rows", &s.stem_rows},
                          {"knot_columns", &s.knot_columns},
                          {"rows_per_knot", &s.rows_per_knot}}) {
    Result<int> v = optional_int(r, key, 1, std::string(key) == "rows_per_knot" ? 256 : 1 << 20);
    if (!v) return v.error();
    *dst = v.value();
  }
  auto kit = j.find("knots");
  if (kit == j.end()) return r.error("knots", "missing key");
  if (!kit->is_array()) return r.error("knots", "expected an array");
  for (size_t i = 0; i < kit->size(); ++i) {
    JsonReader kr((*kit)[i], file, "knots[" + std::to_string(i) + "].");
    SidecarKnot k;
    Result<long long> id = kr.integer("id");
    if (!id) return id.error();
    k.id = static_cast<int>(id.value());
    for (auto [key, dst] : {std::pair{"d_dead", &k.d_dead},
                            {"d_exp", &k.d_exp},
                            {"r_end", &k.r_end},
                            {"r_dead", &k.r_dead},
                            {"fit_rms_mm", &k.fit_rms_mm}}) {
      Result<double> v = kr.number(key);
      if (!v) return v.error();
      *dst = v.value();
    }
    Result<long long> sup = kr.integer("support");
    if (!sup) return sup.error();
    k.support = static_cast<int>(sup.value());
    if (!(k.r_end > 0)) return kr.error("r_end", "must be positive");
    s.knots.push_back(k);
  }
  return s;
}

// ---- map_params.json ---------------------------------------------------------------------------

struct MapParams {
  double rmin = 0, rmax = 0, hmax = 0;
  int n = 0;
};

Result<MapParams> read_map_params(const fs::path& path) {
  Result<Json> parsed = maps_detail::read_json_file(path);
  if (!parsed) return parsed.error();
  const Json& j = parsed.value();
  const std::string file = path.string();
  if (!j.is_array()) return Error(file, "expected an array [rmin, rmax, hmax, N]");
  if (j.size() != 4)
    return Error(file,
                 "expected 4 numbers [rmin, rmax, hmax, N], found " + std::to_string(j.size()));
  const char* names[4] = {"rmin", "rmax", "hmax", "N"};
  double v[4];
  for (int i = 0; i < 4; ++i) {
    if (!j[i].is_number())
      return Error(file,
                   std::string(names[i]) + " (value " + std::to_string(i) + ") is not a number");
    v[i] = j[i].get<double>();
    if (!std::isfinite(v[i])) return Error(file, std::string(names[i]) + " is not finite");
  }
  MapParams p{v[0], v[1], v[2], 0};
  if (!(p.rmin > 0)) return Error(file, "rmin must be positive, found " + num(p.rmin));
  if (!(p.rmax > p.rmin))
    return Error(file,
                 "rmax (" + num(p.rmax) + ") must be greater than rmin (" + num(p.rmin) + ")");
  if (!(p.hmax > 0)) return Error(file, "hmax must be positive, found " + num(p.hmax));
  if (v[3] < 0 || v[3] != std::floor(v[3]) || v[3] > 1e6)
    return Error(file, "knot count N must be a whole number from 0, found " + num(v[3]));
  p.n = static_cast<int>(v[3]);
  return p;
}

// ---- export ------------------------------------------------------------------------------------

struct EncodedMaps {
  Rgb8Image pith, height, orient, state;
  Json params, sidecar;
};

EncodedMaps encode(const LogModel& log, const PublishedMapOptions& o,
                   PublishedMapExportSummary* sum) {
  const Stem& s = log.stem;
  const int n = s.slice_count();
  EncodedMaps out;

  double rmin = 1e300, rmax = 0;
  for (const auto& row : s.radius)
    for (double r : row) rmin = std::min(rmin, r), rmax = std::max(rmax, r);
  rmax = std::max(rmax, rmin + kMinRadiusSpanMm);
  const double hmax = s.length_mm();
  const double z_origin = s.z_begin();
  const Vec2 mid = s.pith[n / 2];
  const int nk = static_cast<int>(log.knots.size());

  sum->rmin = rmin, sum->rmax = rmax, sum->hmax = hmax, sum->knots = nk;
  sum->stem_columns = o.stem_columns, sum->stem_rows = n;
  sum->knot_columns = o.knot_columns, sum->rows_per_knot = o.rows_per_knot;

  // Stem: one row per stem sample; R, G the pith offset from the mid pith in units of rmin
  // around 0.5; B the outer radius between rmin and rmax, resampled to the column azimuths.
  out.pith = Rgb8Image(o.stem_columns, n);
  for (int i = 0; i < n; ++i) {
    const Vec2 d = s.pith[i] - mid;
    int clamped = 0;
    const std::uint8_t px = encode_unit(d.x / rmin + 0.5, &clamped);
    const std::uint8_t py = encode_unit(d.y / rmin + 0.5, &clamped);
    if (clamped) ++sum->clamped_pith_rows;
    for (int c = 0; c < o.stem_columns; ++c) {
      const double r = s.radius_at(stem_column_omega(c, o.stem_columns), s.z_at(i));
      out.pith.at(c, i, 0) = px;
      out.pith.at(c, i, 1) = py;
      out.pith.at(c, i, 2) = encode_unit((r - rmin) / (rmax - rmin), nullptr);
    }
  }

  // Knots: rows_per_knot identical rows each; with no knots one block of zeros, so that the
  // renderer still finds images to load.
  const int kw = o.knot_columns;
  const int kh = std::max(nk, 1) * o.rows_per_knot;
  out.height = Rgb8Image(kw, kh);
  out.orient = Rgb8Image(kw, kh);
  out.state = Rgb8Image(kw, kh);
  for (int i = 0; i < nk; ++i) {
    const Knot& k = log.knots[i];
    const std::uint8_t h0 = encode_unit((k.z0 - z_origin) / hmax, &sum->clamped_knot_starts);
    const std::uint8_t w0 = encode_unit(wrap_angle(k.omega0) / kTwoPi, nullptr);
    const std::uint8_t dead = encode_unit(k.r_dead / rmin, nullptr);
    if (k.r_dead >= rmin) ++sum->saturated_r_dead;
    // Blue of the state map (our extension): r_end / rmax, never 0 (0 means "not recorded").
    if (k.r_end > rmax) ++sum->clamped_r_end;
    const std::uint8_t end = std::max<std::uint8_t>(1, encode_unit(k.r_end / rmax, nullptr));
    for (int j = 0; j < kw; ++j) {
      const double r = knot_column_r(j, kw, rmin);
      const double rise = k.height_at(r) - k.z0;  // a·√r + b·r
      const double tw = k.twist * log_r(r);
      const std::uint8_t rise_dn =
          encode_unit(std::max(-rise, 0.0) / rmin, &sum->clamped_rise_texels);
      const std::uint8_t rise_up =
          encode_unit(std::max(rise, 0.0) / rmin, &sum->clamped_rise_texels);
      const std::uint8_t tw_cw =
          encode_unit(std::max(-tw, 0.0) / kHalfPi, &sum->clamped_twist_texels);
      const std::uint8_t tw_ccw =
          encode_unit(std::max(tw, 0.0) / kHalfPi, &sum->clamped_twist_texels);
      const std::uint8_t alive = r < k.r_dead ? 255 : 0;
      for (int row = i * o.rows_per_knot; row < (i + 1) * o.rows_per_knot; ++row) {
        out.height.at(j, row, 0) = h0;
        out.height.at(j, row, 1) = rise_dn;
        out.height.at(j, row, 2) = rise_up;
        out.orient.at(j, row, 0) = w0;
        out.orient.at(j, row, 1) = tw_cw;
        out.orient.at(j, row, 2) = tw_ccw;
        out.state.at(j, row, 0) = alive;
        out.state.at(j, row, 1) = dead;
        out.state.at(j, row, 2) = end;
      }
    }
  }

  // Exactly four numbers: the renderer unpacks this array into four variables.
  out.params = Json::array({rmin, rmax, hmax, nk});
  if (o.write_sidecar)
    out.sidecar =
        sidecar_to_json(log, z_origin, mid, o.stem_columns, o.knot_columns, o.rows_per_knot);
  return out;
}

// ---- import ------------------------------------------------------------------------------------

std::string default_log_id(const fs::path& dir) {
  std::error_code ec;
  fs::path p = fs::absolute(dir, ec).lexically_normal();
  if (ec) p = dir;
  if (p.filename().empty()) p = p.parent_path();
  std::string name = p.filename().string();
  if ((name == "published_maps" || name == "maps") && !p.parent_path().filename().empty())
    name = p.parent_path().filename().string();
  return name;
}

Status check_size(const fs::path& path, const Rgb8Image& img, int columns, int rows) {
  if (columns >= 0 && img.width != columns)
    return Error(path.string(), "expected " + std::to_string(columns) + " columns, found " +
                                    std::to_string(img.width));
  if (rows >= 0 && img.height != rows)
    return Error(path.string(),
                 "expected " + std::to_string(rows) + " rows, found " + std::to_string(img.height));
  return Status::Ok();
}

// Per-column channel means over the rows of one knot.
struct KnotColumns {
  std::vector<double> c[3];  // byte values (0..255), one per column
};

KnotColumns knot_columns(const Rgb8Image& img, int knot, int rows_per_knot) {
  KnotColumns out;
  for (int ch = 0; ch < 3; ++ch) out.c[ch].assign(img.width, 0.0);
  for (int row = knot * rows_per_knot; row < (knot + 1) * rows_per_knot; ++row)
    for (int j = 0; j < img.width; ++j)
      for (int ch = 0; ch < 3; ++ch) out.c[ch][j] += img.at(j, row, ch);
  for (int ch = 0; ch < 3; ++ch)
    for (double& v : out.c[ch]) v /= rows_per_knot;
  return out;
}

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

struct AxisFit {
  double a = 0, b = 0;  // rise ρ(r) = a·√r + b·r, mm
  double twist = 0;     // twist term τ(r) = twist·ln r, rad
  double height_rms = 0, azimuth_rms = 0;
  int columns = 0;
};

// Least squares over the first `m` columns (at pith distances r), both without intercept (the
// start height and azimuth come from the red channels): rise ρ_j = a·√r_j + b·r_j and twist
// term τ_j = twist·ln r_j. (A free azimuth intercept would follow the shipped Gran_1 maps'
// angles more closely near the pith, but it moves their axes further sideways, up to 1.4 mm
// against 0.55 mm without it, at larger r; docs/maps.md.)
AxisFit fit_axis(const std::vector<double>& r, const std::vector<double>& rise,
                 const std::vector<double>& tw, int m) {
  AxisFit f;
  f.columns = m;
  double s11 = 0, s12 = 0, s22 = 0, t1 = 0, t2 = 0, sll = 0, tl = 0;
  for (int j = 0; j < m; ++j) {
    const double q = std::sqrt(r[j]), l = log_r(r[j]);
    s11 += r[j], s12 += q * r[j], s22 += r[j] * r[j];
    t1 += q * rise[j], t2 += r[j] * rise[j];
    sll += l * l, tl += l * tw[j];
  }
  const double det = s11 * s22 - s12 * s12;
  if (m >= 2 && det > 1e-12 * s11 * s22) {
    f.a = (t1 * s22 - t2 * s12) / det;
    f.b = (s11 * t2 - s12 * t1) / det;
  } else if (s22 > 0) {
    f.b = t2 / s22;  // a single column: a straight line through the pith
  }
  if (sll > 0) f.twist = tl / sll;
  double eh = 0, ew = 0;
  for (int j = 0; j < m; ++j) {
    const double dh = f.a * std::sqrt(r[j]) + f.b * r[j] - rise[j];
    const double dw = f.twist * log_r(r[j]) - tw[j];
    eh += dh * dh, ew += dw * dw;
  }
  if (m > 0) f.height_rms = std::sqrt(eh / m), f.azimuth_rms = std::sqrt(ew / m);
  return f;
}

}  // namespace

// ---- public
// --------------------------------------------------------------------------------------

Status PublishedMapOptions::validate() const {
  if (stem_columns < 4 || stem_columns > 65536)
    return Error("PublishedMapOptions.stem_columns",
                 "must be between 4 and 65536, got " + std::to_string(stem_columns));
  if (knot_columns < 2 || knot_columns > 65536)
    return Error("PublishedMapOptions.knot_columns",
                 "must be between 2 and 65536, got " + std::to_string(knot_columns));
  if (rows_per_knot < 1 || rows_per_knot > 256)
    return Error("PublishedMapOptions.rows_per_knot",
                 "must be between 1 and 256, got " + std::to_string(rows_per_knot));
  return Status::Ok();
}

void PublishedMapExportSummary::print(std::ostream& os) const {
  os << "published maps: rmin " << rmin << " mm, rmax " << rmax << " mm, hmax " << hmax << " mm, "
     << knots << " knots; stem map " << stem_columns << " x " << stem_rows << ", knot maps "
     << knot_columns << " x " << std::max(knots, 1) * rows_per_knot << "\n";
  if (clamped_pith_rows || clamped_knot_starts || clamped_rise_texels || clamped_twist_texels)
    os << "  clamped to the 8-bit ranges: " << clamped_pith_rows << " pith rows, "
       << clamped_knot_starts << " knot starts, " << clamped_rise_texels << " rise texels, "
       << clamped_twist_texels << " twist texels\n";
  if (saturated_r_dead || clamped_r_end)
    os << "  beyond the maps' range (exact only in the sidecar): r_dead >= rmin in "
       << saturated_r_dead << " of " << knots << " knots, r_end > rmax in " << clamped_r_end
       << "\n";
}

void PublishedMapImportSummary::print(std::ostream& os) const {
  os << "published maps: rmin " << rmin << " mm, rmax " << rmax << " mm, hmax " << hmax << " mm, "
     << knots << " knots; stem map " << stem_columns << " x " << stem_rows << ", knot maps "
     << knot_columns << " columns x " << rows_per_knot << " rows per knot; sidecar "
     << (sidecar ? "used" : "absent") << "\n"
     << "  knot fit residual (worst knot): height " << max_height_fit_rms_mm << " mm, azimuth "
     << max_azimuth_fit_rms << " rad\n";
}

Status export_published_maps(const LogModel& log, const fs::path& dir,
                             const PublishedMapOptions& options,
                             PublishedMapExportSummary* summary) {
  if (Status st = options.validate(); !st) return st.error().with_context(dir.string());
  if (Status st = validate(log); !st) return st.error().with_context(dir.string());
  if (Status st = maps_detail::check_finite(log.stem); !st)
    return st.error().with_context(dir.string());
  PublishedMapExportSummary local;
  PublishedMapExportSummary* sum = summary ? summary : &local;
  *sum = {};
  const EncodedMaps maps = encode(log, options, sum);

  return write_dir_atomic(dir, [&](const fs::path& tmp) -> Status {
    const std::pair<const char*, const Rgb8Image*> images[] = {{kPithMapFile, &maps.pith},
                                                               {kHeightMapFile, &maps.height},
                                                               {kOrientMapFile, &maps.orient},
                                                               {kStateMapFile, &maps.state}};
    for (const auto& [name, img] : images) {
      Status st = maps_detail::write_bmp_rgb8(tmp / name, *img, (dir / name).string());
      if (!st) return st;
    }
    Status st = maps_detail::write_json_file(tmp / kParamsFile, maps.params, -1,
                                             (dir / kParamsFile).string());
    if (!st) return st;
    if (options.write_sidecar) {
      st = maps_detail::write_json_file(tmp / kSidecarFile, maps.sidecar, 2,
                                        (dir / kSidecarFile).string());
      if (!st) return st;
    }
    return Status::Ok();
  });
}

Result<LogModel> import_published_maps(const fs::path& dir, PublishedMapImportSummary* summary) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return Error(dir.string(), "no such folder");
  if (!fs::is_directory(dir, ec))
    return Error(dir.string(), "is a file, expected a folder of maps");

  Result<MapParams> params = read_map_params(dir / kParamsFile);
  if (!params) return params.error();
  const MapParams p = params.value();

  std::optional<Sidecar> side;
  if (fs::exists(dir / kSidecarFile, ec)) {
    Result<Sidecar> sc = read_sidecar(dir / kSidecarFile);
    if (!sc) return sc.error();
    side = std::move(sc).value();
    if (static_cast<int>(side->knots.size()) != p.n)
      return Error((dir / kSidecarFile).string(), "lists " + std::to_string(side->knots.size()) +
                                                      " knots, " + kParamsFile + " says " +
                                                      std::to_string(p.n));
  }

  // ---- stem
  const fs::path pith_path = dir / kPithMapFile;
  Result<Rgb8Image> pith_img = maps_detail::read_rgb8(pith_path);
  if (!pith_img) return pith_img.error();
  const Rgb8Image& pm = pith_img.value();
  if (Status st =
          check_size(pith_path, pm, side ? side->stem_columns : -1, side ? side->stem_rows : -1);
      !st)
    return st.error();
  if (pm.width < 3)
    return Error(pith_path.string(),
                 "expected at least 3 columns, found " + std::to_string(pm.width));
  // One stem sample per row, n_angles radii each: the log model's limits before the rows are
  // resampled into it.
  const int n_angles = side ? side->n_angles : kDefaultAngles;
  if (pm.height > log_limits::kMaxSlices ||
      static_cast<long long>(pm.height) * n_angles > log_limits::kMaxStemValues)
    return Error(pith_path.string(), std::to_string(pm.height) + " rows × " +
                                         std::to_string(n_angles) +
                                         " angles, more than the log model allows (" +
                                         std::to_string(log_limits::kMaxSlices) + " rows, " +
                                         std::to_string(log_limits::kMaxStemValues) + " radii)");

  LogModel log;
  log.id = side ? side->id : default_log_id(dir);
  log.species = side ? side->species : "";
  log.source = side
                   ? side->source
                   : "imported from published maps (Larsson et al. 2022 format) in " + dir.string();
  Stem& s = log.stem;
  const double z_origin = side ? side->z_origin_mm : 0.0;
  const Vec2 mid = side ? side->pith_mid : Vec2{};
  s.dz_mm = p.hmax / pm.height;
  s.z0_mm = z_origin + 0.5 * s.dz_mm;
  s.n_angles = side ? side->n_angles : kDefaultAngles;
  // The renderer reads the pith at u = 0.5: between the two middle columns for an even width.
  const double xmid = 0.5 * pm.width - 0.5;
  const int c0 = static_cast<int>(std::floor(xmid));
  const double tmid = xmid - c0;
  const int c1 = (c0 + 1) % pm.width;
  std::vector<double> col(pm.width);
  for (int i = 0; i < pm.height; ++i) {
    const double bx = (1 - tmid) * pm.at(c0, i, 0) + tmid * pm.at(c1, i, 0);
    const double by = (1 - tmid) * pm.at(c0, i, 1) + tmid * pm.at(c1, i, 1);
    s.pith.push_back(mid +
                     Vec2{(decode_unit(bx) - 0.5) * p.rmin, (decode_unit(by) - 0.5) * p.rmin});
    for (int c = 0; c < pm.width; ++c)
      col[c] = p.rmin + decode_unit(pm.at(c, i, 2)) * (p.rmax - p.rmin);
    std::vector<double> row(s.n_angles);
    for (int k = 0; k < s.n_angles; ++k) {
      const double phi = wrap_angle(kHalfPi - kTwoPi * k / s.n_angles);
      // The map cannot hold radii outside [rmin, rmax]; keep the cubic's overshoot inside too.
      row[k] = std::clamp(periodic_catmull_rom(col, phi / kTwoPi * pm.width - 0.5), p.rmin, p.rmax);
    }
    s.radius.push_back(std::move(row));
  }

  PublishedMapImportSummary local;
  PublishedMapImportSummary* sum = summary ? summary : &local;
  *sum = {};
  sum->rmin = p.rmin, sum->rmax = p.rmax, sum->hmax = p.hmax, sum->knots = p.n;
  sum->stem_columns = pm.width, sum->stem_rows = pm.height;
  sum->sidecar = side.has_value();

  // ---- knots
  if (p.n > 0) {
    Rgb8Image maps[3];
    const char* names[3] = {kHeightMapFile, kOrientMapFile, kStateMapFile};
    for (int m = 0; m < 3; ++m) {
      const fs::path path = dir / names[m];
      Result<Rgb8Image> img = maps_detail::read_rgb8(path);
      if (!img) return img.error();
      maps[m] = std::move(img).value();
      // The first map fixes the size (unless the sidecar does); the others must match it.
      const int want_w = m > 0 ? maps[0].width : (side ? side->knot_columns : -1);
      const int want_h = m > 0 ? maps[0].height
                               : (side && side->rows_per_knot > 0 ? side->rows_per_knot * p.n : -1);
      if (Status st = check_size(path, maps[m], want_w, want_h); !st) return st.error();
      if (m == 0 && maps[0].width < 2)
        return Error(path.string(),
                     "expected at least 2 columns, found " + std::to_string(maps[0].width));
      if (m == 0 && maps[0].height % p.n != 0)
        return Error(path.string(), std::to_string(maps[0].height) +
                                        " rows are not a multiple of the knot count " +
                                        std::to_string(p.n) + " (" + kParamsFile + ")");
    }
    const int rpk = maps[0].height / p.n;
    const int kw = maps[0].width;
    sum->knot_columns = kw, sum->rows_per_knot = rpk;

    std::vector<double> r(kw), rise(kw), tw(kw);
    for (int j = 0; j < kw; ++j) r[j] = knot_column_r(j, kw, p.rmin);
    for (int i = 0; i < p.n; ++i) {
      const KnotColumns hc = knot_columns(maps[0], i, rpk);
      const KnotColumns oc = knot_columns(maps[1], i, rpk);
      const KnotColumns sc = knot_columns(maps[2], i, rpk);
      Knot k;
      k.id = side ? side->knots[i].id : i;
      k.z0 = z_origin + decode_unit(mean(hc.c[0])) * p.hmax;
      k.omega0 = wrap_angle(kTwoPi * decode_unit(mean(oc.c[0])));
      for (int j = 0; j < kw; ++j) {
        rise[j] = decode_unit(hc.c[2][j] - hc.c[1][j]) * p.rmin;
        tw[j] = decode_unit(oc.c[2][j] - oc.c[1][j]) * kHalfPi;
      }
      // r_end: the sidecar, else the state map's blue (our extension), else to the bark.
      const double end_byte = mean(sc.c[2]);
      k.r_end =
          side ? side->knots[i].r_end : (end_byte > 0 ? decode_unit(end_byte) * p.rmax : p.rmax);
      // r_dead: green in units of rmin; saturated green means "rmin or beyond".
      const double dead_byte = mean(sc.c[1]);
      const bool saturated = dead_byte >= 255.0;
      k.r_dead = saturated ? std::max(p.rmin, k.r_end) : decode_unit(dead_byte) * p.rmin;
      if (side) {
        // The sidecar refines r_dead to full precision where it agrees with the map (always,
        // for maps we wrote); a map edited since keeps the map's value.
        const double rd = side->knots[i].r_dead;
        if ((saturated && rd >= p.rmin * (254.5 / 255.0)) ||
            std::abs(rd - k.r_dead) <= 0.5 * p.rmin / 255.0 + 1e-9 * p.rmin)
          k.r_dead = rd;
      }
      int m = 0;
      while (m < kw && r[m] <= k.r_end * (1 + 1e-12)) ++m;
      m = std::max(m, 2);
      const AxisFit f = fit_axis(r, rise, tw, m);
      k.a = f.a, k.b = f.b, k.twist = f.twist;
      sum->max_height_fit_rms_mm = std::max(sum->max_height_fit_rms_mm, f.height_rms);
      sum->max_azimuth_fit_rms = std::max(sum->max_azimuth_fit_rms, f.azimuth_rms);
      if (side) {
        const SidecarKnot& sk = side->knots[i];
        k.diameter = {sk.d_dead, sk.d_exp};
        k.fit_rms_mm = sk.fit_rms_mm;
        k.support = sk.support;
      } else {
        const int slice = std::clamp(static_cast<int>(std::lround((k.z0 - s.z0_mm) / s.dz_mm)), 0,
                                     s.slice_count() - 1);
        k.diameter = fit_paper_diameter(k.r_dead, s.mean_radius(slice), p.rmin);
        k.fit_rms_mm = f.height_rms;
        k.support = f.columns;
      }
      log.knots.push_back(k);
    }
  }

  if (Status st = validate(log); !st) return st.error().with_context(dir.string());
  return log;
}

}  // namespace sawyer
