// The random log generator: determinism, realistic ranges over many seeds, valid models that
// survive log.json exactly, and options checked with a message naming the bad one.
//
// The ranges asserted here are the product's (docs/architecture.md section 6 and the sawmill
// engineer's brief), written out as literals on purpose: they are the specification that the
// generator's own constants must stay inside, not a copy of them.
#include "sawyer/model/log_generator.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "sawyer/core/file_util.h"
#include "sawyer/model/log_json.h"
#include "sawyer/model/log_summary.h"
#include "sawyer/test/test_util.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int kSeeds = 20;  // logs per species in the range tests
const Species kSpecies[] = {Species::kPine, Species::kSpruce};

// The committed sample logs: sample_logs/<species>_<seed>/log.json.
struct Sample {
  Species species;
  std::uint64_t seed;
};
const Sample kSamples[] = {{Species::kPine, 8}, {Species::kSpruce, 77}};

LogModel make(Species species, std::uint64_t seed,
              const std::function<void(GeneratorOptions&)>& tweak = {}) {
  GeneratorOptions o;
  o.species = species;
  o.seed = seed;
  if (tweak) tweak(o);
  Result<LogModel> r = generate_log(o);
  EXPECT_TRUE(r) << (r ? std::string() : r.error().message());
  return r ? std::move(r).value() : LogModel{};
}

// The logs of seeds 1..kSeeds, generated once per test process.
const std::vector<LogModel>& logs(Species species) {
  static std::map<Species, std::vector<LogModel>> cache;
  std::vector<LogModel>& v = cache[species];
  if (v.empty())
    for (int s = 1; s <= kSeeds; ++s) v.push_back(make(species, s));
  return v;
}

const char* name(Species s) { return species_name(s); }

double equal_area_diameter(const Stem& s, int i) { return 2.0 * std::sqrt(s.area(i) / kPi); }

// Centroid of the polar outline of sample i, relative to its pith.
Vec2 outline_centroid(const Stem& s, int i) {
  const std::vector<double>& r = s.radius[i];
  const int n = s.n_angles;
  double a = 0, cx = 0, cy = 0;
  for (int k = 0; k < n; ++k) {
    const double w0 = kTwoPi * k / n, w1 = kTwoPi * (k + 1) / n;
    const double x0 = r[k] * std::cos(w0), y0 = r[k] * std::sin(w0);
    const double x1 = r[(k + 1) % n] * std::cos(w1), y1 = r[(k + 1) % n] * std::sin(w1);
    const double c = x0 * y1 - x1 * y0;
    a += c;
    cx += (x0 + x1) * c;
    cy += (y0 + y1) * c;
  }
  return {cx / (3.0 * a), cy / (3.0 * a)};
}

// Largest distance of points p(z) from their least-squares straight line.
double deviation_from_line(const std::vector<double>& z, const std::vector<Vec2>& p) {
  const double n = static_cast<double>(z.size());
  double mz = 0, mx = 0, my = 0;
  for (size_t i = 0; i < z.size(); ++i) mz += z[i] / n, mx += p[i].x / n, my += p[i].y / n;
  double szz = 0, szx = 0, szy = 0;
  for (size_t i = 0; i < z.size(); ++i) {
    szz += (z[i] - mz) * (z[i] - mz);
    szx += (z[i] - mz) * (p[i].x - mx);
    szy += (z[i] - mz) * (p[i].y - my);
  }
  double worst = 0;
  for (size_t i = 0; i < z.size(); ++i) {
    const double ex = p[i].x - mx - szx / szz * (z[i] - mz);
    const double ey = p[i].y - my - szy / szz * (z[i] - mz);
    worst = std::max(worst, std::hypot(ex, ey));
  }
  return worst;
}

// Knots grouped by z0: single linkage with gaps of at most 40 mm (a whorl's knots lie within
// ±20 mm of it). Whorls are the groups of 3 or more; single knots are interwhorl knots.
std::vector<std::vector<int>> groups_by_height(const LogModel& log) {
  std::vector<int> order(log.knots.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return log.knots[a].z0 < log.knots[b].z0; });
  std::vector<std::vector<int>> out;
  for (int i : order) {
    if (out.empty() || log.knots[i].z0 - log.knots[out.back().back()].z0 > 40.0) out.push_back({});
    out.back().push_back(i);
  }
  return out;
}

double mean_z0(const LogModel& log, const std::vector<int>& group) {
  double m = 0;
  for (int i : group) m += log.knots[i].z0 / group.size();
  return m;
}

bool is_whorl(const std::vector<int>& group) { return group.size() >= 3; }

// Outer radius where the knot's axis is at pith distance r.
double stem_radius_on_axis(const LogModel& log, const Knot& k, double r) {
  return log.stem.radius_at(k.azimuth_at(r), k.height_at(r));
}

// ---- Options -----------------------------------------------------------------------------------

TEST(GeneratorOptions, DefaultsAreValid) {
  GeneratorOptions o;
  EXPECT_TRUE(o.validate());
  o.species = Species::kPine;
  o.length_mm = 4000;
  o.top_diameter_mm = 200;
  o.position = LogPosition::kTop;
  EXPECT_TRUE(o.validate());
}

TEST(GeneratorOptions, BadOptionsAreRejectedNamingTheOption) {
  struct Case {
    std::function<void(GeneratorOptions&)> tweak;
    const char* option;
  };
  const Case cases[] = {
      {[](GeneratorOptions& o) { o.length_mm = -4000; }, "length_mm"},
      {[](GeneratorOptions& o) { o.length_mm = 50000; }, "length_mm"},
      {[](GeneratorOptions& o) { o.length_mm = std::nan(""); }, "length_mm"},
      {[](GeneratorOptions& o) { o.dz_mm = 0; }, "dz_mm"},
      {[](GeneratorOptions& o) { o.dz_mm = -10; }, "dz_mm"},
      {[](GeneratorOptions& o) { o.n_angles = 4; }, "n_angles"},
      {[](GeneratorOptions& o) { o.n_angles = 7; }, "n_angles"},
      {[](GeneratorOptions& o) { o.n_angles = 4000; }, "n_angles"},
      {[](GeneratorOptions& o) {
         o.dz_mm = 0.5;
         o.n_angles = 3600;
       },
       "dz_mm"},
      {[](GeneratorOptions& o) { o.top_diameter_mm = 50; }, "top_diameter_mm"},
      {[](GeneratorOptions& o) { o.top_diameter_mm = 600; }, "top_diameter_mm"},
      {[](GeneratorOptions& o) { o.top_diameter_mm = -1; }, "top_diameter_mm"},
      {[](GeneratorOptions& o) { o.species = static_cast<Species>(7); }, "species"},
      {[](GeneratorOptions& o) { o.position = static_cast<LogPosition>(9); }, "position"},
      {[](GeneratorOptions& o) { o.eccentricity_max = 0.5; }, "eccentricity_max"},
      {[](GeneratorOptions& o) { o.eccentricity_max = std::nan(""); }, "eccentricity_max"},
      {[](GeneratorOptions& o) {
         o.eccentricity_min = 0.2;
         o.eccentricity_max = 0.1;
       },
       "eccentricity_min"},
      {[](GeneratorOptions& o) {
         o.eccentricity_min = -0.1;
         o.eccentricity_max = 0.1;
       },
       "eccentricity_min"},
      {[](GeneratorOptions& o) {
         o.eccentricity_max = 0.2;
         o.eccentricity_change = -0.01;
       },
       "eccentricity_change"},
      {[](GeneratorOptions& o) {
         o.eccentricity_max = 0.2;
         o.eccentricity_turn_rad = 4;
       },
       "eccentricity_turn_rad"},
  };
  for (const Case& c : cases) {
    GeneratorOptions o;
    c.tweak(o);
    const Status st = o.validate();
    ASSERT_FALSE(st) << c.option;
    EXPECT_THAT(st.error().message(), HasSubstr(c.option));
    // generate_log checks them too, and makes nothing.
    const Result<LogModel> r = generate_log(o);
    ASSERT_FALSE(r) << c.option;
    EXPECT_THAT(r.error().message(), HasSubstr(c.option));
  }
}

TEST(GeneratorOptions, SpeciesAndPositionNamesParse) {
  EXPECT_EQ(parse_species("pine").value(), Species::kPine);
  EXPECT_EQ(parse_species("Spruce").value(), Species::kSpruce);
  EXPECT_STREQ(species_name(Species::kPine), "pine");
  EXPECT_STREQ(species_name(Species::kSpruce), "spruce");
  const Result<Species> oak = parse_species("oak");
  ASSERT_FALSE(oak);
  EXPECT_THAT(oak.error().message(), HasSubstr("'oak'"));
  for (LogPosition p :
       {LogPosition::kDrawn, LogPosition::kButt, LogPosition::kMiddle, LogPosition::kTop})
    EXPECT_EQ(parse_log_position(log_position_name(p)).value(), p);
  const Result<LogPosition> root = parse_log_position("root");
  ASSERT_FALSE(root);
  EXPECT_THAT(root.error().message(), HasSubstr("'root'"));
}

// ---- Determinism and the file format -----------------------------------------------------------

TEST(LogGenerator, SameSeedGivesByteIdenticalJson) {
  for (Species sp : kSpecies) {
    const std::string a = log_to_json(make(sp, 42));
    const std::string b = log_to_json(make(sp, 42));
    EXPECT_EQ(a, b) << name(sp);
  }
}

TEST(LogGenerator, DifferentSeedsAndSpeciesGiveDifferentLogs) {
  for (Species sp : kSpecies) {
    const LogModel a = make(sp, 1), b = make(sp, 2);
    EXPECT_NE(log_to_json(a), log_to_json(b)) << name(sp);
    EXPECT_NE(a.stem.radius[0], b.stem.radius[0]) << name(sp);
  }
  // The species is part of the random key: pine 1 and spruce 1 are unrelated logs.
  const LogModel p = make(Species::kPine, 1), s = make(Species::kSpruce, 1);
  EXPECT_NE(p.stem.radius[0], s.stem.radius[0]);
}

TEST(LogGenerator, IdSpeciesAndSourceAreFilled) {
  const LogModel log = make(Species::kPine, 42);
  EXPECT_EQ(log.id, "pine_s42");
  EXPECT_EQ(log.species, "pine");
  EXPECT_THAT(log.source, HasSubstr("sawyer generate --species pine --seed 42, generator v1"));
  const LogModel s = make(Species::kSpruce, 3, [](GeneratorOptions& o) {
    o.length_mm = 4000;
    o.position = LogPosition::kButt;
  });
  EXPECT_EQ(s.id, "spruce_s3");
  EXPECT_EQ(s.species, "spruce");
  EXPECT_THAT(s.source, HasSubstr("--seed 3 --length-m 4 --position butt"));
  EXPECT_THAT(s.source, HasSubstr("butt log"));
}

TEST(LogGenerator, LogsValidateAndSurviveLogJsonExactly) {
  for (Species sp : kSpecies) {
    for (int seed = 1; seed <= 4; ++seed) {
      const LogModel log = make(sp, seed);
      const Status v = validate(log);
      ASSERT_TRUE(v) << v.error().message();
      const std::string text = log_to_json(log);
      const Result<LogModel> back = log_from_json(text);
      ASSERT_TRUE(back) << back.error().message();
      EXPECT_EQ(log_to_json(back.value()), text);
      EXPECT_EQ(back.value().stem.radius, log.stem.radius);
      EXPECT_EQ(back.value().stem.heartwood, log.stem.heartwood);
      EXPECT_EQ(back.value().stem.pith, log.stem.pith);
      ASSERT_EQ(back.value().knots.size(), log.knots.size());
      for (size_t i = 0; i < log.knots.size(); ++i) {
        EXPECT_EQ(back.value().knots[i].r_end, log.knots[i].r_end);
        EXPECT_EQ(back.value().knots[i].a, log.knots[i].a);
      }
    }
  }
}

// Stem values are rounded to 0.01 mm, knot lengths to 0.001 mm, the rest to 1e-6.
TEST(LogGenerator, OutputIsRoundedForACompactFile) {
  auto on_grid = [](double v, double q) { return std::abs(v / q - std::round(v / q)) < 1e-6; };
  const LogModel log = make(Species::kSpruce, 5);
  for (size_t i = 0; i < log.stem.radius.size(); ++i) {
    ASSERT_TRUE(on_grid(log.stem.pith[i].x, 0.01) && on_grid(log.stem.pith[i].y, 0.01));
    for (double r : log.stem.radius[i]) ASSERT_TRUE(on_grid(r, 0.01)) << r;
    for (double h : log.stem.heartwood[i]) ASSERT_TRUE(on_grid(h, 0.01)) << h;
    ASSERT_TRUE(on_grid(log.stem.bark_mm[i], 0.01));
  }
  for (const Knot& k : log.knots) {
    for (double v : {k.z0, k.r_dead, k.r_end, k.diameter.d_dead})
      EXPECT_TRUE(on_grid(v, 1e-3)) << v;
    for (double v : {k.a, k.b, k.omega0, k.twist, k.diameter.exponent})
      EXPECT_TRUE(on_grid(v, 1e-6)) << v;
  }
  // A 5 m log with heartwood stays near 2.5 MB (500 × 360 radii twice).
  const LogModel five = make(Species::kPine, 5, [](GeneratorOptions& o) { o.length_mm = 5000; });
  EXPECT_LT(log_to_json(five).size(), 2.6e6);
}

// ---- Stem ranges over many seeds ----------------------------------------------------------------

TEST(LogGenerator, LengthDiametersAndTaperAreInRange) {
  for (Species sp : kSpecies) {
    // Taper of the diameter, mm/m: pine 6–10, spruce 8–12 (±1 for form, swellings, ovality).
    const double lo = sp == Species::kPine ? 5.0 : 7.0, hi = sp == Species::kPine ? 11.0 : 13.0;
    for (const LogModel& log : logs(sp)) {
      const LogSummary s = summarize(log);
      SCOPED_TRACE(log.id);
      EXPECT_GE(s.length_mm, 3000.0);
      EXPECT_LE(s.length_mm, 6000.0);
      EXPECT_NEAR(std::fmod(s.length_mm, 100.0), 0.0, 1e-9);  // whole decimetres
      EXPECT_GE(s.butt_diameter_mm, 120.0);
      EXPECT_LE(s.butt_diameter_mm, 450.0);
      EXPECT_GE(s.top_diameter_mm, 105.0);
      EXPECT_LT(s.top_diameter_mm, s.butt_diameter_mm);
      // Taper: least-squares slope of the equal-area diameter above the butt flare (z ≥ 0.6 m).
      const Stem& st = log.stem;
      double n = 0, mz = 0, md = 0;
      for (int i = 0; i < st.slice_count(); ++i)
        if (st.z_at(i) >= 600) n += 1, mz += st.z_at(i), md += equal_area_diameter(st, i);
      mz /= n, md /= n;
      double szz = 0, szd = 0;
      for (int i = 0; i < st.slice_count(); ++i)
        if (st.z_at(i) >= 600) {
          szz += (st.z_at(i) - mz) * (st.z_at(i) - mz);
          szd += (st.z_at(i) - mz) * (equal_area_diameter(st, i) - md);
        }
      const double taper = -szd / szz * 1000.0;
      EXPECT_GE(taper, lo);
      EXPECT_LE(taper, hi);
    }
  }
}

TEST(LogGenerator, OvalityIsAFewPercent) {
  for (Species sp : kSpecies)
    for (const LogModel& log : logs(sp)) {
      const double ov = summarize(log).ovality;
      EXPECT_GE(ov, 0.005) << log.id;
      EXPECT_LE(ov, 0.10) << log.id;
    }
}

TEST(LogGenerator, SweepEccentricityAndPithWanderAreBounded) {
  for (Species sp : kSpecies) {
    int nearly_straight = 0;
    for (const LogModel& log : logs(sp)) {
      SCOPED_TRACE(log.id);
      const Stem& s = log.stem;
      std::vector<double> z;
      std::vector<Vec2> centre;
      double worst_offset = 0;
      for (int i = 0; i < s.slice_count(); ++i) {
        const Vec2 c = outline_centroid(s, i);
        z.push_back(s.z_at(i));
        centre.push_back(s.pith[i] + c);
        // The pith is off the outline's centre by eccentricity (≤ 6 % of R) and wander (≤ 4 mm).
        worst_offset = std::max(worst_offset, c.norm() - 0.06 * s.mean_radius(i));
      }
      EXPECT_LE(worst_offset, 5.0);
      // Bow of the outline's centre line: at most 1.5 % of the length (plus slack for lobes).
      const double bow = deviation_from_line(z, centre);
      EXPECT_LE(bow, 0.015 * s.length_mm() + 2.0);
      if (bow <= 0.005 * s.length_mm()) ++nearly_straight;
      // Pith: smooth (no kinks) — small steps and tiny second differences.
      for (int i = 1; i + 1 < s.slice_count(); ++i) {
        const Vec2 d1 = s.pith[i] - s.pith[i - 1];
        const Vec2 d2 = s.pith[i + 1] - 2.0 * s.pith[i] + s.pith[i - 1];
        ASSERT_LE(d1.norm(), 1.5) << "slice " << i;
        ASSERT_LE(d2.norm(), 0.15) << "slice " << i;
      }
    }
    // Most logs are nearly straight (bow ≤ 0.5 % of the length).
    EXPECT_GE(nearly_straight, kSeeds / 2) << name(sp);
  }
}

TEST(LogGenerator, StemAndHeartwoodAreSmooth) {
  for (Species sp : kSpecies)
    for (int j = 0; j < 4; ++j) {
      const LogModel& log = logs(sp)[j];
      const Stem& s = log.stem;
      const int n = s.n_angles;
      for (const auto* grid : {&s.radius, &s.heartwood})
        for (int i = 1; i + 1 < s.slice_count(); ++i)
          for (int k = 0; k < n; ++k) {
            const auto& g = *grid;
            const double dw = g[i][(k + 1) % n] - 2 * g[i][k] + g[i][(k + n - 1) % n];
            const double dz = g[i + 1][k] - 2 * g[i][k] + g[i - 1][k];
            ASSERT_LE(std::abs(dw), 0.3) << log.id << " slice " << i << " angle " << k;
            ASSERT_LE(std::abs(dz), 0.6) << log.id << " slice " << i << " angle " << k;
          }
    }
}

TEST(LogGenerator, HeartwoodIsInsideTheStemWithRealisticProportions) {
  for (Species sp : kSpecies)
    for (const LogModel& log : logs(sp)) {
      SCOPED_TRACE(log.id);
      const Stem& s = log.stem;
      ASSERT_TRUE(s.has_heartwood());
      double first_share = 0, last_share = 0, band = 0;
      for (int i = 0; i < s.slice_count(); ++i) {
        double h = 0;
        for (int k = 0; k < s.n_angles; ++k) {
          ASSERT_GE(s.heartwood[i][k], 0.0);
          ASSERT_LE(s.heartwood[i][k], s.radius[i][k] - 15.0 + 1e-9);
          h += s.heartwood[i][k] / s.n_angles;
        }
        const double share = h / s.mean_radius(i);
        if (i == 0) first_share = share;
        if (i + 1 == s.slice_count()) last_share = share;
        band += (s.mean_radius(i) - h) / s.slice_count();
      }
      if (sp == Species::kPine) {
        // Pine heartwood: ≈ 40–65 % of the radius at the stump, less higher up the tree.
        EXPECT_GE(first_share, 0.25);
        EXPECT_LE(first_share, 0.66);
        EXPECT_LT(last_share, first_share);
      } else {
        // Spruce dry core inside a wet sapwood band 20–40 mm wide.
        EXPECT_GE(band, 17.0);
        EXPECT_LE(band, 43.0);
      }
    }
}

// ---- Knots over many seeds ---------------------------------------------------------------------

TEST(LogGenerator, KnotCountsAndWhorlsAreRealistic) {
  for (Species sp : kSpecies)
    for (const LogModel& log : logs(sp)) {
      SCOPED_TRACE(log.id);
      EXPECT_GE(log.knots.size(), 30u);
      EXPECT_LE(log.knots.size(), 120u);
      const auto groups = groups_by_height(log);
      std::vector<double> whorl_z;
      int interwhorl_run = 0;
      for (const auto& g : groups) {
        if (is_whorl(g)) {
          // 3–6 knots, all within ±20 mm of the whorl's height.
          EXPECT_LE(g.size(), 6u);
          const double zc = mean_z0(log, g);
          for (int i : g) EXPECT_LE(std::abs(log.knots[i].z0 - zc), 20.0 + 1e-6);
          whorl_z.push_back(zc);
          interwhorl_run = 0;
        } else if (sp == Species::kPine) {
          ADD_FAILURE() << "pine knot outside a whorl at z0 = " << log.knots[g[0]].z0;
        } else {
          // Spruce interwhorl knots: 0–4 between whorls, and small.
          interwhorl_run += static_cast<int>(g.size());
          EXPECT_LE(interwhorl_run, 4);
          for (int i : g) EXPECT_LE(log.knots[i].diameter.d_dead, 12.0);
        }
      }
      ASSERT_GE(whorl_z.size(), 5u);
      // Whorls every 0.3–0.6 m, measured from the knots.
      for (size_t w = 1; w < whorl_z.size(); ++w) {
        EXPECT_GE(whorl_z[w] - whorl_z[w - 1], 300.0 - 0.01);
        EXPECT_LE(whorl_z[w] - whorl_z[w - 1], 600.0 + 0.01);
      }
    }
}

TEST(LogGenerator, KnotGeometryFollowsBranchAngles) {
  for (Species sp : kSpecies)
    for (const LogModel& log : logs(sp))
      for (const Knot& k : log.knots) {
        SCOPED_TRACE(log.id + " knot " + std::to_string(k.id));
        EXPECT_LE(std::abs(k.twist), 0.05);
        EXPECT_GE(k.omega0, 0.0);
        EXPECT_LT(k.omega0, kTwoPi);
        // Mean rise over 100 mm: branch angle 50–82° from the stem axis, slope cot(angle) with a
        // curvature term on top.
        const double slope = (k.height_at(100.0) - k.z0) / 100.0;
        EXPECT_GE(slope, 0.08);
        EXPECT_LE(slope, 1.2);
        if (sp == Species::kPine) {
          // Pine whorl knots: 50–80° from the axis, mean slope ≈ 0.2–0.8 out to the bark.
          const double r = std::max(k.r_end, 60.0);
          const double mean_slope = (k.height_at(r) - k.z0) / r;
          EXPECT_GE(mean_slope, 0.1);
          EXPECT_LE(mean_slope, 1.0);
        }
      }
}

TEST(LogGenerator, KnotDiametersAreInRange) {
  for (Species sp : kSpecies)
    for (const LogModel& log : logs(sp))
      for (const auto& g : groups_by_height(log))
        for (int i : g) {
          const Knot& k = log.knots[i];
          SCOPED_TRACE(log.id + " knot " + std::to_string(k.id));
          EXPECT_GE(k.diameter.exponent, 0.5);
          EXPECT_LE(k.diameter.exponent, 1.2);
          const double d = k.diameter.d_dead;
          if (!is_whorl(g)) {
            EXPECT_GE(d, 5.0);  // interwhorl
            EXPECT_LE(d, 12.0);
          } else if (sp == Species::kPine) {
            EXPECT_GE(d, 8.0);
            EXPECT_LE(d, 40.0);
          } else {
            EXPECT_GE(d, 8.0);
            EXPECT_LE(d, 25.0);
          }
        }
}

TEST(LogGenerator, WhorlNeighboursDoNotOverlapAt30mm) {
  for (Species sp : kSpecies)
    for (const LogModel& log : logs(sp))
      for (const auto& g : groups_by_height(log)) {
        if (!is_whorl(g)) continue;
        std::vector<const Knot*> ks;
        for (int i : g) ks.push_back(&log.knots[i]);
        std::sort(ks.begin(), ks.end(), [](const Knot* a, const Knot* b) {
          return a->azimuth_at(30.0) < b->azimuth_at(30.0);
        });
        for (size_t i = 0; i < ks.size(); ++i) {
          const Knot& a = *ks[i];
          const Knot& b = *ks[(i + 1) % ks.size()];
          const double gap = wrap_angle(b.azimuth_at(30.0) - a.azimuth_at(30.0));
          EXPECT_GE(30.0 * gap, 0.5 * (a.diameter_at(30.0) + b.diameter_at(30.0)))
              << log.id << " knots " << a.id << " and " << b.id;
        }
      }
}

TEST(LogGenerator, KnotsEndInsideTheStem) {
  for (Species sp : kSpecies) {
    int total = 0, at_surface = 0, overgrown = 0;
    for (const LogModel& log : logs(sp))
      for (const Knot& k : log.knots) {
        SCOPED_TRACE(log.id + " knot " + std::to_string(k.id));
        EXPECT_GE(k.r_dead, 0.0);
        EXPECT_GT(k.r_end, 1.0);
        // r_end never beyond the outer surface where the axis is, nor outside the log's ends.
        const double R = stem_radius_on_axis(log, k, k.r_end);
        EXPECT_LE(k.r_end, R + 1e-9);
        const double z_end = k.height_at(k.r_end);
        EXPECT_GE(z_end, log.stem.z_begin());
        EXPECT_LE(z_end, log.stem.z_end());
        // A dead part starts 20 mm or more from the pith (the branch lived a few years).
        if (k.has_dead_part()) {
          EXPECT_GE(k.r_dead, 20.0 - 1e-9);
        }
        ++total;
        const bool on_end_face = z_end > log.stem.z_end() - 2.0 || z_end < log.stem.z_begin() + 2.0;
        if (k.r_end >= R - 1.0 || on_end_face)
          ++at_surface;
        else if (k.r_end < R - 10.0)
          ++overgrown;
      }
    // Most knots reach the bark (or an end face); some were overgrown.
    EXPECT_GT(at_surface, total * 6 / 10) << name(sp);
    EXPECT_GT(overgrown, 0) << name(sp);
  }
}

// Butt logs: dead knots with a short sound core (r_dead 20–80 mm), pine often overgrown. Top
// logs: most knots sound out to the bark.
TEST(LogGenerator, KnotsAreSoundHigherUpInTheTree) {
  for (Species sp : kSpecies) {
    double sound_share[2] = {0, 0};
    std::vector<double> butt_r_dead;
    int butt_overgrown = 0, butt_knots = 0;
    for (int j = 0; j < 2; ++j) {
      int sound = 0, n = 0;
      for (int seed = 1; seed <= 6; ++seed) {
        const LogModel log = make(sp, seed, [&](GeneratorOptions& o) {
          o.position = j == 0 ? LogPosition::kButt : LogPosition::kTop;
        });
        for (const Knot& k : log.knots) {
          ++n;
          if (!k.has_dead_part()) ++sound;
          if (j == 0) {
            ++butt_knots;
            if (k.has_dead_part()) butt_r_dead.push_back(k.r_dead);
            if (k.r_end < stem_radius_on_axis(log, k, k.r_end) - 10.0) ++butt_overgrown;
          }
        }
      }
      sound_share[j] = double(sound) / n;
    }
    EXPECT_GE(sound_share[1], sound_share[0] + 0.3) << name(sp);
    ASSERT_FALSE(butt_r_dead.empty());
    std::sort(butt_r_dead.begin(), butt_r_dead.end());
    const double median = butt_r_dead[butt_r_dead.size() / 2];
    EXPECT_GE(median, 20.0) << name(sp);
    EXPECT_LE(median, 80.0) << name(sp);
    if (sp == Species::kPine) {
      EXPECT_GT(butt_overgrown, butt_knots / 5);  // the knot-free zone of pine butt logs
    }
  }
}

// The model finds the knots where the generator put them.
TEST(LogGenerator, KnotsAreWhereTheModelLooksForThem) {
  for (Species sp : kSpecies) {
    const LogModel& log = logs(sp)[0];
    int found = 0, tried = 0;
    for (size_t i = 0; i < log.knots.size(); ++i) {
      const Knot& k = log.knots[i];
      if (k.r_end < 60) continue;
      const double r = 0.6 * k.r_end;
      const MaterialSample m = log.material_at(k.axis_point(r, log.stem));
      ++tried;
      const Material want = k.dead_at(r) ? Material::kDeadKnot : Material::kSoundKnot;
      if (m.knot == static_cast<int>(i) && m.material == want) ++found;
    }
    EXPECT_GT(tried, 20);
    EXPECT_GE(found, tried * 95 / 100) << name(sp);
  }
}

// ---- Options change what they say --------------------------------------------------------------

TEST(LogGenerator, OptionsShapeTheLog) {
  const LogModel plain = make(Species::kPine, 9, [](GeneratorOptions& o) {
    o.heartwood = false;
    o.bark = false;
  });
  EXPECT_FALSE(plain.stem.has_heartwood());
  EXPECT_TRUE(plain.stem.bark_mm.empty());

  const LogModel fine = make(Species::kPine, 9);
  const LogModel coarse = make(Species::kPine, 9, [](GeneratorOptions& o) {
    o.dz_mm = 20;
    o.n_angles = 90;
  });
  EXPECT_EQ(coarse.stem.n_angles, 90);
  EXPECT_EQ(coarse.stem.radius[0].size(), 90u);
  EXPECT_DOUBLE_EQ(coarse.stem.dz_mm, 20.0);
  EXPECT_DOUBLE_EQ(coarse.stem.length_mm(), fine.stem.length_mm());
  EXPECT_TRUE(validate(coarse));
  // The log starts at z = 0: sample 0 is centred half a step up.
  EXPECT_DOUBLE_EQ(coarse.stem.z_begin(), 0.0);
  // Pine bark is thicker at the butt than at the top.
  EXPECT_GT(fine.stem.bark_mm.front(), fine.stem.bark_mm.back());

  const LogModel given = make(Species::kSpruce, 9, [](GeneratorOptions& o) {
    o.length_mm = 4000;
    o.top_diameter_mm = 250;
  });
  const LogSummary s = summarize(given);
  EXPECT_DOUBLE_EQ(s.length_mm, 4000.0);
  EXPECT_NEAR(s.top_diameter_mm, 250.0, 8.0);
  EXPECT_LE(s.butt_diameter_mm, 450.0);
}

// ---- Pith eccentricity (issue 41) ---------------------------------------------------------------

// The pith's offset from its outline's centroid, a share of the equal-area radius.
double eccentricity(const Stem& s, int i) {
  return outline_centroid(s, i).norm() / std::sqrt(s.area(i) / kPi);
}

LogModel eccentric(Species sp, std::uint64_t seed, double lo, double hi, double change = 0.05) {
  return make(sp, seed, [&](GeneratorOptions& o) {
    o.eccentricity_min = lo;
    o.eccentricity_max = hi;
    o.eccentricity_change = change;
  });
}

// Real piths sit 0–25 % of the radius off the outline's centre: asked for, the generated pith
// spans the asked stretch along the log, smoothly, inside the same outline.
TEST(LogGenerator, AskedEccentricityIsReachedAndChangesAlongTheLog) {
  struct Ask {
    double lo, hi;
  };
  for (Species sp : kSpecies)
    for (int seed = 1; seed <= 3; ++seed)
      for (const Ask a : {Ask{0.20, 0.25}, Ask{0.0, 0.25}, Ask{0.12, 0.12}}) {
        const LogModel log = eccentric(sp, seed, a.lo, a.hi);
        SCOPED_TRACE(log.id + " asked " + std::to_string(a.lo) + ".." + std::to_string(a.hi));
        ASSERT_TRUE(validate(log));
        EXPECT_THAT(log.source, HasSubstr("--eccentricity "));
        const Stem& s = log.stem;
        double e_min = 1, e_max = 0;
        for (int i = 0; i < s.slice_count(); ++i) {
          e_min = std::min(e_min, eccentricity(s, i));
          e_max = std::max(e_max, eccentricity(s, i));
        }
        // Inside the asked range, and changing by the asked 5 % of the radius along the log
        // (the whole range when it is narrower). The slack is the lobes' own centroid shift.
        EXPECT_GE(e_min, a.lo - 0.004);
        EXPECT_LE(e_max, a.hi + 0.004);
        EXPECT_NEAR(e_max - e_min, std::min(0.05, a.hi - a.lo), 0.006);
        // Smooth along z, as the default pith is.
        for (int i = 1; i + 1 < s.slice_count(); ++i) {
          const Vec2 d1 = s.pith[i] - s.pith[i - 1];
          const Vec2 d2 = s.pith[i + 1] - 2.0 * s.pith[i] + s.pith[i - 1];
          ASSERT_LE(d1.norm(), 1.5) << "slice " << i;
          ASSERT_LE(d2.norm(), 0.15) << "slice " << i;
        }
      }
  // A stretch at the top of the range reaches it: 20 and 25 % both occur along the log.
  const LogModel top = eccentric(Species::kPine, 4, 0.20, 0.25);
  double e_min = 1, e_max = 0;
  for (int i = 0; i < top.stem.slice_count(); ++i) {
    e_min = std::min(e_min, eccentricity(top.stem, i));
    e_max = std::max(e_max, eccentricity(top.stem, i));
  }
  EXPECT_LE(e_min, 0.205);
  EXPECT_GE(e_max, 0.245);
}

// The pith moves inside the outline the default log has: the same section (area, centroid in
// the scanner frame), the near side's radii shorter and the far side's longer.
TEST(LogGenerator, AskedEccentricityMovesOnlyThePith) {
  for (Species sp : kSpecies) {
    const LogModel base = make(sp, 5);
    const LogModel ecc = eccentric(sp, 5, 0.25, 0.25);
    ASSERT_EQ(ecc.stem.slice_count(), base.stem.slice_count());
    for (int i = 0; i < base.stem.slice_count(); i += 25) {
      SCOPED_TRACE(name(sp) + std::string(" slice ") + std::to_string(i));
      EXPECT_NEAR(ecc.stem.area(i), base.stem.area(i), 5e-4 * base.stem.area(i));
      const Vec2 c0 = base.stem.pith[i] + outline_centroid(base.stem, i);
      const Vec2 c1 = ecc.stem.pith[i] + outline_centroid(ecc.stem, i);
      EXPECT_LT((c1 - c0).norm(), 0.1);
      const auto [lo, hi] =
          std::minmax_element(ecc.stem.radius[i].begin(), ecc.stem.radius[i].end());
      const double r = std::sqrt(ecc.stem.area(i) / kPi);
      EXPECT_LT(*lo, 0.85 * r);  // 0.75 r, give or take the ovality and lobes
      EXPECT_GT(*hi, 1.15 * r);
    }
    EXPECT_FALSE(ecc.knots.empty());
  }
}

// Not asked (eccentricity_max < 0), the other eccentricity options change nothing: the log is
// the default's, byte for byte (the committed samples below check the default itself).
TEST(LogGenerator, EccentricityNotAskedLeavesTheLogAsItWas) {
  for (Species sp : kSpecies) {
    const std::string plain = log_to_json(make(sp, 11));
    EXPECT_EQ(log_to_json(make(sp, 11,
                               [](GeneratorOptions& o) {
                                 o.eccentricity_min = 0.1;
                                 o.eccentricity_change = 0.2;
                                 o.eccentricity_turn_rad = 1.0;
                               })),
              plain);
    EXPECT_NE(log_to_json(eccentric(sp, 11, 0.1, 0.2)), plain);
  }
}

// ---- Committed samples and the command line ----------------------------------------------------

TEST(LogGenerator, CommittedSampleLogsAreExactlyWhatTheGeneratorMakes) {
  for (const Sample& smp : kSamples) {
    const std::string dir = std::string(name(smp.species)) + "_" + std::to_string(smp.seed);
    const fs::path path = test::sample_log(dir) / "log.json";
    const Result<std::string> text = read_text_file(path);
    ASSERT_TRUE(text) << text.error().message();
    EXPECT_EQ(text.value(), log_to_json(make(smp.species, smp.seed)))
        << path << " is stale: regenerate it (sample_logs/README.md)";
    EXPECT_LT(fs::file_size(path), 2u * 1000 * 1000) << path;
  }
}

TEST(LogGenerator, CommandLineWritesTheLibrarysLog) {
  test::TempDir tmp;
  const fs::path out = tmp / "pine.json";
  std::string output;
  ASSERT_EQ(
      test::run_sawyer("generate --species pine --seed 7 -o \"" + out.string() + "\"", &output), 0)
      << output;
  const Result<std::string> text = read_text_file(out);
  ASSERT_TRUE(text) << text.error().message();
  EXPECT_EQ(text.value(), log_to_json(make(Species::kPine, 7)));
  EXPECT_THAT(output, HasSubstr("pine_s7"));

  const fs::path ecc = tmp / "eccentric.json";
  ASSERT_EQ(test::run_sawyer("generate --species pine --seed 7 --eccentricity 0.1,0.25 "
                             "--eccentricity-change 0.08 --eccentricity-turn-rad 1 -o \"" +
                                 ecc.string() + "\"",
                             &output),
            0)
      << output;
  const Result<std::string> ecc_text = read_text_file(ecc);
  ASSERT_TRUE(ecc_text) << ecc_text.error().message();
  EXPECT_EQ(ecc_text.value(), log_to_json(make(Species::kPine, 7, [](GeneratorOptions& o) {
              o.eccentricity_min = 0.1;
              o.eccentricity_max = 0.25;
              o.eccentricity_change = 0.08;
              o.eccentricity_turn_rad = 1;
            })));
}

TEST(LogGenerator, CommandLineRejectsBadOptionsWithoutWriting) {
  test::TempDir tmp;
  const fs::path out = tmp / "bad.json";
  std::string output;
  EXPECT_NE(test::run_sawyer("generate --length-m -2 -o \"" + out.string() + "\"", &output), 0);
  EXPECT_THAT(output, HasSubstr("length"));
  EXPECT_NE(test::run_sawyer("generate --species oak -o \"" + out.string() + "\"", &output), 0);
  EXPECT_THAT(output, HasSubstr("oak"));
  EXPECT_NE(test::run_sawyer("generate --position root -o \"" + out.string() + "\"", &output), 0);
  EXPECT_THAT(output, HasSubstr("root"));
  EXPECT_NE(test::run_sawyer("generate --eccentricity 0.5 -o \"" + out.string() + "\"", &output),
            0);
  EXPECT_THAT(output, HasSubstr("--eccentricity"));
  EXPECT_NE(test::run_sawyer("generate --eccentricity 0.1,x -o \"" + out.string() + "\"", &output),
            0);
  EXPECT_THAT(output, HasSubstr("--eccentricity"));
  EXPECT_NE(
      test::run_sawyer("generate --eccentricity-change 0.1 -o \"" + out.string() + "\"", &output),
      0);
  EXPECT_THAT(output, HasSubstr("needs --eccentricity"));
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace sawyer
