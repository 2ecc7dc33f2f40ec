// One sawing job (see sawing_job.h).
#include "sawyer/sawing/sawing_job.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>

#include "fit_text.h"
#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/setup.h"

namespace sawyer::sawing {

using Json = nlohmann::ordered_json;

std::vector<std::filesystem::path> setup_input_files(const SawNames& names) {
  std::vector<std::filesystem::path> files;
  std::error_code ec;
  for (const std::string* f : {&names.pattern, &names.pattern_set, &names.grading, &names.prices})
    if (!f->empty() && std::filesystem::exists(*f, ec)) files.emplace_back(*f);
  return files;
}

Result<SawSetup> load_saw_setup(const SawNames& names, const OptimiseOptions& options) {
  SawSetup s;
  s.names = names;
  s.options = options;
  if (!names.pattern_set.empty()) {
    Result<PatternSet> set = pattern_set_by_name(names.pattern_set);
    if (!set) return set.error();
    s.pattern_set = std::move(set.value());
  } else {
    Result<Pattern> pattern = pattern_by_name(names.pattern);
    if (!pattern) return pattern.error();
    s.pattern = std::move(pattern.value());
  }
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
  if (!s.pattern_set) {
    if (Status st = s.options.validate(s.pattern); !st) return st.error();
  } else {
    // Every pattern the set may choose (a 180° rotation range suits point-symmetric ones only).
    for (const Pattern* p : s.pattern_set->patterns())
      if (Status st = s.options.validate(*p); !st)
        return st.error().with_context(names.pattern_set + ": pattern '" + p->name + "'");
  }
  return s;
}

double wood_reach_mm(const SawLog& log) {
  const Stem& st = log.model().stem;
  double reach = 0;
  for (int i = 0; i < st.slice_count(); ++i) {
    double r = 0;
    for (double v : st.radius[static_cast<size_t>(i)]) r = std::max(r, v);
    reach = std::max(reach, (st.pith[static_cast<size_t>(i)] - log.line_at(st.z_at(i))).norm() + r);
  }
  return reach;
}

Status check_offsets_reach(const SawSetup& setup, double reach_mm, const std::string& reach_what) {
  char within[160];
  std::snprintf(within, sizeof within, "%s lies within %.0f mm of the log's centre line",
                reach_what.c_str(), reach_mm);
  if (setup.position) {
    const LogPosition& p = *setup.position;
    const double d = std::hypot(p.offset_x_mm, p.offset_y_mm);
    if (d > reach_mm) {
      char buf[320];
      std::snprintf(buf, sizeof buf,
                    "offset (%g, %g) mm puts the pattern's centre %.0f mm from the log's centre "
                    "line, outside the log: %s; give offsets within that",
                    p.offset_x_mm, p.offset_y_mm, d, within);
      return Error("SawNames::position", buf);
    }
  }
  const OptimiseOptions& o = setup.options;
  for (const auto& [option, max] : {std::pair{"offset_x_max_mm", o.offset_x_max_mm},
                                    std::pair{"offset_y_max_mm", o.offset_y_max_mm}}) {
    if (max <= reach_mm) continue;
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "%g mm reaches past the log, whose positions there saw nothing: %s; give at "
                  "most %.0f mm",
                  max, within, std::floor(reach_mm));
    return Error(option, buf);
  }
  return Status::Ok();
}

namespace {

// The sawing of one pattern: the optimiser's grid, then the boards sold at its best position and
// at the given one (SawingOutcome's fields of the same names).
struct PatternSawing {
  OptimiseResult opt;
  SawResult best_sawn;
  LogValue best_value;
  std::optional<SawResult> given_sawn;
  std::optional<LogValue> given_value;
  const LogValue& chosen_value() const { return given_value ? *given_value : best_value; }
  void move_into(SawingOutcome& out) {
    out.opt = std::move(opt);
    out.best_sawn = std::move(best_sawn);
    out.best_value = std::move(best_value);
    out.given_sawn = std::move(given_sawn);
    out.given_value = std::move(given_value);
  }
};

Result<PatternSawing> saw_pattern(const SawSetup& setup, const SawLog& log, const Pattern& pattern,
                                  const std::function<void(int, int)>& progress) {
  Result<OptimiseResult> opt =
      optimise_position(log, pattern, setup.rules, setup.prices, setup.options, progress);
  if (!opt) return opt.error();
  PatternSawing out;
  out.opt = std::move(opt.value());
  out.best_sawn = saw_for_sale(log, pattern, out.opt.best.pos, setup.rules, setup.prices);
  out.best_value = value_of(out.best_sawn, setup.rules, setup.prices);
  if (setup.position) {
    out.given_sawn = saw_for_sale(log, pattern, *setup.position, setup.rules, setup.prices);
    out.given_value = value_of(*out.given_sawn, setup.rules, setup.prices);
  }
  return out;
}

// Every candidate of the set that fits the log sawn in turn; the best kept in `out`.
Status choose_and_saw(const SawSetup& setup, SawingOutcome& out,
                      const std::function<void(int, int)>& progress) {
  const PatternSet& set = *setup.pattern_set;
  const double usable = out.saw_log.usable_diameter_mm();
  PatternChoice choice;
  choice.set = set.name;
  choice.usable_diameter_mm = usable;
  choice.at_given_position = setup.position.has_value();
  choice.class_label = set.classes[static_cast<size_t>(set.class_of(usable))].label();
  const std::vector<PatternCandidate> candidates = set.candidates(usable);
  int to_saw = 0;
  for (const PatternCandidate& c : candidates) {
    PatternCandidateResult r;
    r.name = c.pattern->name;
    r.class_label = set.classes[static_cast<size_t>(c.class_index)].label();
    r.own_class = c.own_class;
    r.needed_diameter_mm = c.pattern->required_diameter_mm();
    r.fits = r.needed_diameter_mm <= usable;
    to_saw += r.fits;
    choice.candidates.push_back(std::move(r));
  }
  // Each candidate that fits in turn; the best one's sawing kept.
  std::optional<PatternSawing> best;
  int sawn = 0;
  for (size_t i = 0; i < candidates.size(); ++i) {
    PatternCandidateResult& r = choice.candidates[i];
    if (!r.fits) continue;
    // Progress over every candidate: each has the same grid (but for a 180° or 360° range).
    auto each = [&](int done, int total) {
      if (progress) progress(sawn * total + done, to_saw * total);
    };
    Result<PatternSawing> trial = saw_pattern(setup, out.saw_log, *candidates[i].pattern, each);
    if (!trial) return trial.error().with_context("pattern '" + r.name + "'");
    ++sawn;
    r.value = trial.value().chosen_value().value;
    r.has_expected = !setup.position;
    r.expected_value = r.has_expected ? trial.value().opt.best.smoothed : 0.0;
    auto rank = [&](int k) { return choice.candidates[static_cast<size_t>(k)].rank_value(); };
    if (choice.chosen < 0 || r.rank_value() > rank(choice.chosen)) {
      choice.next_best = choice.chosen;
      choice.chosen = static_cast<int>(i);
      best = std::move(trial).value();
    } else if (choice.next_best < 0 || r.rank_value() > rank(choice.next_best)) {
      choice.next_best = static_cast<int>(i);
    }
  }
  out.pattern = *candidates[static_cast<size_t>(choice.chosen)].pattern;
  best->move_into(out);
  out.choice = std::move(choice);
  return Status::Ok();
}

}  // namespace

FitNeed fit_need(const SawSetup& setup, double usable_diameter_mm) {
  if (!setup.pattern_set) return {setup.pattern.name, setup.pattern.required_diameter_mm()};
  const PatternSet& set = *setup.pattern_set;
  if (set.class_of(usable_diameter_mm) < 0) return {"", set.classes.front().min_diameter_mm};
  FitNeed need{"", -1};
  for (const PatternCandidate& c : set.candidates(usable_diameter_mm)) {
    const double d = c.pattern->required_diameter_mm();
    if (need.needed_diameter_mm < 0 || d < need.needed_diameter_mm) need = {c.pattern->name, d};
  }
  return need;
}

Status check_setup_fits(const SawSetup& setup, double usable, const std::string& log_id) {
  if (!setup.pattern_set) return check_pattern_fits(setup.pattern, usable, log_id);
  const FitNeed need = fit_need(setup, usable);
  if (need.needed_diameter_mm <= usable) return Status::Ok();
  const PatternSet& set = *setup.pattern_set;
  const std::string log = "log '" + log_id + "'";
  const std::string usable_text = usable_diameter_text(usable);
  if (need.pattern.empty())
    return Error(log, "no pattern of pattern set '" + set.name + "' fits: " + usable_text +
                          ", below the set's smallest class (" + set.classes.front().label() + ")");
  return Error(log, "no pattern of pattern set '" + set.name + "' fits: the smallest of its " +
                        "candidates for class " +
                        set.classes[static_cast<size_t>(set.class_of(usable))].label() + ", '" +
                        need.pattern + "', needs a diameter of " +
                        fmt("%.1f", need.needed_diameter_mm) + " mm, " + usable_text);
}

Result<SawingOutcome> saw_log_model(const LogModel& log, const SawSetup& setup,
                                    const std::function<void(int, int)>& progress) {
  SawingOutcome out{SawLog(log), {}, {}, {}, {}, {}, {}, {}};
  if (Status s = check_setup_fits(setup, out.saw_log.usable_diameter_mm(), log.id); !s)
    return s.error();
  if (Status s = check_offsets_reach(setup, wood_reach_mm(out.saw_log), "the log's wood"); !s)
    return s.error();
  if (setup.pattern_set) {
    if (Status s = choose_and_saw(setup, out, progress); !s) return s.error();
    return out;
  }
  out.pattern = setup.pattern;
  Result<PatternSawing> sawn = saw_pattern(setup, out.saw_log, setup.pattern, progress);
  if (!sawn) return sawn.error();
  sawn.value().move_into(out);
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
         (x && y ? "x and y"
          : x    ? "x"
                 : "y") +
         "): a wider range (" + (y && !x ? "offset_y_max_mm" : "offset_x_max_mm") +
         ") may be worth more";
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

}  // namespace sawyer::sawing
