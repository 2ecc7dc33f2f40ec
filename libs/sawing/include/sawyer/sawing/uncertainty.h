// What a scanned model may have got wrong, for a sawing decision that holds on the true log
// (issue 21, item 4; docs/sawing.md "Value under scan uncertainty").
//
//   ScanSpread s = scan_spread(model);                   // per knot: σ of diameter and r_dead
//   LogModel m = draw_model(model, s, 3, 42);            // one draw of what the log may be
//   OptimiseOptions o;  o.model_draws = 8;               // the optimiser's expected value then
//                                                        // averages over draws as well
//
// A knot's fitted diameter and sound/dead border are the scan's least certain numbers (the
// robustness sweep, docs/scan.md: knot diameter RMSE about 2 mm on fine scans, r_dead median
// error 14 mm). A draw moves each knot's d_dead and r_dead by Gaussian errors of those sizes, so
// a knot near a grade's size limit, or near the grading's minimum size, is sometimes over it and
// sometimes under, as the scan may be. A model whose scan QA failed (pith or knots) gets twice
// the spread. A knot may also not be a knot at all (a streak or a pocket taken for one): a draw
// leaves it out with the chance Knot::confidence gives it of being so. A model that did not come
// from a scan has none of this.
//
// Thread safety: plain values; the free functions are reentrant.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sawyer/model/log_model.h"

namespace sawyer::sawing {

// Spread of a fitted knot, from the robustness sweep's errors.
inline constexpr double kKnotDiameterSdMm = 2.0;  // at least; 8 % of the diameter above 25 mm
inline constexpr double kKnotDiameterSdFraction = 0.08;
inline constexpr double kKnotRDeadSdMm = 12.0;

struct KnotSpread {
  double diameter_sd_mm = 0;  // of d_dead
  double r_dead_sd_mm = 0;
  double real_p = 1;  // the chance the knot is real (Knot::confidence): a draw leaves it out else
};

struct ScanSpread {
  std::vector<KnotSpread> knots;  // as LogModel::knots
  double factor = 1.0;            // 2 when the scan's QA failed its pith or knots
  std::string note;               // where the spread came from, one line
  bool any() const;
};

ScanSpread scan_spread(const LogModel& model);

// Draw `k` (0, 1, ...) of the model under `spread`: every knot's d_dead and r_dead moved by
// N(0, σ) (d_dead kept ≥ 1 mm, r_dead in [0, r_end]), and each knot left out with the chance
// 1 − real_p that it is not a knot at all; seeded by (seed, k), so the same k gives the same
// model. Draws come in antithetic pairs (2j and 2j+1 move each knot by ±the same error, and
// leave it out at u and at 1 − u of the same uniform u).
LogModel draw_model(const LogModel& model, const ScanSpread& spread, int k, std::uint64_t seed);

}  // namespace sawyer::sawing
