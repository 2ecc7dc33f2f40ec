// Outer contour under bark and heartwood border (issue 4) on phantoms of the bundled logs, with
// the phantom's exact pith as input so that the accuracy is the contour's own: RMS and worst
// radius error against the truth over 360 angles and a dozen slices, with the default scanner
// (512², 0.8 mm, σ 20 HU), doubled noise, the bed touching the log, knots reaching the surface,
// a log without a dry core and an air-only slice. The figures are printed for the record; the
// assertions are generous bounds around them.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "sawyer/ct/phantom/phantom.h"
#include "sawyer/ct/stem/stem_detect.h"
#include "sawyer/model/log_json.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

const LogModel& sample(const std::string& name) { return test::sample_model(name); }

std::unique_ptr<Phantom> make(const LogModel& log, const PhantomOptions& o) {
  auto r = Phantom::create(log, o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message());
  return r.ok() ? std::move(r).value() : nullptr;
}

// Slices 5 mm thick every 100 mm over the log from 150 mm inside its ends (sparse slices keep
// the truth cheap; each slice is still a full 5 mm slab). run_log() picks evenly among them.
PhantomOptions spread(const LogModel& log) {
  PhantomOptions o;
  o.from_mm = log.stem.z_begin() + 150;
  o.to_mm = log.stem.z_end() - 150;
  o.slice_spacing_mm = 100;
  o.slice_thickness_mm = 5;
  return o;
}

struct Errors {
  double sum2 = 0, worst = 0;
  long n = 0, invalid = 0;
  void add(double e) {
    sum2 += e * e;
    worst = std::max(worst, std::abs(e));
    ++n;
  }
  double rms() const { return n ? std::sqrt(sum2 / n) : 0; }
};

struct Report {
  Errors outer, heart, bark;
  double ms = 0;  // contour + heartwood, per slice
  int slices = 0;
  bool all_present = true;
};

// Runs contour and heartwood on slice i with the exact pith and adds the errors against the
// truth. `sector` (when ≥ 0) keeps only angles within `half_width` rad of it.
// Returns the rendered slice.
Slice measure(const Phantom& ph, const LogModel& truth, int i, Report* rep, double sector = -1,
              double half_width = 0) {
  Slice s = ph.render_slice(i);
  const Vec2 pith = ph.pith(i);
  // Time: the best of three runs (the machine is shared).
  ContourResult c;
  HeartwoodResult h;
  double best = 1e9;
  for (int run = 0; run < 3; ++run) {
    const auto t0 = std::chrono::steady_clock::now();
    c = detect_contour(s, ph.geometry(), pith, {});
    h = detect_heartwood(s, ph.geometry(), pith, c, {});
    const auto t1 = std::chrono::steady_clock::now();
    best = std::min(best, std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  rep->ms += best;
  ++rep->slices;
  EXPECT_EQ(c.radius.size(), 360u);
  EXPECT_EQ(h.radius.size(), 360u);
  if (c.radius.size() != 360u || h.radius.size() != 360u) return s;
  rep->all_present = rep->all_present && h.present;
  const double z = truth.stem.z_at(i);
  double bark_sum = 0;
  int bark_n = 0;
  for (int k = 0; k < 360; ++k) {
    const double w = kTwoPi * k / 360;
    if (sector >= 0 && std::abs(angle_diff(w, sector)) > half_width) continue;
    if (c.valid[k])
      rep->outer.add(c.radius[k] - truth.stem.radius_at(w, z));
    else
      ++rep->outer.invalid;
    if (h.valid[k])
      rep->heart.add(h.radius[k] - truth.stem.heartwood_at(w, z));
    else
      ++rep->heart.invalid;
    if (c.bark_mm[k] > 0) {
      bark_sum += c.bark_mm[k];
      ++bark_n;
    }
  }
  if (bark_n > 0 && sector < 0) rep->bark.add(bark_sum / bark_n - truth.stem.bark_mm[i]);
  return s;
}

void print(const std::string& what, const Report& r) {
  std::printf(
      "[contour] %-28s %2d slices  outer RMS %.3f worst %.2f mm (%ld invalid of %ld)  "
      "heartwood RMS %.2f worst %.1f mm (%ld invalid)  bark (mean per slice) RMS %.2f mm  "
      "%.2f ms/slice\n",
      what.c_str(), r.slices, r.outer.rms(), r.outer.worst, r.outer.invalid,
      r.outer.n + r.outer.invalid, r.heart.rms(), r.heart.worst, r.heart.invalid,
      r.bark.n ? std::sqrt(r.bark.sum2 / r.bark.n) : 0.0, r.slices ? r.ms / r.slices : 0.0);
}

Report run_log(const std::string& name, PhantomOptions o, const std::string& label, int count) {
  Report rep;
  auto ph = make(sample(name), o);
  if (!ph) return rep;
  const LogModel truth = ph->truth_log();
  const int n = ph->nominal_count();
  for (int j = 0; j < count; ++j) {
    const int i = count == 1 ? 0 : static_cast<int>(std::lround(j * (n - 1.0) / (count - 1)));
    (void)measure(*ph, truth, i, &rep);
  }
  print(name + " " + label, rep);
  return rep;
}

class ContourLogs : public ::testing::TestWithParam<std::string> {};

// Default scanner: 512², 0.8 mm, σ 20 HU, PSF 0.7 px, the bed under the log.
TEST_P(ContourLogs, DefaultScannerMeetsTheIssueTargets) {
  const std::string name = GetParam();
  const Report r = run_log(name, spread(sample(name)), "default", 12);
  EXPECT_EQ(r.slices, 12);
  EXPECT_LE(r.outer.rms(), 0.5);
  EXPECT_LE(r.outer.worst, 3.0);
  EXPECT_LE(r.outer.invalid, 12 * 360 / 100);  // ≤ 1 % of the angles
  EXPECT_TRUE(r.all_present);
  EXPECT_LE(r.heart.rms(), 2.0);
  EXPECT_LE(r.heart.invalid, 12 * 360 / 100);
  EXPECT_LE(std::sqrt(r.bark.sum2 / std::max(1L, r.bark.n)), 1.0);
}

// Twice the noise: the issue allows twice the error.
TEST_P(ContourLogs, DoubledNoiseStaysWithinTwiceTheTargets) {
  const std::string name = GetParam();
  PhantomOptions o = spread(sample(name));
  o.noise_hu = 40;
  o.seed = 7;
  const Report r = run_log(name, o, "noise 40 HU", 6);
  EXPECT_LE(r.outer.rms(), 1.0);
  EXPECT_LE(r.outer.invalid, 6 * 360 / 50);
  EXPECT_LE(r.heart.rms(), 4.0);
}

INSTANTIATE_TEST_SUITE_P(SampleLogs, ContourLogs,
                         ::testing::Values("gran1_spruce", "pine_8", "spruce_77"));

// The bed's belt touches the log's lowest point over the scanned range (0.5 mm below the bark):
// scan a short stretch so that every slice lies close to the touching one, and check that the
// belt really is within a few mm of the wood in the image.
TEST(Contour, BedTouchingTheLog) {
  for (const std::string name : {"gran1_spruce", "spruce_77"}) {
    const LogModel& log = sample(name);
    PhantomOptions o;
    o.from_mm = 0.5 * (log.stem.z_begin() + log.stem.z_end());
    o.to_mm = *o.from_mm + 20;
    o.noise_hu = 40;  // and twice the noise
    auto ph = make(log, o);
    ASSERT_TRUE(ph);
    const LogModel truth = ph->truth_log();
    Report rep;
    double closest = 1e9;  // belt pixel nearest the under-bark surface, over the slices
    for (int i = 0; i < ph->nominal_count(); ++i) {
      // Belt pixels (> +120 HU, below the pith) and their distance to the true surface.
      const Slice s = measure(*ph, truth, i, &rep);
      const Vec2 p = ph->pith(i);
      const double px = o.pixel_mm;
      for (int row = 0; row < s.height; ++row)
        for (int col = 0; col < s.width; ++col) {
          const double x = col * px, y = row * px;
          if (y <= p.y || s.at(col, row) < 120) continue;
          const double w = wrap_angle(std::atan2(y - p.y, x - p.x));
          const double d =
              std::hypot(x - p.x, y - p.y) - truth.stem.radius_at(w, truth.stem.z_at(i));
          if (d > 0) closest = std::min(closest, d);
        }
    }
    print(name + " bed + noise 40", rep);
    std::printf(
        "[contour] %s: belt pixels come within %.2f mm of the under-bark surface "
        "(bark %.1f mm)\n",
        name.c_str(), closest, truth.stem.bark_mm[0]);
    EXPECT_LE(closest, truth.stem.bark_mm[0] + 3.0) << "the belt does not touch the log";
    EXPECT_LE(rep.outer.rms(), 1.0);
    EXPECT_LE(rep.outer.invalid, rep.slices * 360 / 50);
  }
}

// Knots that reach the surface: slices through their exits, errors in the sector the knot
// covers (and over the whole slice).
TEST(Contour, KnotsReachingTheSurface) {
  struct Exit {
    double z, omega, d;
    std::string log;
  };
  std::vector<Exit> exits;
  for (const std::string name : {"pine_8", "gran1_spruce"}) {
    const LogModel& log = sample(name);
    const Stem& st = log.stem;
    std::vector<Exit> here;
    for (const Knot& k : log.knots) {
      auto outside = [&](double r) {
        return r > st.radius_at(wrap_angle(k.azimuth_at(r)), k.height_at(r));
      };
      if (!outside(k.r_end)) continue;
      double lo = 1, hi = k.r_end;  // bisection for the exit
      for (int it = 0; it < 40; ++it) (outside(0.5 * (lo + hi)) ? hi : lo) = 0.5 * (lo + hi);
      const double z = k.height_at(lo);
      if (z < st.z_begin() + 50 || z > st.z_end() - 50) continue;
      here.push_back({z, wrap_angle(k.azimuth_at(lo)), k.diameter_at(lo), name});
    }
    std::sort(here.begin(), here.end(), [](const Exit& a, const Exit& b) { return a.d > b.d; });
    for (size_t j = 0; j < std::min<size_t>(2, here.size()); ++j) exits.push_back(here[j]);
  }
  ASSERT_GE(exits.size(), 2u) << "no knots reaching the surface in the sample logs";
  for (const Exit& e : exits) {
    PhantomOptions o;
    o.from_mm = e.z;
    o.to_mm = e.z + 5;
    auto ph = make(sample(e.log), o);
    ASSERT_TRUE(ph);
    const LogModel truth = ph->truth_log();
    const double R = truth.stem.radius_at(e.omega, truth.stem.z_at(0));
    Report sector, whole;
    (void)measure(*ph, truth, 0, &sector, e.omega, std::max(0.05, e.d / R));
    (void)measure(*ph, truth, 0, &whole);
    char what[96];
    std::snprintf(what, sizeof what, "%s knot %.0f mm sector", e.log.c_str(), e.d);
    print(what, sector);
    print(e.log + " knot slice, all", whole);
    EXPECT_LE(sector.outer.rms(), 1.0);
    EXPECT_LE(sector.outer.worst, 4.0);
    EXPECT_LE(whole.outer.rms(), 0.5);
  }
}

// Edits of a rendered slice the phantom does not make: the bark knocked off over 40° (wood
// next to air), and the belt pressed onto bare wood over 30° at the bottom (wood next to +200 HU:
// no under-bark edge there at all, so those angles must come from their neighbours).
TEST(Contour, BarkGapAndBeltOnBareWood) {
  const LogModel& log = sample("spruce_77");
  PhantomOptions o;
  o.from_mm = 0.5 * (log.stem.z_begin() + log.stem.z_end());
  o.to_mm = *o.from_mm + 5;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  const LogModel truth = ph->truth_log();
  const double gap_w = 3.6, belt_w = kPi / 2;  // sector centres (rad); +y is down
  Slice s = ph->render_slice(0);
  const Vec2 p = ph->pith(0);
  const double z = truth.stem.z_at(0), bark = truth.stem.bark_mm[0];
  std::uint64_t x = 99;
  auto noise = [&x] {  // uniform ±35 HU, σ 20
    x = x * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<float>(((x >> 11) / 9007199254740992.0 - 0.5) * 69.3);
  };
  for (int row = 0; row < s.height; ++row)
    for (int col = 0; col < s.width; ++col) {
      const double px = col * o.pixel_mm - p.x, py = row * o.pixel_mm - p.y;
      const double w = wrap_angle(std::atan2(py, px)), r = std::hypot(px, py);
      const double R = truth.stem.radius_at(w, z);
      float& v = s.hu[static_cast<size_t>(row) * s.width + col];
      if (std::abs(angle_diff(w, gap_w)) <= 20 * kPi / 180 && r > R + 0.4 && r < R + 1.5 * bark + 3)
        v = -1000 + noise();
      if (std::abs(angle_diff(w, belt_w)) <= 15 * kPi / 180 && r > R + 0.4 && r < R + 8)
        v = 200 + noise();
    }
  // (The painted air starts 0.4 mm outside the surface, so ~0.2 mm of the gap's error is the
  // edit's own.)
  const ContourResult c = detect_contour(s, ph->geometry(), p, {});
  Errors gap, belt, all;
  for (int k = 0; k < 360; ++k) {
    const double w = kTwoPi * k / 360;
    const double e = c.valid[k] ? c.radius[k] - truth.stem.radius_at(w, z) : 1e9;
    if (!c.valid[k]) ++all.invalid;
    if (c.valid[k]) all.add(e);
    if (std::abs(angle_diff(w, gap_w)) <= 20 * kPi / 180 && c.valid[k]) gap.add(e);
    if (std::abs(angle_diff(w, belt_w)) <= 15 * kPi / 180 && c.valid[k]) belt.add(e);
  }
  std::printf(
      "[contour] spruce_77 bark gap 40 deg: RMS %.3f worst %.2f mm; belt on bare wood "
      "30 deg: RMS %.3f worst %.2f mm; whole slice RMS %.3f, %ld invalid\n",
      gap.rms(), gap.worst, belt.rms(), belt.worst, all.rms(), all.invalid);
  EXPECT_EQ(all.invalid, 0);
  EXPECT_GE(gap.n, 35);
  EXPECT_LE(gap.rms(), 0.5);
  EXPECT_LE(belt.rms(), 1.5);
  EXPECT_LE(all.rms(), 0.5);
}

// Rot or a heart check at the centre reads as air: the first rays' walks from the pith stop in
// it. They are tried again from the surface the other rays found (the rays before the first
// success used to stay without a surface: over half the outline lost).
TEST(Contour, RotAtTheCentreOverTheFirstRays) {
  const LogModel& log = sample("spruce_77");
  PhantomOptions o;
  o.from_mm = 0.5 * (log.stem.z_begin() + log.stem.z_end());
  o.to_mm = *o.from_mm + 5;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  const LogModel truth = ph->truth_log();
  Slice s = ph->render_slice(0);
  const Vec2 p = ph->pith(0);
  const double z = truth.stem.z_at(0);
  // A half-moon of decayed wood (-900 HU) from 3 to 16 mm off the pith over azimuths -30 to 170
  // deg (the first rays cross it).
  for (int row = 0; row < s.height; ++row)
    for (int col = 0; col < s.width; ++col) {
      const double px = col * o.pixel_mm - p.x, py = row * o.pixel_mm - p.y;
      const double w = wrap_angle(std::atan2(py, px)), r = std::hypot(px, py);
      if (r > 3 && r < 16 && (w < 170 * kPi / 180 || w > 330 * kPi / 180))
        s.hu[static_cast<size_t>(row) * s.width + col] = -900;
    }
  const ContourResult c = detect_contour(s, ph->geometry(), p, {});
  Errors all;
  for (int k = 0; k < 360; ++k) {
    if (!c.valid[k]) {
      ++all.invalid;
      continue;
    }
    all.add(c.radius[k] - truth.stem.radius_at(kTwoPi * k / 360, z));
  }
  std::printf(
      "[contour] spruce_77 rot at the centre over 200 deg from -30: RMS %.3f worst %.2f mm, %ld "
      "invalid\n",
      all.rms(), all.worst, all.invalid);
  EXPECT_LE(all.invalid, 10);
  EXPECT_LE(all.rms(), 0.5);
}

// Clutter: a steel chain lying on the log and steel bars under the belt.
TEST(Contour, SteelChainOnTheLog) {
  const LogModel& log = sample("gran1_spruce");
  PhantomOptions o;
  o.from_mm = 1000;
  o.to_mm = 1500;
  o.clutter = true;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  const LogModel truth = ph->truth_log();
  Report rep;
  int links = 0;
  for (const ClutterObject& obj : ph->clutter()) {
    if (obj.kind != "chain_link" || links >= 3) continue;
    const int i = static_cast<int>(std::lround(obj.centre.z / o.slice_spacing_mm));
    if (i < 0 || i >= ph->nominal_count()) continue;
    const Slice s = measure(*ph, truth, i, &rep);
    EXPECT_GT(std::count_if(s.hu.begin(), s.hu.end(), [](float v) { return v > 2500; }), 20)
        << "no steel in slice " << i;
    ++links;
  }
  ASSERT_GE(links, 1);
  print("gran1_spruce chain slices", rep);
  EXPECT_LE(rep.outer.rms(), 0.5);
  EXPECT_LE(rep.outer.invalid, rep.slices * 360 / 50);
}

// Other angular grids: a 720-angle contour, and a 180-angle heartwood on it.
TEST(Contour, OtherAngularGrids) {
  const LogModel& log = sample("spruce_77");
  PhantomOptions o;
  o.from_mm = 0.5 * (log.stem.z_begin() + log.stem.z_end());
  o.to_mm = *o.from_mm + 5;
  auto ph = make(log, o);
  ASSERT_TRUE(ph);
  const LogModel truth = ph->truth_log();
  const Slice s = ph->render_slice(0);
  ContourOptions co;
  co.n_angles = 720;
  const ContourResult c = detect_contour(s, ph->geometry(), ph->pith(0), co);
  HeartwoodOptions ho;
  ho.n_angles = 180;
  const HeartwoodResult h = detect_heartwood(s, ph->geometry(), ph->pith(0), c, ho);
  ASSERT_EQ(c.radius.size(), 720u);
  ASSERT_EQ(h.radius.size(), 180u);
  Errors outer, heart;
  for (int k = 0; k < 720; ++k)
    if (c.valid[k]) outer.add(c.radius[k] - truth.stem.radius_at(kTwoPi * k / 720, 0));
  for (int k = 0; k < 180; ++k)
    if (h.valid[k]) heart.add(h.radius[k] - truth.stem.heartwood_at(kTwoPi * k / 180, 0));
  EXPECT_EQ(outer.n, 720);
  EXPECT_EQ(heart.n, 180);
  EXPECT_LE(outer.rms(), 0.5);
  EXPECT_LE(heart.rms(), 2.0);
}

// A tilted, rolled, off-centre log: oblique sections (the truth is solved on them).
TEST(Contour, TiltedOffCentreLog) {
  PhantomOptions o;
  o.from_mm = 1000;
  o.to_mm = 2000;
  o.slice_spacing_mm = 100;
  o.slice_thickness_mm = 5;
  o.placement.tilt_x_deg = 3;
  o.placement.tilt_y_deg = -2;
  o.placement.roll_deg = 30;
  o.placement.offset_x_mm = 25;
  o.placement.offset_y_mm = -15;
  const Report r = run_log("pine_8", o, "tilt 3/-2, roll 30, offset", 6);
  EXPECT_EQ(r.slices, 6);
  EXPECT_LE(r.outer.rms(), 0.5);
  EXPECT_LE(r.outer.invalid, 6 * 360 / 100);
  EXPECT_LE(r.heart.rms(), 2.0);
}

// A log with no dry core (heartwood as wet as sapwood): no heartwood, the contour unaffected.
TEST(Contour, WetLogHasNoHeartwood) {
  PhantomOptions o = spread(sample("pine_8"));
  o.hu.heartwood = o.hu.sapwood;
  auto ph = make(sample("pine_8"), o);
  ASSERT_TRUE(ph);
  const LogModel truth = ph->truth_log();
  Report rep;
  (void)measure(*ph, truth, 0, &rep);
  EXPECT_FALSE(rep.all_present);
  EXPECT_EQ(rep.heart.n, 0);
  EXPECT_LE(rep.outer.rms(), 0.5);
}

// Air, noise and a piece of the bed: every angle invalid, no heartwood.
TEST(Contour, AirOnlySliceIsAllInvalid) {
  VolumeGeometry g;
  g.width = g.height = 512;
  g.spacing_x = g.spacing_y = 0.8;
  g.z = {0.0};
  Slice s;
  s.index = 0;
  s.width = s.height = 512;
  s.hu.resize(512 * 512);
  std::uint64_t x = 12345;
  auto uniform = [&x] {
    x = x * 6364136223846793005ULL + 1442695040888963407ULL;
    return ((x >> 11) + 0.5) / 9007199254740992.0;
  };
  for (float& v : s.hu)
    v = static_cast<float>(-1000 +
                           20 * std::sqrt(-2 * std::log(uniform())) * std::cos(kTwoPi * uniform()));
  for (int row = 400; row < 410; ++row)  // a belt
    for (int col = 150; col < 362; ++col) s.hu[row * 512 + col] = 200;
  for (int row = 410; row < 448; ++row)  // a rail's walls
    for (int col = 120; col < 158; ++col)
      if (row < 414 || row > 443 || col < 124 || col > 153) s.hu[row * 512 + col] = 2200;
  const Vec2 pith{204.8, 204.8};
  const ContourResult c = detect_contour(s, g, pith, {});
  EXPECT_EQ(std::count(c.valid.begin(), c.valid.end(), true), 0);
  const HeartwoodResult h = detect_heartwood(s, g, pith, c, {});
  EXPECT_FALSE(h.present);
  EXPECT_EQ(std::count(h.valid.begin(), h.valid.end(), true), 0);
}

}  // namespace
}  // namespace sawyer::ct
