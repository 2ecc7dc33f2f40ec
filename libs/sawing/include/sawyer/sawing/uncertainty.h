// What a scanned model may have got wrong, for a sawing decision that holds on the true log
// (issue 21, item 4; docs/sawing.md "Value under scan uncertainty").
//
//   ScanSpread s = scan_spread(model);                   // per knot: σ of diameter and r_dead
//   LogModel m = draw_model(model, s, 3, 42);            // one draw of what the log may be
//   OptimiseOptions o;  o.model_draws = 8;               // the optimiser's expected value then
//                                                        // averages over draws as well
//
// A knot's fitted diameter and sound/dead border are the scan's least certain numbers, and a
// scan misses some knots. Their errors, as the robustness sweep measures them (bench/robustness
// --conditions 80 with SAWYER_KNOT_CSV: every found knot paired with its true one; the figures
// in docs/sawing.md "Claims under the scan's uncertainty"), are not one spread about the fit,
// and differ between fine and coarse scans (ScanQa::scan_class):
//   - diameter: RMSE about 2 mm on fine scans; a draw moves d_dead by N(0, 2 mm or 8 %);
//   - a knot the scan calls dead (r_dead < r_end): its border is found to within a few mm
//     (quartiles of found − true −1.5 / +0.5 mm fine, −3.7 / +0.7 coarse); a draw moves it by
//     N(0, 3 mm). One in seven is sound in truth: a draw makes it sound with that chance;
//   - a knot the scan calls sound over its whole length: 38 % of these (fine) and 58 % (coarse)
//     are dead in truth, from 0.2–1.2 of their found length (median 0.62): the scan misses the
//     dead part, and a board the model grades clear then has a dead knot. A draw makes such a
//     knot dead from a drawn fraction of its length with that chance (its outer diameter kept,
//     as the scan saw it);
//   - knots missed: recall 98 % of the knots ≥ 10 mm (fine), 80 % of those ≥ 15 mm (coarse). A
//     draw adds, for each knot, a missed one with the chance 1/recall − 1 (times its confidence):
//     a copy at the same height (a whorl's other branch) at a drawn azimuth.
// A model whose scan QA failed (pith or knots) gets twice the diameter and border spreads. A
// knot may also not be a knot at all (a streak or a pocket taken for one): a draw leaves it out
// with the chance Knot::confidence gives it of being so. A model that did not come from a scan
// has none of this. A scan of unknown class (an older log.json) gets the rates of both pooled.
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
inline constexpr double kKnotRDeadSdMm = 3.0;    // of a knot the scan calls dead
inline constexpr double kDeadKnotSoundP = 0.14;  // the chance a knot called dead is sound
// A knot the scan calls sound over its length: the chance that it is dead in truth (fine,
// coarse, class unknown), and where its dead part starts, as a fraction of its found length:
// N(median, sd), kept in [0.15, 1.2].
inline constexpr double kSoundKnotDeadP[3] = {0.38, 0.58, 0.52};
inline constexpr double kDeadFromMedian = 0.62;
inline constexpr double kDeadFromSd = 0.21;
// Knot recall (fine, coarse, class unknown).
inline constexpr double kKnotRecall[3] = {0.98, 0.80, 0.87};

struct KnotSpread {
  double diameter_sd_mm = 0;  // of d_dead
  double r_dead_sd_mm = 0;
  double real_p = 1;   // the chance the knot is real (Knot::confidence): a draw leaves it out else
  double dead_p = 0;   // the chance that a knot called sound over its length has a dead part
  double sound_p = 0;  // the chance that a knot called dead is sound over its length
  double twin_p = 0;   // the chance of a missed knot beside it (a copy at a drawn azimuth)
};

struct ScanSpread {
  std::vector<KnotSpread> knots;  // as LogModel::knots
  double factor = 1.0;            // 2 when the scan's QA failed its pith or knots
  std::string note;               // where the spread came from, one line
  bool any() const;
};

ScanSpread scan_spread(const LogModel& model);

// Draw `k` (0, 1, ...) of the model under `spread`: every knot's d_dead moved by N(0, σ) (kept
// ≥ 1 mm); a dead knot's r_dead moved by N(0, σ) (in [0, r_end]) or, with the chance sound_p,
// the knot made sound; a knot called sound over its length made dead from a drawn fraction of
// it with the chance dead_p; a missed knot added beside it with the chance twin_p; and each
// knot left out with the chance 1 − real_p that it is not a knot at all. Seeded by (seed, k), so
// the same k gives the same model. Draws come in antithetic pairs (2j and 2j+1 move each knot
// by ±the same errors, take its chances at u and at 1 − u of the same uniform u, and turn a
// missed knot half a turn apart).
LogModel draw_model(const LogModel& model, const ScanSpread& spread, int k, std::uint64_t seed);

}  // namespace sawyer::sawing
