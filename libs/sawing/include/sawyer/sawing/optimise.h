// Log positioning optimiser: the value of the log sawn at every position of a rotation × offset
// grid, that value surface smoothed by the positioning error, the best smoothed position and its
// gain over horns-down and horns-up (docs/sawing.md).
//
//   OptimiseOptions o;                      // 2° steps, offsets ±10 mm step 2, σ 5° / 2 mm
//   Result<OptimiseResult> r = optimise_position(saw_log, pattern, rules, prices, o);
//   r.value().best, r.value().gain_over_horns_down ...
//
// The value at a position is value_of(saw(...)) (value.h); every position uses the same grading
// and prices. Smoothing: a separable Gaussian over the grid, circular in rotation (period =
// the rotation range; with a 180° range the wrap also mirrors the offsets, since a
// point-symmetric pattern at rot + 180°, (x, y) cuts the same boards as at rot, (−x, −y)),
// truncated and renormalised at the offset ends. The smoothed value is the expected value when
// the saw's position error is N(0, σ_rot) × N(0, σ_offset).
//
// Thread safety: optimise_position() runs `threads` std::threads of its own over a read-only
// SawLog (see sawing.h); the inputs must not change while it runs.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/value.h"

namespace sawyer::sawing {

// True when the pattern maps onto itself under a 180° turn about the origin: every board has a
// twin of the same size, axis and edging at (−u, −v).
bool is_point_symmetric(const Pattern& p);

// Limits of OptimiseOptions::validate(). A saw sets a log to about 1° and 1 mm; steps of 0.01
// are a hundred times finer. Offsets beyond the largest log radius (log_json.h) saw nothing. A
// positioning error σ of 90° or 100 mm means no positioning at all. A million positions is a
// thousand times the default grid (90 × 11), minutes of sawing, 16 MB of value surface.
inline constexpr double kMinRotStepDeg = 0.01;
inline constexpr double kMinOffsetStepMm = 0.01;
inline constexpr double kMaxOffsetMm = 1500.0;
inline constexpr double kMaxSigmaRotDeg = 90.0;
inline constexpr double kMaxSigmaOffsetMm = 100.0;
inline constexpr double kMaxPositions = 1e6;
inline constexpr int kMaxModelDraws = 64;

struct OptimiseOptions {
  double rot_step_deg = 2.0;
  double rot_range_deg = 0.0;  // 0: 180 for a point-symmetric pattern, else 360; else 180 or 360
  double offset_x_max_mm = 10.0, offset_x_step_mm = 2.0;  // grid −max..max
  double offset_y_max_mm = 0.0, offset_y_step_mm = 2.0;   // 0: no y offsets
  double sigma_rot_deg = 5.0;                             // 0: no smoothing in rotation
  double sigma_offset_mm = 2.0;                           // both offsets; 0: none
  int threads = 0;                                        // 0: std::thread::hardware_concurrency()
  int ranked = 20;  // positions kept in OptimiseResult::ranked
  // Scan uncertainty (uncertainty.h): the value at a position is the mean over the model and
  // this many draws of what its knots may be (scan_spread); 0: the model as it is. Costs one
  // more saw() per draw and position. Nothing changes for a model that did not come from a scan.
  int model_draws = 0;  // 0..kMaxModelDraws
  std::uint64_t draw_seed = 1;
  // Range divisible by the step, offsets' max a whole number of steps, sizes > 0, σ ≥ 0; 180 only
  // for a point-symmetric pattern; every value within the limits above and at most
  // kMaxPositions positions. Errors name the option (--rot-step, --offsets, ...).
  Status validate(const Pattern& p) const;
};

struct RankedPosition {
  LogPosition pos;
  double value = 0;     // at the position
  double smoothed = 0;  // expected under the positioning error
};

// The gain over horns-down that a decision may claim, with its range, when the value surface was
// drawn under the scan's uncertainty (OptimiseOptions::model_draws). The best of many noisy
// estimates is biased upwards (the optimiser's curse): the best position of the mean surface is
// best partly because of the draws' noise there. So the claim is cross-validated. The model as
// it is and each antithetic pair of draws are one group each (a pair's two draws are not
// independent); for each group, the best smoothed position of the mean over all other groups is
// taken, and each member of the group gives its gain over horns-down there (smoothed values,
// the member's own surface). gain is the mean of those N held-out gains (N = draws + 1), and
// [low, high] is the 90 % prediction range of one more member's gain under a normal spread:
// gain ± t(0.95, N − 1) · sd · √(1 + 1/N).
struct ClaimRange {
  double gain = 0, low = 0, high = 0;
  int groups = 0;  // held-out groups the claim came from (0: no draws, the plain gain)
};

struct OptimiseResult {
  bool symmetric = false;                                         // pattern point-symmetric
  double rot_range_deg = 360;                                     // as used
  std::vector<double> rotations_deg, offsets_x_mm, offsets_y_mm;  // grid axes
  // Surfaces, index (ir × nx + ix) × ny + iy.
  std::vector<double> value, smoothed;
  size_t index(size_t ir, size_t ix, size_t iy) const {
    return (ir * offsets_x_mm.size() + ix) * offsets_y_mm.size() + iy;
  }
  RankedPosition best;                  // by smoothed value
  RankedPosition best_raw;              // by raw value
  RankedPosition horns_down, horns_up;  // rotation 0 and 180, offset 0
  double gain_over_horns_down = 0;      // smoothed best / smoothed horns-down − 1
  double gain_over_horns_up = 0;
  std::vector<RankedPosition> ranked;  // best smoothed first
  int positions = 0;
  int threads = 1;
  int model_draws = 0;      // draws the values averaged over (0 when the model had no spread)
  std::string spread_note;  // ScanSpread::note, when draws were used
  // The claim under the scan's uncertainty (with draws; see ClaimRange). Without draws
  // claim.gain is gain_over_horns_down and the range is empty (low = high = gain).
  ClaimRange claim;
  double seconds = 0;  // wall clock of the grid evaluation
};

// Smooths a rotation × x × y grid in place (see above). `mirror_on_wrap`: the 180° case.
void smooth_value_surface(std::vector<double>& surface, size_t nr, size_t nx, size_t ny,
                          double rot_step_deg, double x_step_mm, double y_step_mm,
                          double sigma_rot_deg, double sigma_offset_mm, bool mirror_on_wrap);

// The cross-validated claim (ClaimRange) from the smoothed value surfaces of the model as it is
// (smoothed[0]) and of its draws (smoothed[1..], antithetic pairs (1, 2), (3, 4), ...), all over
// the same positions; `horns_down` is horns-down's index in them.
ClaimRange cross_validated_claim(const std::vector<std::vector<double>>& smoothed,
                                 size_t horns_down);

// "+12.3 % (90 % range +8.1 to +15.0 %)" for a claim with a range, "+12.3 %" without.
std::string claim_text(const ClaimRange& c);

// `progress`, when set, is called from the calling thread with (done, total) now and then.
Result<OptimiseResult> optimise_position(const SawLog& log, const Pattern& pattern,
                                         const GradingRules& rules, const PriceTable& prices,
                                         const OptimiseOptions& options,
                                         const std::function<void(int, int)>& progress = {});

}  // namespace sawyer::sawing
