// The random log generator: realistic Scots pine (Pinus sylvestris) and Norway spruce (Picea
// abies) saw logs, deterministic by seed.
//
// WHAT IS DRAWN, AND WHERE THE RANGES COME FROM
//
// Every range below is a named constant further down, with its source. "DESIGN" is
// docs/architecture.md section 6 (what log scanners see: logs 3–6 m, 12–45 cm in diameter, 30–120
// knots, pine whorls every 0.3–0.6 m with 3–6 knots). "Gran_1" is the real CT-measured spruce
// log in sample_logs/gran1_spruce (4 m, 108 knots), used as a check on knot geometry: its knots
// have b ≈ 0.1–0.5, a ≈ −0.4–0, |twist| ≲ 0.08 rad per ln mm, r_dead ≈ 40–140 mm; `sawyer info`
// gives it 6.3 % ovality and 3 mm/m taper. The wood science comes from CT studies of Nordic saw
// logs: Moberg 2001 (Forest Ecol. Manage. 147:123–138, internal knot properties of 114 CT-scanned
// Norway spruce: whorl knot diameter, knots per whorl, sound- and loose-knot length, all by
// height in the tree); Björklund & Moberg 1999 (Studia Forestalia Suecica, the same for Scots
// pine from the Swedish Pine Stem Bank); Björklund 1999 (Silva Fennica 33(2), heartwood of 198
// CT-scanned Scots pines); the Norwegian heartwood-profile models for Scots pine (Can. J. For.
// Res. 39(3), 2009: heartwood diameter falls from the butt upwards much like the stem's);
// Tong et al. (Wood Fiber Sci., white spruce: most knots 60–80° from the axis); log grading
// practice (sweep capped at about 1–2 % of the length, e.g. 4 in. over a 16 ft log). They are
// rounded, plausible ranges, not a fitted model.
//
// The log's place in the tree: a butt log (40 %), a middle log (35 %) or a top log (25 %),
// unless options.position says. It sets the height above ground H of every point (butt end at
// H0 = 0.3 m stump height, ~4–6 m for a middle log, ~8–11 m for a top log), and through H the
// state of the knots: branches below the crown base died young (short sound part, a dead part,
// in pine often overgrown), branches near or inside the crown are sound out to the bark.
//
// Stem (all smooth in ω and z; the log spans z ∈ [0, L], butt first):
//   length L        3.0–6.0 m in whole decimetres (DESIGN)
//   top diameter    under bark, ~N(230 / 205 / 175 mm for butt / middle / top logs, 40 mm),
//                   at least 110 mm (a saw log's minimum top), and kept so that the butt
//                   diameter stays within 125–440 mm (inside DESIGN's 120–450 mm)
//   taper           pine 6–10 mm/m, spruce 8–12 mm/m of diameter (Nordic saw logs)
//   stem form       ±2 mm of radius at mid length (slightly convex or concave), whorl swellings
//                   of 0.3–1.5 mm just above each whorl
//   butt flare      butt logs only: +2–7 % of the radius at the butt end, decaying over
//                   100–200 mm (so it is gone by ~0.5 m), with the lobes (buttress) doubled
//   ovality         elliptic term ε = 0.8–3.5 % (1 − min/max diameter ≈ 2ε ≈ 2–7 %), varying
//                   ±30 % and turning by up to ±0.6 rad along the log
//   lobes           Fourier orders 3–6, 0.2–0.8 % of the radius each, phases drifting slowly
//   sweep (bow)     the centre line bends in one direction, sin(πt) + β·sin(2πt) (β ≤ 0.2 moves
//                   the peak off mid length), bow height = 1.5 % · L · u³ (u uniform): most logs
//                   nearly straight (median 0.2 % of L), about one in eight above 1 %
//   tilt            the log lies up to 2 mm/m oblique to the scanner's z axis
//   eccentricity    the pith sits 1–5 % (±20 % along the log) of the radius off the outline's
//                   centre (compression wood side), direction turning by up to ±0.5 rad
//   pith wander     1–4 mm, a sum of three waves of 0.5–3 m wavelength
//   (asked)         with GeneratorOptions::eccentricity_max ≥ 0 the two above give way to the
//                   asked eccentricity: within [min, max] (real piths sit 0–25 % off: wind,
//                   compression wood; Lapland pines average 12 %), changing by
//                   eccentricity_change along the log (a wave of 1.5–6 m wavelength stretched
//                   to span exactly that over the log), direction turning by up to
//                   ±eccentricity_turn_rad; drawn from a stream of its own
//   heartwood       pine: 45–65 % of the radius at the stump, falling 0.8–1.5 % per metre of
//                   height (Scots pine heartwood); spruce: a dry core inside a wet sapwood band
//                   20–40 mm wide (spruce has no coloured heartwood, but CT sees the dry zone);
//                   always within [0, R − 15 mm]
//   bark            pine: 15–30 mm at the stump thinning to 4–8 mm within a few metres (thick
//                   plated butt bark, thin flaky upper bark); spruce: 4–8 mm
//
// Knots (DESIGN section 4: z(r) = z0 + a·√r + b·r, ω(r) = omega0 + twist·ln r):
//   whorls          every 0.3–0.6 m (DESIGN): a per-log mean spacing of 0.33–0.55 m with
//                   ±50 mm year-to-year variation; whorl knots' z0 within ±20 mm of the whorl
//   knots per whorl 3–6 (pine weights 15/35/32/18 %, spruce 20/35/30/15 % for 3/4/5/6), evenly
//                   spread in azimuth with ±20 % jitter, so that neighbours do not overlap at
//                   r = 30 mm (arc gap ≥ the mean of their diameters)
//   interwhorl      spruce only: 0–4 small knots between two whorls, ≥ 80 mm from the whorls and
//                   ≥ 55 mm apart in z0 (fewer when the whorls are close)
//   count           30–120 per log (DESIGN): knots are added to or removed from whorls (and
//                   interwhorl sets) until the count is inside that range
//   branch angle    pine 50–80°, spruce 60–82° from the stem axis (mean slope dz/dr = cot of it,
//                   0.2–0.84 for pine); steeper knots higher in the crown
//   curvature       the √r term carries −25 … +25 % of the rise at the local radius (Gran_1's
//                   knots dip near the pith, a < 0; Tong et al. saw knots rise steeply first)
//   twist           N(0, 0.02) clamped to ±0.05 rad per ln mm
//   diameter d_dead pine whorl 8–40 mm, spruce whorl 8–25 mm, interwhorl 5–12 mm; it grows with
//                   r_dead (a branch that lived longer got thicker: pine 6 + 0.14·r_dead,
//                   spruce 5 + 0.09·r_dead, interwhorl 3.5 + 0.04·r_dead mm, × lognormal 0.2),
//                   so larger knots sit higher, in the crown part of the tree
//   exponent d_exp  0.5–1.2
//   sound / dead    a knot is sound to its end with probability smoothstep(0.55, 1, c), where
//                   c = (H − 1 m) / (crown base − 1 m) clamped to [0, 1] and the crown base is
//                   10–15 m (pine) or 7–12 m (spruce) above ground. Otherwise r_dead =
//                   22–45 mm (pine) / 22–55 mm (spruce) per whorl, ±8 % per knot, plus
//                   c · 30–90 % (±15 %) of the rest of the radius: 20–80 mm on a butt log. A dead
//                   knot was overgrown (ends inside the wood, ≥ 15 mm under the bark) with
//                   probability 0.6·(1 − c)³ (pine, good self-pruning: the knot-free zone of
//                   butt logs) or 0.25·(1 − c)³ (spruce), with a dead stub of 10–40 / 15–50 mm;
//                   otherwise it ends at the bark.
//   r_end           at the bark: where the axis meets the stem's outer surface (solved on the
//                   stored, interpolated stem, so r_end ≤ R(ω(r_end), z(r_end))); a knot whose
//                   axis reaches an end face of the log first ends there.
//
// DETERMINISM AND OUTPUT SIZE
//
// The random numbers are our own (splitmix64 seeding xoshiro256**, uniform doubles from the top
// 53 bits, normals by Marsaglia's polar method); the standard library's distributions are not
// used because their output differs between implementations. Independent streams feed the stem
// and the knots, so a change to one does not reshuffle the other. Besides IEEE-exact arithmetic
// (+ − × ÷ √, round, floor, fmod) the generator uses libm's sin, cos, tan, exp and log, whose
// last bit may differ between libm implementations; the rounding below absorbs that except in
// (vanishingly rare) ties. The seed and the species together make the random key.
//
// Rounding before return, so log.json stays compact (a 4 m log with heartwood ≈ 1.9 MB):
// stem radii, heartwood radii, pith and bark to 0.01 mm; knot lengths (z0, r_dead, r_end,
// d_dead) to 0.001 mm; dimensionless and angular knot parameters (a, b, omega0, twist, d_exp) to
// 1e-6. r_end is solved after the other knot parameters are rounded and rounded down.
#include "sawyer/model/log_generator.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

namespace sawyer {
namespace {

constexpr int kGeneratorVersion = 1;

// ---- Option limits (validate()) ----------------------------------------------------------------
constexpr double kMinLengthOption = 1000.0, kMaxLengthOption = 12000.0;  // explicit length, mm
constexpr double kMinTopOption = 100.0, kMaxTopOption = 420.0;           // explicit top diam., mm
constexpr double kMinDz = 0.5, kMaxDz = 50.0;                            // mm
constexpr int kMinAngles = 8, kMaxAngles = 3600;
constexpr double kMaxStemSamples = 2e7;  // heights × angles (160 MB per grid of doubles)

// ---- Stem ranges -------------------------------------------------------------------------------
// DESIGN section 6: logs 3–6 m; lengths are recorded in whole decimetres.
constexpr double kMinLength = 3000.0, kMaxLength = 6000.0, kLengthStep = 100.0;
// DESIGN section 6: 12–45 cm; we keep 5 mm inside so ovality, lobes and flare stay inside.
constexpr double kMinButtDiameter = 125.0, kMaxButtDiameter = 440.0;
// A usual smallest top diameter (under bark) that sawmills accept as a saw log.
constexpr double kMinTopDiameter = 110.0;
// Top diameter by position in the tree (mean, sd), mm: second and top logs are thinner.
constexpr double kTopDiameterMean[3] = {230.0, 205.0, 175.0}, kTopDiameterSd = 40.0;
// Taper of the diameter, mm per m (the brief's Nordic saw-log ranges; spruce tapers more).
constexpr double kPineTaper[2] = {6.0, 10.0}, kSpruceTaper[2] = {8.0, 12.0};
constexpr double kMaxFormBulge = 2.0;                 // mm of radius at mid length
constexpr double kWhorlSwell[2] = {0.3, 1.5};         // mm of radius
constexpr double kWhorlSwellSigma[2] = {30.0, 60.0};  // mm along z
constexpr double kWhorlSwellOffset = 20.0;            // mm above the whorl
constexpr double kFlare[2] = {0.02, 0.07};            // butt flare, share of the radius
constexpr double kFlareLength[2] = {100.0, 200.0};    // e-folding length, mm
constexpr double kOvality[2] = {0.008, 0.035};        // ε of the elliptic term
constexpr double kOvalityVariation = 0.3;             // ± share along the log
constexpr double kOvalityTurn = 0.6;                  // rad over the log, at most
constexpr double kLobe[2] = {0.002, 0.008};           // orders 3..6, share of R
constexpr double kMaxSweep = 0.015;                   // bow height / length
constexpr double kSweepSkew = 0.2;   // the bow's peak moves up to ~0.13·L off mid length
constexpr double kMaxTilt = 2.0e-3;  // mm per mm
constexpr double kEccentricity[2] = {0.01, 0.05};             // share of the radius
constexpr double kEccentricityVariation = 0.2;                // ± share along the log
constexpr double kEccentricityTurn = 0.5;                     // rad over the log, at most
constexpr double kPithWander[2] = {1.0, 4.0};                 // mm
constexpr double kMaxEccentricityOption = 0.4;                // share of the radius
constexpr double kPithWanderWavelength[2] = {500.0, 3000.0};  // mm
constexpr double kStumpHeight = 0.3;                          // m
constexpr double kMiddleLogStart[2] = {4.0, 5.8};             // m above ground
constexpr double kTopLogStart[2] = {8.3, 11.3};               // m above ground
constexpr double kPositionWeights[3] = {0.40, 0.35, 0.25};    // butt, middle, top
// Heartwood. Pine: share of the radius at the stump, and its fall per metre of height.
constexpr double kPineHeartwoodStump[2] = {0.45, 0.65};
constexpr double kPineHeartwoodFall[2] = {0.008, 0.015};
constexpr double kPineHeartwoodFollow[2] = {0.5, 0.8};  // how much it follows the outline's shape
// Spruce: the wet sapwood band outside the dry core, mm.
constexpr double kSpruceSapwood[2] = {20.0, 40.0};
constexpr double kSapwoodVariation = 0.15;        // ± share along the log
constexpr double kSapwoodAround[2] = {3.0, 2.0};  // mm, orders 1 and 2 around the stem
constexpr double kHeartwoodMargin = 15.0;         // heartwood ≤ R − this
// Bark thickness, mm.
constexpr double kPineBarkStump[2] = {15.0, 30.0}, kPineBarkUpper[2] = {4.0, 8.0};
constexpr double kPineBarkDecay[2] = {1.5, 3.0};  // m
constexpr double kSpruceBark[2] = {4.0, 8.0};

// ---- Knot ranges -------------------------------------------------------------------------------
constexpr double kWhorlSpacingMean[2] = {330.0, 550.0};  // mm, per log
constexpr double kWhorlSpacingSd = 50.0;                 // mm, year to year
constexpr double kWhorlSpacing[2] = {300.0, 600.0};      // DESIGN section 6
constexpr double kWhorlHeightJitter = 10.0;  // mm before centring: z0 within ±20 of the whorl
constexpr double kFirstWhorlMin = 40.0, kLastWhorlMargin = 60.0;  // mm from the ends
constexpr int kMinKnotsPerWhorl = 3, kMaxKnotsPerWhorl = 6;
constexpr double kPineWhorlWeights[4] = {0.15, 0.35, 0.32, 0.18};         // 3, 4, 5, 6 knots
constexpr double kSpruceWhorlWeights[4] = {0.20, 0.35, 0.30, 0.15};       // 3, 4, 5, 6 knots
constexpr double kInterwhorlWeights[5] = {0.15, 0.25, 0.30, 0.20, 0.10};  // 0..4 knots
constexpr double kInterwhorlFromWhorl = 80.0, kInterwhorlSpacing = 55.0;  // mm
constexpr int kMinKnots = 30, kMaxKnots = 120;                            // DESIGN section 6
constexpr double kAzimuthJitter = 0.2;                  // share of the even spacing 2π/n
constexpr double kPineBranchAngle[2] = {50.0, 80.0};    // degrees from the stem axis
constexpr double kSpruceBranchAngle[2] = {60.0, 82.0};  // degrees
// Mean angle of a whorl below the crown (c = 0) and inside it (c = 1): upper branches are
// steeper. Spread of whorl means, and of knots within a whorl.
constexpr double kPineBranchAngleMean[2] = {70.0, 60.0};
constexpr double kSpruceBranchAngleMean[2] = {76.0, 68.0};
constexpr double kWhorlAngleSd = 5.0, kBranchAngleSd = 4.0;  // degrees
constexpr double kCurvature = 0.25;                          // share of the rise in the √r term
constexpr double kTwistSd = 0.02, kMaxTwist = 0.05;          // rad per ln mm
constexpr double kOverlapRadius = 30.0;                      // mm: whorl neighbours checked here
constexpr double kPineWhorlDiameter[2] = {8.0, 40.0};
constexpr double kSpruceWhorlDiameter[2] = {8.0, 25.0};
constexpr double kInterwhorlDiameter[2] = {5.0, 12.0};
// d_dead = a + b·(pith distance the branch grew to while alive), mm: pine whorl, spruce whorl,
// interwhorl.
constexpr double kPineDiameterRule[2] = {6.0, 0.14};
constexpr double kSpruceDiameterRule[2] = {5.0, 0.09};
constexpr double kInterwhorlDiameterRule[2] = {3.5, 0.04};
constexpr double kDiameterSpread = 0.2;  // lognormal σ (whorl and knot share it half and half)
constexpr double kExponent[2] = {0.5, 1.2};
constexpr double kPineCrownBase[2] = {10.0, 15.0};   // m above ground
constexpr double kSpruceCrownBase[2] = {7.0, 12.0};  // m above ground
constexpr double kPineDeadStart[2] = {22.0, 45.0};   // r_dead at the stump (whorl), mm
constexpr double kSpruceDeadStart[2] = {22.0, 55.0};
constexpr double kDeadStartJitter = 0.08;  // ± share, knot to knot in a whorl
// Share of the rest of the radius a branch grew through before dying, at crown position 1
// (scaled by c below it): whorl and (shaded, earlier-dying) interwhorl branches.
constexpr double kDeadShare[2] = {0.3, 0.9}, kInterwhorlDeadShare[2] = {0.2, 0.6};
constexpr double kMinDeadPart = 10.0;  // mm: a shorter dead part counts as sound to the bark
// Chance that a dead knot was overgrown, at the stump; it falls as (1 − c)³ up the tree.
constexpr double kPineOvergrown = 0.6, kSpruceOvergrown = 0.25;
constexpr double kPineStub[2] = {10.0, 40.0}, kSpruceStub[2] = {15.0, 50.0};  // dead part, mm
constexpr double kOvergrownCover = 15.0;  // mm of clear wood over an overgrown knot
constexpr double kBarkEndMargin = 0.05;   // mm: r_end of a knot at the bark, inside the surface

// ---- Random numbers: bit-exact on every machine -----------------------------------------------

std::uint64_t splitmix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// xoshiro256** (Blackman & Vigna), seeded through splitmix64 from (key, stream).
class Rng {
 public:
  Rng(std::uint64_t key, std::uint64_t stream) {
    std::uint64_t x = key ^ (stream * 0xD1B54A32D192ED03ULL);
    for (auto& w : s_) w = splitmix64(x);
  }
  std::uint64_t next() {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  // Uniform in [0, 1), exact: the top 53 bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double uniform(const double (&range)[2]) { return uniform(range[0], range[1]); }
  double angle() { return kTwoPi * uniform(); }
  bool chance(double p) { return uniform() < p; }
  // Standard normal (Marsaglia's polar method).
  double normal() {
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    return u * std::sqrt(-2.0 * std::log(s) / s);
  }
  // Normal(mean, sd) inside [lo, hi]: redrawn a few times, then clamped.
  double normal(double mean, double sd, double lo, double hi) {
    for (int i = 0; i < 16; ++i) {
      const double x = mean + sd * normal();
      if (x >= lo && x <= hi) return x;
    }
    return std::clamp(mean, lo, hi);
  }
  // Index drawn with the given weights (they sum to 1).
  template <size_t N>
  int pick(const double (&weights)[N]) {
    double u = uniform();
    for (size_t i = 0; i + 1 < N; ++i) {
      if (u < weights[i]) return static_cast<int>(i);
      u -= weights[i];
    }
    return static_cast<int>(N - 1);
  }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::array<std::uint64_t, 4> s_{};
};

// Streams: one per part of the model, so that the parts do not reshuffle each other.
enum Stream : std::uint64_t {
  kStreamLog = 1,
  kStreamShape,
  kStreamWhorls,
  kStreamKnots,
  kStreamWood,
  kStreamEccentricity  // only for an asked eccentricity (the default log never draws from it)
};

// ---- Helpers -----------------------------------------------------------------------------------

// Rounds to a decimal quantum 10^-digits so that the shortest decimal form is short.
// (The quotient of an integer-valued double by 10^d is the double nearest to the decimal.)
template <int Digits>
double round_decimals(double x) {
  constexpr double kScale = Digits == 2 ? 1e2 : Digits == 3 ? 1e3 : 1e6;
  static_assert(Digits == 2 || Digits == 3 || Digits == 6);
  return std::round(x * kScale) / kScale;
}
double floor_milli(double x) { return std::floor(x * 1e3) / 1e3; }
double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}
double deg(double d) { return d * kPi / 180.0; }

// A smooth random function of z with values in [−1, 1]: three cosines of random wavelength.
struct Wave {
  std::array<double, 3> weight{}, k{}, phase{};
  static Wave draw(Rng& rng, double lambda_min, double lambda_max) {
    Wave w;
    double sum = 0;
    for (int i = 0; i < 3; ++i) {
      w.weight[i] = rng.uniform(0.3, 1.0);
      w.k[i] = kTwoPi / rng.uniform(lambda_min, lambda_max);
      w.phase[i] = rng.angle();
      sum += w.weight[i];
    }
    for (double& x : w.weight) x /= sum;
    return w;
  }
  double at(double z) const {
    double v = 0;
    for (int i = 0; i < 3; ++i) v += weight[i] * std::cos(k[i] * z + phase[i]);
    return v;
  }
};

const char* position_label(LogPosition p) {
  switch (p) {
    case LogPosition::kButt:
      return "butt log";
    case LogPosition::kMiddle:
      return "middle log";
    case LogPosition::kTop:
      return "top log";
    case LogPosition::kDrawn:
      break;
  }
  return "log";
}

// ---- The log's overall draw --------------------------------------------------------------------

struct LogPlan {
  Species species = Species::kSpruce;
  LogPosition position = LogPosition::kButt;
  double length = 0;                   // mm
  int n = 0;                           // stem samples
  double dz = 10;                      // mm
  double h0 = 0;                       // height above ground of z = 0, m
  double crown_base = 0;               // m above ground
  double taper = 0;                    // mm of diameter per mm of length
  double r_top = 0;                    // mean radius at z = L (before flare, form, swellings), mm
  double flare = 0, flare_length = 1;  // butt flare share of the radius, e-folding length
  std::vector<double> whorls;          // whorl heights z, mm

  bool is_pine() const { return species == Species::kPine; }
  // Crown position c in [0, 1] at log height z: 0 far below the crown base, 1 inside the crown.
  double crown(double z) const {
    const double h = h0 + z * 1e-3;
    return std::clamp((h - 1.0) / (crown_base - 1.0), 0.0, 1.0);
  }
};

LogPlan plan_log(const GeneratorOptions& o, std::uint64_t key) {
  Rng rng(key, kStreamLog);
  LogPlan p;
  p.species = o.species;
  p.dz = o.dz_mm;
  const bool pine = p.is_pine();

  p.position = o.position;
  const int drawn_position = rng.pick(kPositionWeights);  // always drawn: keeps the stream fixed
  if (p.position == LogPosition::kDrawn) p.position = static_cast<LogPosition>(1 + drawn_position);
  const int pos_index = static_cast<int>(p.position) - 1;
  const double start_middle = rng.uniform(kMiddleLogStart);
  const double start_top = rng.uniform(kTopLogStart);
  p.h0 = p.position == LogPosition::kButt     ? kStumpHeight
         : p.position == LogPosition::kMiddle ? start_middle
                                              : start_top;
  p.crown_base = rng.uniform(pine ? kPineCrownBase : kSpruceCrownBase);

  const double drawn_length =
      kMinLength +
      kLengthStep * std::floor(rng.uniform() * ((kMaxLength - kMinLength) / kLengthStep + 1));
  const double length = o.length_mm > 0 ? o.length_mm : drawn_length;
  p.n = std::max(1, static_cast<int>(std::lround(length / p.dz)));
  p.length = p.n * p.dz;
  const double length_m = p.length * 1e-3;

  double taper_mm_per_m = rng.uniform(pine ? kPineTaper : kSpruceTaper);
  const double flare = rng.uniform(kFlare);
  p.flare_length = rng.uniform(kFlareLength);
  p.flare = p.position == LogPosition::kButt ? flare : 0.0;
  // The butt diameter over its first 100 mm ≈ (top + taper·L)·(1 + 0.8·flare).
  const double butt_max = kMaxButtDiameter / (1.0 + 0.8 * p.flare);
  const double drawn_top = [&] {
    const double lo = std::max(kMinTopDiameter, kMinButtDiameter - taper_mm_per_m * length_m);
    const double hi = butt_max - taper_mm_per_m * length_m;
    return rng.normal(kTopDiameterMean[pos_index], kTopDiameterSd, lo, std::max(lo, hi));
  }();
  double top = drawn_top;
  if (o.top_diameter_mm > 0) {
    top = o.top_diameter_mm;
    // A given top diameter keeps the butt within range by tapering less.
    taper_mm_per_m = std::clamp((butt_max - top) / length_m, 0.0, taper_mm_per_m);
  }
  p.taper = taper_mm_per_m * 1e-3;
  p.r_top = 0.5 * top;

  // Whorl heights: a per-log mean spacing with year-to-year variation. A short log with long
  // spacings could not hold 30 knots; its spacing is drawn again, shorter.
  Rng wr(key, kStreamWhorls);
  double mean_spacing = wr.uniform(kWhorlSpacingMean);
  const int min_whorls = (kMinKnots + kMaxKnotsPerWhorl - 1) / kMaxKnotsPerWhorl + 1;
  for (int attempt = 0; attempt < 32; ++attempt) {
    p.whorls.clear();
    double z = wr.uniform(kFirstWhorlMin, kFirstWhorlMin + mean_spacing);
    while (z <= p.length - kLastWhorlMargin) {
      p.whorls.push_back(z);
      z += wr.normal(mean_spacing, kWhorlSpacingSd, kWhorlSpacing[0], kWhorlSpacing[1]);
    }
    if (static_cast<int>(p.whorls.size()) >= min_whorls) break;
    mean_spacing = std::max(kWhorlSpacing[0], 0.92 * mean_spacing);
  }
  return p;
}

// ---- Stem --------------------------------------------------------------------------------------

struct Lobe {
  int order = 3;
  double amp = 0, phase = 0, drift = 0;
  Wave wave;
};

// The outline's coefficients at one height: mean radius, and the Fourier terms of orders 2
// (ellipse) to 6 (lobes) as cosine and sine weights, so that the outline costs no libm call:
// ρ(θ) = r0·(1 + Σ_k cw[k]·cos kθ + sw[k]·sin kθ).
struct Section {
  double r0 = 0;
  std::array<double, 7> cw{}, sw{};  // index = order; 0 and 1 unused
};

// The random shape of the stem: outline around its centre line, and the pith's offset from it.
struct StemShape {
  const LogPlan* plan = nullptr;
  double bulge = 0;
  std::vector<std::array<double, 3>> swells;  // z, amplitude, sigma
  double ovality = 0;
  Wave ovality_wave, turn_wave;
  double ovality_angle = 0, ovality_turn = 0;
  std::array<Lobe, 4> lobes;
  double sweep = 0, sweep_angle = 0, sweep_skew = 0, sweep_norm = 1;
  Vec2 tilt;
  double ecc = 0, ecc_angle = 0, ecc_turn = 0;
  Wave ecc_wave;
  double wander = 0;
  Wave wander_x, wander_y;
  // An asked eccentricity (GeneratorOptions::eccentricity_max >= 0) replaces the two above.
  bool asked = false;
  double asked_lo = 0, asked_hi = 0;  // the log's stretch of the asked range, share of r0
  double asked_angle = 0, asked_turn = 0;
  Wave asked_wave;
  double asked_wave_lo = -1, asked_wave_hi = 1;  // the wave's extremes over the log

  static StemShape draw(const LogPlan& p, std::uint64_t key) {
    Rng rng(key, kStreamShape);
    StemShape s;
    s.plan = &p;
    const double L = p.length;
    s.bulge = rng.uniform(-kMaxFormBulge, kMaxFormBulge);
    for (double zw : p.whorls)
      s.swells.push_back(
          {zw + kWhorlSwellOffset, rng.uniform(kWhorlSwell), rng.uniform(kWhorlSwellSigma)});
    s.ovality = rng.uniform(kOvality);
    s.ovality_wave = Wave::draw(rng, 1500.0, 6000.0);
    s.ovality_angle = rng.angle();
    s.ovality_turn = rng.uniform(-kOvalityTurn, kOvalityTurn);
    s.turn_wave = Wave::draw(rng, 1000.0, 4000.0);
    for (int i = 0; i < 4; ++i) {
      Lobe& l = s.lobes[i];
      l.order = 3 + i;
      l.amp = rng.uniform(kLobe);
      l.phase = rng.angle();
      l.drift = rng.uniform(-1.0, 1.0) * kPi / l.order;
      l.wave = Wave::draw(rng, 1000.0, 5000.0);
    }
    const double u = rng.uniform();
    s.sweep = kMaxSweep * u * u * u * L;
    s.sweep_angle = rng.angle();
    // Bow shape sin(πt) + β·sin(2πt): β moves the peak off mid length; scaled to peak 1.
    s.sweep_skew = rng.uniform(-kSweepSkew, kSweepSkew);
    double peak = 0;
    for (int i = 0; i <= 200; ++i) peak = std::max(peak, s.bow_shape(i / 200.0));
    s.sweep_norm = 1.0 / peak;
    const double tilt = rng.uniform(0.0, kMaxTilt), tilt_angle = rng.angle();
    s.tilt = {tilt * std::cos(tilt_angle), tilt * std::sin(tilt_angle)};
    s.ecc = rng.uniform(kEccentricity);
    s.ecc_angle = rng.angle();
    s.ecc_turn = rng.uniform(-kEccentricityTurn, kEccentricityTurn);
    s.ecc_wave = Wave::draw(rng, 1500.0, 6000.0);
    s.wander = rng.uniform(kPithWander);
    s.wander_x = Wave::draw(rng, kPithWanderWavelength[0], kPithWanderWavelength[1]);
    s.wander_y = Wave::draw(rng, kPithWanderWavelength[0], kPithWanderWavelength[1]);
    return s;
  }

  // The asked eccentricity: its own stream, so nothing else of the log changes.
  void ask_eccentricity(const GeneratorOptions& o, std::uint64_t key) {
    Rng rng(key, kStreamEccentricity);
    asked = true;
    const double change = std::min(o.eccentricity_change, o.eccentricity_max - o.eccentricity_min);
    asked_lo =
        o.eccentricity_min + rng.uniform() * (o.eccentricity_max - o.eccentricity_min - change);
    asked_hi = asked_lo + change;
    asked_angle = rng.angle();
    asked_turn = rng.uniform(-o.eccentricity_turn_rad, o.eccentricity_turn_rad);
    asked_wave = Wave::draw(rng, 1500.0, 6000.0);
    // Stretched so that the eccentricity spans [asked_lo, asked_hi] over the log exactly (at
    // the stem's sample heights), whatever part of the wave the log holds.
    asked_wave_lo = 1, asked_wave_hi = -1;
    for (int i = 0; i < plan->n; ++i) {
      const double w = asked_wave.at((i + 0.5) * plan->dz);
      asked_wave_lo = std::min(asked_wave_lo, w);
      asked_wave_hi = std::max(asked_wave_hi, w);
    }
  }

  double flare_weight(double z) const {
    return plan->flare > 0 ? std::exp(-z / plan->flare_length) : 0.0;
  }
  // Mean radius at height z (taper, form, flare, whorl swellings).
  double mean_radius(double z) const {
    const LogPlan& p = *plan;
    const double t = z / p.length;
    double r = p.r_top + 0.5 * p.taper * (p.length - z) + 4.0 * bulge * t * (1.0 - t);
    r *= 1.0 + p.flare * flare_weight(z);
    for (const auto& w : swells) {
      const double d = (z - w[0]) / w[2];
      r += w[1] * std::exp(-0.5 * d * d);
    }
    return r;
  }
  Section section(double z) const {
    Section s;
    const double t = z / plan->length;
    s.r0 = mean_radius(z);
    // amp·cos(k(θ − φ)) = amp·cos kφ·cos kθ + amp·sin kφ·sin kθ
    auto add = [&](int k, double amp, double phi) {
      s.cw[k] += amp * std::cos(k * phi);
      s.sw[k] += amp * std::sin(k * phi);
    };
    add(2, ovality * (1.0 + kOvalityVariation * ovality_wave.at(z)),
        ovality_angle + ovality_turn * (t - 0.5) + 0.15 * turn_wave.at(z));
    const double buttress = 1.0 + 2.0 * flare_weight(z);
    for (const Lobe& l : lobes)
      add(l.order, l.amp * (1.0 + 0.5 * l.wave.at(z)) * buttress, l.phase + l.drift * t);
    return s;
  }
  // Outline radius around the centre line in the direction (c1, s1) = (cos θ, sin θ).
  static double outline(double c1, double s1, const Section& s) {
    double f = 1.0, ck = c1, sk = s1;
    for (int k = 2; k <= 6; ++k) {
      const double cn = ck * c1 - sk * s1, sn = sk * c1 + ck * s1;  // cos kθ, sin kθ
      ck = cn;
      sk = sn;
      f += s.cw[k] * ck + s.sw[k] * sk;
    }
    return s.r0 * f;
  }
  double bow_shape(double t) const { return std::sin(kPi * t) + sweep_skew * std::sin(kTwoPi * t); }
  // Centre line of the outline, scanner frame.
  Vec2 centre(double z) const {
    const double L = plan->length;
    const double t = std::clamp(z / L, 0.0, 1.0);
    const double bow = sweep * sweep_norm * bow_shape(t);
    return (z - 0.5 * L) * tilt + bow * Vec2{std::cos(sweep_angle), std::sin(sweep_angle)};
  }
  // Pith offset from the centre line: eccentricity plus wander, or the asked eccentricity.
  Vec2 pith_offset(double z, double r0) const {
    const double t = z / plan->length;
    if (asked) {
      const double span = asked_wave_hi - asked_wave_lo;
      const double u = span > 1e-12 ? (asked_wave.at(z) - asked_wave_lo) / span : 0.5;
      const double e = (asked_lo + (asked_hi - asked_lo) * std::clamp(u, 0.0, 1.0)) * r0;
      const double a = asked_angle + asked_turn * (t - 0.5);
      return Vec2{e * std::cos(a), e * std::sin(a)};
    }
    const double e = ecc * (1.0 + kEccentricityVariation * ecc_wave.at(z)) * r0;
    const double a = ecc_angle + ecc_turn * (t - 0.5);
    return Vec2{e * std::cos(a), e * std::sin(a)} + wander * Vec2{wander_x.at(z), wander_y.at(z)};
  }
};

// Radii from the pith p along the unit directions (ux[k], uy[k]) to the outline: solves
// |p + t·u| = ρ(θ) with θ the direction of p + t·u from the centre. Starts from the circle ρ = r0
// and iterates on θ; three steps agree with twelve to well under the 0.01 mm output rounding
// for the drawn eccentricity (≤ 6 %). The error shrinks about as fast as the eccentricity
// times the outline's own slope, so an asked eccentricity of up to 40 % takes six.
// (Steps outside, angles inside: the inner loop has independent iterations and vectorises.)
void radii_from_pith(const Section& sec, Vec2 p, const std::vector<double>& ux,
                     const std::vector<double>& uy, std::vector<double>& t, int steps) {
  const size_t n = ux.size();
  t.resize(n);
  std::vector<double> q(n), pu(n);
  for (size_t k = 0; k < n; ++k) {
    pu[k] = p.x * ux[k] + p.y * uy[k];
    q[k] = pu[k] * pu[k] - (p.x * p.x + p.y * p.y);
    t[k] = -pu[k] + std::sqrt(std::max(0.0, q[k] + sec.r0 * sec.r0));
  }
  for (int it = 0; it < steps; ++it)
    for (size_t k = 0; k < n; ++k) {
      const double x = p.x + t[k] * ux[k], y = p.y + t[k] * uy[k];
      const double inv = 1.0 / std::sqrt(x * x + y * y);
      const double rho = StemShape::outline(x * inv, y * inv, sec);
      t[k] = -pu[k] + std::sqrt(std::max(0.0, q[k] + rho * rho));
    }
}

struct WoodShape {
  // Pine heartwood.
  double stump_share = 0, fall = 0, follow = 0;
  // Spruce sapwood band.
  double sapwood = 0;
  Wave band_wave;
  double band_amp1 = 0, band_phase1 = 0, band_amp2 = 0, band_phase2 = 0;
  // Bark.
  double bark_stump = 0, bark_upper = 0, bark_decay = 1, spruce_bark = 0;

  static WoodShape draw(std::uint64_t key) {
    Rng rng(key, kStreamWood);
    WoodShape w;
    w.stump_share = rng.uniform(kPineHeartwoodStump);
    w.fall = rng.uniform(kPineHeartwoodFall);
    w.follow = rng.uniform(kPineHeartwoodFollow);
    w.sapwood = rng.uniform(kSpruceSapwood);
    w.band_wave = Wave::draw(rng, 1000.0, 4000.0);
    w.band_amp1 = rng.uniform(0.0, kSapwoodAround[0]);
    w.band_phase1 = rng.angle();
    w.band_amp2 = rng.uniform(0.0, kSapwoodAround[1]);
    w.band_phase2 = rng.angle();
    w.bark_stump = rng.uniform(kPineBarkStump);
    w.bark_upper = rng.uniform(kPineBarkUpper);
    w.bark_decay = rng.uniform(kPineBarkDecay);
    w.spruce_bark = rng.uniform(kSpruceBark);
    return w;
  }
};

Stem build_stem(const LogPlan& p, const StemShape& shape, const WoodShape& wood,
                const GeneratorOptions& o) {
  Stem s;
  s.dz_mm = p.dz;
  s.z0_mm = 0.5 * p.dz;
  s.n_angles = o.n_angles;
  const int na = o.n_angles;
  std::vector<double> cos_w(na), sin_w(na);
  for (int k = 0; k < na; ++k) {
    const double w = kTwoPi * k / na;
    cos_w[k] = std::cos(w);
    sin_w[k] = std::sin(w);
  }
  // The spruce sapwood band's variation around the stem (orders 1 and 2), mm.
  std::vector<double> band_shape(na);
  for (int k = 0; k < na; ++k) {
    const double w = kTwoPi * k / na;
    band_shape[k] = wood.band_amp1 * std::cos(w - wood.band_phase1) +
                    wood.band_amp2 * std::cos(2.0 * (w - wood.band_phase2));
  }
  for (int i = 0; i < p.n; ++i) {
    const double z = s.z_at(i);
    const Section sec = shape.section(z);
    const Vec2 off = shape.pith_offset(z, sec.r0);
    const Vec2 pith = shape.centre(z) + off;
    s.pith.push_back({round_decimals<2>(pith.x), round_decimals<2>(pith.y)});
    std::vector<double> row;
    radii_from_pith(sec, off, cos_w, sin_w, row, shape.asked ? 6 : 3);
    double mean = 0;
    for (double r : row) mean += r / na;
    for (double& r : row) r = round_decimals<2>(r);
    if (o.heartwood) {
      std::vector<double> h(na);
      const double height = p.h0 + z * 1e-3;
      const double share = std::max(0.2, wood.stump_share - wood.fall * height);
      const double band = wood.sapwood * (1.0 + kSapwoodVariation * wood.band_wave.at(z));
      for (int k = 0; k < na; ++k) {
        double v;
        if (p.is_pine()) {
          v = share * (mean + wood.follow * (row[k] - mean));
        } else {
          v = row[k] - band - band_shape[k];
        }
        h[k] =
            round_decimals<2>(std::min(std::max(v, 0.0), std::max(0.0, row[k] - kHeartwoodMargin)));
      }
      s.heartwood.push_back(std::move(h));
    }
    if (o.bark) {
      const double height = p.h0 + z * 1e-3;
      const double b = p.is_pine() ? wood.bark_upper + (wood.bark_stump - wood.bark_upper) *
                                                           std::exp(-height / wood.bark_decay)
                                   : std::max(3.0, wood.spruce_bark * (1.0 - 0.02 * height));
      s.bark_mm.push_back(round_decimals<2>(b));
    }
    s.radius.push_back(std::move(row));
  }
  return s;
}

// ---- Knots -------------------------------------------------------------------------------------

enum class KnotKind { kWhorl, kInterwhorl };

struct KnotDraft {
  Knot knot;
  KnotKind kind = KnotKind::kWhorl;
  double omega30 = 0;  // azimuth at r = 30 mm
};

// Pith distance where the knot's axis leaves the stem (bark) or reaches an end face, whichever
// comes first; *at_bark says which.
double knot_exit(const Knot& k, const Stem& stem, double rmax, bool* at_bark) {
  const double zlo = stem.z_begin(), zhi = stem.z_end();
  auto outside = [&](double r) {
    const double z = k.height_at(r);
    if (z <= zlo || z >= zhi) return 2;
    return stem.radius_at(k.azimuth_at(r), z) < r ? 1 : 0;
  };
  double lo = 1.0, hi = lo;
  int why = 0;
  for (double r = 2.0; r <= rmax + 2.0; r += 2.0) {
    why = outside(r);
    if (why) {
      hi = r;
      break;
    }
    lo = r;
  }
  if (!why) {
    *at_bark = true;
    return lo;
  }
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    const int w = outside(mid);
    if (w) {
      hi = mid;
      why = w;
    } else {
      lo = mid;
    }
  }
  *at_bark = why == 1;
  return lo;
}

// True when the two knots' axes stay at least the mean of their diameters apart from r = 30 mm
// out to where the shorter one ends (compared at equal pith distance).
bool knots_clear(const Knot& a, const Knot& b, const Stem& stem) {
  const double rmax = std::min(a.r_end, b.r_end);
  for (double r = kOverlapRadius; r <= rmax; r += 5.0) {
    const double need = 0.5 * (a.diameter_at(r) + b.diameter_at(r));
    if ((a.axis_point(r, stem) - b.axis_point(r, stem)).norm() < need) return false;
  }
  return true;
}

// The whorl / interwhorl layout: how many knots at which heights.
struct KnotLayout {
  std::vector<int> per_whorl;                // knots in each whorl
  std::vector<std::vector<double>> between;  // interwhorl knot heights after each whorl
};

KnotLayout plan_counts(const LogPlan& p, Rng& rng) {
  KnotLayout lay;
  const size_t nw = p.whorls.size();
  for (size_t w = 0; w < nw; ++w)
    lay.per_whorl.push_back(kMinKnotsPerWhorl +
                            rng.pick(p.is_pine() ? kPineWhorlWeights : kSpruceWhorlWeights));
  lay.between.assign(nw, {});
  std::vector<int> capacity(nw, 0);
  std::vector<int> wanted(nw, 0);
  if (!p.is_pine()) {
    for (size_t w = 0; w + 1 < nw; ++w) {
      const double room = p.whorls[w + 1] - p.whorls[w] - 2.0 * kInterwhorlFromWhorl;
      capacity[w] = room < 0 ? 0 : std::min(4, 1 + static_cast<int>(room / kInterwhorlSpacing));
      wanted[w] = std::min(capacity[w], rng.pick(kInterwhorlWeights));
    }
  }
  // Keep the total within [kMinKnots, kMaxKnots]: grow or shrink whorls and interwhorl sets.
  auto total = [&] {
    int t = 0;
    for (size_t w = 0; w < nw; ++w) t += lay.per_whorl[w] + wanted[w];
    return t;
  };
  for (int guard = 0; guard < 10000 && total() < kMinKnots; ++guard) {
    const size_t w = static_cast<size_t>(rng.uniform() * nw);
    if (!p.is_pine() && wanted[w] < capacity[w] && rng.chance(0.5))
      ++wanted[w];
    else if (lay.per_whorl[w] < kMaxKnotsPerWhorl)
      ++lay.per_whorl[w];
  }
  for (int guard = 0; guard < 10000 && total() > kMaxKnots; ++guard) {
    const size_t w = static_cast<size_t>(rng.uniform() * nw);
    if (wanted[w] > 0)
      --wanted[w];
    else if (lay.per_whorl[w] > kMinKnotsPerWhorl && rng.chance(0.3))
      --lay.per_whorl[w];
  }
  // Interwhorl heights: `wanted` points at least kInterwhorlSpacing apart in the gap.
  for (size_t w = 0; w + 1 < nw; ++w) {
    const int m = wanted[w];
    if (m == 0) continue;
    const double lo = p.whorls[w] + kInterwhorlFromWhorl;
    const double hi = p.whorls[w + 1] - kInterwhorlFromWhorl;
    const double slack = std::max(0.0, (hi - lo) - (m - 1) * kInterwhorlSpacing);
    std::vector<double> u(m);
    for (double& x : u) x = rng.uniform() * slack;
    std::sort(u.begin(), u.end());
    for (int j = 0; j < m; ++j) lay.between[w].push_back(lo + u[j] + j * kInterwhorlSpacing);
  }
  return lay;
}

// The knot's geometry: z0, a, b, omega0, twist (rounded), from a mean slope and a curvature.
Knot knot_geometry(double z0, double omega30, double angle_deg, double r_ref, Rng& rng) {
  Knot k;
  const double slope = 1.0 / std::tan(deg(angle_deg));
  const double c = rng.uniform(-kCurvature, kCurvature);
  k.z0 = round_decimals<3>(z0);
  k.a = round_decimals<6>(c * slope * std::sqrt(r_ref));
  k.b = round_decimals<6>(slope * (1.0 - c));
  k.twist = round_decimals<6>(std::clamp(kTwistSd * rng.normal(), -kMaxTwist, kMaxTwist));
  k.omega0 = round_decimals<6>(wrap_angle(omega30 - k.twist * std::log(kOverlapRadius)));
  if (k.omega0 >= kTwoPi) k.omega0 = 0.0;
  return k;
}

struct DeathDraw {
  double start = 0;  // r_dead at the stump, mm
  double share = 0;  // share of the rest of the radius, at crown position 1
};

// Sound/dead border and end of a knot, and its diameter profile.
void knot_state(Knot& k, KnotKind kind, const LogPlan& p, const Stem& stem, double rmax,
                const DeathDraw& death, double size_factor, Rng& rng) {
  const bool pine = p.is_pine();
  bool at_bark = true;
  const double exit = knot_exit(k, stem, rmax, &at_bark);
  // The branch's own life: sound or dead, and how far it grew (independent of an end-face cut).
  const double bark_r = at_bark ? exit : stem.radius_at(k.azimuth_at(exit), k.height_at(exit));
  const double c = p.crown(k.z0);
  const double jitter = rng.uniform(0.85, 1.15);
  const double start = death.start * rng.uniform(1.0 - kDeadStartJitter, 1.0 + kDeadStartJitter);
  const bool sound = rng.chance(smoothstep(0.55, 1.0, c));
  const double over_p =
      (pine ? kPineOvergrown : kSpruceOvergrown) * (1.0 - c) * (1.0 - c) * (1.0 - c);
  const bool overgrown = rng.chance(over_p);
  const double stub = rng.uniform(pine ? kPineStub : kSpruceStub);
  const double r_dead = start + c * death.share * jitter * std::max(0.0, bark_r - start);
  double r_end = exit - kBarkEndMargin;
  const bool is_sound = sound || r_dead > bark_r - kMinDeadPart;
  if (!is_sound && overgrown && r_dead + stub <= bark_r - kOvergrownCover)
    r_end = std::min(r_end, r_dead + stub);
  // Diameter at the sound/dead border: a longer-lived branch is thicker.
  const double grow_r = is_sound ? bark_r : r_dead;
  const bool inter = kind == KnotKind::kInterwhorl;
  const double(&rule)[2] = inter  ? kInterwhorlDiameterRule
                           : pine ? kPineDiameterRule
                                  : kSpruceDiameterRule;
  const double(&range)[2] = inter  ? kInterwhorlDiameter
                            : pine ? kPineWhorlDiameter
                                   : kSpruceWhorlDiameter;
  double d = rule[0] + rule[1] * grow_r;
  d *= size_factor * std::exp(0.5 * kDiameterSpread * rng.normal());
  k.diameter.d_dead = round_decimals<3>(std::clamp(d, range[0], range[1]));
  k.diameter.exponent = round_decimals<6>(rng.uniform(kExponent));
  k.r_end = floor_milli(std::max(r_end, 1.0));
  k.r_dead = is_sound ? k.r_end : round_decimals<3>(std::min(r_dead, k.r_end));
}

// Shrinks the d_dead of whorl neighbours that would overlap at r = 30 mm (rare: large knots in
// a 6-knot whorl).
void separate_whorl(std::vector<KnotDraft*>& whorl, const Stem& stem, double d_min) {
  std::sort(whorl.begin(), whorl.end(),
            [](const KnotDraft* a, const KnotDraft* b) { return a->omega30 < b->omega30; });
  const size_t n = whorl.size();
  for (int pass = 0; pass < 40; ++pass) {
    bool changed = false;
    for (size_t i = 0; i < n; ++i) {
      Knot& a = whorl[i]->knot;
      Knot& b = whorl[(i + 1) % n]->knot;
      double gap = whorl[(i + 1) % n]->omega30 - whorl[i]->omega30;
      if (i + 1 == n) gap += kTwoPi;
      const double need = 0.5 * (a.diameter_at(kOverlapRadius) + b.diameter_at(kOverlapRadius));
      if (kOverlapRadius * gap >= need + 0.5 && knots_clear(a, b, stem)) continue;
      for (Knot* k : {&a, &b})
        k->diameter.d_dead = round_decimals<3>(std::max(d_min, 0.92 * k->diameter.d_dead));
      changed = true;
    }
    if (!changed) break;
  }
}

std::vector<Knot> build_knots(const LogPlan& p, const StemShape& shape, const Stem& stem,
                              std::uint64_t key) {
  Rng rng(key, kStreamKnots);
  const bool pine = p.is_pine();
  const KnotLayout lay = plan_counts(p, rng);
  const double(&angles)[2] = pine ? kPineBranchAngle : kSpruceBranchAngle;
  std::vector<KnotDraft> drafts;
  double rmax = 0;
  for (const auto& row : stem.radius)
    for (double r : row) rmax = std::max(rmax, r);

  for (size_t w = 0; w < p.whorls.size(); ++w) {
    const int n = lay.per_whorl[w];
    const double zc = p.whorls[w];
    const double c = p.crown(zc);
    // Branches high in the crown are steeper (smaller angle to the stem axis).
    const double(&mean_by_crown)[2] = pine ? kPineBranchAngleMean : kSpruceBranchAngleMean;
    const double angle_mean =
        rng.normal(mean_by_crown[0] + c * (mean_by_crown[1] - mean_by_crown[0]), kWhorlAngleSd,
                   angles[0], angles[1]);
    const double base = rng.angle();
    DeathDraw death;
    death.start = rng.uniform(pine ? kPineDeadStart : kSpruceDeadStart);
    death.share = rng.uniform(kDeadShare);
    const double whorl_size = std::exp(0.5 * kDiameterSpread * rng.normal());
    std::vector<double> dz(n);
    double mean_dz = 0;
    for (double& x : dz) {
      x = std::clamp(kWhorlHeightJitter * 0.5 * rng.normal(), -kWhorlHeightJitter,
                     kWhorlHeightJitter);
      mean_dz += x / n;
    }
    const size_t first = drafts.size();
    for (int i = 0; i < n; ++i) {
      KnotDraft kd;
      kd.kind = KnotKind::kWhorl;
      const double step = kTwoPi / n;
      kd.omega30 =
          wrap_angle(base + i * step + rng.uniform(-kAzimuthJitter, kAzimuthJitter) * step);
      const double angle =
          std::clamp(angle_mean + kBranchAngleSd * rng.normal(), angles[0], angles[1]);
      const double z0 = zc + dz[i] - mean_dz;
      kd.knot = knot_geometry(z0, kd.omega30, angle, shape.mean_radius(z0), rng);
      knot_state(kd.knot, kd.kind, p, stem, rmax, death, whorl_size, rng);
      drafts.push_back(kd);
    }
    std::vector<KnotDraft*> members;
    for (size_t i = first; i < drafts.size(); ++i) members.push_back(&drafts[i]);
    separate_whorl(members, stem, pine ? kPineWhorlDiameter[0] : kSpruceWhorlDiameter[0]);
  }

  // Interwhorl knots (spruce): random azimuth, clear of the knots around them.
  for (size_t w = 0; w < lay.between.size(); ++w) {
    for (double z0 : lay.between[w]) {
      DeathDraw death;
      death.start = rng.uniform(kSpruceDeadStart);
      death.share = rng.uniform(kInterwhorlDeadShare);
      const double angle = rng.uniform(angles);
      for (int attempt = 0; attempt < 24; ++attempt) {
        KnotDraft kd;
        kd.kind = KnotKind::kInterwhorl;
        kd.omega30 = rng.angle();
        kd.knot = knot_geometry(z0, kd.omega30, angle, shape.mean_radius(z0), rng);
        knot_state(kd.knot, kd.kind, p, stem, rmax, death, 1.0, rng);
        bool clear = true;
        for (size_t j = 0; j < drafts.size() && clear; ++j)
          if (std::abs(drafts[j].knot.z0 - z0) < 600.0)
            clear = knots_clear(kd.knot, drafts[j].knot, stem);
        if (clear) {
          drafts.push_back(kd);
          break;
        }
      }
    }
  }

  std::vector<Knot> knots;
  for (const KnotDraft& kd : drafts) knots.push_back(kd.knot);
  std::stable_sort(knots.begin(), knots.end(), [](const Knot& a, const Knot& b) {
    return a.z0 != b.z0 ? a.z0 < b.z0 : a.omega0 < b.omega0;
  });
  for (size_t i = 0; i < knots.size(); ++i) knots[i].id = static_cast<int>(i);
  return knots;
}

std::string describe(const GeneratorOptions& o, const LogPlan& p) {
  std::ostringstream os;
  os << "sawyer generate --species " << species_name(o.species) << " --seed " << o.seed;
  if (o.length_mm > 0) os << " --length-m " << o.length_mm * 1e-3;
  if (o.top_diameter_mm > 0) os << " --top-diameter-mm " << o.top_diameter_mm;
  if (o.position != LogPosition::kDrawn) os << " --position " << log_position_name(o.position);
  const GeneratorOptions d;
  if (o.eccentricity_max >= 0) {
    os << " --eccentricity " << o.eccentricity_min << "," << o.eccentricity_max;
    if (o.eccentricity_change != d.eccentricity_change)
      os << " --eccentricity-change " << o.eccentricity_change;
    if (o.eccentricity_turn_rad != d.eccentricity_turn_rad)
      os << " --eccentricity-turn-rad " << o.eccentricity_turn_rad;
  }
  os << ", generator v" << kGeneratorVersion << ", " << position_label(p.position);
  if (o.dz_mm != d.dz_mm) os << ", dz_mm " << o.dz_mm;
  if (o.n_angles != d.n_angles) os << ", n_angles " << o.n_angles;
  if (!o.heartwood) os << ", no heartwood";
  if (!o.bark) os << ", no bark";
  return os.str();
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

Status GeneratorOptions::validate() const {
  if (species != Species::kPine && species != Species::kSpruce)
    return Error("species", "must be pine or spruce");
  if (position != LogPosition::kDrawn && position != LogPosition::kButt &&
      position != LogPosition::kMiddle && position != LogPosition::kTop)
    return Error("position", "must be drawn, butt, middle or top");
  if (!(length_mm == 0 || (length_mm >= kMinLengthOption && length_mm <= kMaxLengthOption)))
    return Error("length_mm", "must be 0 (drawn from 3-6 m) or within " + num(kMinLengthOption) +
                                  ".." + num(kMaxLengthOption) + " mm, got " + num(length_mm));
  if (!(top_diameter_mm == 0 ||
        (top_diameter_mm >= kMinTopOption && top_diameter_mm <= kMaxTopOption)))
    return Error("top_diameter_mm", "must be 0 (drawn) or within " + num(kMinTopOption) + ".." +
                                        num(kMaxTopOption) + " mm, got " + num(top_diameter_mm));
  if (!(dz_mm >= kMinDz && dz_mm <= kMaxDz))
    return Error("dz_mm",
                 "must be within " + num(kMinDz) + ".." + num(kMaxDz) + " mm, got " + num(dz_mm));
  if (n_angles < kMinAngles || n_angles > kMaxAngles)
    return Error("n_angles", "must be within " + std::to_string(kMinAngles) + ".." +
                                 std::to_string(kMaxAngles) + ", got " + std::to_string(n_angles));
  if (eccentricity_max >= 0) {
    const std::string range = "0.." + num(kMaxEccentricityOption);
    if (!(eccentricity_max <= kMaxEccentricityOption))
      return Error("eccentricity_max", "must be within " + range + " (share of the radius), got " +
                                           num(eccentricity_max));
    if (!(eccentricity_min >= 0 && eccentricity_min <= eccentricity_max))
      return Error("eccentricity_min", "must be within 0 and the maximum " + num(eccentricity_max) +
                                           " (share of the radius), got " + num(eccentricity_min));
    if (!(eccentricity_change >= 0 && eccentricity_change <= kMaxEccentricityOption))
      return Error(
          "eccentricity_change",
          "must be within " + range + " (share of the radius), got " + num(eccentricity_change));
    if (!(eccentricity_turn_rad >= 0 && eccentricity_turn_rad <= kPi))
      return Error("eccentricity_turn_rad",
                   "must be within 0..pi, got " + num(eccentricity_turn_rad));
  } else if (!(eccentricity_max < 0)) {  // NaN
    return Error("eccentricity_max", "must be a number");
  }
  const double longest = length_mm > 0 ? length_mm : kMaxLength;
  if (longest / dz_mm * n_angles > kMaxStemSamples)
    return Error("dz_mm, n_angles", "give more than " + num(kMaxStemSamples) +
                                        " stem samples; use a larger dz_mm or fewer n_angles");
  return Status::Ok();
}

Result<LogModel> generate_log(const GeneratorOptions& options) {
  Status v = options.validate();
  if (!v) return v.error();
  // The random key: the seed and the species, so that pine 1 and spruce 1 are unrelated logs.
  std::uint64_t mix = options.seed ^ (options.species == Species::kPine ? 0x5049u : 0x5350u);
  const std::uint64_t key = splitmix64(mix);
  const LogPlan plan = plan_log(options, key);
  StemShape shape = StemShape::draw(plan, key);
  if (options.eccentricity_max >= 0) shape.ask_eccentricity(options, key);
  const WoodShape wood = WoodShape::draw(key);
  LogModel log;
  log.id = std::string(species_name(options.species)) + "_s" + std::to_string(options.seed);
  log.species = species_name(options.species);
  log.source = describe(options, plan);
  log.stem = build_stem(plan, shape, wood, options);
  log.knots = build_knots(plan, shape, log.stem, key);
  return log;
}

const char* species_name(Species s) { return s == Species::kPine ? "pine" : "spruce"; }

Result<Species> parse_species(const std::string& name) {
  const std::string n = lower(name);
  if (n == "pine") return Species::kPine;
  if (n == "spruce") return Species::kSpruce;
  return Error("species", "unknown species '" + name + "' (pine, spruce)");
}

const char* log_position_name(LogPosition p) {
  switch (p) {
    case LogPosition::kButt:
      return "butt";
    case LogPosition::kMiddle:
      return "middle";
    case LogPosition::kTop:
      return "top";
    case LogPosition::kDrawn:
      break;
  }
  return "drawn";
}

Result<LogPosition> parse_log_position(const std::string& name) {
  const std::string n = lower(name);
  for (LogPosition p :
       {LogPosition::kDrawn, LogPosition::kButt, LogPosition::kMiddle, LogPosition::kTop})
    if (n == log_position_name(p)) return p;
  return Error("position", "unknown log position '" + name + "' (drawn, butt, middle, top)");
}

}  // namespace sawyer
