// Scan uncertainty of a model's knots and draws of the model under it (see uncertainty.h).
#include "sawyer/sawing/uncertainty.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

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
  for (size_t i = 0; i < model.knots.size(); ++i) {
    const double d = model.knots[i].diameter.d_dead;
    s.knots[i].diameter_sd_mm = s.factor * std::max(kKnotDiameterSdMm, kKnotDiameterSdFraction * d);
    s.knots[i].r_dead_sd_mm = s.factor * kKnotRDeadSdMm;
    s.knots[i].real_p = model.knots[i].confidence();
  }
  char buf[200];
  std::snprintf(
      buf, sizeof buf,
      "knots from a scan: diameter σ %.0f mm (or %.0f %% above %.0f mm), r_dead σ %.0f mm%s; "
      "each knot left out of a draw with the chance that it is not real (1 - its confidence)",
      s.factor * kKnotDiameterSdMm, 100 * kKnotDiameterSdFraction,
      kKnotDiameterSdMm / kKnotDiameterSdFraction, s.factor * kKnotRDeadSdMm,
      s.factor > 1 ? " (doubled: the scan's QA failed)" : "");
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
  for (size_t i = 0; i < m.knots.size() && i < spread.knots.size(); ++i) {
    Knot& q = m.knots[i];
    const double ed = sign * n01(rng), er = sign * n01(rng);
    // The pair's draws leave a knot out at u and at 1 - u: each with the chance 1 - real_p.
    const double u = u01(rng);
    keep[i] = (k % 2 ? 1.0 - u : u) < spread.knots[i].real_p;
    q.diameter.d_dead = std::max(1.0, q.diameter.d_dead + ed * spread.knots[i].diameter_sd_mm);
    q.r_dead = std::clamp(q.r_dead + er * spread.knots[i].r_dead_sd_mm, 0.0, q.r_end);
  }
  size_t w = 0;
  for (size_t i = 0; i < m.knots.size(); ++i)
    if (keep[i]) m.knots[w++] = m.knots[i];
  m.knots.resize(w);
  return m;
}

}  // namespace sawyer::sawing
