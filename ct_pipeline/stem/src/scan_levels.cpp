// The CT levels of a log scan from its own histogram (see scan_levels.h).
#include "sawyer/ct/stem/scan_levels.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "sawyer/core/stats.h"

namespace sawyer::ct {
namespace {

// Histogram bins: at least this wide (HU), and at most this many over the data's range.
constexpr double kMinBinHu = 2.0;
constexpr int kMaxBins = 2048;
// Gaussian smoothing of the histogram (HU): wider than an 8-bit export's level spacing (a
// 1000-1600 HU window stores 4-6 HU per level), narrower than any two levels worth telling apart.
constexpr double kSmoothHu = 12.0;
// A mode stands out of the valleys on both sides by this share of its height...
constexpr double kMinProminence = 0.3;
// ...and holds this share of the pixels (air: of the slice; wood: of the log's pixels; any mode
// at all: of the slice, a floor against noise). The floor is low: a log in a wide field of view
// (a 512 px, 1.6 mm industrial scan of a 300 mm log) fills 10 % of the slice, and its wet
// sapwood ring a quarter of that; at a 3 % floor the sapwood mode was dropped, the log read as
// dried and no outline closed.
constexpr double kMinAirShare = 0.05, kMinModeShare = 0.005, kMinWoodModeShare = 0.10;
// The air/log threshold this share of the way from air to the lightest wood mode: for a green log
// at the nominal calibration the -700 HU the stem pass always used (air -1000, heartwood -500),
// above the outer bark's edge blurred with air, so logs touching bark to bark stay apart.
constexpr double kLogShare = 0.6;
// Wood modes lie above air by more than this share of the way to the dominant wood mode (the
// log's pixels above it). Not half: a dry core reads far lighter than wet sapwood in real logs
// (a real pine butt: heartwood -510 HU, sapwood +25, air -900, i.e. 40 % of the way), and at
// half the heartwood was taken for the air's edge, the log's threshold put above it and the
// whole core left out of the wood. The air's blurred edge with the bark is no mode.
constexpr double kWoodModeFloor = 0.25;
// Two wood modes count as two (a dry core in wet sapwood) when this many noise sigmas apart, or
// when the histogram between them falls below this share of the smaller one's height: two
// populations with few pixels between (the border's partial volume), whatever the noise. The
// noise sigma alone misses them on a coarse, noisy scan with a compressed calibration (1.8 mm
// pixels, 55 HU noise, slope 0.9: heartwood and sapwood 400 HU apart are "only" 7.5 sigmas).
constexpr double kTwoModeSigmas = 8.0;
constexpr double kTwoModeValley = 1.0 / 3.0;
// Denser than the densest wood mode by this share of its height over air (green sapwood ~950
// kg/m^3 -> ~1140, under the belt's 1200; knots of dried wood fall above it and are no bother),
// and at least this many noise sigmas: the bed, the rails and clutter.
constexpr double kDenseShare = 0.2, kDenseSigmas = 4.0;
// The fewest samples whose median dense_median_hu is for (the contour's inside window spans 3
// coarse steps on a 1-2 mm scan, more on a finer one).
constexpr double kDenseMedianSamples = 3.0;
// Wood lighter than this over air (HU ~ kg/m^3 at a slope-1 calibration), in one mode, looks
// dried: green sapwood holds 800-1050 kg/m^3, dried softwood 350-550.
constexpr double kDriedBelowHu = 700.0;
// A spike of one stored value at the data's floor holding this share of the pixels is air
// clipped by a window.
constexpr double kClippedShare = 0.03;

struct Mode {
  double hu;     // position (HU)
  double share;  // of all samples, between its valleys
  int peak_bin;
};

double mad_sigma(std::vector<float>& d) {
  if (d.size() < 16) return 0;
  const double med = median_inplace(d);
  for (float& v : d) v = std::abs(v - static_cast<float>(med));
  return 1.4826 * median_inplace(d);
}

}  // namespace

ScanLevels estimate_levels(const Slice& slice, int samples) {
  ScanLevels out;
  const int W = slice.width, H = slice.height;
  if (W < 3 || H < 3 || slice.hu.size() != static_cast<size_t>(W) * H) {
    out.notes = "empty slice";
    return out;
  }
  const int stride = std::max(
      1, static_cast<int>(std::sqrt(static_cast<double>(W) * H / std::max(1000, samples))));
  std::vector<float> v;
  v.reserve(static_cast<size_t>((W / stride + 1) * (H / stride + 1)));
  for (int y = 0; y < H; y += stride)
    for (int x = 0; x < W; x += stride) {
      const float q = slice.hu[static_cast<size_t>(y) * W + x];
      if (std::isfinite(q)) v.push_back(q);
    }
  if (v.size() < 100) {
    out.notes = "too few pixels";
    return out;
  }
  const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
  const double lo = *mn, hi = *mx;
  if (!(hi - lo > 4 * kMinBinHu)) {
    out.notes = "flat slice: one value";
    return out;
  }
  const double bw = std::max(kMinBinHu, (hi - lo) / kMaxBins);
  const int nb = static_cast<int>((hi - lo) / bw) + 1;
  std::vector<double> raw(nb, 0.0);
  int at_floor = 0, at_ceiling = 0;
  for (float q : v) {
    raw[std::min(nb - 1, static_cast<int>((q - lo) / bw))] += 1;
    at_floor += q == *mn;
    at_ceiling += q == *mx;
  }
  const double total = static_cast<double>(v.size());
  // Smoothed histogram (zero beyond the range, so a spike at the floor stays a peak).
  const double sb = std::max(1.0, kSmoothHu / bw);
  const int kr = static_cast<int>(std::ceil(3 * sb));
  std::vector<double> ker(2 * kr + 1);
  for (int k = -kr; k <= kr; ++k) ker[k + kr] = std::exp(-0.5 * k * k / (sb * sb));
  std::vector<double> S(nb, 0.0);
  for (int i = 0; i < nb; ++i) {
    if (raw[i] == 0) continue;
    for (int k = -kr; k <= kr; ++k) {
      const int j = i + k;
      if (j >= 0 && j < nb) S[j] += raw[i] * ker[k + kr];
    }
  }
  // Modes: local maxima standing out of the valleys on both sides, each with the samples between
  // its two valleys.
  std::vector<Mode> modes;
  for (int i = 0; i < nb; ++i) {
    const double hl = i > 0 ? S[i - 1] : 0, hr = i + 1 < nb ? S[i + 1] : 0;
    if (!(S[i] > hl && S[i] >= hr)) continue;
    // A side with no higher bin up to the histogram's end drops to nothing beyond it.
    int a = i, b = i, j = i - 1;
    double minl = S[i], minr = S[i];
    for (; j >= 0 && S[j] <= S[i]; --j)
      if (S[j] < minl) minl = S[j], a = j;
    if (j < 0) minl = 0;
    for (j = i + 1; j < nb && S[j] <= S[i]; ++j)
      if (S[j] < minr) minr = S[j], b = j;
    if (j >= nb) minr = 0;
    if (S[i] - std::max(minl, minr) < kMinProminence * S[i]) continue;
    double m = 0;
    for (int k = a; k <= b; ++k) m += raw[k];
    if (m < kMinModeShare * total) continue;
    // A spike of one value at the data's top is what a window or the scanner's range clipped
    // (the bed, metal, dense knots in a windowed export), not a wood mode.
    if (at_ceiling >= kMinModeShare * total && hi - (lo + (i + 0.5) * bw) <= 3 * kSmoothHu)
      continue;
    // Sub-bin position: parabola through the smoothed peak.
    double off = 0;
    if (i > 0 && i + 1 < nb) {
      const double den = S[i - 1] - 2 * S[i] + S[i + 1];
      if (den < 0) off = std::clamp(0.5 * (S[i - 1] - S[i + 1]) / den, -0.5, 0.5);
    }
    modes.push_back({lo + (i + 0.5 + off) * bw, m / total, i});
  }
  // Air: the lowest mode with a large share; clipped to the floor by a window when one value there
  // holds a good share of the slice.
  const Mode* air = nullptr;
  for (const Mode& m : modes)
    if (m.share >= kMinAirShare) {
      air = &m;
      break;
    }
  if (!air) {
    out.notes = "no air mode (the log fills the field of view, or not a CT of a log in air)";
    return out;
  }
  out.air_clipped = at_floor >= kClippedShare * total && air->peak_bin * bw <= 3 * kSmoothHu;
  out.air_hu = out.air_clipped ? lo : air->hu;
  // Wood: the largest mode above air; the modes holding a good share of the log's pixels.
  const Mode* dom = nullptr;
  for (const Mode& m : modes)
    if (m.hu > air->hu && m.peak_bin > air->peak_bin && (!dom || m.share > dom->share)) dom = &m;
  if (!dom) {
    out.notes = "no wood mode above air (air only, or an object too small)";
    return out;
  }
  out.wood_hu = dom->hu;
  double log_share = 0;
  const double split = out.air_hu + kWoodModeFloor * (dom->hu - out.air_hu);
  for (float q : v) log_share += q > split;
  log_share /= total;
  out.wood_low_hu = out.wood_high_hu = dom->hu;
  std::vector<const Mode*> wood_modes;
  for (const Mode& m : modes)
    if (m.hu > split && m.share >= kMinWoodModeShare * log_share) wood_modes.push_back(&m);

  // Noise: the second difference across a row, v - (left + right) / 2, has sigma * sqrt(1.5) for
  // white noise; its MAD among pixels whose three samples sit in air, and in wood.
  const double air_half = 0.25 * (dom->hu - out.air_hu);
  std::vector<float> d_air, d_wood;
  for (int y = 0; y < H; y += stride) {
    const float* row = &slice.hu[static_cast<size_t>(y) * W];
    for (int x = 1; x + 1 < W; x += stride) {
      const float a = row[x - 1], b = row[x], c = row[x + 1];
      const float d = b - 0.5f * (a + c);
      if (std::abs(a - out.air_hu) < air_half && std::abs(b - out.air_hu) < air_half &&
          std::abs(c - out.air_hu) < air_half)
        d_air.push_back(d);
      else if (a > split && b > split && c > split)
        d_wood.push_back(d);
    }
  }
  out.noise_air_hu = mad_sigma(d_air) / std::sqrt(1.5);
  out.noise_wood_hu = mad_sigma(d_wood) / std::sqrt(1.5);
  const double sigma = std::max(out.noise_hu(), bw);
  const Mode *low = dom, *high = dom;
  for (const Mode* m : wood_modes) {
    if (m->hu < low->hu) low = m;
    if (m->hu > high->hu) high = m;
  }
  out.wood_low_hu = low->hu, out.wood_high_hu = high->hu;
  double valley = 0;
  if (low != high) {
    valley = std::min(S[low->peak_bin], S[high->peak_bin]);
    for (int i = low->peak_bin; i <= high->peak_bin; ++i) valley = std::min(valley, S[i]);
  }
  out.two_wood_modes =
      low != high && (out.wood_high_hu - out.wood_low_hu >= kTwoModeSigmas * sigma ||
                      valley < kTwoModeValley * std::min(S[low->peak_bin], S[high->peak_bin]));
  if (!out.two_wood_modes) out.wood_low_hu = out.wood_high_hu = out.wood_hu;
  out.log_hu = out.air_hu + kLogShare * (out.wood_low_hu - out.air_hu);
  // A dried log's own texture above its wood mode: latewood bands (a real dried disc: earlywood
  // -700 HU, latewood -300 around a -585 HU mode), which a pixel's noise does not show. Water
  // evens a green log's earlywood out towards its latewood; dried, the bands keep their whole
  // density contrast, and at the green log's margin the latewood and the bark read as the bed,
  // so that no outline closed. The one-sided robust spread of the samples above the mode (the
  // bed and knots are few of them); green logs keep their margin, which keeps the bed out.
  out.dried = !out.two_wood_modes && out.wood_high_hu - out.air_hu < kDriedBelowHu;
  if (out.dried) {
    std::vector<float> up;
    for (float q : v)
      if (q > out.wood_high_hu) up.push_back(q - static_cast<float>(out.wood_high_hu));
    out.texture_wood_hu = up.size() >= 16 ? 1.4826 * median_inplace(up) : 0.0;
  }
  // Dense: beyond the wood's noise and a dried log's texture.
  const double dense_sigma = std::max(sigma, out.texture_wood_hu);
  out.dense_hu = out.wood_high_hu + std::max(kDenseShare * (out.wood_high_hu - out.air_hu),
                                             kDenseSigmas * dense_sigma);
  // The median of a few samples averages the noise down, not a band of latewood.
  out.dense_median_hu =
      out.wood_high_hu + std::max(kDenseShare * (out.wood_high_hu - out.air_hu),
                                  kDenseSigmas * std::max(sigma / std::sqrt(kDenseMedianSamples),
                                                          out.texture_wood_hu));
  // A clipped air says nothing of the calibration.
  out.shift_hu = out.air_clipped ? 0.0 : out.air_hu + 1000.0;
  out.wood_over_air_hu = out.wood_hu - out.air_hu;
  double in_log = 0;
  for (float q : v) in_log += q > out.log_hu && q < out.dense_hu;
  out.fraction_log = in_log / total;
  out.valid = true;
  std::string notes;
  if (out.air_clipped) notes += "air clipped at the data's floor (a windowed export); ";
  if (std::abs(out.shift_hu) > 50)
    notes += "HU appear shifted by about " + std::string(out.shift_hu > 0 ? "+" : "") +
             std::to_string(static_cast<int>(std::lround(out.shift_hu))) + "; ";
  if (out.dried) notes += "the wood looks dried (one light wood mode); ";
  if (!notes.empty()) notes.resize(notes.size() - 2);
  out.notes = notes;
  return out;
}

ScanLevels pool_levels(const std::vector<ScanLevels>& slices) {
  ScanLevels out;
  std::vector<const ScanLevels*> ok;
  for (const ScanLevels& l : slices)
    if (l.valid) ok.push_back(&l);
  if (ok.empty()) {
    out.notes = slices.empty() ? "no slice" : "no slice looks like a log in air";
    if (!slices.empty() && !slices.front().notes.empty()) out.notes += ": " + slices.front().notes;
    return out;
  }
  auto med = [&](double ScanLevels::*f) {
    std::vector<double> x;
    for (const ScanLevels* l : ok) x.push_back(l->*f);
    return median(x);
  };
  auto vote = [&](bool ScanLevels::*f) {
    size_t k = 0;
    for (const ScanLevels* l : ok) k += l->*f;
    return 2 * k > ok.size();
  };
  out.valid = true;
  out.two_wood_modes = vote(&ScanLevels::two_wood_modes);
  // The wood modes from the slices that agree with the majority on their number.
  std::vector<const ScanLevels*> all = ok;
  ok.clear();
  for (const ScanLevels* l : all)
    if (l->two_wood_modes == out.two_wood_modes) ok.push_back(l);
  out.air_hu = med(&ScanLevels::air_hu);
  out.wood_hu = med(&ScanLevels::wood_hu);
  out.wood_low_hu = med(&ScanLevels::wood_low_hu);
  out.wood_high_hu = med(&ScanLevels::wood_high_hu);
  out.noise_air_hu = med(&ScanLevels::noise_air_hu);
  out.noise_wood_hu = med(&ScanLevels::noise_wood_hu);
  out.texture_wood_hu = med(&ScanLevels::texture_wood_hu);
  out.log_hu = med(&ScanLevels::log_hu);
  out.dense_hu = med(&ScanLevels::dense_hu);
  out.dense_median_hu = med(&ScanLevels::dense_median_hu);
  out.shift_hu = med(&ScanLevels::shift_hu);
  out.wood_over_air_hu = med(&ScanLevels::wood_over_air_hu);
  out.fraction_log = med(&ScanLevels::fraction_log);
  out.dried = vote(&ScanLevels::dried);
  out.air_clipped = vote(&ScanLevels::air_clipped);
  for (const ScanLevels* l : ok)
    if (!l->notes.empty()) {
      out.notes = l->notes;
      break;
    }
  return out;
}

ScanLevels slice_levels_or_scan(const ScanLevels& slice, const ScanLevels& scan) {
  if (!scan.valid) return slice;
  if (!slice.valid || slice.two_wood_modes != scan.two_wood_modes) return scan;
  const double tol = std::max(4.0 * scan.noise_hu(), 0.1 * (scan.wood_hu - scan.air_hu));
  if (std::abs(slice.wood_low_hu - scan.wood_low_hu) > tol ||
      std::abs(slice.wood_high_hu - scan.wood_high_hu) > tol ||
      std::abs(slice.air_hu - scan.air_hu) > tol)
    return scan;
  return slice;
}

std::string describe(const ScanLevels& l) {
  if (!l.valid) return "no levels: " + l.notes;
  char buf[256];
  std::snprintf(buf, sizeof buf, "air %.0f, wood %.0f", l.air_hu, l.wood_hu);
  std::string s = buf;
  if (l.two_wood_modes) {
    std::snprintf(buf, sizeof buf, " (two modes %.0f/%.0f)", l.wood_low_hu, l.wood_high_hu);
    s += buf;
  }
  std::snprintf(buf, sizeof buf, ", noise %.0f HU (air %.0f), log above %.0f, dense above %.0f",
                l.noise_wood_hu, l.noise_air_hu, l.log_hu, l.dense_hu);
  s += buf;
  if (!l.notes.empty()) s += "; " + l.notes;
  return s;
}

}  // namespace sawyer::ct
