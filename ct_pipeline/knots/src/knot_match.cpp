// Found knots against true knots (see knot_match.h).
#include "sawyer/ct/knots/knot_match.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace sawyer::ct {
namespace {

// Evaluation radius of a true knot: 50 mm, or its end when it is shorter.
double eval_r(const Knot& t) { return std::min(50.0, std::max(5.0, t.r_end)); }

// Where a pair is compared: the evaluation radius, or the found knot's end when it ends sooner
// (its axis beyond is an extrapolation; r_end's error is reported on its own).
double pair_r(const Knot& t, const Knot& f) { return std::min(eval_r(t), std::max(5.0, f.r_end)); }

std::string describe(const char* what, const Knot& k) {
  const double r = eval_r(k);
  char line[200];
  std::snprintf(
      line, sizeof line,
      "%s knot %d: z %.0f mm and azimuth %.0f deg at r %.0f mm, %.1f mm thick, r_end %.0f mm", what,
      k.id, k.height_at(r), k.azimuth_at(r) * 180 / kPi, r, k.max_diameter(), k.r_end);
  return line;
}

}  // namespace

double KnotMatch::diameter_rmse() const {
  return diameter_count ? std::sqrt(diameter_sum2 / static_cast<double>(diameter_count)) : NAN;
}

double median_of(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

KnotMatch match_knots(const std::vector<Knot>& found, const std::vector<Knot>& truth,
                      const Stem& truth_stem, const KnotMatchOptions& o) {
  KnotMatch m;
  m.found = static_cast<int>(found.size());
  struct Pair {
    double d;
    size_t t, f;
  };
  std::vector<Pair> pairs;
  for (size_t t = 0; t < truth.size(); ++t) {
    for (size_t f = 0; f < found.size(); ++f) {
      const double r = pair_r(truth[t], found[f]);
      const double dw = std::abs(angle_diff(found[f].azimuth_at(r), truth[t].azimuth_at(r)));
      const double dz = std::abs(found[f].height_at(r) - truth[t].height_at(r));
      if (dw > o.max_azimuth_rad || dz > o.max_height_mm) continue;
      pairs.push_back({dw / o.max_azimuth_rad + dz / o.max_height_mm, t, f});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.d < b.d; });
  std::vector<int> of_truth(truth.size(), -1), of_found(found.size(), -1);
  for (const Pair& q : pairs)
    if (of_truth[q.t] < 0 && of_found[q.f] < 0)
      of_truth[q.t] = static_cast<int>(q.f), of_found[q.f] = static_cast<int>(q.t);
  m.found_pair = of_found;

  for (size_t t = 0; t < truth.size(); ++t) {
    const Knot& k = truth[t];
    double z0, z1;
    k.z_range(&z0, &z1);
    const bool inside = z0 >= o.z_lo && z1 <= o.z_hi;
    const bool counted = inside && k.max_diameter() >= o.min_diameter_mm;
    m.truth_counted += counted;
    if (of_truth[t] < 0) {
      if (counted) m.missed.push_back(describe("missed true", k));
      continue;
    }
    if (!inside) continue;
    m.truth_found += counted;
    const Knot& f = found[static_cast<size_t>(of_truth[t])];
    const double r = pair_r(k, f);
    m.azimuth_deg.push_back(std::abs(angle_diff(f.azimuth_at(r), k.azimuth_at(r))) * 180 / kPi);
    m.height_mm.push_back(std::abs(f.height_at(r) - k.height_at(r)));
    const double outer = truth_stem.slice_count()
                             ? truth_stem.radius_at(k.azimuth_at(k.r_end), k.height_at(k.r_end))
                             : k.r_end;
    const double true_end = std::min(k.r_end, outer);
    m.r_end_mm.push_back(std::abs(f.r_end - true_end));
    if (k.r_dead < true_end) {
      m.r_dead_signed_mm.push_back(std::min(f.r_dead, f.r_end) - k.r_dead);
      m.r_dead_mm.push_back(std::abs(m.r_dead_signed_mm.back()));
    }
    double pair2 = 0;
    int pair_n = 0;
    for (double q = 5.0; q <= std::min(f.r_end, true_end); q += 2.0) {
      const double e = f.diameter_at(q) - k.diameter_at(q);
      m.diameter_sum2 += e * e;
      ++m.diameter_count;
      pair2 += e * e, ++pair_n;
    }
    char line[240];
    std::snprintf(
        line, sizeof line,
        "true knot %d ~ found %d: d_dead %.1f ~ %.1f mm, exponent %.2f ~ %.2f, r_dead %.0f ~ "
        "%.0f mm, r_end %.0f ~ %.0f mm, diameter RMSE %.2f mm",
        k.id, f.id, k.diameter.d_dead, f.diameter.d_dead, k.diameter.exponent, f.diameter.exponent,
        k.r_dead, f.r_dead, true_end, f.r_end, pair_n ? std::sqrt(pair2 / pair_n) : 0.0);
    m.pairs.push_back(line);
  }
  for (size_t f = 0; f < found.size(); ++f)
    if (of_found[f] < 0) {
      ++m.spurious;
      std::string line = describe("spurious found", found[f]);
      // The nearest true knot at the found knot's own evaluation radius, to tell a knot found
      // twice (its true knot paired with another found knot) from one that is not there.
      const double r = eval_r(found[f]);
      double best = 1e300;
      size_t bt = 0;
      for (size_t t = 0; t < truth.size(); ++t) {
        const double d = std::hypot(r * angle_diff(found[f].azimuth_at(r), truth[t].azimuth_at(r)),
                                    found[f].height_at(r) - truth[t].height_at(r));
        if (d < best) best = d, bt = t;
      }
      if (best < 1e300) {
        char more[160];
        std::snprintf(more, sizeof more, "; nearest true knot %d, %.1f mm away at r %.0f mm%s",
                      truth[bt].id, best, r,
                      of_truth[bt] >= 0 ? " (paired with another found knot)" : "");
        line += more;
      }
      m.spurious_list.push_back(line);
    }
  return m;
}

}  // namespace sawyer::ct
