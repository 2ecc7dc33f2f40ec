// Rotation × offset grid, parallel evaluation, Gaussian smoothing of the value surface.
#include "sawyer/sawing/optimise.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <sstream>
#include <string>
#include <thread>

#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/uncertainty.h"

namespace sawyer::sawing {

namespace {

bool whole(double ratio) { return std::abs(ratio - std::round(ratio)) < 1e-6; }

std::vector<double> axis(double max, double step) {
  std::vector<double> out;
  if (max <= 0) return {0.0};
  const int n = static_cast<int>(std::lround(max / step));
  for (int i = -n; i <= n; ++i) out.push_back(i * step);
  return out;
}

// Normalised Gaussian weights for offsets −radius..radius grid steps.
std::vector<double> kernel(double sigma, double step, int max_radius) {
  if (sigma <= 0) return {1.0};
  const int radius = std::min(max_radius, static_cast<int>(std::ceil(3.0 * sigma / step)));
  std::vector<double> w;
  for (int k = -radius; k <= radius; ++k)
    w.push_back(std::exp(-0.5 * std::pow(k * step / sigma, 2)));
  return w;
}

// Truncated, renormalised smoothing of a line of n values with stride.
void smooth_line(double* base, size_t n, size_t stride, const std::vector<double>& w,
                 std::vector<double>& tmp) {
  const int r = static_cast<int>(w.size() / 2);
  tmp.assign(n, 0.0);
  for (size_t i = 0; i < n; ++i) {
    double s = 0, ws = 0;
    for (int k = -r; k <= r; ++k) {
      const long j = static_cast<long>(i) + k;
      if (j < 0 || j >= static_cast<long>(n)) continue;
      s += w[k + r] * base[j * stride];
      ws += w[k + r];
    }
    tmp[i] = s / ws;
  }
  for (size_t i = 0; i < n; ++i) base[i * stride] = tmp[i];
}

// One-sided 95 % quantile of Student's t with `df` degrees of freedom: exact to 3 decimals for
// df ≤ 10, the Cornish-Fisher expansion above.
double t95(int df) {
  static const double kTable[] = {0,     6.314, 2.920, 2.353, 2.132, 2.015,
                                  1.943, 1.895, 1.860, 1.833, 1.812};
  if (df < 1) return NAN;
  if (df <= 10) return kTable[df];
  const double z = 1.6448536, v = df;
  return z + (z * z * z + z) / (4 * v) +
         (5 * std::pow(z, 5) + 16 * z * z * z + 3 * z) / (96 * v * v);
}

}  // namespace

ClaimRange cross_validated_claim(const std::vector<std::vector<double>>& smoothed,
                                 size_t horns_down) {
  const size_t n = smoothed.size();
  ClaimRange c;
  if (n == 0 || smoothed[0].empty()) return c;
  const size_t total = smoothed[0].size();
  // Groups: member 0 (the model as it is), then draws (1, 2), (3, 4), ...: an antithetic pair.
  std::vector<std::pair<size_t, size_t>> groups{{0, 1}};
  for (size_t m = 1; m < n; m += 2) groups.push_back({m, std::min(n, m + 2)});
  std::vector<double> sum(total, 0.0);
  for (const std::vector<double>& s : smoothed)
    for (size_t i = 0; i < total; ++i) sum[i] += s[i];
  std::vector<double> gains;
  for (auto [b, e] : groups) {
    size_t best = 0;
    double best_v = -INFINITY;
    for (size_t i = 0; i < total; ++i) {
      double v = sum[i];
      for (size_t m = b; m < e; ++m) v -= smoothed[m][i];
      if (v > best_v) best_v = v, best = i;  // the first of equals, as the optimiser's sort
    }
    for (size_t m = b; m < e; ++m) {
      const double ref = smoothed[m][horns_down];
      gains.push_back(ref > 0 ? smoothed[m][best] / ref - 1.0 : 0.0);
    }
  }
  const double k = static_cast<double>(gains.size());
  double mean = 0, var = 0;
  for (double g : gains) mean += g / k;
  for (double g : gains) var += (g - mean) * (g - mean);
  c.gain = c.low = c.high = mean;
  c.groups = static_cast<int>(groups.size());
  if (gains.size() > 1) {
    const double half =
        t95(static_cast<int>(gains.size()) - 1) * std::sqrt(var / (k - 1)) * std::sqrt(1 + 1 / k);
    c.low = mean - half, c.high = mean + half;
  }
  return c;
}

std::string claim_text(const ClaimRange& c) {
  char b[96];
  if (c.groups > 0 && c.high > c.low)
    std::snprintf(b, sizeof b, "%+.1f %% (90 %% range %+.1f to %+.1f %%)", 100 * c.gain,
                  100 * c.low, 100 * c.high);
  else
    std::snprintf(b, sizeof b, "%+.1f %%", 100 * c.gain);
  return b;
}

bool is_point_symmetric(const Pattern& p) {
  auto near = [](double a, double b) { return std::abs(a - b) < 1e-6; };
  for (const BoardSpec& b : p.boards) {
    bool twin = false;
    for (const BoardSpec& c : p.boards)
      twin = twin || (near(c.u_mm, -b.u_mm) && near(c.v_mm, -b.v_mm) &&
                      near(c.thickness_mm, b.thickness_mm) && near(c.width_mm, b.width_mm) &&
                      c.thickness_axis == b.thickness_axis && c.edged == b.edged);
    if (!twin) return false;
  }
  return true;
}

namespace {

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// "<what> (<option>) <v><unit> is outside <lo>-<hi><unit>" for a value out of [lo, hi] or NaN.
Status in_range(const char* what, const char* option, double v, double lo, double hi,
                const char* unit) {
  if (std::isfinite(v) && v >= lo && v <= hi) return Status::Ok();
  return Error(std::string(what) + " (" + option + ")",
               num(v) + unit + " is outside " + num(lo) + "-" + num(hi) + unit);
}

}  // namespace

Status OptimiseOptions::validate(const Pattern& p) const {
  if (!(rot_step_deg > 0)) return Error("rotation step", "must be > 0");
  if (rot_range_deg != 0 && rot_range_deg != 180 && rot_range_deg != 360)
    return Error("rotation range", "must be 180 or 360 (or 0: from the pattern's symmetry)");
  if (rot_range_deg == 180 && !is_point_symmetric(p))
    return Error("rotation range", "180° needs a point-symmetric pattern; '" + p.name + "' is not");
  const double range = rot_range_deg != 0 ? rot_range_deg : (is_point_symmetric(p) ? 180 : 360);
  // Steps below 0.01° or 0.01 mm are far finer than any saw can set a log; the bounds also keep
  // the grid's counts within int before the position budget below is checked.
  if (Status st =
          in_range("rotation step", "rot_step_deg", rot_step_deg, kMinRotStepDeg, range, "°");
      !st)
    return st;
  if (!whole(range / rot_step_deg) || range / rot_step_deg < 1)
    return Error("rotation step", "must divide " + std::to_string(static_cast<int>(range)) + "°");
  for (auto [name, opt, opt_step, max, step] :
       {std::tuple{"offset x", "offset_x_max_mm", "offset_x_step_mm", offset_x_max_mm,
                   offset_x_step_mm},
        std::tuple{"offset y", "offset_y_max_mm", "offset_y_step_mm", offset_y_max_mm,
                   offset_y_step_mm}}) {
    if (!(max >= 0)) return Error(name, "range must be ≥ 0");
    if (Status st = in_range(name, opt, max, 0, kMaxOffsetMm, " mm"); !st) return st;
    if (max > 0 && (!(step > 0) || !whole(max / step)))
      return Error(name, "step must be > 0 and divide the range");
    if (max > 0) {
      const std::string what = std::string(name) + " step";
      if (Status st = in_range(what.c_str(), opt_step, step, kMinOffsetStepMm, max, " mm"); !st)
        return st;
    }
  }
  if (!(sigma_rot_deg >= 0) || !(sigma_offset_mm >= 0)) return Error("sigma", "must be ≥ 0");
  if (Status st = in_range("sigma", "sigma_rot_deg", sigma_rot_deg, 0, kMaxSigmaRotDeg, "°"); !st)
    return st;
  if (Status st =
          in_range("sigma", "sigma_offset_mm", sigma_offset_mm, 0, kMaxSigmaOffsetMm, " mm");
      !st)
    return st;
  if (threads < 0) return Error("threads", "must be ≥ 0");
  if (model_draws < 0 || model_draws > kMaxModelDraws)
    return Error("model draws (model_draws)",
                 std::to_string(model_draws) + " is outside 0-" + std::to_string(kMaxModelDraws));
  // Every position is sawn and graded, and the value surface is kept twice: the grid's size is
  // the job's time and memory.
  const double nr = std::round(range / rot_step_deg);
  const double nx =
      offset_x_max_mm > 0 ? 2 * std::round(offset_x_max_mm / offset_x_step_mm) + 1 : 1;
  const double ny =
      offset_y_max_mm > 0 ? 2 * std::round(offset_y_max_mm / offset_y_step_mm) + 1 : 1;
  if (nr * nx * ny > kMaxPositions)
    return Error("sawing grid",
                 num(nr * nx * ny) + " positions (" + num(nr) + " rotations × " + num(nx) + " × " +
                     num(ny) + " offsets from rot_step_deg " + num(rot_step_deg) +
                     ", offset_x_max_mm " + num(offset_x_max_mm) + " offset_x_step_mm " +
                     num(offset_x_step_mm) + ", offset_y_max_mm " + num(offset_y_max_mm) +
                     " offset_y_step_mm " + num(offset_y_step_mm) + ") is more than the " +
                     num(kMaxPositions) + " allowed; use coarser steps or narrower offsets");
  // Each draw of the scan's uncertainty saws every position once more.
  if (nr * nx * ny * (1 + model_draws) > kMaxPositions)
    return Error("model draws (model_draws)",
                 num(nr * nx * ny) + " positions × " + num(1 + model_draws) +
                     " models is more than the " + num(kMaxPositions) +
                     " sawings allowed; use fewer draws or a coarser grid");
  return Status::Ok();
}

void smooth_value_surface(std::vector<double>& s, size_t nr, size_t nx, size_t ny,
                          double rot_step_deg, double x_step_mm, double y_step_mm,
                          double sigma_rot_deg, double sigma_offset_mm, bool mirror_on_wrap) {
  auto at = [&](size_t ir, size_t ix, size_t iy) { return (ir * nx + ix) * ny + iy; };
  // Rotation: circular; a wrap past the 180° range mirrors the offsets.
  const std::vector<double> wr = kernel(sigma_rot_deg, rot_step_deg, static_cast<int>(nr) / 2);
  if (wr.size() > 1) {
    const std::vector<double> in = s;
    const int r = static_cast<int>(wr.size() / 2);
    for (size_t ir = 0; ir < nr; ++ir)
      for (size_t ix = 0; ix < nx; ++ix)
        for (size_t iy = 0; iy < ny; ++iy) {
          double sum = 0, wsum = 0;
          for (int k = -r; k <= r; ++k) {
            wsum += wr[k + r];
            const long j = static_cast<long>(ir) + k;
            const long n = static_cast<long>(nr);
            const long wraps = j < 0 ? (j - n + 1) / n : j / n;
            const size_t jr = static_cast<size_t>(j - wraps * n);
            const bool flip = mirror_on_wrap && (wraps % 2 != 0);
            sum += wr[k + r] * in[at(jr, flip ? nx - 1 - ix : ix, flip ? ny - 1 - iy : iy)];
          }
          s[at(ir, ix, iy)] = sum / wsum;
        }
  }
  std::vector<double> tmp;
  const std::vector<double> wx = kernel(sigma_offset_mm, x_step_mm, static_cast<int>(nx));
  if (nx > 1 && wx.size() > 1)
    for (size_t ir = 0; ir < nr; ++ir)
      for (size_t iy = 0; iy < ny; ++iy) smooth_line(&s[at(ir, 0, iy)], nx, ny, wx, tmp);
  const std::vector<double> wy = kernel(sigma_offset_mm, y_step_mm, static_cast<int>(ny));
  if (ny > 1 && wy.size() > 1)
    for (size_t ir = 0; ir < nr; ++ir)
      for (size_t ix = 0; ix < nx; ++ix) smooth_line(&s[at(ir, ix, 0)], ny, 1, wy, tmp);
}

Result<OptimiseResult> optimise_position(const SawLog& log, const Pattern& pattern,
                                         const GradingRules& rules, const PriceTable& prices,
                                         const OptimiseOptions& o,
                                         const std::function<void(int, int)>& progress) {
  if (Status s = o.validate(pattern); !s) return s.error();
  OptimiseResult res;
  res.symmetric = is_point_symmetric(pattern);
  res.rot_range_deg = o.rot_range_deg != 0 ? o.rot_range_deg : (res.symmetric ? 180 : 360);
  const int nr = static_cast<int>(std::lround(res.rot_range_deg / o.rot_step_deg));
  for (int i = 0; i < nr; ++i) res.rotations_deg.push_back(i * o.rot_step_deg);
  res.offsets_x_mm = axis(o.offset_x_max_mm, o.offset_x_step_mm);
  res.offsets_y_mm = axis(o.offset_y_max_mm, o.offset_y_step_mm);
  const size_t nx = res.offsets_x_mm.size(), ny = res.offsets_y_mm.size();
  const int total = static_cast<int>(nr * nx * ny);
  res.positions = total;
  res.value.assign(total, 0.0);

  auto position_of = [&](size_t i) {
    const size_t iy = i % ny, ix = (i / ny) % nx, ir = i / (ny * nx);
    return LogPosition{res.rotations_deg[ir], res.offsets_x_mm[ix], res.offsets_y_mm[iy]};
  };
  // Draws of the scanned model (uncertainty.h), each set up in `log`'s frame so that a position
  // means the same cut on all of them.
  std::vector<LogModel> drawn;
  std::vector<SawLog> draw_logs;
  if (o.model_draws > 0) {
    const ScanSpread spread = scan_spread(log.model());
    if (spread.any()) {
      const ScannerPosition frame = scanner_position(log, {});
      drawn.reserve(o.model_draws);
      draw_logs.reserve(o.model_draws);
      for (int k = 0; k < o.model_draws; ++k) {
        drawn.push_back(draw_model(log.model(), spread, k, o.draw_seed));
        draw_logs.emplace_back(drawn.back(), frame);
      }
      res.model_draws = o.model_draws;
      res.spread_note = spread.note;
    }
  }
  auto value_on = [&](const SawLog& l, const LogPosition& p) {
    return value_of(saw_for_sale(l, pattern, p, rules, prices), rules, prices).value;
  };
  // The value at p of the model and of each draw (`out`, when given, gets them one by one), and
  // their mean.
  const size_t members = 1 + draw_logs.size();
  auto value_at = [&](const LogPosition& p, double* out = nullptr) {
    double v = value_on(log, p);
    if (out) out[0] = v;
    for (size_t m = 1; m < members; ++m) {
      const double vm = value_on(draw_logs[m - 1], p);
      if (out) out[m] = vm;
      v += vm;
    }
    return v / static_cast<double>(members);
  };
  // Per member, position by position ([i × members + m]), for the claim's range.
  std::vector<double> member_value(members > 1 ? members * static_cast<size_t>(total) : 0);

  res.threads = o.threads > 0 ? o.threads : std::max(1u, std::thread::hardware_concurrency());
  const auto t0 = std::chrono::steady_clock::now();
  std::atomic<int> next{0}, done{0};
  auto work = [&] {
    for (int i; (i = next.fetch_add(1)) < total;) {
      res.value[i] = value_at(position_of(i), members > 1 ? &member_value[i * members] : nullptr);
      done.fetch_add(1);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < res.threads; ++t) pool.emplace_back(work);
  while (progress && done.load() < total) {
    progress(done.load(), total);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  for (std::thread& t : pool) t.join();
  if (progress) progress(total, total);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  res.smoothed = res.value;
  smooth_value_surface(res.smoothed, nr, nx, ny, o.rot_step_deg, o.offset_x_step_mm,
                       o.offset_y_step_mm, o.sigma_rot_deg, o.sigma_offset_mm,
                       res.rot_range_deg == 180);

  std::vector<int> order(total);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return res.smoothed[a] > res.smoothed[b]; });
  for (int k = 0; k < std::min(total, std::max(1, o.ranked)); ++k)
    res.ranked.push_back({position_of(order[k]), res.value[order[k]], res.smoothed[order[k]]});
  res.best = res.ranked.front();
  const int raw_best =
      static_cast<int>(std::max_element(res.value.begin(), res.value.end()) - res.value.begin());
  res.best_raw = {position_of(raw_best), res.value[raw_best], res.smoothed[raw_best]};

  // Horns-down / horns-up at offset 0: raw from a direct saw, smoothed from the grid.
  const size_t cx = (nx - 1) / 2, cy = (ny - 1) / 2;
  res.horns_down = {LogPosition{0, 0, 0}, value_at({0, 0, 0}), res.smoothed[res.index(0, cx, cy)]};
  const bool up_on_grid = whole(180.0 / o.rot_step_deg);
  const size_t up_r =
      res.rot_range_deg == 180 ? 0 : static_cast<size_t>(std::lround(180.0 / o.rot_step_deg));
  res.horns_up = {LogPosition{180, 0, 0}, value_at({180, 0, 0}),
                  up_on_grid ? res.smoothed[res.index(up_r, cx, cy)] : value_at({180, 0, 0})};
  auto gain = [](double best, double ref) { return ref > 0 ? best / ref - 1.0 : 0.0; };
  res.gain_over_horns_down = gain(res.best.smoothed, res.horns_down.smoothed);
  res.gain_over_horns_up = gain(res.best.smoothed, res.horns_up.smoothed);
  res.claim = {res.gain_over_horns_down, res.gain_over_horns_down, res.gain_over_horns_down, 0};
  if (members > 1) {
    std::vector<std::vector<double>> smoothed(members, std::vector<double>(total));
    for (size_t m = 0; m < members; ++m) {
      for (int i = 0; i < total; ++i) smoothed[m][i] = member_value[i * members + m];
      smooth_value_surface(smoothed[m], nr, nx, ny, o.rot_step_deg, o.offset_x_step_mm,
                           o.offset_y_step_mm, o.sigma_rot_deg, o.sigma_offset_mm,
                           res.rot_range_deg == 180);
    }
    res.claim = cross_validated_claim(smoothed, res.index(0, cx, cy));
  }
  return res;
}

}  // namespace sawyer::sawing
