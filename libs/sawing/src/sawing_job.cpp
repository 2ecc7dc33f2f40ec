// One sawing job (see sawing_job.h).
#include "sawyer/sawing/sawing_job.h"

#include <cstdio>

#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/sawing_json.h"
#include "sawyer/sawing/setup.h"

namespace sawyer::sawing {

using Json = nlohmann::ordered_json;

Result<SawSetup> load_saw_setup(const SawNames& names, const OptimiseOptions& options) {
  SawSetup s;
  s.names = names;
  s.options = options;
  Result<Pattern> pattern = pattern_by_name(names.pattern);
  if (!pattern) return pattern.error();
  s.pattern = std::move(pattern.value());
  Result<GradingRules> rules = grading_by_name(names.grading);
  if (!rules) return rules.error();
  s.rules = std::move(rules.value());
  s.prices_path = names.prices.empty() ? bundled_data_dir() / "prices/example_prices.json"
                                       : std::filesystem::path(names.prices);
  Result<PriceTable> prices = prices_by_name(names.prices);
  if (!prices) return prices.error();
  s.prices = std::move(prices.value());
  if (Status st = s.prices.check_covers(s.rules); !st)
    return st.error().with_context(s.prices_path.string());
  if (!names.position.empty()) {
    Result<LogPosition> p = parse_position(names.position);
    if (!p) return p.error();
    s.position = p.value();
  }
  if (Status st = s.options.validate(s.pattern); !st) return st.error();
  return s;
}

Result<SawingOutcome> saw_log_model(const LogModel& log, const SawSetup& setup,
                                    const std::function<void(int, int)>& progress) {
  SawingOutcome out{SawLog(log), {}, {}, {}, {}, {}};
  if (Status s = check_pattern_fits(setup.pattern, out.saw_log.usable_diameter_mm(), log.id); !s)
    return s.error();
  Result<OptimiseResult> opt = optimise_position(out.saw_log, setup.pattern, setup.rules,
                                                 setup.prices, setup.options, progress);
  if (!opt) return opt.error();
  out.opt = std::move(opt.value());
  out.best_sawn =
      saw_for_sale(out.saw_log, setup.pattern, out.opt.best.pos, setup.rules, setup.prices);
  out.best_value = value_of(out.best_sawn, setup.rules, setup.prices);
  if (setup.position) {
    out.given_sawn =
        saw_for_sale(out.saw_log, setup.pattern, *setup.position, setup.rules, setup.prices);
    out.given_value = value_of(*out.given_sawn, setup.rules, setup.prices);
  }
  return out;
}

std::string offset_edge_note(const OptimiseResult& r) {
  const auto on_edge = [](const std::vector<double>& grid, double v) {
    return grid.size() > 1 && (v == grid.front() || v == grid.back());
  };
  const bool x = on_edge(r.offsets_x_mm, r.best.pos.offset_x_mm);
  const bool y = on_edge(r.offsets_y_mm, r.best.pos.offset_y_mm);
  if (!x && !y) return "";
  return std::string("the best position is on the edge of the offset grid (") +
         (x && y ? "x and y" : x ? "x" : "y") +
         "): a wider range (--offsets" + (y && !x ? "-y" : "") + ") may be worth more";
}

std::string bow_line(const BowInfo& b) {
  char buf[256];
  if (b.straight)
    std::snprintf(buf, sizeof buf,
                  "log straight (arc bow %.1f mm < %.0f mm, sweep %.1f mm): horns-down is the "
                  "orientation it had in the scanner, a convention",
                  b.height_mm, kMinBowMm, b.chord_mm);
  else
    std::snprintf(buf, sizeof buf,
                  "horns-down from an arc bow of %.1f mm (sweep %.1f mm), horns at %.0f° in the "
                  "scanner",
                  b.height_mm, b.chord_mm, b.horns_azimuth * 180.0 / kPi);
  return buf;
}

std::string saw_setup_text(double turn_deg, const std::array<Vec3, 2>& ends, bool scanner_frame) {
  const Vec3 &a = ends[0], &b = ends[1];
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "turn %+.1f° from the scan; pattern centre (%.1f, %.1f) mm at z %.0f, (%.1f, "
                "%.1f) mm at z %.0f (%s frame)",
                turn_deg, a.x, a.y, a.z, b.x, b.y, b.z, scanner_frame ? "scanner" : "log model");
  return buf;
}

std::string saw_setup_line(const SawLog& log, const LogPosition& pos) {
  return saw_setup_text(scanner_position(log, pos).turn_deg, pattern_centre_at_ends(log, pos),
                        log.model().scanner_frame.has_value());
}

std::string offcut_note(double sawn_begin, double sawn_end, double z_begin, double z_end) {
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "; cross-cut from %.2f m: %.2f m off at z %.2f m, %.2f m at z %.2f m",
                (sawn_end - sawn_begin) * 1e-3, (z_begin - sawn_begin) * 1e-3, sawn_begin * 1e-3,
                (sawn_end - z_end) * 1e-3, sawn_end * 1e-3);
  return buf;
}

namespace {

// The position as the saw executes it: the turn from the log's orientation in the scanner and
// the pattern centre at the log's two ends, in scanner x, y, z (docs/sawing.md, "Frames").
Json scanner_json(const SawLog& log, const LogPosition& pos) {
  Json ends = Json::array();
  for (const Vec3& c : pattern_centre_at_ends(log, pos)) ends.push_back({c.x, c.y, c.z});
  return {{"turn_deg", scanner_position(log, pos).turn_deg}, {"pattern_centre_at_ends_mm", ends}};
}

Json ranked_json(const SawLog& log, const RankedPosition& r) {
  Json j = position_json(r.pos);
  j["value"] = r.value;
  j["smoothed_value"] = r.smoothed;
  j["scanner"] = scanner_json(log, r.pos);
  return j;
}

Json bow_json(const BowInfo& b) {
  return {{"method",
           "arc fitted to the outline's centre line (area centroids per height); the horns point "
           "along its curvature"},
          {"arc_sagitta_mm", b.height_mm},
          {"chord_sweep_mm", b.chord_mm},
          {"min_bow_mm", kMinBowMm},
          {"straight", b.straight},
          {"horns_azimuth_deg", b.horns_azimuth * 180.0 / kPi},
          {"horns_down",
           b.straight ? "convention: the log as it lay in the scanner (bow below min_bow_mm)"
                      : "from the bow"}};
}

// Which frame the positions and coordinates are in: offsets and rotation are relative to the
// log (its mean pith line and horns), the log's x, y are the scanner's when the model came from
// a CT scan (its scanner_frame, recorded here so a saw can be set from it).
Json frame_json(const LogModel& log) {
  Json j;
  j["position"] =
      "rotation_deg from horns down about the mean pith line; offset_x_mm, offset_y_mm from the "
      "mean pith line in the turned cross-section (docs/sawing.md); \"scanner\": the same "
      "position as executed: turn_deg from the log's orientation in the scanner, counter-"
      "clockwise in the scanner's x-y plane, and the pattern centre at the log's two ends";
  j["coordinates"] = log.scanner_frame ? "scanner" : "log model";
  if (log.scanner_frame) {
    const ScannerFrame& f = *log.scanner_frame;
    j["scanner_frame"] = {{"origin_mm", {f.origin_mm.x, f.origin_mm.y, f.origin_mm.z}},
                          {"row_dir", {f.row_dir.x, f.row_dir.y, f.row_dir.z}},
                          {"col_dir", {f.col_dir.x, f.col_dir.y, f.col_dir.z}},
                          {"z0_mm", f.z0_mm},
                          {"z_dir", f.z_dir}};
  }
  return j;
}

}  // namespace

Json sawing_file_json(const LogModel& log, const SawSetup& setup, const SawingOutcome& out) {
  const OptimiseResult& r = out.opt;
  const OptimiseOptions& o = setup.options;
  Json j;
  j["format"] = "sawyer-sawing/1";
  j["log"] = log.id;
  j["pattern"] = setup.pattern.name;
  j["grading"] = setup.rules.name;
  j["prices"] = setup.prices.name;
  j["currency"] = setup.prices.currency;
  j["inputs"] = {{"pattern", setup.names.pattern},
                 {"grading", setup.names.grading},
                 {"prices", setup.prices_path.string()}};
  j["options"] = {
      {"rot_step_deg", o.rot_step_deg},       {"rot_range_deg", r.rot_range_deg},
      {"offset_x_max_mm", o.offset_x_max_mm}, {"offset_x_step_mm", o.offset_x_step_mm},
      {"offset_y_max_mm", o.offset_y_max_mm}, {"offset_y_step_mm", o.offset_y_step_mm},
      {"sigma_rot_deg", o.sigma_rot_deg},     {"sigma_offset_mm", o.sigma_offset_mm},
      {"model_draws", r.model_draws}};
  if (r.model_draws > 0) j["options"]["scan_spread"] = r.spread_note;
  j["frame"] = frame_json(log);
  j["bow"] = bow_json(out.saw_log.bow());
  j["pattern_point_symmetric"] = r.symmetric;
  j["chosen"] = out.chosen_is_given() ? "given" : "best";
  j["best"] = ranked_json(out.saw_log, r.best);
  j["horns_down"] = ranked_json(out.saw_log, r.horns_down);
  j["horns_up"] = ranked_json(out.saw_log, r.horns_up);
  j["gain_over_horns_down"] = r.gain_over_horns_down;
  j["gain_over_horns_up"] = r.gain_over_horns_up;
  Json ranked = Json::array();
  for (const RankedPosition& p : r.ranked) ranked.push_back(ranked_json(out.saw_log, p));
  j["ranked"] = ranked;
  j["boards"] = boards_json(out.best_sawn, out.best_value, setup.rules, true);
  if (out.given_sawn) {
    j["given_position"] = position_json(*setup.position);
    j["given_position"]["value"] = out.given_value->value;
    j["given_position"]["scanner"] = scanner_json(out.saw_log, *setup.position);
    // Raw over raw: a position off the grid has no smoothed value.
    j["given_position"]["gain_over_horns_down"] =
        r.horns_down.value > 0 ? out.given_value->value / r.horns_down.value - 1 : 0.0;
    j["given_position"]["boards"] =
        boards_json(*out.given_sawn, *out.given_value, setup.rules, true);
  }
  j["surface"] = {{"index", "(rotation × offsets_x + x) × offsets_y + y"},
                  {"rotations_deg", r.rotations_deg},
                  {"offsets_x_mm", r.offsets_x_mm},
                  {"offsets_y_mm", r.offsets_y_mm},
                  {"value", r.value},
                  {"smoothed_value", r.smoothed}};
  return j;
}

}  // namespace sawyer::sawing
