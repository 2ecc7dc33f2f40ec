#include "sawyer/sawing/sawing_session.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "sawyer/core/file_util.h"
#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/sawing_file.h"
#include "sawyer/sawing/setup.h"

namespace sawyer::sawing {
namespace {

namespace fs = std::filesystem;
using namespace sawyer::sawing;

}  // namespace

namespace {

// The colour at t in [0, 1] along n equally spaced RGB stops, linear between them.
template <size_t N>
std::array<unsigned char, 3> along_stops(const double (&stops)[N][3], double t) {
  const double x = std::clamp(t, 0.0, 1.0) * (N - 1);
  const size_t i = std::min(N - 2, static_cast<size_t>(x));
  const double f = x - static_cast<double>(i);
  std::array<unsigned char, 3> c{};
  for (int k = 0; k < 3; ++k)
    c[k] =
        static_cast<unsigned char>(std::lround(stops[i][k] + f * (stops[i + 1][k] - stops[i][k])));
  return c;
}

}  // namespace

std::array<unsigned char, 3> heat_colour(double t) {
  if (std::isnan(t)) return {128, 128, 128};
  // Stops of a perceptually ordered map (dark to light).
  static const double stops[5][3] = {
      {10, 7, 60}, {90, 20, 130}, {190, 55, 90}, {245, 140, 30}, {252, 245, 170}};
  return along_stops(stops, t);
}

std::array<unsigned char, 3> grade_colour(int grade, int grades) {
  if (grade < 0 || grade >= grades) return {235, 50, 50};  // reject
  // Best green, through yellow, to orange for the last grade.
  static const double stops[3][3] = {{60, 220, 90}, {245, 225, 50}, {250, 130, 40}};
  return along_stops(stops, grades > 1 ? static_cast<double>(grade) / (grades - 1) : 0.0);
}

Result<std::unique_ptr<SawingSession>> SawingSession::create(const LogModel& log,
                                                             const SawingChoice& choice) {
  Result<Pattern> pattern = pattern_by_name(choice.pattern);
  if (!pattern) return pattern.error();
  Result<GradingRules> rules = grading_by_name(choice.grading);
  if (!rules) return rules.error();
  Result<PriceTable> prices = prices_by_name(choice.prices);
  if (!prices) return prices.error();
  if (Status s = prices.value().check_covers(rules.value()); !s)
    return s.error().with_context(choice.prices.empty() ? "example_prices.json" : choice.prices);
  std::unique_ptr<SawingSession> s(new SawingSession());
  s->log_ = &log;
  s->saw_log_ = std::make_unique<SawLog>(log);
  if (Status st = check_pattern_fits(pattern.value(), s->saw_log_->usable_diameter_mm(), log.id);
      !st)
    return st.error();
  s->pattern_ = std::move(pattern).value();
  s->rules_ = std::move(rules).value();
  s->prices_ = std::move(prices).value();
  s->choice_ = choice;
  s->horns_down_ = value_of(saw_for_sale(*s->saw_log_, s->pattern_, {}, s->rules_, s->prices_),
                            s->rules_, s->prices_)
                       .value;
  s->set_position({});
  return s;
}

void SawingSession::set_position(const LogPosition& pos) {
  pos_ = pos;
  sawn_ = saw_for_sale(*saw_log_, pattern_, pos_, rules_, prices_);
  value_ = value_of(sawn_, rules_, prices_);
}

double SawingSession::gain_over_horns_down() const {
  return horns_down_ > 0 ? value_.value / horns_down_ - 1.0 : 0.0;
}

// saw(): pattern (u, v) = Rot(φ)·(scanner − line_at(z)) − offset.
double SawingSession::phi() const { return pattern_rotation(*saw_log_, pos_); }

std::array<Vec2, 4> SawingSession::rect_in_scanner(double u, double v, double size_u, double size_v,
                                                   double z) const {
  const double c = std::cos(phi()), s = std::sin(phi());
  const Vec2 o = saw_log_->line_at(z);
  const double du[4] = {-0.5, 0.5, 0.5, -0.5}, dv[4] = {-0.5, -0.5, 0.5, 0.5};
  std::array<Vec2, 4> out;
  for (int i = 0; i < 4; ++i) {
    const double a = u + du[i] * size_u + pos_.offset_x_mm;
    const double b = v + dv[i] * size_v + pos_.offset_y_mm;
    out[i] = {o.x + c * a + s * b, o.y - s * a + c * b};  // Rot(−φ)
  }
  return out;
}

Vec2 SawingSession::scanner_to_pattern_delta(double dx, double dy) const {
  const double c = std::cos(phi()), s = std::sin(phi());
  return {c * dx - s * dy, s * dx + c * dy};
}

BoardBox SawingSession::board_in_scanner(size_t i) const {
  return board_placement(*saw_log_, sawn_.boards.at(i), pos_);
}

std::string SawingSession::to_json(const std::string& log_id) const {
  SavedPosition p;
  p.log_id = log_id;
  p.pattern = &pattern_;
  p.rules = &rules_;
  p.prices = &prices_;
  p.horns_down_value = horns_down_;
  p.pos = pos_;
  p.sawn = &sawn_;
  p.value = &value_;
  p.gain_over_horns_down = gain_over_horns_down();
  return position_file_json(p).dump(1) + "\n";
}

Status SawingSession::save(const fs::path& path, const std::string& log_id) const {
  return write_text_file_atomic(path, to_json(log_id));
}

Result<LogPosition> read_saw_position(const fs::path& path) {
  Result<SawingRecord> r = read_sawing_file(path);
  if (!r) return r.error();
  return r.value().chosen.pos;
}

}  // namespace sawyer::sawing
