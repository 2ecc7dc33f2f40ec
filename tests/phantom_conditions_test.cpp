// The phantom's condition space (docs/phantom.md "Condition space"): each condition's options
// are range-checked, and for each one the truth describes what was drawn: ring contrast and
// width profile, density drift, moisture states and wet pockets, scanner calibration, cupping
// and windowed 8-bit export, cracks, resin and rot pockets, compression wood, bark patches and
// resin-soaked knots.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/phantom/phantom.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

const LogModel& sample(const std::string& name) { return test::sample_model(name); }

// No noise, no blur, one plane per slice: CT numbers exactly as the model gives them.
PhantomOptions quiet(double z) {
  PhantomOptions o;
  o.noise_hu = 0;
  o.blur_px = 0;
  o.sub_slices = 1;
  o.from_mm = o.to_mm = z;
  return o;
}

std::unique_ptr<Phantom> make(const LogModel& log, const PhantomOptions& o) {
  auto r = Phantom::create(log, o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message());
  return r.ok() ? std::move(r).value() : nullptr;
}

// Scanner point at log-frame pith distance r and azimuth w, height z.
Vec3 log_polar(const Phantom& p, double r, double w, double z) {
  const Vec2 c = p.log().stem.pith_at(z);
  return p.to_scanner({c.x + r * std::cos(w), c.y + r * std::sin(w), z});
}

Vec3 defect_centre(const Phantom& p, const Defect& d) {
  return log_polar(p, d.r_mm, d.omega, d.z_mm);
}

bool clear_of_knots(const PhantomPoint& q) {
  return q.field.knot < 0 && std::abs(q.field.t - q.field.t_stem) < 0.01;
}

double mean_of(const std::vector<double>& v) {
  double a = 0;
  for (double x : v) a += x;
  return a / v.size();
}

double sd_of(const std::vector<double>& v) {
  const double m = mean_of(v);
  double b = 0;
  for (double x : v) b += (x - m) * (x - m);
  return std::sqrt(b / v.size());
}

// Heartwood pixels of slice 0 clear of knots, at least 8 mm from the pith and the boundary.
std::vector<double> heartwood_pixels(const Phantom& ph, const Slice& s) {
  std::vector<double> v;
  const double px = ph.options().pixel_mm;
  for (int y = 0; y < s.height; y += 1)
    for (int x = 0; x < s.width; x += 1) {
      const PhantomPoint q = ph.sample_point({x * px, y * px, ph.nominal_z(0)});
      if (q.region != Region::kHeartwood || !clear_of_knots(q)) continue;
      if (q.field.r < 8 || q.field.r > q.heartwood_radius - 8) continue;
      v.push_back(s.at(x, y));
    }
  return v;
}

// ---- options ---------------------------------------------------------------------------------

TEST(PhantomConditions, OptionsOutsideTheirRangesAreRefusedNamingTheOption) {
  auto expect_bad = [](PhantomOptions o, const std::string& opt, const std::string& value) {
    Status st = o.validate();
    ASSERT_FALSE(st.ok()) << opt;
    const std::string m = st.error().message();
    EXPECT_NE(m.find(opt), std::string::npos) << m;
    EXPECT_NE(m.find(value), std::string::npos) << m;
    EXPECT_NE(m.find("outside"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos);
  };
  EXPECT_TRUE(PhantomOptions{}.validate().ok());
  PhantomOptions o;
  o.juvenile_ring_width_mm = 0.1;
  expect_bad(o, "PhantomOptions::juvenile_ring_width_mm", "0.1");
  o = {};
  o.ring_contrast_hu = 900;
  expect_bad(o, "PhantomOptions::ring_contrast_hu", "900");
  o = {};
  o.latewood_fraction = 0.95;
  expect_bad(o, "PhantomOptions::latewood_fraction", "0.95");
  o = {};
  o.density_drift_hu_per_m = 1e300;
  expect_bad(o, "PhantomOptions::density_drift_hu_per_m", "1e+300");
  o = {};
  o.wet_pockets = -1;
  expect_bad(o, "PhantomOptions::wet_pockets", "-1");
  o = {};
  o.hu_offset = 700;
  expect_bad(o, "PhantomOptions::hu_offset", "700");
  o = {};
  o.hu_slope = 0;
  expect_bad(o, "PhantomOptions::hu_slope", "0");
  o = {};
  o.cupping_hu = std::nan("");
  expect_bad(o, "PhantomOptions::cupping_hu", "nan");
  o = {};
  o.window_width_hu = 2;
  expect_bad(o, "PhantomOptions::window_width_hu", "2");
  o = {};
  o.cracks = 51;
  expect_bad(o, "PhantomOptions::cracks", "51");
  o = {};
  o.crack_width_mm = 0;
  expect_bad(o, "PhantomOptions::crack_width_mm", "0");
  o = {};
  o.compression_wood = 2;
  expect_bad(o, "PhantomOptions::compression_wood", "2");
  o = {};
  o.resin_knots = -0.5;
  expect_bad(o, "PhantomOptions::resin_knots", "-0.5");
  o = {};
  o.knot_bark_mm = 9;
  expect_bad(o, "PhantomOptions::knot_bark_mm", "9");
}

// ---- rings -----------------------------------------------------------------------------------

// The ring contrast option is the standard deviation of the ring signal in heartwood: measured
// on a rendered slice (no noise or blur), it matches within 10 %, for the weak end (spruce), the
// strong end (Douglas fir) and with a latewood plateau; the original phantom's is 0.08 × 420 HU
// peak to peak, about 9.9 HU.
TEST(PhantomConditions, RingContrastIsTheHeartwoodStd) {
  const LogModel& log = sample("pine_8");
  struct Case {
    double contrast, latewood;
  };
  for (const Case c : {Case{0, 0}, Case{30, 0}, Case{250, 0}, Case{120, 0.3}}) {
    PhantomOptions o = quiet(1500);
    o.image_size = 384;
    o.pixel_mm = 1.0;
    o.ring_width_mm = 4;
    o.ring_contrast_hu = c.contrast;
    o.latewood_fraction = c.latewood;
    o.knot_noise = 0;
    auto ph = make(log, o);
    ASSERT_TRUE(ph);
    const std::vector<double> v = heartwood_pixels(*ph, ph->render_slice(0));
    ASSERT_GT(v.size(), 2000u);
    const double want = c.contrast > 0 ? c.contrast : 9.87;
    const double got = sd_of(v);
    std::printf("ring contrast %.0f HU (latewood %.1f): heartwood std %.1f HU on %zu pixels\n",
                c.contrast, c.latewood, got, v.size());
    EXPECT_NEAR(got, want, 0.1 * want) << "requested " << c.contrast;
  }
  // What a scanner shows of it: 0.7 mm pixels, the default PSF and noise; narrow rings lose
  // most of their contrast to the PSF (figures in docs/phantom.md).
  for (double width : {4.0, 1.5}) {
    PhantomOptions o;
    o.from_mm = o.to_mm = 1500;
    o.pixel_mm = 0.7;
    o.ring_width_mm = width;
    o.ring_contrast_hu = 120;
    o.knot_noise = 0;
    auto ph = make(log, o);
    ASSERT_TRUE(ph);
    const double got = sd_of(heartwood_pixels(*ph, ph->render_slice(0)));
    const double rings_only = std::sqrt(std::max(0.0, got * got - o.noise_hu * o.noise_hu));
    std::printf(
        "120 HU rings of %.1f mm at 0.7 mm, PSF 0.7 px, noise 20 HU: std %.1f HU "
        "(%.1f HU without the noise)\n",
        width, got, rings_only);
    EXPECT_LT(rings_only, 120);
    EXPECT_GT(rings_only, width > 2 ? 70 : 20);
  }
}

// Rings counted in the CT numbers along a knot-free radius: wide (juvenile) near the pith,
// narrow (mature) outside, each within 15 % of the profile's width there.
TEST(PhantomConditions, JuvenileRingsNearThePithAreWiderThanTheOuterRings) {
  const LogModel& log = sample("pine_8");
  bool found = false;
  for (double z = 600; z < 5000 && !found; z += 131) {
    if (z > log.stem.z_end() - 10) break;
    PhantomOptions o = quiet(z);
    o.ring_width_mm = 1.2;
    o.juvenile_ring_width_mm = 5;
    o.juvenile_radius_mm = 40;
    o.ring_contrast_hu = 100;
    auto ph = make(log, o);
    ASSERT_TRUE(ph);
    for (double w = 0; w < kTwoPi && !found; w += 0.7) {
      const double R = log.stem.radius_at(w, z);
      std::vector<PhantomPoint> pts;
      bool clear = true;
      constexpr double kStep = 0.02;
      for (double r = 1; r < R - 3 && clear; r += kStep) {
        pts.push_back(ph->sample_point(log_polar(*ph, r, w, z)));
        clear = clear_of_knots(pts.back());
      }
      if (!clear) continue;
      found = true;
      // Latewood bands (the signal above its mean by 0.3 of the peak-to-peak modulation),
      // counted in one region (heartwood or sapwood: a constant base) at a time.
      auto width = [&](double r0, double r1, double* want) {
        std::vector<double> v;
        const size_t a = static_cast<size_t>((r0 - 1) / kStep),
                     b = static_cast<size_t>((r1 - 1) / kStep);
        for (size_t i = a; i < b; ++i) v.push_back(pts[i].hu);
        const double m = mean_of(v);
        const double thr = m + 0.3 * 100 / 0.2937;
        int bands = 0;
        for (size_t i = 1; i < v.size(); ++i) bands += v[i] > thr && v[i - 1] <= thr;
        const double t0 = pts[a].field.t, t1 = pts[b].field.t;
        *want = (r1 - r0) / (ph->rings_at(t1, w) - ph->rings_at(t0, w));
        return (r1 - r0) / std::max(bands, 1);
      };
      const double H = pts[0].heartwood_radius;
      ASSERT_GT(H, 45);
      double want_in, want_out;
      const double in = width(2, 32, &want_in);
      const double out = width(R - 38, R - 8, &want_out);
      std::printf("z %.0f: juvenile rings %.2f mm (profile %.2f), outer %.2f mm (profile %.2f)\n",
                  z, in, want_in, out, want_out);
      EXPECT_NEAR(in, want_in, 0.15 * want_in);
      EXPECT_NEAR(out, want_out, 0.15 * want_out);
      EXPECT_GT(want_in, 3.0);
      EXPECT_LT(want_out, 1.5);
    }
  }
  EXPECT_TRUE(found) << "no knot-free radius";
}

TEST(PhantomConditions, DensityDriftChangesTheWoodAlongTheLog) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(2000);
  o.ring_amplitude = 0;
  o.density_drift_hu_per_m = 40;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  int checked = 0;
  for (double w = 0; w < kTwoPi; w += 0.5) {
    const PhantomPoint a = ph->sample_point(log_polar(*ph, 20, w, 1000));
    const PhantomPoint b = ph->sample_point(log_polar(*ph, 20, w, 3000));
    if (a.region != Region::kHeartwood || b.region != Region::kHeartwood) continue;
    if (!clear_of_knots(a) || !clear_of_knots(b)) continue;
    EXPECT_NEAR(b.hu - a.hu, 80, 0.5);
    ++checked;
  }
  EXPECT_GT(checked, 3);
}

// ---- moisture --------------------------------------------------------------------------------

TEST(PhantomConditions, DriedLogReadsAboutMinus600Throughout) {
  const LogModel& log = sample("pine_8");
  for (Moisture m : {Moisture::kGreen, Moisture::kDried}) {
    PhantomOptions o;
    o.image_size = 384;
    o.pixel_mm = 1.0;
    o.from_mm = o.to_mm = 1500;
    o.moisture = m;
    auto ph = make(log, o);
    ASSERT_TRUE(ph);
    const Slice s = ph->render_slice(0);
    std::vector<double> heart, sap;
    for (int y = 0; y < s.height; y += 2)
      for (int x = 0; x < s.width; x += 2) {
        const PhantomPoint q = ph->sample_point({x * 1.0, y * 1.0, 0});
        if (q.field.knot >= 0 || q.region == Region::kAir) continue;
        if (q.region == Region::kHeartwood && q.field.r < q.heartwood_radius - 6)
          heart.push_back(s.at(x, y));
        if (q.region == Region::kSapwood && q.field.r > q.heartwood_radius + 6 &&
            q.field.r < q.field.radius - 3)
          sap.push_back(s.at(x, y));
      }
    ASSERT_GT(heart.size(), 200u);
    ASSERT_GT(sap.size(), 200u);
    std::printf("%s: heartwood %.0f HU, sapwood %.0f HU\n", moisture_name(m), mean_of(heart),
                mean_of(sap));
    if (m == Moisture::kDried) {
      EXPECT_NEAR(mean_of(heart), -600, 15);
      EXPECT_NEAR(mean_of(sap), -600, 15);
      EXPECT_EQ(ph->hu().sapwood, -600);
    } else {
      EXPECT_GT(mean_of(sap) - mean_of(heart), 300);
    }
  }
}

TEST(PhantomConditions, WetPocketsInTheHeartwoodReadAsSapwood) {
  const LogModel& log = sample("spruce_77");
  PhantomOptions o = quiet(1800);
  o.ring_amplitude = 0;
  o.wet_pockets = 6;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  const nlohmann::json truth = nlohmann::json::parse(ph->truth_json());
  int listed = 0;
  for (const auto& d : truth["defects"]) listed += d["kind"] == "wet_pocket";
  EXPECT_EQ(listed, 6);
  int wet = 0;
  for (const Defect& d : ph->defects()) {
    ASSERT_EQ(d.kind, "wet_pocket");
    const PhantomPoint c = ph->sample_point(defect_centre(*ph, d));
    if (c.field.knot >= 0) continue;  // a knot through the pocket's centre
    EXPECT_EQ(c.region, Region::kWetPocket);
    EXPECT_NEAR(c.hu, ph->hu().sapwood, 1.0);
    // Beyond its extent (1.25 × its semi-axis, the outline's largest lobe) it is heartwood.
    const PhantomPoint f =
        ph->sample_point(log_polar(*ph, d.r_mm - 1.3 * d.radial_mm, d.omega, d.z_mm));
    if (f.field.knot < 0 && f.region != Region::kWetPocket) {
      EXPECT_NEAR(f.hu, ph->hu().heartwood, 1.0);
    }
    ++wet;
  }
  EXPECT_GE(wet, 4);
}

// ---- scanner ---------------------------------------------------------------------------------

TEST(PhantomConditions, CalibrationOffsetAndSlopeApplyToEveryValue) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(1500);
  o.image_size = 256;
  o.pixel_mm = 1.4;
  auto base = make(log, o);
  o.hu_offset = 150;
  o.hu_slope = 1.1;
  auto cal = make(log, o);
  ASSERT_TRUE(base && cal);
  const Slice a = base->render_slice(0), b = cal->render_slice(0);
  float worst = 0;
  for (size_t p = 0; p < a.hu.size(); ++p)
    worst = std::max(worst, std::abs(b.hu[p] - (150 + 1.1f * a.hu[p])));
  EXPECT_LT(worst, 0.05f);
  EXPECT_NEAR(b.at(0, 0), 150 - 1100, 0.05);  // air
  const Vec3 s = log_polar(*cal, 10, 0.3, 1500);
  EXPECT_NEAR(cal->sample_point(s).hu, 150 + 1.1 * base->sample_point(s).hu, 0.05);
}

TEST(PhantomConditions, CuppingLowersTheCentreOfTheSection) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(1500);
  o.ring_amplitude = 0;
  auto base = make(log, o);
  o.cupping_hu = 80;
  auto cup = make(log, o);
  ASSERT_TRUE(base && cup);
  int checked = 0;
  for (double w = 0; w < kTwoPi; w += 0.4) {
    const double R = log.stem.radius_at(w, 1500);
    for (double f : {0.02, 0.5, 0.98}) {
      const Vec3 s = log_polar(*cup, f * R, w, 1500);
      const PhantomPoint a = base->sample_point(s), b = cup->sample_point(s);
      if (!clear_of_knots(a)) continue;
      const double rr = a.field.r / a.field.radius;
      EXPECT_NEAR(b.hu - a.hu, -80 * (1 - rr * rr), 0.05);
      ++checked;
    }
  }
  EXPECT_GT(checked, 20);
}

// The streaks the truth describes at a scanner point of a slice at height z; *near: whether any
// line passes within 4 σ.
double streaks_at(const Phantom& ph, double z, double x, double y, bool* near) {
  double v = 0;
  *near = false;
  for (const MetalStreaks& m : ph.streaks()) {
    if (z < m.z_min || z > m.z_max) continue;
    for (size_t k = 0; k < m.angles.size(); ++k) {
      const double ux = std::cos(m.angles[k]), uy = std::sin(m.angles[k]);
      const double dx = x - m.centre.x, dy = y - m.centre.y;
      const double d = std::abs(dx * uy - dy * ux), l = std::abs(dx * ux + dy * uy);
      if (d > 4 * m.sigma_mm) continue;
      *near = true;
      v += (k % 2 == 0 ? -1 : 1) * m.amplitude_hu *
           std::exp(-0.5 * d * d / (m.sigma_mm * m.sigma_mm) - l / m.decay_mm);
    }
  }
  return v;
}

// Streaks follow the truth's lines: on a line the slice changes by ±amplitude · e^(−L/decay),
// away from every line not at all.
TEST(PhantomConditions, MetalStreaksRunWhereTheTruthSays) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(0);
  o.from_mm = 1000;
  o.to_mm = 1400;
  o.clutter = true;
  auto base = make(log, o);
  o.metal_streak_hu = 300;
  auto st = make(log, o);
  ASSERT_TRUE(base && st);
  ASSERT_EQ(st->streaks().size(), st->clutter().size());
  const nlohmann::json truth = nlohmann::json::parse(st->truth_json());
  ASSERT_EQ(truth["metal_streaks"].size(), st->streaks().size());
  const double px = o.pixel_mm;
  int on = 0, off = 0;
  for (const MetalStreaks& m : st->streaks()) {
    // The slice nearest the object's middle.
    const int i = static_cast<int>(std::lround(0.5 * (m.z_min + m.z_max) / o.slice_spacing_mm));
    if (i < 0 || i >= st->nominal_count()) continue;
    const double z = st->nominal_z(i);
    if (z < m.z_min || z > m.z_max) continue;
    const Slice a = base->render_slice(i), b = st->render_slice(i);
    auto check = [&](double dir, bool on_line) {
      const int cx = static_cast<int>(std::lround((m.centre.x + 60 * std::cos(dir)) / px));
      const int cy = static_cast<int>(std::lround((m.centre.y + 60 * std::sin(dir)) / px));
      if (cx < 0 || cy < 0 || cx >= a.width || cy >= a.height) return;
      bool near;
      const double want = streaks_at(*st, z, cx * px, cy * px, &near);
      if (on_line) {
        ASSERT_TRUE(near);
        EXPECT_GT(std::abs(want), 50);
        EXPECT_NEAR(b.at(cx, cy) - a.at(cx, cy), want, 0.05);
        ++on;
      } else if (!near) {
        EXPECT_EQ(b.at(cx, cy), a.at(cx, cy));
        ++off;
      }
    };
    for (size_t k = 0; k < m.angles.size(); ++k) check(m.angles[k], true);
    // Between two neighbouring lines (at least 9° from either): more than 4 σ from them.
    check(0.5 * (m.angles[0] + m.angles[1]), false);
    check(0.5 * (m.angles[2] + m.angles[3]) + kPi, false);
  }
  EXPECT_GE(on, 6);
  EXPECT_GE(off, 1);
  o.clutter = false;
  EXPECT_NE(o.validate().error().message().find("PhantomOptions::metal_streak_hu"),
            std::string::npos);
}

// The 8-bit slices and the window in the truth give back the HU within half a level.
TEST(PhantomConditions, WindowedExportMapsBackToHuWithinQuantisation) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o;
  o.image_size = 256;
  o.pixel_mm = 1.4;
  o.from_mm = 1200;
  o.to_mm = 1220;
  o.window_centre_hu = -400;
  o.window_width_hu = 1000;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  TempDir tmp;
  const fs::path out = tmp / "preview";
  PhantomWriteOptions wo;
  wo.format = Format::kPngStack;
  auto sum = write_phantom(*ph, out, wo);
  ASSERT_TRUE(sum.ok()) << sum.error().message();
  std::ifstream in(out / "truth/phantom.json");
  const nlohmann::json truth = nlohmann::json::parse(in);
  const nlohmann::json& w = truth["output"];
  EXPECT_EQ(w["bits_stored"], 8);
  EXPECT_EQ(w["window_centre_hu"], -400);
  EXPECT_EQ(w["window_width_hu"], 1000);
  const double slope = w["rescale_slope"], icpt = w["rescale_intercept"];
  EXPECT_NEAR(slope, 1000 / 255.0, 1e-9);
  EXPECT_NEAR(icpt, -900, 1e-9);

  auto src = open_ct(out, {});
  ASSERT_TRUE(src.ok()) << src.error().message();
  EXPECT_EQ(src.value()->geometry().bits_stored, 8);
  Slice s;
  for (int i = 0; i < src.value()->geometry().slice_count(); ++i) {
    ASSERT_TRUE(src.value()->read(i, s).ok());
    const Slice want = ph->render_slice(ph->kept()[i]);
    float worst = 0;
    for (size_t p = 0; p < s.hu.size(); ++p) {
      const float hu = std::clamp(want.hu[p], -900.0f, 100.0f);
      worst = std::max(worst, std::abs(s.hu[p] - hu));
    }
    EXPECT_LE(worst, 0.5 * slope + 1e-3) << "slice " << i;
  }
  // Only image stacks: a windowed DICOM is refused, naming the option, and nothing is written.
  const fs::path dcm = tmp / "dicom";
  wo.format = Format::kDicom;
  auto bad = write_phantom(*ph, dcm, wo);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message().find("PhantomOptions::window_width_hu"), std::string::npos);
  EXPECT_FALSE(fs::exists(dcm));
}

// ---- defects ---------------------------------------------------------------------------------

TEST(PhantomConditions, CracksAreAirWhereTheTruthSays) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(2500);
  o.cracks = 6;
  o.crack_width_mm = 4;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  const Slice s = ph->render_slice(0);
  const double px = o.pixel_mm;
  ASSERT_EQ(ph->defects().size(), 6u);
  for (const Defect& d : ph->defects()) {
    ASSERT_EQ(d.kind, "crack");
    EXPECT_GT(d.r_max, d.r_min);
    // Its middle: open by half its width there.
    const Vec3 c = defect_centre(*ph, d);
    const PhantomPoint q = ph->sample_point(c);
    EXPECT_EQ(q.region, Region::kCrack);
    EXPECT_EQ(q.hu, -1000);
    const int x = static_cast<int>(std::lround(c.x / px)),
              y = static_cast<int>(std::lround(c.y / px));
    EXPECT_EQ(s.at(x, y), -1000) << "rendered crack pixel";
    // 3 mm to the side (beyond the 1 mm half-opening there) it is wood.
    const Vec3 side = log_polar(*ph, d.r_mm, d.omega + 3.0 / d.r_mm, d.z_mm);
    EXPECT_NE(ph->sample_point(side).region, Region::kCrack);
    EXPECT_GT(ph->sample_point(side).hu, -900);
  }
}

TEST(PhantomConditions, ResinAndRotPocketsHoldTheirCtNumbers) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(2000);
  o.ring_amplitude = 0;
  o.resin_pockets = 8;
  o.rot_pockets = 3;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  int resin = 0, rot = 0;
  for (const Defect& d : ph->defects()) {
    const PhantomPoint q = ph->sample_point(defect_centre(*ph, d));
    if (q.field.knot >= 0) continue;
    if (d.kind == "resin_pocket") {
      EXPECT_EQ(q.region, Region::kResinPocket);
      EXPECT_NEAR(q.hu, 80, 0.01);
      ++resin;
    } else {
      ASSERT_EQ(d.kind, "rot");
      if (q.region == Region::kResinPocket) continue;  // a resin pocket inside the rot
      EXPECT_EQ(q.region, Region::kRot);
      EXPECT_NEAR(q.hu, -750, 0.01);
      EXPECT_LE(d.r_mm, 0.4 * q.heartwood_radius + 1e-6);
      ++rot;
    }
  }
  EXPECT_GE(resin, 6);
  EXPECT_GE(rot, 2);
}

TEST(PhantomConditions, CompressionWoodIsDenserWithWiderRingsOnItsSide) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(2000);
  o.ring_amplitude = 0;
  o.compression_wood = 1;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  ASSERT_EQ(ph->defects().size(), 1u);
  const Defect& d = ph->defects()[0];
  EXPECT_EQ(d.kind, "compression_wood");
  int checked = 0;
  for (double r = 10; r < 60; r += 5) {
    const PhantomPoint on = ph->sample_point(log_polar(*ph, r, d.omega, 2000));
    const PhantomPoint off = ph->sample_point(log_polar(*ph, r, d.omega + kPi, 2000));
    if (!clear_of_knots(on) || !clear_of_knots(off) || on.region != Region::kHeartwood ||
        off.region != Region::kHeartwood)
      continue;
    EXPECT_NEAR(on.hu - off.hu, 150, 0.5);
    ++checked;
  }
  EXPECT_GT(checked, 3);
  EXPECT_NEAR(ph->rings_at(1, d.omega + kPi) / ph->rings_at(1, d.omega), 1.6, 1e-9);
}

TEST(PhantomConditions, BarkPatchesAreMissingOrStandOffTheWood) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(2000);
  o.bark_missing = 3;
  o.bark_loose = 3;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  int missing = 0, loose = 0;
  for (const Defect& d : ph->defects()) {
    const double R = log.stem.radius_at(d.omega, d.z_mm);
    auto at = [&](double r) { return ph->sample_point(log_polar(*ph, r, d.omega, d.z_mm)); };
    if (d.kind == "bark_missing") {
      EXPECT_EQ(at(R + 0.3).region, Region::kAir);
      EXPECT_NE(at(R - 1).region, Region::kAir);
      ++missing;
    } else {
      ASSERT_EQ(d.kind, "bark_loose");
      EXPECT_GE(d.width_mm, 1);
      EXPECT_EQ(at(R + 0.5 * d.width_mm).region, Region::kAir);
      EXPECT_EQ(at(R + d.width_mm + 0.2).region, Region::kBark);
      ++loose;
    }
  }
  EXPECT_EQ(missing, 3);
  EXPECT_EQ(loose, 3);
}

TEST(PhantomConditions, ResinKnotsAreDenseDeadKnots) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(2000);
  o.ring_amplitude = 0;
  o.resin_knots = 1;
  o.knot_noise = 0;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  int listed = 0, dead = 0, checked = 0;
  for (const Knot& k : log.knots) dead += k.r_dead < k.r_end;
  for (const Defect& d : ph->defects()) {
    ASSERT_EQ(d.kind, "resin_knot");
    ++listed;
    const Knot* k = nullptr;
    for (const Knot& kk : log.knots)
      if (kk.id == d.knot_id) k = &kk;
    ASSERT_TRUE(k);
    const double r = 0.5 * (k->r_dead + k->r_end);
    const Vec3 a = k->axis_point(r, log.stem);
    const PhantomPoint q = ph->sample_point(ph->to_scanner(a));
    if (q.field.knot < 0 || log.knots[q.field.knot].id != k->id) continue;
    EXPECT_EQ(q.region, Region::kDeadKnot);
    EXPECT_NEAR(q.hu, 250, 0.01);
    ++checked;
  }
  EXPECT_EQ(listed, dead);
  EXPECT_GT(checked, 3);
}

// ---- clutter ---------------------------------------------------------------------------------

// The second log lies where the truth says (its pith, in its own log frame), never inside the
// first, and touches it (within a pixel and a half) at the slice the truth names.
TEST(PhantomConditions, SecondLogTouchesTheFirstWhereTheTruthSays) {
  const LogModel& log = sample("pine_8");
  PhantomOptions o = quiet(0);
  o.from_mm = 1000;
  o.to_mm = 1400;
  o.slice_spacing_mm = 100;
  o.pixel_mm = 1.4;
  o.second_log = true;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  ASSERT_TRUE(ph->has_second_log());
  const nlohmann::json truth = nlohmann::json::parse(ph->truth_json());
  ASSERT_EQ(truth["second_log"]["pith"].size(), static_cast<size_t>(ph->nominal_count()));
  const double px = o.pixel_mm;
  std::vector<double> gaps;
  for (int i = 0; i < ph->nominal_count(); ++i) {
    const Slice s = ph->render_slice(i);
    const double z = ph->nominal_z(i);
    const Vec2 p2 = ph->second_pith(i), p1 = ph->pith(i);
    const int cx = static_cast<int>(std::lround(p2.x / px)),
              cy = static_cast<int>(std::lround(p2.y / px));
    const PhantomPoint q = ph->sample_point({cx * px, cy * px, z});
    EXPECT_TRUE(q.second_log);
    EXPECT_NE(q.region, Region::kAir);
    EXPECT_NEAR(q.log_point.z, ph->second_to_log({0, 0, z}).z, 1e-9);
    EXPECT_NEAR(s.at(cx, cy), q.hu, 2.0) << "slice " << i;
    // Rows across both logs: the first log's rightmost and the second's leftmost pixel.
    double gap = 1e9;
    const int x_lo = static_cast<int>(p1.x / px), x_hi = std::min(cx, s.width - 1);
    for (int y = static_cast<int>((p1.y - 160) / px); y <= static_cast<int>((p1.y + 160) / px);
         ++y) {
      if (y < 0 || y >= s.height) continue;
      int right1 = -1, left2 = -1;
      for (int x = x_lo; x <= x_hi; ++x) {
        const PhantomPoint r = ph->sample_point({x * px, y * px, z});
        if (r.region == Region::kAir || r.region == Region::kBed) continue;
        if (!r.second_log) {
          right1 = x;
          EXPECT_LT(left2, 0) << "the first log right of the second, row " << y;
        } else if (left2 < 0) {
          left2 = x;
        }
      }
      if (right1 >= 0 && left2 >= 0) gap = std::min(gap, (left2 - right1 - 1) * px);
    }
    gaps.push_back(gap);
  }
  const int t = ph->second_touch_slice();
  ASSERT_GE(t, 0);
  std::printf("second log: gap %.1f mm at the touch slice %d\n", gaps[t], t);
  EXPECT_LE(gaps[t], 1.5 * px);
  EXPECT_GE(gaps[t], 0);
  for (double g : gaps) EXPECT_GE(g, gaps[t] - px);

  o.second_log = false;
  auto one = make(log, o);
  EXPECT_FALSE(one->has_second_log());
  const Vec2 p2 = ph->second_pith(0);
  EXPECT_EQ(one->sample_point({p2.x, p2.y, 0}).region, Region::kAir);
}

// ---- command line ----------------------------------------------------------------------------

TEST(PhantomConditionsCli, WritesConditionsIntoTheTruthAndRefusesOutOfRangeValues) {
  TempDir tmp;
  const std::string log = test::quoted((test::sample_log("pine_8") / "log.json").string());
  const fs::path out = tmp / "ct";
  std::string text;
  const int rc = test::run_sawyer(
      "phantom " + log + " -o " + test::quoted(out.string()) +
          " --from-mm 1000 --to-mm 1010 --size 256 --pixel-mm 1.4 --moisture dried --cracks 2 "
          "--ring-contrast-hu 80 --format png --window-width-hu 800",
      &text);
  ASSERT_EQ(rc, 0) << text;
  std::ifstream in(out / "truth/phantom.json");
  const nlohmann::json truth = nlohmann::json::parse(in);
  EXPECT_EQ(truth["options"]["moisture"], "dried");
  EXPECT_EQ(truth["options"]["ring_contrast_hu"], 80);
  EXPECT_EQ(truth["defects"].size(), 2u);
  EXPECT_EQ(truth["hu"]["heartwood"], -600);
  EXPECT_EQ(truth["output"]["window_width_hu"], 800);

  const fs::path bad = tmp / "bad";
  for (const auto& [opt, value] : {std::pair<std::string, std::string>{"--ring-contrast-hu", "900"},
                                   {"--moisture", "frozen"}}) {
    std::string err;
    const int b = test::run_sawyer(
        "phantom " + log + " -o " + test::quoted(bad.string()) + " " + opt + " " + value, &err);
    EXPECT_EQ(b, 1);
    EXPECT_NE(err.find(opt), std::string::npos) << err;
    EXPECT_NE(err.find(value), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_FALSE(fs::exists(bad));
  }
}

}  // namespace
}  // namespace sawyer::ct
