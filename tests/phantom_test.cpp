// The phantom synthesiser: CT numbers of every region at points chosen from the model, ground
// truth against the model with the placement applied, annual rings from the wood field (and
// their distortion by knots), determinism and noise, placement, missing slices, bad input, and
// the written series read back through open_ct.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/phantom/phantom.h"
#include "sawyer/model/log_json.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

const LogModel& sample(const std::string& name) { return test::sample_model(name); }

// No noise, no blur: CT numbers exactly as the model gives them.
PhantomOptions quiet() {
  PhantomOptions o;
  o.noise_hu = 0;
  o.blur_px = 0;
  return o;
}

std::unique_ptr<Phantom> make(const LogModel& log, const PhantomOptions& o) {
  auto r = Phantom::create(log, o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message());
  return r.ok() ? std::move(r).value() : nullptr;
}

// Mean and standard deviation of a w x h window of a slice.
void window_stats(const Slice& s, int x0, int y0, int w, int h, double* mean, double* sd) {
  double a = 0, b = 0;
  for (int y = y0; y < y0 + h; ++y)
    for (int x = x0; x < x0 + w; ++x) {
      a += s.at(x, y);
      b += static_cast<double>(s.at(x, y)) * s.at(x, y);
    }
  const double n = static_cast<double>(w) * h;
  *mean = a / n;
  *sd = std::sqrt(std::max(0.0, b / n - *mean * *mean));
}

// Centroid (mm, scanner frame) of the pixels above `thr` HU.
Vec2 centroid(const Slice& s, double px, float thr = -800) {
  double sx = 0, sy = 0, n = 0;
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x)
      if (s.at(x, y) > thr) {
        sx += x * px;
        sy += y * px;
        n += 1;
      }
  return {sx / n, sy / n};
}

// Scanner point at log-frame pith distance r and azimuth w, height z.
Vec3 log_polar(const Phantom& p, double r, double w, double z) {
  const Vec2 c = p.log().stem.pith_at(z);
  return p.to_scanner({c.x + r * std::cos(w), c.y + r * std::sin(w), z});
}

// ---- options and bad input -------------------------------------------------------------------

TEST(PhantomOptions, RejectsNonsenseNamingTheOption) {
  auto expect_bad = [](PhantomOptions o, const std::string& word) {
    Status st = o.validate();
    ASSERT_FALSE(st.ok()) << word;
    EXPECT_NE(st.error().message().find(word), std::string::npos) << st.error().message();
    EXPECT_EQ(st.error().message().find('\n'), std::string::npos);
    EXPECT_FALSE(Phantom::create(sample("pine_8"), o).ok());
  };
  PhantomOptions o;
  EXPECT_TRUE(o.validate().ok());
  o = {};
  o.slice_spacing_mm = -5;
  expect_bad(o, "PhantomOptions::slice_spacing_mm");
  o = {};
  o.placement.tilt_x_deg = 12;
  expect_bad(o, "Placement::tilt_x_deg");
  o = {};
  o.placement.tilt_y_deg = -10.5;
  expect_bad(o, "Placement::tilt_y_deg");
  o = {};
  o.image_size = 0;
  expect_bad(o, "PhantomOptions::image_size");
  o = {};
  o.pixel_mm = 0;
  expect_bad(o, "PhantomOptions::pixel_mm");
  o = {};
  o.noise_hu = -1;
  expect_bad(o, "PhantomOptions::noise_hu");
  o = {};
  o.ring_width_mm = 0;
  expect_bad(o, "PhantomOptions::ring_width_mm");
  o = {};
  o.from_mm = 500;
  o.to_mm = 100;
  expect_bad(o, "PhantomOptions::from_mm");
  o = {};
  o.drop_slices = -1;
  expect_bad(o, "PhantomOptions::drop_slices");
}

TEST(Phantom, RejectsARangeOutsideTheLog) {
  PhantomOptions o;
  o.from_mm = -100;
  o.to_mm = 100;
  auto r = Phantom::create(sample("pine_8"), o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message().find("extent"), std::string::npos) << r.error().message();
}

TEST(Phantom, FieldOfViewCheckGivesTheSmallestPixelThatFits) {
  PhantomOptions o;
  o.from_mm = 1000;
  o.to_mm = 1100;
  o.pixel_mm = 0.4;  // 205 mm field of view: the 250 mm spruce does not fit
  auto r = Phantom::create(sample("gran1_spruce"), o);
  ASSERT_FALSE(r.ok());
  const std::string m = r.error().message();
  EXPECT_NE(m.find("does not fit the field of view"), std::string::npos) << m;
  const auto at = m.find("fits is ");
  ASSERT_NE(at, std::string::npos) << m;
  const double px = std::stod(m.substr(at + 8));
  EXPECT_GT(px, 0.4);
  o.pixel_mm = px;
  EXPECT_TRUE(Phantom::create(sample("gran1_spruce"), o).ok()) << px;
  o.pixel_mm = px - 0.01;
  EXPECT_FALSE(Phantom::create(sample("gran1_spruce"), o).ok()) << px;
}

// ---- CT numbers ------------------------------------------------------------------------------

// Pine_8 has heartwood, bark and knots with sound cores and dead outer parts.
TEST(PhantomHu, RegionsAtPointsFromTheModelAreInTheirRanges) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet();
  const double z = 1800;
  o.from_mm = z - 100;
  o.to_mm = z + 100;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  const Stem& st = log.stem;

  // Stem regions along azimuths with no knot near: air, bark, sapwood, heartwood.
  int checked = 0;
  for (int k = 0; k < 36 && checked < 6; ++k) {
    const double w = kTwoPi * k / 36;
    const double R = st.radius_at(w, z), H = st.heartwood_at(w, z);
    const PhantomPoint heart = ph->sample_point(log_polar(*ph, 0.3 * H, w, z));
    const PhantomPoint sap = ph->sample_point(log_polar(*ph, 0.5 * (H + R) + 0.25 * (R - H), w, z));
    if (heart.field.knot >= 0 || sap.field.knot >= 0) continue;
    ++checked;
    EXPECT_EQ(heart.region, Region::kHeartwood);
    EXPECT_GE(heart.hu, -600) << "heartwood 400-550 kg/m3";
    EXPECT_LE(heart.hu, -450);
    EXPECT_EQ(sap.region, Region::kSapwood);
    EXPECT_GE(sap.hu, -150) << "wet sapwood 850-1050 kg/m3";
    EXPECT_LE(sap.hu, 50);
    const PhantomPoint probe = ph->sample_point(log_polar(*ph, R + 0.1, w, z));
    const PhantomPoint bark = ph->sample_point(log_polar(*ph, R + 0.5 * probe.bark_mm, w, z));
    EXPECT_EQ(bark.region, Region::kBark);
    EXPECT_GE(bark.hu, -700) << "bark 300-600 kg/m3";
    EXPECT_LE(bark.hu, -400);
    const PhantomPoint air = ph->sample_point(log_polar(*ph, R + probe.bark_mm + 3, w, z));
    EXPECT_TRUE(air.region == Region::kAir || air.region == Region::kBed);
    if (air.region == Region::kAir) {
      EXPECT_FLOAT_EQ(air.hu, -1000);
    }
  }
  EXPECT_GE(checked, 6);

  // Knots: on the axis in the sound part and in the dead part.
  int sound = 0, dead = 0;
  double sound_sum = 0, dead_sum = 0;
  for (const Knot& k : log.knots) {
    // The mapping to the scanner holds at every height, so points beyond the scanned range
    // can be sampled too.
    const double rs = 0.7 * std::min(k.r_dead, k.r_end);
    if (rs > 8 && 0.5 * k.diameter_at(rs) > 2.5) {
      const PhantomPoint p = ph->sample_point(ph->to_scanner(k.axis_point(rs, st)));
      if (p.field.knot >= 0 && &log.knots[p.field.knot] == &k) {
        EXPECT_EQ(p.region, Region::kSoundKnot);
        EXPECT_GE(p.hu, -300) << "knots 700-1100 kg/m3";
        EXPECT_LE(p.hu, 100);
        sound_sum += p.hu;
        ++sound;
      }
    }
    if (k.r_end - k.r_dead > 8 && 0.5 * k.max_diameter() > 3) {
      const double rd = 0.5 * (k.r_dead + k.r_end);
      const PhantomPoint p = ph->sample_point(ph->to_scanner(k.axis_point(rd, st)));
      if (p.field.knot >= 0 && &log.knots[p.field.knot] == &k) {
        EXPECT_EQ(p.region, Region::kDeadKnot);
        EXPECT_GE(p.hu, -300);
        EXPECT_LE(p.hu, 100);
        dead_sum += p.hu;
        ++dead;
        // The encased bark ring at the dead knot's outline, straight above its axis.
        const Vec3 axis = k.axis_point(rd, st);
        const double rho = 0.5 * k.diameter_at(rd);
        int ring = 0;
        for (double f = 0.85; f < 1.0; f += 0.01) {
          const PhantomPoint q =
              ph->sample_point(ph->to_scanner({axis.x, axis.y, axis.z + f * rho}));
          if (q.region == Region::kKnotBark) {
            ++ring;
            EXPECT_LE(q.hu, -400);
          }
        }
        EXPECT_GT(ring, 0) << "knot " << k.id;
      }
    }
    if (sound >= 5 && dead >= 5) break;
  }
  ASSERT_GE(sound, 3);
  ASSERT_GE(dead, 3);
  EXPECT_GT(sound_sum / sound, dead_sum / dead + 80) << "sound knots are denser than dead ones";
}

TEST(PhantomHu, KnotsContrastStronglyInHeartwoodAndLittleInSapwood) {
  const HuTable hu;
  EXPECT_GT(hu.sound_knot - hu.heartwood, 300);
  EXPECT_LT(std::abs(hu.sound_knot - hu.sapwood), 100);
  EXPECT_GT(hu.dead_knot - hu.heartwood, 200);
}

TEST(PhantomHu, RenderedRegionsKeepTheirMeansUnderBlurAndNoise) {
  const LogModel& log = sample("spruce_77");
  PhantomOptions o;  // default noise and blur
  o.from_mm = o.to_mm = 2000;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  const Slice s = ph->render_slice(0);
  const double px = o.pixel_mm;
  const double z = ph->pith_log_z(0);
  int checked = 0;
  for (int k = 0; k < 24; ++k) {
    const double w = kTwoPi * k / 24;
    const double R = log.stem.radius_at(w, z), H = log.stem.heartwood_at(w, z);
    struct Probe {
      double r;
      double lo, hi;
    };
    bool clear = true;
    for (double r = 0.2 * H; r < R - 2; r += 1)
      if (ph->sample_point(log_polar(*ph, r, w, z)).field.knot >= 0) clear = false;
    if (!clear) continue;
    ++checked;
    for (Probe p : {Probe{0.4 * H, -600, -450}, Probe{0.5 * (H + R) + 0.2 * (R - H), -150, 50}}) {
      const Vec3 c = log_polar(*ph, p.r, w, z);
      double mean, sd;
      window_stats(s, static_cast<int>(std::lround(c.x / px)) - 2,
                   static_cast<int>(std::lround(c.y / px)) - 2, 5, 5, &mean, &sd);
      EXPECT_GE(mean, p.lo) << "r " << p.r << " w " << w;
      EXPECT_LE(mean, p.hi) << "r " << p.r << " w " << w;
    }
  }
  EXPECT_GE(checked, 3);
}

// The rendered slice (no blur, no noise, one sub-slice) agrees with the point sampler, which
// uses the field's exact 3D sample() instead of its per-height Slice.
TEST(PhantomHu, RenderedSliceAgreesWithPointSamples) {
  PhantomOptions o = quiet();
  o.sub_slices = 1;
  o.image_size = 256;
  o.pixel_mm = 1.4;
  o.from_mm = o.to_mm = 1210;
  auto ph = make(sample("spruce_77"), o);
  ASSERT_TRUE(ph);
  const Slice s = ph->render_slice(0);
  int n = 0, off = 0;
  for (int y = 0; y < s.height; y += 2)
    for (int x = 0; x < s.width; x += 2) {
      const PhantomPoint p = ph->sample_point({x * o.pixel_mm, y * o.pixel_mm, 0});
      if (p.region == Region::kAir) continue;
      ++n;
      if (std::abs(p.hu - s.at(x, y)) > 2) ++off;
    }
  ASSERT_GT(n, 1000);
  EXPECT_LT(off, 0.01 * n) << off << " of " << n;
}

// ---- ground truth ----------------------------------------------------------------------------

TEST(PhantomTruth, PithAndOutlineAreTheModelsWithThePlacementApplied) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet();
  o.from_mm = 1000;
  o.to_mm = 1500;
  o.placement.offset_x_mm = 15;
  o.placement.offset_y_mm = -10;
  o.placement.roll_deg = 30;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  const LogModel t = ph->truth_log();
  ASSERT_EQ(t.stem.slice_count(), ph->nominal_count());
  EXPECT_EQ(t.stem.z0_mm, 0);
  EXPECT_EQ(t.stem.dz_mm, o.slice_spacing_mm);
  const double centre = 0.5 * (o.image_size - 1) * o.pixel_mm;
  const double roll = 30 * kPi / 180;
  const double zc = 0.5 * (1000 + 1500);
  const Vec2 pc = log.stem.pith_at(zc);
  for (int i = 0; i < t.stem.slice_count(); ++i) {
    const double z = 1000 + i * o.slice_spacing_mm;
    const Vec2 d = log.stem.pith_at(z) - pc;
    const Vec2 want{centre + 15 + std::cos(roll) * d.x - std::sin(roll) * d.y,
                    centre - 10 + std::sin(roll) * d.x + std::cos(roll) * d.y};
    EXPECT_NEAR(t.stem.pith[i].x, want.x, 1e-6) << i;
    EXPECT_NEAR(t.stem.pith[i].y, want.y, 1e-6) << i;
    EXPECT_NEAR(ph->pith(i).x, want.x, 1e-6);
    for (int k = 0; k < t.stem.n_angles; k += 7) {
      const double w = kTwoPi * k / t.stem.n_angles;
      EXPECT_NEAR(t.stem.radius[i][k], log.stem.radius_at(w - roll, z), 1e-4) << i << " " << k;
      EXPECT_NEAR(t.stem.heartwood[i][k], log.stem.heartwood_at(w - roll, z), 1e-4);
    }
  }
  // The truth is a valid log model that round-trips through log.json.
  EXPECT_TRUE(validate(t).ok());
  TempDir tmp;
  ASSERT_TRUE(ph->write_truth(tmp.path()).ok());
  auto back = read_log_json(tmp / "truth/log.json");
  ASSERT_TRUE(back.ok()) << back.error().message();
  EXPECT_EQ(back.value().knots.size(), t.knots.size());
  std::ifstream in(tmp / "truth/phantom.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["format"], "sawyer-phantom/1");
  ASSERT_EQ(j["slices"].size(), static_cast<size_t>(ph->nominal_count()));
  EXPECT_NEAR(j["slices"][7]["pith"][0].get<double>(), ph->pith(7).x, 1e-9);
  EXPECT_EQ(j["options"]["seed"].get<std::uint64_t>(), o.seed);
  EXPECT_EQ(j["hu"]["sapwood"].get<double>(), o.hu.sapwood);
}

// Knot axes of the truth against the model's knot axes mapped into the scanner.
double max_knot_error(const Phantom& ph) {
  const LogModel& log = ph.log();
  const LogModel t = ph.truth_log();
  double worst = 0;
  int compared = 0;
  for (const Knot& q : t.knots) {
    const Knot* k = nullptr;
    for (const Knot& m : log.knots)
      if (m.id == q.id) k = &m;
    if (!k) return 1e9;
    for (double r = 2; r <= k->r_end; r += 2) {
      const Vec3 want = ph.to_scanner(k->axis_point(r, log.stem));
      if (want.z < 0 || want.z > t.stem.z_end() - t.stem.dz_mm) continue;  // outside the scan
      // The truth's knot at the same scanner pith distance (a tilt changes pith distances).
      const Vec2 pc = t.stem.pith_at(want.z);
      const Vec3 got = q.axis_point(std::hypot(want.x - pc.x, want.y - pc.y), t.stem);
      worst = std::max(worst, (got - want).norm());
      ++compared;
    }
  }
  EXPECT_GT(compared, 50);
  return worst;
}

TEST(PhantomTruth, KnotsFollowTheRollAndOffsetExactly) {
  PhantomOptions o = quiet();
  o.from_mm = 800;
  o.to_mm = 2000;
  o.placement = {20, 5, 0, 0, 75};
  auto ph = make(sample("spruce_77"), o);
  ASSERT_TRUE(ph);
  EXPECT_LT(max_knot_error(*ph), 0.05);  // pith interpolation at the slice step only
}

TEST(PhantomTruth, KnotsFollowATiltApproximately) {
  PhantomOptions o = quiet();
  o.from_mm = 800;
  o.to_mm = 2000;
  o.placement = {0, 0, 3, -2, 10};
  auto ph = make(sample("spruce_77"), o);
  ASSERT_TRUE(ph);
  EXPECT_LT(max_knot_error(*ph), 0.3);  // a least-squares refit (docs/phantom.md)
}

// ---- rings -----------------------------------------------------------------------------------

// Along a knot-free radius the rings follow t with ring_count = R_ref / ring width: count the
// sharp drops at the ring borders in point samples from pith to bark, and find the period in a
// rendered row.
TEST(PhantomRings, ModulationIsPeriodicWithTheExpectedRingCount) {
  const LogModel& log = sample("spruce_77");
  PhantomOptions o = quiet();
  o.ring_width_mm = 2;
  o.sub_slices = 1;
  // Rings from pith to bark: the field's reference radius over the ring width.
  const double N = WoodField(log).reference_radius() / o.ring_width_mm;
  bool found = false;
  for (double z = 300; z < 3800 && !found; z += 97) {
    o.from_mm = o.to_mm = z;
    auto ph = make(log, o);
    ASSERT_TRUE(ph);
    EXPECT_NEAR(ph->ring_count(), N, 1e-9);
    const double zl = ph->pith_log_z(0);
    // The +x scanner direction from the pith (a row of the image).
    const Vec2 pc = ph->pith(0);
    const double R = log.stem.radius_at(0, zl), H = log.stem.heartwood_at(0, zl);
    const double r0 = 3, r1 = R - 2;
    std::vector<PhantomPoint> pts;
    bool clear = true;
    for (double r = r0; r <= r1 && clear; r += 0.05) {
      pts.push_back(ph->sample_point({pc.x + r, pc.y, 0}));
      clear = pts.back().field.knot < 0 &&
              std::abs(pts.back().field.t - pts.back().field.t_stem) < 0.01;
    }
    if (!clear) continue;
    found = true;
    // Ring borders (integer crossings of t·N, and of the stem's own t_s·N) and sharp drops in
    // the CT numbers, away from the heartwood/sapwood step where a drop can hide in the rise.
    auto masked = [&](size_t i) { return std::abs(r0 + 0.05 * i - H) < 4; };
    int borders = 0, stem_borders = 0, drops = 0;
    const double drop = 0.3 * o.ring_amplitude * o.hu.dry_wood_density;
    for (size_t i = 1; i < pts.size(); ++i) {
      if (masked(i) || masked(i - 1)) continue;
      borders += std::floor(pts[i].field.t * N) > std::floor(pts[i - 1].field.t * N);
      stem_borders += std::floor(pts[i].field.t_stem * N) > std::floor(pts[i - 1].field.t_stem * N);
    }
    for (size_t i = 6; i < pts.size(); ++i) {
      if (masked(i) || masked(i - 6)) continue;
      if (pts[i - 6].hu - pts[i].hu > drop && pts[i - 1].hu - pts[i].hu > 0) {
        ++drops;
        i += 10;
      }
    }
    EXPECT_NEAR(drops, borders, 1) << "z " << z;
    EXPECT_NEAR(stem_borders, borders, 1) << "z " << z;
    EXPECT_GE(borders, 35);

    // Rendered row (default blur, 4 mm rings to stay clear of the pixel grid's limit): the
    // dominant period is the local ring width in pixels.
    PhantomOptions ob = o;
    ob.blur_px = 0.7;
    ob.ring_width_mm = 4;
    auto pb = make(log, ob);
    const Slice s = pb->render_slice(0);
    const int row = static_cast<int>(std::lround(pc.y / o.pixel_mm));
    // The sapwood part of the row: no heartwood step in it.
    const int c0 = static_cast<int>(std::ceil((pc.x + H + 4) / o.pixel_mm));
    const int c1 = static_cast<int>(std::floor((pc.x + r1 - 2) / o.pixel_mm));
    ASSERT_GT(c1 - c0, 15);
    std::vector<double> v;
    for (int c = c0; c <= c1; ++c) v.push_back(s.at(c, row));
    const double mean = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
    double best = 0, best_p = 0;
    for (double p = 2.5; p <= 12; p += 0.02) {
      double re = 0, im = 0;
      for (size_t i = 0; i < v.size(); ++i) {
        re += (v[i] - mean) * std::cos(kTwoPi * i / p);
        im += (v[i] - mean) * std::sin(kTwoPi * i / p);
      }
      if (re * re + im * im > best) {
        best = re * re + im * im;
        best_p = p;
      }
    }
    const double want = R / (N / 2) / o.pixel_mm;
    EXPECT_NEAR(best_p, want, 0.15 * want) << "z " << z;
  }
  EXPECT_TRUE(found) << "no knot-free radius in the sapwood";
}

// Near a knot the field's t is not the stem's r / R, and the phantom's CT numbers show it:
// they differ from a phantom of the same stem without knots, while far from knots they agree.
TEST(PhantomRings, KnotsDistortTheRings) {
  const LogModel& log = sample("spruce_77");
  LogModel bare = log;
  bare.knots.clear();
  int near_checked = 0, far_checked = 0;
  for (const Knot& k : log.knots) {
    const double r = 0.6 * std::min(k.r_dead, k.r_end);
    const double rho = 0.5 * k.diameter_at(r);
    if (rho < 3 || r < 15) continue;
    const Vec3 a = k.axis_point(r, log.stem);
    const double z = a.z + 1.8 * rho;  // above the knot, outside it
    if (z < log.stem.z_begin() + 5 || z > log.stem.z_end() - 5) continue;
    PhantomOptions o = quiet();
    o.from_mm = o.to_mm = z;
    auto pk = make(log, o);
    auto pb = make(bare, o);
    ASSERT_TRUE(pk && pb);
    const Vec3 s = pk->to_scanner({a.x, a.y, z});
    const PhantomPoint with = pk->sample_point(s);
    const PhantomPoint without = pb->sample_point(s);
    if (with.field.knot >= 0) continue;  // inside a neighbour
    EXPECT_GT(std::abs(with.field.t - with.field.t_stem), 0.003) << "knot " << k.id;
    EXPECT_FLOAT_EQ(without.field.t, without.field.t_stem);
    if (std::abs(with.hu - without.hu) > 0.5) ++near_checked;
    // Far from every knot's influence the two phantoms agree.
    const Vec2 pc = log.stem.pith_at(z);
    for (int j = 0; j < 16; ++j) {
      const double w = kTwoPi * j / 16;
      const Vec3 f = pk->to_scanner({pc.x + 5 * std::cos(w), pc.y + 5 * std::sin(w), z});
      const PhantomPoint fw = pk->sample_point(f);
      if (fw.field.t != fw.field.t_stem || fw.field.knot >= 0) continue;
      EXPECT_FLOAT_EQ(fw.hu, pb->sample_point(f).hu);
      ++far_checked;
    }
    if (near_checked >= 5) break;
  }
  EXPECT_GE(near_checked, 5);
  EXPECT_GT(far_checked, 0);
}

// ---- determinism and noise -------------------------------------------------------------------

TEST(PhantomNoise, SameSeedGivesIdenticalSlicesInAnyOrder) {
  PhantomOptions o;
  o.image_size = 256;
  o.pixel_mm = 1.4;
  o.from_mm = 1000;
  o.to_mm = 1040;
  o.placement.tilt_x_deg = 2;  // exercises the tilted height cache too
  o.clutter = true;
  auto ph = make(sample("pine_8"), o);
  ASSERT_TRUE(ph);
  Phantom::Renderer a(*ph), b(*ph);
  Slice s1, s3, t3, t1;
  a.render(1, s1);
  a.render(3, s3);
  b.render(3, t3);
  b.render(1, t1);
  EXPECT_EQ(s1.hu, t1.hu);
  EXPECT_EQ(s3.hu, t3.hu);
  EXPECT_EQ(ph->render_slice(3).hu, s3.hu);
  auto again = make(sample("pine_8"), o);
  EXPECT_EQ(again->render_slice(1).hu, s1.hu);
}

TEST(PhantomNoise, DifferentSeedsDifferOnlyByNoise) {
  PhantomOptions o;
  o.image_size = 256;
  o.pixel_mm = 1.4;
  o.from_mm = o.to_mm = 1500;
  o.noise_hu = 20;
  o.seed = 1;
  auto p1 = make(sample("pine_8"), o);
  o.seed = 2;
  auto p2 = make(sample("pine_8"), o);
  const Slice a = p1->render_slice(0), b = p2->render_slice(0);
  double s = 0, ss = 0;
  for (size_t i = 0; i < a.hu.size(); ++i) {
    const double d = a.hu[i] - b.hu[i];
    s += d;
    ss += d * d;
  }
  const double n = static_cast<double>(a.hu.size());
  EXPECT_NEAR(s / n, 0, 0.5);
  EXPECT_NEAR(std::sqrt(ss / n), std::sqrt(2.0) * 20, 0.1 * std::sqrt(2.0) * 20);
  // Without noise the seed changes nothing (the anatomy is not seeded).
  o.noise_hu = 0;
  o.seed = 1;
  auto q1 = make(sample("pine_8"), o);
  o.seed = 2;
  auto q2 = make(sample("pine_8"), o);
  EXPECT_EQ(q1->render_slice(0).hu, q2->render_slice(0).hu);
}

TEST(PhantomNoise, SigmaInAUniformRegionMatchesTheOption) {
  for (double sigma : {10.0, 25.0}) {
    PhantomOptions o;
    o.noise_hu = sigma;
    o.from_mm = o.to_mm = 2000;
    auto ph = make(sample("spruce_77"), o);
    ASSERT_TRUE(ph);
    const Slice s = ph->render_slice(0);
    double mean, sd;
    window_stats(s, 4, 4, 60, 60, &mean, &sd);  // air in the corner, far from log and bed
    EXPECT_NEAR(sd, sigma, 0.15 * sigma);
    EXPECT_NEAR(mean, -1000, 3);
  }
}

// ---- placement -------------------------------------------------------------------------------

TEST(PhantomPlacement, OffsetMovesTheLogByTheOffset) {
  PhantomOptions o = quiet();
  o.bed = false;
  o.from_mm = o.to_mm = 2500;
  auto p0 = make(sample("spruce_77"), o);
  o.placement.offset_x_mm = 31.5;
  o.placement.offset_y_mm = -18;
  auto p1 = make(sample("spruce_77"), o);
  ASSERT_TRUE(p0 && p1);
  const Vec2 c0 = centroid(p0->render_slice(0), o.pixel_mm);
  const Vec2 c1 = centroid(p1->render_slice(0), o.pixel_mm);
  EXPECT_NEAR(c1.x - c0.x, 31.5, 0.2);
  EXPECT_NEAR(c1.y - c0.y, -18, 0.2);
  EXPECT_NEAR(p1->pith(0).x - p0->pith(0).x, 31.5, 1e-9);
  EXPECT_NEAR(p1->truth_log().stem.pith[0].y - p0->pith(0).y, -18, 1e-9);
}

TEST(PhantomPlacement, TiltMovesTheLogWhereTheTruthSays) {
  PhantomOptions o = quiet();
  o.bed = false;
  o.from_mm = 1000;
  o.to_mm = 2000;
  auto p0 = make(sample("spruce_77"), o);
  o.placement.tilt_x_deg = 4;
  o.placement.tilt_y_deg = -3;
  auto p1 = make(sample("spruce_77"), o);
  ASSERT_TRUE(p0 && p1);
  const LogModel t0 = p0->truth_log(), t1 = p1->truth_log();
  for (int i : {0, p1->nominal_count() / 2, p1->nominal_count() - 1}) {
    const Vec2 c0 = centroid(p0->render_slice(i), o.pixel_mm);
    const Vec2 c1 = centroid(p1->render_slice(i), o.pixel_mm);
    const Vec2 moved = t1.stem.pith[i] - t0.stem.pith[i];
    EXPECT_GT(moved.norm(), i == p1->nominal_count() / 2 ? -1 : 20) << i;
    EXPECT_NEAR(c1.x - c0.x, moved.x, 1.0) << i;
    EXPECT_NEAR(c1.y - c0.y, moved.y, 1.0) << i;
    // The truth's pith is where the rendered log has its pith.
    const PhantomPoint p =
        p1->sample_point({t1.stem.pith[i].x, t1.stem.pith[i].y, t1.stem.z_at(i)});
    EXPECT_LT(p.field.r, 1e-3) << i;
    // The truth's outline is where the rendered log's wood ends.
    for (int k = 0; k < t1.stem.n_angles; k += 15) {
      const double w = kTwoPi * k / t1.stem.n_angles, R = t1.stem.radius[i][k];
      auto at = [&](double r) {
        const PhantomPoint q =
            p1->sample_point({t1.stem.pith[i].x + r * std::cos(w),
                              t1.stem.pith[i].y + r * std::sin(w), t1.stem.z_at(i)});
        return q.field.r <= q.field.radius;
      };
      EXPECT_TRUE(at(R - 0.05)) << i << " " << k;
      EXPECT_FALSE(at(R + 0.05)) << i << " " << k;
    }
  }
}

// ---- missing slices --------------------------------------------------------------------------

TEST(PhantomMissing, DroppedSlicesAreListedAndLeftOut) {
  PhantomOptions o = quiet();
  o.from_mm = 1000;
  o.to_mm = 1100;
  o.drop_slices = 4;
  o.seed = 9;
  auto ph = make(sample("pine_8"), o);
  ASSERT_TRUE(ph);
  ASSERT_EQ(ph->nominal_count(), 21);
  ASSERT_EQ(ph->dropped().size(), 4u);
  EXPECT_EQ(ph->geometry().slice_count(), 17);
  EXPECT_EQ(ph->kept().front(), 0);
  EXPECT_EQ(ph->kept().back(), 20);
  for (int d : ph->dropped()) {
    EXPECT_EQ(std::count(ph->kept().begin(), ph->kept().end(), d), 0);
    EXPECT_EQ(std::count(ph->geometry().z.begin(), ph->geometry().z.end(), ph->nominal_z(d)), 0);
  }
  const nlohmann::json j = nlohmann::json::parse(ph->truth_json());
  EXPECT_EQ(j["dropped"].get<std::vector<int>>(), ph->dropped());
  int flagged = 0;
  for (const auto& s : j["slices"]) flagged += s["dropped"].get<bool>();
  EXPECT_EQ(flagged, 4);
  o.drop_slices = 20;
  EXPECT_FALSE(Phantom::create(sample("pine_8"), o).ok());
}

// ---- writing ---------------------------------------------------------------------------------

TEST(PhantomWrite, DicomSectionReadsBackWithItsGeometryAndHu) {
  PhantomOptions o;
  o.image_size = 256;
  o.pixel_mm = 1.4;
  o.from_mm = 1200;
  o.to_mm = 1240;
  o.clutter = true;
  auto ph = make(sample("pine_8"), o);
  ASSERT_TRUE(ph);
  TempDir tmp;
  const fs::path out = tmp / "scan";
  auto sum = write_phantom(*ph, out, {});
  ASSERT_TRUE(sum.ok()) << sum.error().message();
  EXPECT_EQ(sum.value().slices, 9);
  EXPECT_TRUE(fs::exists(out / "truth/log.json"));
  EXPECT_TRUE(fs::exists(out / "truth/phantom.json"));
  int entries = 0;
  for (const auto& e : fs::directory_iterator(tmp.path())) entries += e.path() != out;
  EXPECT_EQ(entries, 0) << "no temporary folder left";

  OpenOptions oo;
  oo.z_policy = ZPolicy::kReject;
  auto src = open_ct(out, oo);
  ASSERT_TRUE(src.ok()) << src.error().message();
  const VolumeGeometry& g = src.value()->geometry();
  EXPECT_EQ(src.value()->format(), Format::kDicom);
  EXPECT_EQ(g.width, 256);
  EXPECT_EQ(g.height, 256);
  EXPECT_NEAR(g.spacing_x, 1.4, 1e-6);
  EXPECT_NEAR(g.spacing_y, 1.4, 1e-6);
  ASSERT_EQ(g.slice_count(), 9);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(g.z[i], ph->geometry().z[i], 1e-4);
  Slice s;
  for (int i : {0, 4, 8}) {
    ASSERT_TRUE(src.value()->read(i, s).ok());
    const Slice want = ph->render_slice(i);
    float worst = 0;
    for (size_t p = 0; p < s.hu.size(); ++p) {
      const float w = std::clamp(want.hu[p], -32768.0f, 32767.0f);
      worst = std::max(worst, std::abs(s.hu[p] - w));
    }
    EXPECT_LE(worst, 0.5f + 1e-3f) << "slice " << i;
  }
}

// Same seed, same bytes: every file of two writes with different thread counts is identical.
TEST(PhantomWrite, SameSeedWritesTheSameBytesWithAnyThreadCount) {
  PhantomOptions o;
  o.image_size = 256;
  o.pixel_mm = 1.4;
  o.from_mm = 1200;
  o.to_mm = 1260;
  o.clutter = true;
  TempDir tmp;
  for (int threads : {1, 2}) {
    o.threads = threads;
    auto ph = make(sample("pine_8"), o);
    ASSERT_TRUE(ph);
    ASSERT_TRUE(write_phantom(*ph, tmp / (threads == 1 ? "t1" : "t2"), {}).ok());
  }
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(tmp / "t1")) {
    if (!e.is_regular_file()) continue;
    const fs::path other = tmp / "t2" / fs::relative(e.path(), tmp / "t1");
    ASSERT_TRUE(fs::exists(other)) << other;
    EXPECT_EQ(bytes(e.path()), bytes(other)) << e.path();
    ++files;
  }
  EXPECT_EQ(files, 13 + 2);
}

TEST(PhantomWrite, MissingSlicesAreAbsentFromTheStack) {
  PhantomOptions o;
  o.image_size = 256;
  o.pixel_mm = 1.4;
  o.from_mm = 1200;
  o.to_mm = 1300;
  o.drop_slices = 3;
  auto ph = make(sample("pine_8"), o);
  ASSERT_TRUE(ph);
  TempDir tmp;
  const fs::path out = tmp / "stack";
  PhantomWriteOptions wo;
  wo.format = Format::kTiffStack;
  ASSERT_TRUE(write_phantom(*ph, out, wo).ok());
  int tifs = 0;
  for (const auto& e : fs::directory_iterator(out)) tifs += e.path().extension() == ".tif";
  EXPECT_EQ(tifs, 21 - 3);
  OpenOptions oo;
  oo.z_policy = ZPolicy::kReject;
  auto src = open_ct(out, oo);
  ASSERT_FALSE(src.ok()) << "the gaps must show";
}

TEST(PhantomWrite, RefusesToReplaceAFolderThatIsNotAPhantom) {
  PhantomOptions o;
  o.image_size = 256;
  o.pixel_mm = 1.4;
  o.from_mm = o.to_mm = 1200;
  auto ph = make(sample("pine_8"), o);
  TempDir tmp;
  test::write_file(tmp / "scans/keep.txt", "precious");
  auto r = write_phantom(*ph, tmp / "scans", {});
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(fs::exists(tmp / "scans/keep.txt"));
  // An earlier phantom is replaced.
  ASSERT_TRUE(write_phantom(*ph, tmp / "ph", {}).ok());
  EXPECT_TRUE(write_phantom(*ph, tmp / "ph", {}).ok());
}

// ---- command line ----------------------------------------------------------------------------

TEST(PhantomCli, WritesAShortSectionWithTruth) {
  TempDir tmp;
  std::string out;
  const std::string log = (test::sample_log("pine_8") / "log.json").string();
  const int rc = test::run_sawyer("phantom " + test::quoted(log) + " -o " +
                                      test::quoted((tmp / "png").string()) +
                                      " --format png --from-mm 1000 --to-mm 1020 --size 256 "
                                      "--pixel-mm 1.4 --seed 3",
                                  &out);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_TRUE(fs::exists(tmp / "png/truth/log.json")) << out;
  int pngs = 0;
  for (const auto& e : fs::directory_iterator(tmp / "png")) pngs += e.path().extension() == ".png";
  EXPECT_EQ(pngs, 5);
}

TEST(PhantomCli, BadInputGetsOneLineAndNoOutput) {
  TempDir tmp;
  test::write_file(tmp / "bad.json", "{ \"format\": \"sawyer-log/1\", ");
  const std::string good = (test::sample_log("gran1_spruce") / "log.json").string();
  struct Case {
    std::string args, expect;
  };
  const std::vector<Case> cases = {
      {test::quoted((tmp / "missing.json").string()), "missing.json"},
      {test::quoted((tmp / "bad.json").string()), "bad.json"},
      {test::quoted(good) + " --spacing-mm -5", "--spacing-mm"},
      {test::quoted(good) + " --tilt-x-deg 12", "--tilt-x-deg"},
      {test::quoted(good) + " --pixel-mm 0.3", "smallest pixel size"},
      {test::quoted(good) + " --format jpeg", "--format"},
      {test::quoted(good) + " --from-mm 5000 --to-mm 5100", "extent"},
  };
  for (const Case& c : cases) {
    std::string out;
    const int rc =
        test::run_sawyer("phantom " + c.args + " -o " + test::quoted((tmp / "out").string()), &out);
    EXPECT_NE(rc, 0) << c.args;
    EXPECT_NE(out.find(c.expect), std::string::npos) << c.args << "\n" << out;
    EXPECT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
    EXPECT_FALSE(fs::exists(tmp / "out")) << c.args;
  }
}

}  // namespace
}  // namespace sawyer::ct
