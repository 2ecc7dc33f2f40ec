// The knot-formula fit (issue 5): axis by a weighted linear least squares start refined with a
// robust, bounded Ceres solve; diameter profile with r_dead profiled over a grid of candidates.
#include "sawyer/ct/knots/knot_fit.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "sawyer/core/stats.h"
#include "sawyer/core/vec.h"

namespace sawyer::ct {
namespace {

// Parameter bounds, wider than docs/architecture.md 4's typical ranges so that they never bias a
// normal knot, but they keep a short or contaminated trace from running off.
constexpr double kMinA = -10.0, kMaxA = 25.0;  // mm/√mm
constexpr double kMinB = -1.0, kMaxB = 2.5;    // mm/mm
constexpr double kMaxTwist = 0.5;              // rad per ln(mm)
constexpr double kZ0Below = 500.0;  // z0 may lie this far below the lowest shell (knots rise)
constexpr double kZ0Above = 100.0;  // ... and this far above the highest
constexpr double kMinShellWeight = 0.2;
constexpr double kMinDiameter = 0.5;  // mm: smaller diameters carry no usable log information
constexpr double kMaxDiameter = 500.0;
constexpr double kMinExponent = 0.05, kMaxExponent = 3.0;
constexpr double kDefaultExponent = 1.0;      // when no shell lies in the growing part
constexpr double kMinVariance = 0.05 * 0.05;  // mm²: σ̂² floor, for near-noiseless traces
constexpr int kMinDarkShells = 3;             // fewer dark-ring shells: noise, not encased bark
constexpr double kMadToSigma = 1.4826;        // median |e| → σ for Gaussian residuals
constexpr int kGaussNewtonSteps = 3;          // robust Gauss-Newton steps per r_dead candidate
constexpr double kFineSteps = 4;              // the refinement grid is r_dead_step / this

// One shell, prepared for the fits.
struct Shell {
  double r = 0;
  double sqrt_r = 0;
  double ln_r = 0;       // ln r (r > 0), the diameter profile's variable
  double ln_r_axis = 0;  // ln max(r, 1), the twist term's variable (log_model.h)
  double z = 0;
  double omega_raw = 0;  // as measured, [0, 2π) or anything
  double omega = 0;      // unwrapped near the fitted axis
  double d = 0;
  double w = 1;            // evidence weight
  bool dark = false;       // dark (encased-bark) ring
  bool predicted = false;  // followed by prediction, not segmented
  double core_hu = NAN;    // HU of the knot's core (NaN: unknown)
};

// r_dead from the knot's own density: a dead knot is drier and lighter than the sound knot it
// grew from, whatever the wood around it (sound ~1000 kg/m³, dead ~820: a step of well over
// kDeadStepHu in green wood), while the diameter's kink at r_dead is often within the noise.
// Along the shells, the core HU (running median over kCoreWindow shells, the first kCoreSkipMm
// left out: blur around the pith) is compared with its level over the outer part of the knot; a
// knot is dead where the level there lies kDeadStepHu or more below the highest level inside,
// or at least kMinDeadStepHu and kDeadStepSigmas times the core HU's scatter below it (in dried
// wood the dead knot dries with the wood around it, and the step is a few tens of HU). r_dead
// is then where the level falls below the midpoint for good: the split after the highest level
// that leaves the fewest levels on the wrong side of the midpoint. Returns NaN when too few
// shells have a core HU (the caller then decides from the diameters), r_end when the knot is
// sound.
// (Until 2026-12-07: the last shell above the midpoint, which a level rising again over the
// knot's last shells, where it reaches the bark, moved to r_end: a third of the dead knots the
// fine scans of the sweep called sound had a step of 80 HU or more.)
constexpr double kDeadStepHu = 80.0;
constexpr double kMinDeadStepHu = 30.0;
constexpr double kDeadStepSigmas = 5.0;
constexpr int kCoreWindow = 5;
constexpr double kCoreSkipMm = 10.0;
constexpr int kMinCoreShells = 8;
constexpr double kOuterFraction = 0.3;

double r_dead_from_density(const std::vector<Shell>& shells, double r_end, double* step_hu,
                           double* noise_hu) {
  std::vector<std::pair<double, double>> v;  // r, core HU
  for (const Shell& s : shells)
    if (!std::isnan(s.core_hu) && s.r >= kCoreSkipMm) v.push_back({s.r, s.core_hu});
  if (static_cast<int>(v.size()) < kMinCoreShells) return NAN;
  const int n = static_cast<int>(v.size()), h = kCoreWindow / 2;
  std::vector<double> level(v.size()), w;
  for (int i = 0; i < n; ++i) {
    w.clear();
    for (int j = std::max(0, i - h); j <= std::min(n - 1, i + h); ++j) w.push_back(v[j].second);
    level[i] = median_inplace(w);
  }
  const int outer_from = std::min(n - 1, static_cast<int>(n * (1.0 - kOuterFraction)));
  std::vector<double> outer(level.begin() + outer_from, level.end());
  const double dead_level = median_inplace(outer);
  const int peak = static_cast<int>(
      std::max_element(level.begin(), level.begin() + outer_from + 1) - level.begin());
  std::vector<double> dev(v.size());
  for (int i = 0; i < n; ++i) dev[i] = std::abs(v[i].second - level[i]);
  *step_hu = level[peak] - dead_level;
  *noise_hu = kMadToSigma * median_inplace(dev);
  const bool step = *step_hu >= kDeadStepHu ||
                    (*step_hu >= kMinDeadStepHu && *step_hu >= kDeadStepSigmas * *noise_hu);
  if (!step) return r_end;
  // The split after the peak that leaves the fewest levels on the wrong side of the midpoint
  // (at or above it after the split, below it before): a level rising again over the knot's
  // last shells costs those shells only.
  const double mid = 0.5 * (level[peak] + dead_level);
  int wrong = 0;  // levels at or above the midpoint after the split (split = peak + 1)
  for (int i = peak + 1; i < n; ++i) wrong += level[i] >= mid;
  int split = peak + 1, best = wrong;
  for (int t = peak + 2; t <= n; ++t) {
    wrong += (level[t - 1] < mid) - (level[t - 1] >= mid);
    if (wrong < best) best = wrong, split = t;
  }
  if (split >= n) return r_end;
  // Between the last sound shell and the first dead one.
  return 0.5 * (v[split - 1].first + v[split].first);
}

using AxisParams = std::array<double, 5>;  // z0, a, b, omega0, twist

double axis_height(const AxisParams& x, const Shell& s) {
  return x[0] + x[1] * s.sqrt_r + x[2] * s.r;
}
double axis_azimuth(const AxisParams& x, const Shell& s) { return x[3] + x[4] * s.ln_r_axis; }

// Both residuals in mm: the height, and the arc length r·Δω on the shell. The model is linear
// in its parameters, so the Jacobian is constant and written out.
class AxisCost final : public ceres::SizedCostFunction<2, 5> {
 public:
  explicit AxisCost(const Shell& s) : s_(s) {}
  bool Evaluate(double const* const* p, double* res, double** jac) const override {
    const double* x = p[0];
    res[0] = s_.z - (x[0] + x[1] * s_.sqrt_r + x[2] * s_.r);
    res[1] = s_.r * (s_.omega - (x[3] + x[4] * s_.ln_r_axis));
    if (jac != nullptr && jac[0] != nullptr) {
      double* j = jac[0];  // row-major 2 × 5
      j[0] = -1;
      j[1] = -s_.sqrt_r;
      j[2] = -s_.r;
      j[3] = 0;
      j[4] = 0;
      j[5] = 0;
      j[6] = 0;
      j[7] = 0;
      j[8] = -s_.r;
      j[9] = -s_.r * s_.ln_r_axis;
    }
    return true;
  }

 private:
  Shell s_;
};

// d(r) = D·min(1, r/R)^p with R fixed: the kink is not a parameter, so the problem is smooth.
class DiameterCost final : public ceres::SizedCostFunction<1, 2> {
 public:
  DiameterCost(double d, double x) : d_(d), x_(x) {}  // x = min(0, ln r − ln R)
  bool Evaluate(double const* const* p, double* res, double** jac) const override {
    const double g = std::exp(p[0][1] * x_);
    res[0] = d_ - p[0][0] * g;
    if (jac != nullptr && jac[0] != nullptr) {
      jac[0][0] = -g;
      jac[0][1] = -p[0][0] * g * x_;
    }
    return true;
  }

 private:
  double d_, x_;
};

ceres::Solver::Options solver_options(int max_iterations) {
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_QR;
  o.max_num_iterations = max_iterations;
  o.num_threads = 1;
  o.logging_type = ceres::SILENT;
  o.minimizer_progress_to_stdout = false;
  return o;
}

int iterations_of(const ceres::Solver::Summary& s) {
  return s.num_successful_steps + s.num_unsuccessful_steps;
}

// ρ(e²) of the chosen loss at scale delta (mm), as Ceres defines it, and its IRLS weight ρ'.
// delta ≤ 0: plain least squares.
double robust_cost(double e, double delta, RobustLoss loss) {
  if (delta <= 0) return e * e;
  if (loss == RobustLoss::kCauchy) return delta * delta * std::log1p(e * e / (delta * delta));
  const double a = std::abs(e);
  return a <= delta ? e * e : 2 * delta * a - delta * delta;
}
double robust_weight(double e, double delta, RobustLoss loss) {
  if (delta <= 0) return 1.0;
  if (loss == RobustLoss::kCauchy) return 1.0 / (1.0 + e * e / (delta * delta));
  const double a = std::abs(e);
  return a <= delta ? 1.0 : delta / a;
}

// The loss function for Ceres; nullptr is plain least squares.
std::unique_ptr<ceres::LossFunction> make_loss(double delta, RobustLoss loss) {
  if (delta <= 0) return nullptr;
  if (loss == RobustLoss::kCauchy) return std::make_unique<ceres::CauchyLoss>(delta);
  return std::make_unique<ceres::HuberLoss>(delta);
}

// The closed-form start: z and ω are each linear in their parameters. Rows are scaled by √w
// (and the ω rows by r, so that they are arc lengths like the Ceres residuals); QR with
// column pivoting copes with the near-collinear √r and r columns of a short trace.
AxisParams linear_axis(const std::vector<Shell>& shells) {
  const int n = static_cast<int>(shells.size());
  Eigen::MatrixXd hz(n, 3), hw(n, 2);
  Eigen::VectorXd yz(n), yw(n);
  for (int i = 0; i < n; ++i) {
    const Shell& s = shells[i];
    const double sw = std::sqrt(s.w);
    hz.row(i) << sw, sw * s.sqrt_r, sw * s.r;
    yz(i) = sw * s.z;
    hw.row(i) << sw * s.r, sw * s.r * s.ln_r_axis;
    yw(i) = sw * s.r * s.omega;
  }
  const Eigen::Vector3d h = hz.colPivHouseholderQr().solve(yz);
  const Eigen::Vector2d w = hw.colPivHouseholderQr().solve(yw);
  return {h(0), h(1), h(2), w(0), w(1)};
}

struct AxisFit {
  AxisParams x{};
  double rms = 0;
  int iterations = 0;
};

Result<AxisFit> fit_axis(std::vector<Shell>& shells, const KnotFitOptions& options) {
  // Unwrap ω around the weighted circular mean, so that a knot near ω = 0 is one run of values.
  double sx = 0, sy = 0;
  for (const Shell& s : shells) {
    sx += s.w * std::cos(s.omega_raw);
    sy += s.w * std::sin(s.omega_raw);
  }
  const double mean = std::atan2(sy, sx);
  for (Shell& s : shells) s.omega = mean + angle_diff(s.omega_raw, mean);

  AxisParams x = linear_axis(shells);
  // Re-unwrap around the first axis: with a twist, the mean is not the best reference for the
  // outer shells.
  for (Shell& s : shells) {
    const double w = axis_azimuth(x, s);
    s.omega = w + angle_diff(s.omega_raw, w);
  }

  double zmin = shells.front().z, zmax = zmin;
  for (const Shell& s : shells) {
    zmin = std::min(zmin, s.z);
    zmax = std::max(zmax, s.z);
  }
  const AxisParams lo = {zmin - kZ0Below, kMinA, kMinB, x[3] - kPi, -kMaxTwist};
  const AxisParams hi = {zmax + kZ0Above, kMaxA, kMaxB, x[3] + kPi, kMaxTwist};
  for (int k = 0; k < 5; ++k) x[k] = std::clamp(x[k], lo[k], hi[k]);

  // The robust loss outlives the problem, which owns only the per-shell scaled wrappers; the
  // weight scales the loss rather than the residual so that the loss's scale stays in mm.
  const std::unique_ptr<ceres::LossFunction> loss_fn = make_loss(options.huber_mm, options.loss);
  ceres::Problem problem;
  for (const Shell& s : shells)
    problem.AddResidualBlock(
        new AxisCost(s), new ceres::ScaledLoss(loss_fn.get(), s.w, ceres::DO_NOT_TAKE_OWNERSHIP),
        x.data());
  for (int k = 0; k < 5; ++k) {
    problem.SetParameterLowerBound(x.data(), k, lo[k]);
    problem.SetParameterUpperBound(x.data(), k, hi[k]);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options(options.max_iterations), &problem, &summary);
  if (!summary.IsSolutionUsable() ||
      !std::all_of(x.begin(), x.end(), [](double v) { return std::isfinite(v); }))
    return Error("fit_knot", "axis solve failed (" + std::to_string(shells.size()) +
                                 " shells): " + summary.message);

  AxisFit fit;
  fit.x = x;
  fit.iterations = iterations_of(summary);
  double ss = 0;
  for (const Shell& s : shells) {
    const double ez = s.z - axis_height(x, s);
    const double ea = s.r * angle_diff(s.omega_raw, axis_azimuth(x, s));
    ss += ez * ez + ea * ea;
  }
  fit.rms = std::sqrt(ss / (2.0 * static_cast<double>(shells.size())));
  return fit;
}

struct Profile {
  double r_dead = 0;
  double d_dead = 0;
  double exponent = kDefaultExponent;
  double cost = 0;  // robust diameter cost, mm²
};

// Per-shell work space of fit_profile, reused across the candidates.
struct ProfileScratch {
  std::vector<double> x;         // min(0, ln r − ln R), the profile's regressor
  std::vector<double> robust_w;  // IRLS weights of the robust loss
};

// Diameter residuals (mm) of a profile, for the shells that carry a diameter.
void profile_residuals(const std::vector<Shell>& shells, const Profile& p,
                       std::vector<double>* out) {
  const double ln_R = std::log(p.r_dead);
  out->clear();
  for (const Shell& s : shells)
    if (s.d > kMinDiameter)
      out->push_back(s.d - p.d_dead * std::exp(p.exponent * std::min(0.0, s.ln_r - ln_R)));
}

// The diameter profile for one fixed r_dead = R, d = D·exp(p·x) with x = min(0, ln r − ln R).
// Start: ln d is linear in (ln D, p), solved in closed form with weights w·d² (a log residual
// times d is ≈ a residual in mm). Then a few robustly re-weighted Gauss-Newton steps on the
// residuals in mm, so that candidates are compared on the cost they will be polished on, not
// on the log-space approximation (biased where d is small and noisy).
Profile fit_profile(const std::vector<Shell>& shells, double R, double delta, RobustLoss loss,
                    ProfileScratch& scratch) {
  const double ln_R = std::log(R);
  const size_t n = shells.size();
  scratch.x.resize(n);
  scratch.robust_w.assign(n, 1.0);
  double s0 = 0, sx = 0, sxx = 0, sy = 0, sxy = 0;
  for (size_t i = 0; i < n; ++i) {
    const Shell& s = shells[i];
    const double x = std::min(0.0, s.ln_r - ln_R);
    scratch.x[i] = x;
    if (s.d <= kMinDiameter) continue;
    const double w = s.w * s.d * s.d;
    const double y = std::log(s.d);
    s0 += w;
    sx += w * x;
    sxx += w * x * x;
    sy += w * y;
    sxy += w * x * y;
  }
  // No shell in the growing part (R at or before the first shell): p is not observable.
  const bool p_free = sxx > 0 && s0 * sxx - sx * sx > 1e-9 * s0 * sxx;
  double e = p_free ? (s0 * sxy - sx * sy) / (s0 * sxx - sx * sx) : kDefaultExponent;
  e = std::clamp(e, kMinExponent, kMaxExponent);
  double D = std::clamp(std::exp((sy - e * sx) / s0), kMinDiameter, kMaxDiameter);

  Profile best;  // the lowest cost seen: a step without line search may overshoot
  best.r_dead = R;
  best.cost = std::numeric_limits<double>::infinity();
  for (int step = 0; step <= kGaussNewtonSteps; ++step) {
    // Residuals, robust weights and the cost at (D, e); then, but for the last pass, one
    // weighted Gauss-Newton step from the 2 × 2 normal equations.
    double a00 = 0, a01 = 0, a11 = 0, b0 = 0, b1 = 0, cost = 0;
    for (size_t i = 0; i < n; ++i) {
      const Shell& s = shells[i];
      if (s.d <= kMinDiameter) continue;
      const double g = std::exp(e * scratch.x[i]);
      const double r = s.d - D * g;
      cost += s.w * robust_cost(r, delta, loss);
      const double w = s.w * robust_weight(r, delta, loss);
      const double j0 = g, j1 = D * g * scratch.x[i];  // ∂(D·g)/∂D, ∂(D·g)/∂p
      a00 += w * j0 * j0;
      a01 += w * j0 * j1;
      a11 += w * j1 * j1;
      b0 += w * j0 * r;
      b1 += w * j1 * r;
    }
    if (cost < best.cost) {
      best.d_dead = D;
      best.exponent = e;
      best.cost = cost;
    }
    if (step == kGaussNewtonSteps || a00 <= 0) break;
    const double det = a00 * a11 - a01 * a01;
    if (p_free && det > 1e-12 * a00 * a11) {
      D += (a11 * b0 - a01 * b1) / det;
      e += (a00 * b1 - a01 * b0) / det;
    } else {
      D += b0 / a00;
    }
    D = std::clamp(D, kMinDiameter, kMaxDiameter);
    e = std::clamp(e, kMinExponent, kMaxExponent);
  }
  return best;
}

struct DiameterFit {
  Profile profile;
  bool dead = false;
  double rms = 0;
  int iterations = 0;
};

Result<DiameterFit> fit_diameter(const std::vector<Shell>& shells, double r_end,
                                 double r_dead_density, const KnotFitOptions& options) {
  int n_used = 0;
  for (const Shell& s : shells) n_used += s.d > kMinDiameter ? 1 : 0;
  if (n_used < options.min_shells)
    return Error("fit_knot", "too few shells with a diameter: " + std::to_string(n_used) + " < " +
                                 std::to_string(options.min_shells));

  const double delta = options.diameter_huber_mm;
  const double step = options.r_dead_step_mm;
  ProfileScratch scratch;

  // Dead candidates: from the first shell (dead almost from the pith) to just short of r_end.
  // R = r_end is the sound knot (every R beyond the last shell describes the same curves).
  std::vector<Profile> dead;
  for (double R = shells.front().r; R < r_end - 0.5 * step; R += step)
    dead.push_back(fit_profile(shells, R, delta, options.loss, scratch));
  const Profile sound = fit_profile(shells, r_end, delta, options.loss, scratch);

  DiameterFit fit;
  fit.profile = sound;
  if (!std::isnan(r_dead_density)) {
    // The density decided: the profile is fitted with its kink there.
    if (r_dead_density < r_end - 0.5 * step) {
      fit.profile = fit_profile(shells, std::max(r_dead_density, shells.front().r), delta,
                                options.loss, scratch);
      fit.dead = true;
    }
  } else if (!dead.empty()) {
    const auto best_cost =
        std::min_element(dead.begin(), dead.end(),
                         [](const Profile& a, const Profile& b) { return a.cost < b.cost; });
    // The residual scale from the median absolute residual: the robust cost itself is inflated
    // by the outliers it discounts.
    std::vector<double> res;
    profile_residuals(shells, *best_cost, &res);
    for (double& r : res) r = std::abs(r);
    const double mad_sigma = kMadToSigma * median_inplace(res);
    const double sigma2 = std::max(kMinVariance, mad_sigma * mad_sigma);
    // Dark rings where a candidate says "sound" argue for an earlier r_dead. Once a trace
    // shows a ring at all, segmented shells without one where a candidate says "dead" argue
    // for a later r_dead (half as strongly: a thin ring is missed more easily than invented;
    // predicted shells have no trustworthy ring measure).
    int n_dark = 0;
    for (const Shell& s : shells) n_dark += s.dark ? 1 : 0;
    const bool rings_seen = n_dark >= kMinDarkShells;
    auto total = [&](const Profile& p) {
      double ring = 0;
      for (const Shell& s : shells) {
        if (s.dark && s.r <= p.r_dead) ring += s.w;
        if (rings_seen && !s.dark && !s.predicted && s.r > p.r_dead) ring += 0.5 * s.w;
      }
      return p.cost + options.dark_ring_cost * sigma2 * ring;
    };
    auto by_total = [&](const Profile& a, const Profile& b) { return total(a) < total(b); };
    Profile best = *std::min_element(dead.begin(), dead.end(), by_total);
    // Refine on a finer grid around the winner: the coarse step bounds the r_dead error.
    const double fine = step / kFineSteps;
    for (double R = best.r_dead - step + fine; R < best.r_dead + step; R += fine) {
      if (R < shells.front().r || R >= r_end) continue;
      const Profile p = fit_profile(shells, R, delta, options.loss, scratch);
      if (by_total(p, best)) best = p;
    }
    const double penalty = options.dead_penalty * std::log(static_cast<double>(n_used)) * sigma2;
    if (total(best) + penalty < total(sound)) {
      fit.profile = best;
      fit.dead = true;
    }
  }

  // Polish (D, p) with Ceres on the residuals in mm, the kink held fixed.
  Profile& p = fit.profile;
  const double ln_R = std::log(p.r_dead);
  std::array<double, 2> x = {p.d_dead, p.exponent};
  const std::unique_ptr<ceres::LossFunction> loss_fn = make_loss(delta, options.loss);
  ceres::Problem problem;
  for (const Shell& s : shells) {
    if (s.d <= kMinDiameter) continue;
    problem.AddResidualBlock(
        new DiameterCost(s.d, std::min(0.0, s.ln_r - ln_R)),
        new ceres::ScaledLoss(loss_fn.get(), s.w, ceres::DO_NOT_TAKE_OWNERSHIP), x.data());
  }
  problem.SetParameterLowerBound(x.data(), 0, kMinDiameter);
  problem.SetParameterUpperBound(x.data(), 0, kMaxDiameter);
  problem.SetParameterLowerBound(x.data(), 1, kMinExponent);
  problem.SetParameterUpperBound(x.data(), 1, kMaxExponent);
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options(options.max_iterations), &problem, &summary);
  if (!summary.IsSolutionUsable() || !std::isfinite(x[0]) || !std::isfinite(x[1]))
    return Error("fit_knot", "diameter solve failed (" + std::to_string(n_used) +
                                 " shells): " + summary.message);
  p.d_dead = x[0];
  p.exponent = x[1];
  fit.iterations = iterations_of(summary);

  double ss = 0;
  for (const Shell& s : shells) {
    if (s.d <= kMinDiameter) continue;
    const double r = s.d - p.d_dead * std::exp(p.exponent * std::min(0.0, s.ln_r - ln_R));
    ss += r * r;
  }
  fit.rms = std::sqrt(ss / n_used);
  return fit;
}

}  // namespace

Result<KnotFitReport> fit_knot(const KnotTrace& trace, const KnotFitOptions& options) {
  assert(options.min_shells >= 3 && options.r_dead_step_mm > 0 && options.max_iterations > 0);
  const int n = static_cast<int>(trace.shells.size());
  if (n < options.min_shells)
    return Error("fit_knot", "too few shells: " + std::to_string(n) + " < " +
                                 std::to_string(options.min_shells));

  std::vector<Shell> shells;
  shells.reserve(n);
  int dark = 0;
  for (int i = 0; i < n; ++i) {
    const KnotShell& k = trace.shells[i];
    if (!std::isfinite(k.r) || !std::isfinite(k.omega) || !std::isfinite(k.z) ||
        !std::isfinite(k.diameter) || !(k.r > 0))
      return Error("fit_knot", "shell " + std::to_string(i) +
                                   ": r, ω, z or diameter not finite "
                                   "or r ≤ 0");
    Shell s;
    s.r = k.r;
    s.sqrt_r = std::sqrt(k.r);
    s.ln_r = std::log(k.r);
    s.ln_r_axis = std::log(std::max(k.r, 1.0));
    s.z = k.z;
    s.omega_raw = k.omega;
    s.d = k.diameter;
    s.w = k.predicted ? options.predicted_weight : 1.0;
    if (k.voxels > 0 && options.full_weight_voxels > 0)
      s.w *= std::clamp(static_cast<double>(k.voxels) / options.full_weight_voxels, kMinShellWeight,
                        1.0);
    s.dark = k.ring_hu < options.dark_ring_hu;
    s.predicted = k.predicted;
    s.core_hu = k.core_hu;
    dark += s.dark ? 1 : 0;
    shells.push_back(s);
  }
  // The detector orders shells by r; a caller's hand-made trace might not.
  std::sort(shells.begin(), shells.end(), [](const Shell& a, const Shell& b) { return a.r < b.r; });

  // Where the knot ends: at the outermost evidence; a knot that reaches the surface ends at its
  // last shell (the fit must not run it out into the bark).
  const double r_last = shells.back().r;
  const double r_end = trace.reaches_surface ? r_last : std::max(trace.r_last_seen, r_last);

  Result<AxisFit> axis = fit_axis(shells, options);
  if (!axis) return axis.error();
  double step_hu = NAN, noise_hu = NAN;
  const double r_dead_density =
      options.use_density ? r_dead_from_density(shells, r_end, &step_hu, &noise_hu) : std::nan("");
  // A dead knot's outline includes the bark encased around it, darker than the wood, which the
  // detector's diameter (the dense part) leaves out: beyond r_dead the shells are widened by it.
  if (!std::isnan(r_dead_density) && r_dead_density < r_end && options.encased_bark_mm > 0)
    for (Shell& s : shells)
      if (s.r > r_dead_density && s.d > kMinDiameter) s.d += 2.0 * options.encased_bark_mm;
  Result<DiameterFit> diam = fit_diameter(shells, r_end, r_dead_density, options);
  if (!diam) return diam.error();

  const AxisParams& x = axis.value().x;
  const Profile& p = diam.value().profile;
  KnotFitReport report;
  Knot& knot = report.knot;
  knot.z0 = x[0];
  knot.a = x[1];
  knot.b = x[2];
  knot.omega0 = wrap_angle(x[3]);
  knot.twist = x[4];
  knot.r_end = r_end;
  knot.r_dead = diam.value().dead ? p.r_dead : r_end;
  knot.diameter.d_dead = p.d_dead;
  knot.diameter.exponent = p.exponent;
  knot.fit_rms_mm = axis.value().rms;
  knot.support = n;
  report.axis_rms_mm = axis.value().rms;
  report.diameter_rms_mm = diam.value().rms;
  report.iterations = axis.value().iterations + diam.value().iterations;
  report.dark_ring_shells = dark;
  report.dead = diam.value().dead;
  report.density_step_hu = step_hu;
  report.density_noise_hu = noise_hu;
  return report;
}

}  // namespace sawyer::ct
