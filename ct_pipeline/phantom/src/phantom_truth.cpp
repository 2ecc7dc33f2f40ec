// The phantom's ground truth: the log model re-expressed in the scanner frame (truth/log.json)
// and the record of everything the phantom did (truth/phantom.json).
#include <algorithm>
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "phantom_internal.h"
#include "sawyer/core/file_util.h"
#include "sawyer/model/log_json.h"

namespace sawyer::ct {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Outline radius of the log's cross-section in the scanner slice at height zs, along scanner
// azimuth ws from the slice's pith: the r where the mapped point meets `surface(omega, z)` of
// the log frame. Exact up to the iteration tolerance, tilt included (a tilted log's section is
// slightly elongated).
template <typename Surface>
double section_radius(const Phantom& ph, const Stem& st, Vec2 pith_s, double zs, double ws,
                      double r_start, Surface surface) {
  double r = std::max(r_start, 1e-3);
  for (int it = 0; it < 8; ++it) {
    const Vec3 P = ph.to_log({pith_s.x + r * std::cos(ws), pith_s.y + r * std::sin(ws), zs});
    double rl, wl;
    st.polar(P, &rl, &wl);
    const double target = surface(wl, P.z);
    if (rl < 1e-9) break;
    const double next = r * target / rl;
    if (std::abs(next - r) < 1e-7) {
      r = next;
      break;
    }
    r = next;
  }
  return r;
}

}  // namespace

// A tilted knot axis is not exactly a knot-formula curve in the scanner frame (pith distances
// are measured from a pith line that is itself tilted). Fits the formula to the mapped axis by
// least squares: heights z0' + a'√r + b'r with z0' fixed (the start on the pith is exact),
// azimuths ω0' + twist'·ln r, and r_dead, r_end mapped to their scanner pith distances.
void Phantom::refit_tilted_knot(const Knot& k, Knot* q) const {
  const Stem& st = log_.stem;
  // Scanner pith distance, azimuth and height of the model's axis point at pith distance r.
  auto map = [&](double r, double* rs, double* ws, double* zs) {
    const Vec3 Q = to_scanner(k.axis_point(r, st));
    double zl;
    Vec2 pc;
    solve_pith(Q.z, &zl, &pc);
    *rs = std::hypot(Q.x - pc.x, Q.y - pc.y);
    *ws = std::atan2(Q.y - pc.y, Q.x - pc.x);
    *zs = Q.z;
  };
  const double len = std::max(k.r_end, 1.0);
  constexpr int kSamples = 48;
  double Szz[2][2] = {{0, 0}, {0, 0}}, Sz[2] = {0, 0};
  double Sww[2][2] = {{0, 0}, {0, 0}}, Sw[2] = {0, 0};
  double w_prev = 0;
  bool first = true;
  for (int j = 0; j < kSamples; ++j) {
    const double r = len * (j + 0.5) / kSamples;
    double rs, ws, zs;
    map(r, &rs, &ws, &zs);
    // Heights: unknowns a', b' against √rs, rs.
    const double f[2] = {std::sqrt(rs), rs};
    for (int u = 0; u < 2; ++u) {
      for (int v = 0; v < 2; ++v) Szz[u][v] += f[u] * f[v];
      Sz[u] += f[u] * (zs - q->z0);
    }
    // Azimuths, unwrapped along the knot: unknowns ω0', twist' against 1, ln rs.
    if (first) {
      w_prev = ws;
      first = false;
    }
    ws = w_prev + angle_diff(ws, w_prev);
    w_prev = ws;
    const double g[2] = {1.0, std::log(std::max(rs, 1.0))};
    for (int u = 0; u < 2; ++u) {
      for (int v = 0; v < 2; ++v) Sww[u][v] += g[u] * g[v];
      Sw[u] += g[u] * ws;
    }
  }
  auto solve2 = [](const double A[2][2], const double b[2], double* x0, double* x1) {
    const double det = A[0][0] * A[1][1] - A[0][1] * A[1][0];
    if (std::abs(det) < 1e-12 * (std::abs(A[0][0] * A[1][1]) + 1e-300)) return false;
    *x0 = (b[0] * A[1][1] - b[1] * A[0][1]) / det;
    *x1 = (A[0][0] * b[1] - A[1][0] * b[0]) / det;
    return true;
  };
  double a, b, w0, tw;
  if (solve2(Szz, Sz, &a, &b)) {
    q->a = a;
    q->b = b;
  }
  if (solve2(Sww, Sw, &w0, &tw)) {
    q->omega0 = wrap_angle(w0);
    q->twist = tw;
  }
  double rs, ws, zs;
  map(k.r_end, &rs, &ws, &zs);
  q->r_end = rs;
  map(k.r_dead, &rs, &ws, &zs);
  q->r_dead = rs;
}

LogModel Phantom::truth_log() const {
  const Stem& st = log_.stem;
  const int n = nominal_count();
  const double sp = options_.slice_spacing_mm;
  const double roll = options_.placement.roll_deg * kPi / 180.0;
  LogModel t;
  t.id = log_.id.empty() ? "phantom" : log_.id + "_phantom";
  t.species = log_.species;
  t.source = "sawyer phantom of '" + log_.id + "' (" + log_.source +
             "), in the scanner frame: z = 0 at the first slice, x, y = column, row x pixel";
  Stem& s = t.stem;
  s.z0_mm = 0;
  s.dz_mm = sp;
  s.n_angles = st.n_angles;
  for (int i = 0; i < n; ++i) {
    const double zs = nominal_z_[i], zl = pith_log_z_[i];
    const Vec2 pc = pith_[i];
    s.pith.push_back(pc);
    std::vector<double> rad(st.n_angles), heart(st.n_angles);
    double bark_sum = 0;
    for (int k = 0; k < st.n_angles; ++k) {
      const double ws = kTwoPi * k / st.n_angles;
      const double wl0 = wrap_angle(ws - roll);
      const double R0 = st.radius_at(wl0, zl);
      rad[k] = section_radius(*this, st, pc, zs, ws, R0,
                              [&](double w, double z) { return st.radius_at(w, z); });
      heart[k] = section_radius(
          *this, st, pc, zs, ws, heartwood_radius(wl0, zl, R0),
          [&](double w, double z) { return heartwood_radius(w, z, st.radius_at(w, z)); });
      bark_sum += bark_thickness(wl0, zl, R0) - bark_gap(wl0, zl);  // bark, not its air gap
    }
    // 0.1 µm is far below any CT's resolution and keeps truth/log.json compact.
    for (double& v : rad) v = std::round(v * 1e4) / 1e4;
    for (double& v : heart) v = std::round(v * 1e4) / 1e4;
    s.radius.push_back(std::move(rad));
    s.heartwood.push_back(std::move(heart));
    s.bark_mm.push_back(std::round(bark_sum / st.n_angles * 1e4) / 1e4);
  }

  // Knots seen by the scan: those whose z range meets the scanned slabs (in the log frame,
  // widened by the tilt's reach).
  const double tilt = std::acos(std::clamp(M_[2][2], -1.0, 1.0));
  const double reach = max_outer_ * std::sin(tilt) + 0.5 * options_.thickness();
  const double lo = std::min(pith_log_z_.front(), pith_log_z_.back()) - reach;
  const double hi = std::max(pith_log_z_.front(), pith_log_z_.back()) + reach;
  for (const Knot& k : log_.knots) {
    double kz0, kz1;
    k.z_range(&kz0, &kz1);
    if (kz1 < lo || kz0 > hi) continue;
    Knot q = k;
    // Heights: the knot's start is on the pith, mapped exactly. Along the knot, the log's
    // axis maps to height M22 and a horizontal step in the knot's direction gains v.z of
    // height (the tilt's slope seen along the knot): z'(r) ≈ z0' + M22 (a√r + b r) + v.z r.
    // The direction is taken at half the knot's length. Exact without tilt; with tilt this is
    // the first-order form, which refit_tilted_knot() then improves.
    const Vec2 p0 = st.pith_at(k.z0);
    const Vec3 s0 = to_scanner({p0.x, p0.y, k.z0});
    const double w_rep = k.azimuth_at(0.5 * k.r_end);
    const double d[3] = {std::cos(w_rep), std::sin(w_rep), 0};
    Vec3 v;
    v.x = M_[0][0] * d[0] + M_[0][1] * d[1];
    v.y = M_[1][0] * d[0] + M_[1][1] * d[1];
    v.z = M_[2][0] * d[0] + M_[2][1] * d[1];
    const double dw = angle_diff(std::atan2(v.y, v.x), w_rep);
    q.z0 = s0.z;
    q.a = M_[2][2] * k.a;
    q.b = M_[2][2] * k.b + v.z / std::hypot(v.x, v.y);
    q.omega0 = wrap_angle(k.omega0 + dw);
    if (options_.placement.tilted()) refit_tilted_knot(k, &q);
    t.knots.push_back(q);
  }
  return t;
}

std::string Phantom::truth_json(const std::string& output_info_json) const {
  const PhantomOptions& o = options_;
  const Placement& pl = o.placement;
  json j;
  j["format"] = "sawyer-phantom/1";
  j["log"] = {{"id", log_.id},
              {"species", log_.species},
              {"source", log_.source},
              {"z_begin_mm", log_.stem.z_begin()},
              {"z_end_mm", log_.stem.z_end()},
              {"knots", log_.knots.size()}};
  j["options"] = {
      {"image_size", o.image_size},
      {"pixel_mm", o.pixel_mm},
      {"slice_spacing_mm", o.slice_spacing_mm},
      {"slice_thickness_mm", o.thickness()},
      {"sub_slices", sub_slices_},
      {"from_mm", from_},
      {"to_mm", to_},
      {"noise_hu", o.noise_hu},
      {"blur_px", o.blur_px},
      {"seed", o.seed},
      {"ring_width_mm", o.ring_width_mm},
      {"ring_amplitude", o.ring_amplitude},
      {"ring_count", ring_count_},
      {"knot_noise", o.knot_noise},
      {"bed", o.bed},
      {"clutter", o.clutter},
      {"drop_slices", o.drop_slices},
      {"juvenile_ring_width_mm", o.juvenile_ring_width_mm},
      {"juvenile_radius_mm", o.juvenile_radius_mm},
      {"ring_contrast_hu", o.ring_contrast_hu},
      {"ring_modulation_hu_peak_to_peak", ring_amp_hu_},
      {"latewood_fraction", o.latewood_fraction},
      {"density_drift_hu_per_m", o.density_drift_hu_per_m},
      {"moisture", moisture_name(o.moisture)},
      {"wet_pockets", o.wet_pockets},
      {"hu_offset", o.hu_offset},
      {"hu_slope", o.hu_slope},
      {"cupping_hu", o.cupping_hu},
      {"metal_streak_hu", o.metal_streak_hu},
      {"second_log", o.second_log},
      {"window_centre_hu", o.window_centre_hu},
      {"window_width_hu", o.window_width_hu},
      {"cracks", o.cracks},
      {"crack_width_mm", o.crack_width_mm},
      {"resin_pockets", o.resin_pockets},
      {"rot_pockets", o.rot_pockets},
      {"compression_wood", o.compression_wood},
      {"bark_missing", o.bark_missing},
      {"bark_loose", o.bark_loose},
      {"knot_bark_mm", o.knot_bark_mm},
      {"resin_knots", o.resin_knots},
  };
  json m = json::array();
  for (const auto& row : M_) m.push_back({row[0], row[1], row[2]});
  j["placement"] = {
      {"offset_x_mm", pl.offset_x_mm},
      {"offset_y_mm", pl.offset_y_mm},
      {"tilt_x_deg", pl.tilt_x_deg},
      {"tilt_y_deg", pl.tilt_y_deg},
      {"roll_deg", pl.roll_deg},
      {"rule", "scanner = T + M (log - A); M = Ry(tilt_y) Rx(tilt_x) Rz(roll)"},
      {"A_log_mm", {A_.x, A_.y, A_.z}},
      {"T_scanner_mm", {T_.x, T_.y, T_.z}},
      {"M", m},
  };
  const HuTable& h = hu_;  // the table used (dried when the log is)
  j["hu"] = {{"air", h.air},
             {"bark_inner", h.bark_inner},
             {"bark_outer", h.bark_outer},
             {"heartwood", h.heartwood},
             {"sapwood", h.sapwood},
             {"sound_knot", h.sound_knot},
             {"dead_knot", h.dead_knot},
             {"knot_bark", h.knot_bark},
             {"bed_belt", h.bed_belt},
             {"bed_rail", h.bed_rail},
             {"steel", h.steel},
             {"dry_wood_density", h.dry_wood_density},
             {"max_hu", h.max_hu},
             {"resin", h.resin},
             {"rot", h.rot},
             {"resin_knot", h.resin_knot},
             {"reported", "hu_offset + hu_slope x HU (the options' calibration)"}};
  j["geometry"] = {{"width", geometry_.width},
                   {"height", geometry_.height},
                   {"spacing_x", geometry_.spacing_x},
                   {"spacing_y", geometry_.spacing_y},
                   {"origin", {geometry_.origin.x, geometry_.origin.y, geometry_.origin.z}},
                   {"slices_written", geometry_.slice_count()},
                   {"slices_nominal", nominal_count()},
                   {"z", geometry_.z}};
  j["dropped"] = dropped_;
  if (has_bed_) {
    j["bed"] = {
        {"belt_centre", {bed_centre_.x, bed_centre_.y}},
        {"belt_inner_radius_mm", bed_radius_},
        {"belt_thickness_mm", bed_thickness_},
        {"belt_half_angle_deg", bed_half_angle_ * 180 / kPi},
        {"rails", {{rail_centre_[0].x, rail_centre_[0].y}, {rail_centre_[1].x, rail_centre_[1].y}}},
        {"rail_size_mm", 2 * rail_half_},
        {"rail_wall_mm", rail_wall_}};
  }
  json cl = json::array();
  for (const ClutterObject& c : clutter_)
    cl.push_back({{"kind", c.kind},
                  {"centre", {c.centre.x, c.centre.y, c.centre.z}},
                  {"z_min", c.z_min},
                  {"z_max", c.z_max}});
  j["clutter"] = cl;
  json df = json::array();
  for (const Defect& d : defects_) {
    const Vec2 pc = log_.stem.pith_at(std::clamp(d.z_mm, log_.stem.z_begin(), log_.stem.z_end()));
    const Vec3 c =
        to_scanner({pc.x + d.r_mm * std::cos(d.omega), pc.y + d.r_mm * std::sin(d.omega), d.z_mm});
    json e = {{"kind", d.kind},
              {"r_mm", d.r_mm},
              {"omega", d.omega},
              {"z_mm", d.z_mm},
              {"z_min", d.z_min},
              {"z_max", d.z_max},
              {"image_centre", {c.x, c.y, c.z}}};
    if (d.radial_mm > 0) {
      e["radial_mm"] = d.radial_mm;
      e["tangential_mm"] = d.tangential_mm;
    }
    if (d.kind == "crack" || d.kind == "resin_knot") {
      e["r_min"] = d.r_min;
      e["r_max"] = d.r_max;
    }
    if (d.kind == "crack") e["from_bark"] = d.from_bark;
    if (d.half_angle > 0) e["half_angle"] = d.half_angle;
    if (d.width_mm > 0) e[d.kind == "compression_wood" ? "extra_hu" : "width_mm"] = d.width_mm;
    if (d.knot_id >= 0) e["knot_id"] = d.knot_id;
    df.push_back(e);
  }
  j["defects"] = df;
  json ms = json::array();
  for (const MetalStreaks& st : streaks_) {
    json angles = json::array();
    for (double a : st.angles) angles.push_back(a * 180 / kPi);
    ms.push_back({{"centre", {st.centre.x, st.centre.y}},
                  {"z_min", st.z_min},
                  {"z_max", st.z_max},
                  {"angles_deg", angles},
                  {"amplitude_hu", st.amplitude_hu},
                  {"sigma_mm", st.sigma_mm},
                  {"decay_mm", st.decay_mm},
                  {"rule", "first angle dark, then alternately bright and dark"}});
  }
  j["metal_streaks"] = ms;
  if (has_second_) {
    json piths = json::array();
    for (int i = 0; i < nominal_count(); ++i) {
      const Vec2 q = second_pith(i);
      piths.push_back({q.x, q.y});
    }
    j["second_log"] = {{"rule",
                        "log xy = A - (scanner xy - C2), log z = A.z - (scanner z - T.z): the same "
                        "model end for end, touching the first log at touch_slice"},
                       {"C2", {second_c_.x, second_c_.y}},
                       {"touch_slice", second_touch_},
                       {"pith", piths}};
  }
  j["defects_frame"] =
      "log frame around the model's pith: r_mm, omega (rad), z_mm; image_centre, metal_streaks and "
      "second_log: the image frame of slices[].pith (add geometry.origin for the scanner's)";
  json sl = json::array();
  for (int i = 0, d = 0; i < nominal_count(); ++i) {
    const bool drop = d < static_cast<int>(dropped_.size()) && dropped_[d] == i;
    if (drop) ++d;
    sl.push_back({{"index", i},
                  {"z", nominal_z_[i]},
                  {"z_log", pith_log_z_[i]},
                  {"pith", {pith_[i].x, pith_[i].y}},
                  {"dropped", drop}});
  }
  j["slices"] = sl;
  if (!output_info_json.empty()) {
    json out = json::parse(output_info_json, nullptr, false);
    if (!out.is_discarded()) j["output"] = out;
  }
  return j.dump(1);
}

Status Phantom::write_truth(const fs::path& dir, const std::string& output_info_json) const {
  const fs::path truth = dir / "truth";
  std::error_code ec;
  fs::create_directories(truth, ec);
  if (ec) return Error(truth.string(), "cannot create the folder: " + ec.message());
  // truth/log.json in the frame `sawyer scan` writes log.json in: the scanner's x, y (the image
  // axes plus the origin), heights from the first slice (docs/formats.md).
  LogModel t = truth_log();
  ScannerFrame frame;
  frame.origin_mm = geometry_.origin;
  frame.z0_mm = geometry_.origin.z;
  place_in_scanner_frame(t, {geometry_.origin.x, geometry_.origin.y}, frame);
  if (Status st = write_log_json(t, truth / "log.json"); !st) return st;
  return write_text_file_atomic(truth / "phantom.json", truth_json(output_info_json) + "\n");
}

}  // namespace sawyer::ct
