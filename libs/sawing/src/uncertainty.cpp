// Scan uncertainty of a model's knots and draws of the model under it (see uncertainty.h).
#include "sawyer/sawing/uncertainty.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "sawyer/core/vec.h"

namespace sawyer::sawing {

bool ScanSpread::any() const {
  for (const KnotSpread& k : knots)
    if (k.diameter_sd_mm > 0 || k.r_dead_sd_mm > 0 || k.real_p < 1) return true;
  return false;
}

ScanSpread scan_spread(const LogModel& model) {
  ScanSpread s;
  s.knots.resize(model.knots.size());
  if (!model.qa) {
    s.note = "no scan: the model's knots are taken as exact";
    return s;
  }
  for (const ScanQa::Stage& st : model.qa->stages)
    if (!st.ok && (st.name == "pith" || st.name == "knots")) s.factor = 2.0;
  const int cls = model.qa->scan_class == "fine" ? 0 : model.qa->scan_class == "coarse" ? 1 : 2;
  for (size_t i = 0; i < model.knots.size(); ++i) {
    const double d = model.knots[i].diameter.d_dead;
    s.knots[i].diameter_sd_mm = s.factor * std::max(kKnotDiameterSdMm, kKnotDiameterSdFraction * d);
    s.knots[i].r_dead_sd_mm = s.factor * kKnotRDeadSdMm;
    s.knots[i].real_p = model.knots[i].confidence();
    if (model.knots[i].r_dead >= model.knots[i].r_end)
      s.knots[i].dead_p = kSoundKnotDeadP[cls];
    else
      s.knots[i].sound_p = kDeadKnotSoundP;
    s.knots[i].twin_p = std::min(1.0, (1.0 / kKnotRecall[cls] - 1.0) * s.knots[i].real_p);
  }
  char buf[640];
  std::snprintf(
      buf, sizeof buf,
      "knots from a scan: diameter σ %.0f mm (or %.0f %% above %.0f mm), r_dead σ %.0f mm%s; "
      "a %s scan's knot called sound dead from %.0f %% of its length in %.0f %% of the draws, "
      "one called dead sound in %.0f %%; a missed knot beside each in %.0f %% (recall %.0f %%); "
      "each knot left out of a draw with the chance that it is not real (1 - its confidence)",
      s.factor * kKnotDiameterSdMm, 100 * kKnotDiameterSdFraction,
      kKnotDiameterSdMm / kKnotDiameterSdFraction, s.factor * kKnotRDeadSdMm,
      s.factor > 1 ? " (doubled: the scan's QA failed)" : "",
      cls == 0   ? "fine"
      : cls == 1 ? "coarse"
                 : "(class unknown)",
      100 * kDeadFromMedian, 100 * kSoundKnotDeadP[cls], 100 * kDeadKnotSoundP,
      100 * (1.0 / kKnotRecall[cls] - 1.0), 100 * kKnotRecall[cls]);
  s.note = buf;
  return s;
}

LogModel draw_model(const LogModel& model, const ScanSpread& spread, int k, std::uint64_t seed) {
  LogModel m = model;
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(k / 2));
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const double sign = k % 2 ? -1.0 : 1.0;
  std::vector<char> keep(m.knots.size(), 1);
  std::vector<Knot> twins;
  for (size_t i = 0; i < m.knots.size() && i < spread.knots.size(); ++i) {
    Knot& q = m.knots[i];
    const double ed = sign * n01(rng), er = sign * n01(rng);
    // The pair's draws take each chance at u and at 1 - u of one uniform: leaving the knot out
    // (1 - real_p), turning it dead or sound (dead_p, sound_p), a missed knot beside it (twin_p).
    const double u = u01(rng), v = u01(rng), t = u01(rng), az = u01(rng);
    keep[i] = (k % 2 ? 1.0 - u : u) < spread.knots[i].real_p;
    const double d_outer = q.max_diameter();
    q.diameter.d_dead = std::max(1.0, q.diameter.d_dead + ed * spread.knots[i].diameter_sd_mm);
    const double pick = k % 2 ? 1.0 - v : v;
    if (q.r_dead < q.r_end && pick < spread.knots[i].sound_p) {
      q.r_dead = q.r_end;  // called dead, sound in truth
    } else if (q.r_dead < q.r_end) {
      q.r_dead = std::clamp(q.r_dead + er * spread.knots[i].r_dead_sd_mm, 0.0, q.r_end);
    } else if (pick < spread.knots[i].dead_p) {
      // Dead from a fraction of its length; the outer diameter the scan saw is kept (moved by
      // the same diameter error as above).
      const double from = std::clamp(kDeadFromMedian + er * kDeadFromSd, 0.15, 1.2);
      if (from < 1.0) {
        q.diameter.d_dead = std::max(1.0, d_outer + ed * spread.knots[i].diameter_sd_mm);
        q.r_dead = from * q.r_end;
      }
    }
    // A knot the scan missed beside this one: the same knot at the same height, turned.
    if ((k % 2 ? 1.0 - t : t) < spread.knots[i].twin_p) {
      Knot twin = q;
      twin.id = -1 - static_cast<int>(i);
      twin.omega0 += 2.0 * kPi * az + (k % 2 ? kPi : 0.0);
      twins.push_back(twin);
    }
  }
  size_t w = 0;
  for (size_t i = 0; i < m.knots.size(); ++i)
    if (keep[i]) m.knots[w++] = m.knots[i];
  m.knots.resize(w);
  m.knots.insert(m.knots.end(), twins.begin(), twins.end());
  return m;
}

}  // namespace sawyer::sawing
