// Pith (issue 4) against phantoms of the bundled logs: the whole stem pass (tracking on slices
// averaged along z, ring-profile refinement, robust smoothing) on short sections compared with
// the exact pith, the per-slice detector on hard single slices, the refinement on synthetic
// homothetic rings, and the smoother. Bounds are looser than the targets (median
// <= 0.5 mm, p95 <= 1.5 mm, within 2x under doubled noise, bed touching, missing slices), which
// bench/stem_bench measures on longer sections.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "sawyer/ct/phantom/phantom.h"
#include "sawyer/ct/phantom/phantom_source.h"
#include "sawyer/ct/scan/stem_scan.h"
#include "sawyer/ct/stem/pith_track.h"
#include "sawyer/ct/stem/stem_detect.h"
#include "sawyer/model/log_json.h"
#include "sawyer/test/test_util.h"

namespace sawyer::ct {
namespace {

using test::percentile;

struct Stats {
  double median = 0, p95 = 0, max = 0;
};

Stats stats(const std::vector<double>& err) {
  return {percentile(err, 0.5), percentile(err, 0.95), percentile(err, 1.0)};
}

LogModel load(const std::string& name) {
  auto log = read_log_json(test::sample_log(name) / "log.json");
  EXPECT_TRUE(log.ok()) << (log.ok() ? "" : log.error().message());
  return log.ok() ? log.value() : LogModel{};
}

struct Section {
  std::unique_ptr<Phantom> phantom;
  std::vector<Slice> slices;  // kept slices, in z order
  std::vector<Vec2> truth;    // exact pith of each kept slice
};

Section render(const std::string& log_name, double from_mm, double to_mm, PhantomOptions o) {
  Section s;
  o.from_mm = from_mm;
  o.to_mm = to_mm;
  auto ph = Phantom::create(load(log_name), o);
  EXPECT_TRUE(ph.ok()) << (ph.ok() ? "" : ph.error().message());
  if (!ph.ok()) return s;
  s.phantom = std::move(ph).value();
  Phantom::Renderer renderer(*s.phantom);
  for (int i : s.phantom->kept()) {
    Slice sl;
    renderer.render(i, sl);
    s.slices.push_back(std::move(sl));
    s.truth.push_back(s.phantom->pith(i));
  }
  return s;
}

Slice air_slice(std::uint64_t seed);
VolumeGeometry geometry_512();

struct Measured {
  Stats raw;       // detect_pith without a prior, every slice (one slice's evidence only)
  Stats smoothed;  // the stem pass: tracking, refinement, smoothing (scan_stem)
  int slices = 0;
};

// The stem pass (scan_stem) on the phantom's slices through make_uniform_z (so dropped slices
// are resampled as a real scan's would be), compared with the exact pith at every slice.
Measured measure(const Section& s, const std::string& label) {
  Measured m;
  const VolumeGeometry& g = s.phantom->geometry();
  std::vector<double> e_raw, e_smooth;
  for (size_t i = 0; i < s.slices.size(); ++i) {
    const PithResult r = detect_pith(s.slices[i], g, {}, nullptr);
    e_raw.push_back(r.found ? (r.pith_mm - s.truth[i]).norm() : 1e9);
  }
  auto src = make_uniform_z(std::make_unique<PhantomSource>(*s.phantom, true), {});
  EXPECT_TRUE(src.ok());
  if (!src.ok()) return m;
  StemScanOptions o;
  o.threads = 2;
  auto scan = scan_stem(*src.value(), o);
  EXPECT_TRUE(scan.ok()) << (scan.ok() ? "" : scan.error().message());
  if (!scan.ok()) return m;
  const LogModel truth = s.phantom->truth_log();
  for (const StemSliceRecord& rec : scan.value().slices)
    e_smooth.push_back((rec.pith - truth.stem.pith_at(rec.z)).norm());
  m.raw = stats(e_raw);
  m.smoothed = stats(e_smooth);
  m.slices = static_cast<int>(e_smooth.size());
  std::printf(
      "[pith] %-40s %2d slices | median/p95/max mm: single slice %.2f/%.2f/%.2f  "
      "stem pass %.2f/%.2f/%.2f\n",
      label.c_str(), m.slices, m.raw.median, m.raw.p95, m.raw.max, m.smoothed.median,
      m.smoothed.p95, m.smoothed.max);
  return m;
}

PhantomOptions base_options() {
  PhantomOptions o;
  o.image_size = 512;
  o.pixel_mm = 0.8;
  o.slice_spacing_mm = 5.0;
  o.seed = 7;
  o.threads = 1;
  return o;
}

// The hard condition: twice the noise, the log on the belt, `drop` slices missing.
PhantomOptions hard_options(int drop) {
  PhantomOptions o = base_options();
  o.noise_hu = 40;
  o.bed_gap_mm = 0;
  o.drop_slices = drop;
  return o;
}

// The targets are median <= 0.5 mm and p95 <= 1.5 mm (bench/stem_bench prints them on
// longer sections); these short sections are mostly section ends, where the averaging windows
// are one-sided, so the bounds here are twice the targets.

// Real spruce geometry (Gran_1), default noise (20 HU), bed under the log; a stretch where the
// pith leans (0.4 mm per 5 mm slice in x), which the drift-compensated averaging must follow.
TEST(Pith, Gran1SpruceNominal) {
  const Section s = render("gran1_spruce", 1500, 1600, base_options());
  ASSERT_EQ(s.slices.size(), 21u);
  const Measured m = measure(s, "gran1_spruce nominal");
  EXPECT_LE(m.smoothed.median, 1.0);
  EXPECT_LE(m.smoothed.p95, 3.0);
  // Single slices at this noise err by millimetres: the averaging along z is what works.
  EXPECT_GT(m.raw.median, m.smoothed.median);
}

// Pine through a whorl (5 knots starting at 1293-1313 mm), placed off centre and rolled.
TEST(Pith, Pine8WhorlOffsetAndRoll) {
  PhantomOptions o = base_options();
  o.placement.offset_x_mm = 28;
  o.placement.offset_y_mm = -20;
  o.placement.roll_deg = 40;
  const Section s = render("pine_8", 1250, 1350, o);
  ASSERT_EQ(s.slices.size(), 21u);
  const Measured m = measure(s, "pine_8 whorl, offset 28/-20, roll 40");
  EXPECT_LE(m.smoothed.median, 1.0);
  EXPECT_LE(m.smoothed.p95, 3.0);
}

// Second spruce, doubled noise, bed touching, 5 % missing slices: within 2x of the targets,
// and twice that here.
TEST(Pith, Spruce77DoubledNoiseBedTouchingMissingSlices) {
  const Section s = render("spruce_77", 1000, 1100, hard_options(1));
  ASSERT_EQ(s.slices.size(), 20u);  // 21 nominal, one dropped
  ASSERT_EQ(s.phantom->dropped().size(), 1u);
  const Measured m = measure(s, "spruce_77 noise 40, bed touching, 1 of 21 dropped");
  ASSERT_EQ(m.slices, 21);  // the dropped slice is resampled
  EXPECT_LE(m.smoothed.median, 2.0);
  EXPECT_LE(m.smoothed.p95, 6.0);
}

// A scan that starts mid-log in the real spruce at twice the noise, the log on the belt, 2 of
// 40 slices missing: at this noise the strongest vote of the first slices lies some 30 mm from
// the pith, and a track started there never comes back. The first pith is chosen among several
// vote peaks by how well the rings, homothetic to the outline, line up around each out to half
// the radius on the first four searched slices.
TEST(Pith, Gran1MidLogStartDoubledNoiseBedTouching) {
  const Section s = render("gran1_spruce", 1897.5, 2092.5, hard_options(2));
  ASSERT_EQ(s.slices.size(), 38u);  // 40 nominal, two dropped
  const Measured m = measure(s, "gran1_spruce mid-log start, noise 40, belt");
  ASSERT_EQ(m.slices, 40);
  EXPECT_LE(m.smoothed.median, 2.0);
  EXPECT_LE(m.smoothed.p95, 6.0);
}

// A log with no visible rings (ring modulation 0: a wet, uniform core): there is nothing to
// line up, yet the pass completes with one search of the whole slice (not one per slice) and
// keeps the pith inside the log. Where in the log is a guess (docs/scan.md, Limits).
TEST(Pith, RinglessLogIsSearchedOnce) {
  PhantomOptions o = base_options();
  o.ring_amplitude = 0;
  const Section s = render("spruce_77", 1000, 1100, o);
  ASSERT_EQ(s.slices.size(), 21u);
  auto src = make_uniform_z(std::make_unique<PhantomSource>(*s.phantom, true), {});
  ASSERT_TRUE(src.ok());
  StemScanOptions so;
  so.threads = 2;
  auto scan = scan_stem(*src.value(), so);
  ASSERT_TRUE(scan.ok()) << scan.error().message();
  EXPECT_LE(scan.value().pith_full_searches, 2);
  const LogModel truth = s.phantom->truth_log();
  double worst = 0;
  for (const StemSliceRecord& rec : scan.value().slices) {
    ASSERT_TRUE(rec.measured);
    const Vec2 d = rec.pith - truth.stem.pith_at(rec.z);
    const double w = std::atan2(d.y, d.x);
    // Inside the log: nearer the true pith than the bark is in that direction.
    EXPECT_LT(d.norm(), truth.stem.radius_at(w < 0 ? w + kTwoPi : w, rec.z)) << "z " << rec.z;
    worst = std::max(worst, d.norm());
  }
  std::printf("[pith] ringless log: %d whole-slice searches, worst pith error %.1f mm\n",
              scan.value().pith_full_searches, worst);
}

// Where the real spruce's pith turns sharply (x swings 7 mm within 80 mm at z 2290-2370), at
// twice the noise, with 14 cm of scan before the turn: the first track lags the turn, and the
// refinement must still find it.
TEST(Pith, Gran1PithTurnDoubledNoise) {
  PhantomOptions o = base_options();
  o.noise_hu = 40;
  const Section s = render("gran1_spruce", 2150, 2450, o);
  ASSERT_EQ(s.slices.size(), 61u);
  const Measured m = measure(s, "gran1_spruce pith turn, noise 40");
  EXPECT_LE(m.smoothed.median, 2.0);
  EXPECT_LE(m.smoothed.p95, 6.0);
}

// Homothetic rings (the log model's own stem time, docs/architecture.md 5) around an off-centre
// pith in an oval, off-centre section: with the outline the ring-profile refinement lands on the
// pith; fitting circles instead is pulled towards the section's centre.
TEST(Pith, ConcentricRefinementFollowsTheOutline) {
  Slice s = air_slice(6);
  const Vec2 pith{198.4, 207.3};
  std::vector<double> outline(360);
  for (int k = 0; k < 360; ++k) {
    const double w = kTwoPi * k / 360;
    outline[k] = 110.0 + 14.0 * std::cos(w - 0.7) + 6.0 * std::cos(2 * w);  // eccentric, oval
  }
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) {
      const double dx = x * 0.8 - pith.x, dy = y * 0.8 - pith.y;
      double w = std::atan2(dy, dx);
      if (w < 0) w += kTwoPi;
      const double R = outline[static_cast<size_t>(std::lround(w / kTwoPi * 360)) % 360];
      const double t = std::hypot(dx, dy) / R;
      if (t < 1) s.hu[static_cast<size_t>(y) * 512 + x] += 500.f + 17.f * std::sin(kTwoPi * t * 36);
    }
  // As in the stem pass, the outline is expressed around the search's start.
  const Vec2 start = pith + Vec2{1.6, -1.9};
  std::vector<bool> valid(360, true);
  recentre_contour(pith, start, outline, valid);
  ASSERT_EQ(std::count(valid.begin(), valid.end(), true), 360);
  const PithResult a = refine_pith_concentric(s, geometry_512(), start, 3.0, &outline);
  ASSERT_TRUE(a.found);
  EXPECT_LE((a.pith_mm - pith).norm(), 0.25);
  EXPECT_GT(a.confidence, 0.5);
  const PithResult b = refine_pith_concentric(s, geometry_512(), start, 3.0, nullptr);
  ASSERT_TRUE(b.found);
  EXPECT_GT((b.pith_mm - pith).norm(), (a.pith_mm - pith).norm());
  std::printf("[pith] homothetic rings: %.2f mm with the outline, %.2f mm with circles\n",
              (a.pith_mm - pith).norm(), (b.pith_mm - pith).norm());
}

// One slice through the pine whorl, just above the knots' start: knots radiate from the pith.
// No prior, and a prior 10 mm off: both land on the pith.
TEST(Pith, KnotWhorlSlice) {
  const Section s = render("pine_8", 1310, 1315, base_options());
  ASSERT_EQ(s.slices.size(), 2u);
  const VolumeGeometry& g = s.phantom->geometry();
  const Slice& slice = s.slices[1];
  const Vec2 want = s.truth[1];
  // The slice does cut knots near the pith (the whorl is there).
  const LogModel truth = s.phantom->truth_log();
  int knots_here = 0;
  for (const Knot& k : truth.knots)
    if (k.z0 <= g.z[1] + 2.5 && k.height_at(std::min(60.0, k.r_end)) >= g.z[1] - 2.5) ++knots_here;
  EXPECT_GE(knots_here, 3);
  // One slice on its own (no averaging along z): the detector stays within a few mm of the pith
  // even here; the stem pass (tests above) is what meets the accuracy.
  const PithResult a = detect_pith(slice, g, {}, nullptr);
  ASSERT_TRUE(a.found);
  EXPECT_LE((a.pith_mm - want).norm(), 5.0);
  const Vec2 off = want + Vec2{7, -7};
  const PithResult b = detect_pith(slice, g, {}, &off);
  ASSERT_TRUE(b.found);
  EXPECT_LE((b.pith_mm - want).norm(), 5.0);
  std::printf(
      "[pith] whorl slice (%d knots): error %.2f mm (no prior), %.2f mm (prior 9.9 mm off)\n",
      knots_here, (a.pith_mm - want).norm(), (b.pith_mm - want).norm());
}

Slice air_slice(std::uint64_t seed) {
  Slice s;
  s.width = s.height = 512;
  s.hu.resize(512 * 512);
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> noise(0.f, 20.f);
  for (float& v : s.hu) v = -1000.f + noise(rng);
  return s;
}

VolumeGeometry geometry_512() {
  VolumeGeometry g;
  g.width = g.height = 512;
  g.spacing_x = g.spacing_y = 0.8;
  g.z = {0.0};
  return g;
}

TEST(Pith, AirOnlyIsNotFound) {
  const Slice s = air_slice(3);
  const VolumeGeometry g = geometry_512();
  EXPECT_FALSE(detect_pith(s, g, {}, nullptr).found);
  const Vec2 prior{200, 200};
  EXPECT_FALSE(detect_pith(s, g, {}, &prior).found);
}

// A disc of wood smaller than any log (a twig, a chip) is not a log either.
TEST(Pith, TinyObjectIsNotFound) {
  Slice s = air_slice(4);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x)
      if (std::hypot(x - 256, y - 256) * 0.8 < 8.0) s.hu[static_cast<size_t>(y) * 512 + x] = -300;
  EXPECT_FALSE(detect_pith(s, geometry_512(), {}, nullptr).found);
}

// Concentric synthetic rings around a known sub-pixel centre: the refinement is sub-pixel.
TEST(Pith, SyntheticRingsSubPixel) {
  Slice s = air_slice(5);
  const Vec2 c{203.37, 188.91};  // mm
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) {
      const double r = std::hypot(x * 0.8 - c.x, y * 0.8 - c.y);
      if (r < 110)
        s.hu[static_cast<size_t>(y) * 512 + x] += 500.f + 17.f * std::sin(2 * kPi * r / 3.0);
    }
  const PithResult p = detect_pith(s, geometry_512(), {}, nullptr);
  ASSERT_TRUE(p.found);
  EXPECT_LE((p.pith_mm - c).norm(), 0.2);
}

// The smoother ignores isolated wild detections and fills slices that were not found.
TEST(PithTrack, RobustToOutliersAndGaps) {
  std::vector<double> z;
  std::vector<PithResult> raw;
  std::vector<Vec2> truth;
  for (int i = 0; i < 40; ++i) {
    z.push_back(i * 5.0);
    const Vec2 t{200 + 0.02 * i * 5.0, 180 + 3.0 * std::sin(i * 5.0 / 150.0)};
    truth.push_back(t);
    PithResult r;
    r.found = true;
    r.confidence = 0.8;
    r.pith_mm = t + Vec2{0.2 * std::sin(i * 1.7), 0.2 * std::cos(i * 2.3)};
    raw.push_back(r);
  }
  raw[10].pith_mm = raw[10].pith_mm + Vec2{12, -9};  // a knot pulled this one
  raw[25].pith_mm = raw[25].pith_mm + Vec2{-6, 0};
  raw[30].found = false;  // missing
  raw[30].pith_mm = {};
  const std::vector<Vec2> s = smooth_pith_track(z, raw, {});
  ASSERT_EQ(s.size(), z.size());
  for (size_t i = 0; i < z.size(); ++i) EXPECT_LE((s[i] - truth[i]).norm(), 0.35) << "slice " << i;
  std::vector<PithResult> none(3);
  EXPECT_TRUE(smooth_pith_track({0, 5, 10}, none, {}).empty());
}

}  // namespace
}  // namespace sawyer::ct
