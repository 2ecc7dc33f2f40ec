// The published map format (docs/maps.md): round trips within the maps' 8-bit quantisation, the
// shipped Gran_1 maps against an independent decode of the renderer's rules and against the
// source data, the exporter's pixels against the renderer's rules, and bad inputs.
//
// The test reads and writes BMP files with its own small codec (not OpenImageIO), so the pixel
// checks do not share code with the library.
#include "sawyer/maps/published_maps.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "sawyer/core/file_util.h"
#include "sawyer/model/gran1_import.h"
#include "sawyer/test/test_util.h"

namespace sawyer {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using Json = nlohmann::json;

// ---- a minimal 24-bit BMP codec (uncompressed BI_RGB, either row order) ----------------------

struct Bmp {
  int w = 0, h = 0;
  std::vector<std::uint8_t> rgb;  // top row first
  int at(int x, int y, int c) const { return rgb[(static_cast<size_t>(y) * w + x) * 3 + c]; }
  void set(int x, int y, int c, int v) {
    rgb[(static_cast<size_t>(y) * w + x) * 3 + c] = static_cast<std::uint8_t>(v);
  }
};

std::uint32_t le32(const std::string& b, size_t at) {
  return static_cast<std::uint8_t>(b[at]) | static_cast<std::uint8_t>(b[at + 1]) << 8 |
         static_cast<std::uint8_t>(b[at + 2]) << 16 |
         static_cast<std::uint32_t>(static_cast<std::uint8_t>(b[at + 3])) << 24;
}

Bmp read_bmp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Bmp img;
  EXPECT_GE(b.size(), 54u) << path;
  if (b.size() < 54 || b[0] != 'B' || b[1] != 'M') return img;
  const std::uint32_t offset = le32(b, 10);
  img.w = static_cast<std::int32_t>(le32(b, 18));
  const std::int32_t h = static_cast<std::int32_t>(le32(b, 22));
  const int bits = static_cast<std::uint8_t>(b[28]) | static_cast<std::uint8_t>(b[29]) << 8;
  EXPECT_EQ(bits, 24) << path;
  EXPECT_EQ(le32(b, 30), 0u) << path << ": compressed";
  img.h = std::abs(h);
  const bool bottom_up = h > 0;
  const size_t stride = (static_cast<size_t>(img.w) * 3 + 3) & ~size_t{3};
  EXPECT_GE(b.size(), offset + stride * img.h) << path;
  img.rgb.assign(static_cast<size_t>(img.w) * img.h * 3, 0);
  for (int y = 0; y < img.h; ++y) {
    const size_t row = offset + stride * (bottom_up ? img.h - 1 - y : y);
    for (int x = 0; x < img.w; ++x)
      for (int c = 0; c < 3; ++c)  // stored B, G, R
        img.set(x, y, c, static_cast<std::uint8_t>(b[row + x * 3 + (2 - c)]));
  }
  return img;
}

void put32(std::string* b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

void write_bmp(const fs::path& path, const Bmp& img) {
  const size_t stride = (static_cast<size_t>(img.w) * 3 + 3) & ~size_t{3};
  std::string b = "BM";
  put32(&b, static_cast<std::uint32_t>(54 + stride * img.h));
  put32(&b, 0);
  put32(&b, 54);
  put32(&b, 40);
  put32(&b, static_cast<std::uint32_t>(img.w));
  put32(&b, static_cast<std::uint32_t>(img.h));  // bottom-up
  b += std::string("\x01\x00\x18\x00", 4);
  put32(&b, 0);
  put32(&b, static_cast<std::uint32_t>(stride * img.h));
  for (int i = 0; i < 4; ++i) put32(&b, 0);
  for (int y = img.h - 1; y >= 0; --y) {
    std::string row(stride, '\0');
    for (int x = 0; x < img.w; ++x)
      for (int c = 0; c < 3; ++c) row[x * 3 + (2 - c)] = static_cast<char>(img.at(x, y, c));
    b += row;
  }
  test::write_file(path, b);
}

// Same pixels with one column fewer (or rows cut/added).
Bmp resized(const Bmp& img, int w, int h) {
  Bmp out;
  out.w = w, out.h = h;
  out.rgb.assign(static_cast<size_t>(w) * h * 3, 0);
  for (int y = 0; y < std::min(h, img.h); ++y)
    for (int x = 0; x < std::min(w, img.w); ++x)
      for (int c = 0; c < 3; ++c) out.set(x, y, c, img.at(x, y, c));
  return out;
}

// ---- test models -------------------------------------------------------------------------------

// A smooth tapering log away from the origin (z0 = 123 mm, pith near (200, −50)), with heartwood
// and knots that exercise every sign and range: rising and dipping axes, both twists, sound and
// dead knots, r_dead beyond rmin, r_end beyond rmax, ω0 near 0 and 2π.
LogModel smooth_log() {
  LogModel log;
  log.id = "smooth";
  log.species = "pine";
  log.source = "published_maps_test";
  Stem& s = log.stem;
  s.z0_mm = 123.0;
  s.dz_mm = 10.0;
  s.n_angles = 360;
  const int n = 240;
  for (int i = 0; i < n; ++i) {
    const double z = s.z_at(i);
    s.pith.push_back({200.0 + 9.0 * std::sin(z / 700.0), -50.0 + 6.0 * std::cos(z / 450.0)});
    std::vector<double> r(360), h(360);
    for (int k = 0; k < 360; ++k) {
      const double w = kTwoPi * k / 360.0;
      r[k] = 150.0 - 0.01 * (z - 123.0) + 7.0 * std::cos(w - 0.3) + 2.5 * std::cos(2 * w + 1.0) +
             1.5 * std::sin(z / 300.0 + w);
      h[k] = 0.45 * r[k];
    }
    s.radius.push_back(r);
    s.heartwood.push_back(h);
  }
  struct P {
    double z0, a, b, w0, tw, rd, re;
  };
  const P ps[] = {
      {400, 0.8, 0.25, 0.3, 0.04, 40, 90},     {900, -0.6, 0.45, 2.0, -0.05, 70, 140},
      {1500, 0.0, 0.10, 6.27, 0.02, 200, 60},  {1800, 1.2, -0.05, 0.01, -0.03, 10, 180},
      {2100, -0.3, 0.60, 4.1, 0.06, 120, 150}, {2300, 0.4, 0.30, 3.3, 0.0, 3, 8},
      {2450, 0.5, 0.20, 5.0, 0.03, 95, 115},
  };
  int id = 100;
  for (const P& p : ps) {
    Knot k;
    k.id = id += 7;
    k.z0 = p.z0, k.a = p.a, k.b = p.b, k.omega0 = p.w0, k.twist = p.tw;
    k.r_dead = p.rd, k.r_end = p.re;
    k.diameter = {12.0 + p.a, 0.7 + 0.1 * p.b};
    k.fit_rms_mm = 0.3 + 0.01 * id;
    k.support = 40 + id;
    log.knots.push_back(k);
  }
  return log;
}

double min_radius(const Stem& s) {
  double v = 1e300;
  for (const auto& row : s.radius)
    for (double r : row) v = std::min(v, r);
  return v;
}
double max_radius(const Stem& s) {
  double v = 0;
  for (const auto& row : s.radius)
    for (double r : row) v = std::max(v, r);
  return v;
}

const LogModel& gran1() {
  static const LogModel log = [] {
    Result<LogModel> r = import_gran1(test::gran1_source_dir());
    EXPECT_TRUE(r) << r.error().message();
    return r ? r.value() : LogModel{};
  }();
  return log;
}

fs::path shipped_maps() { return test::sample_log("gran1_spruce") / "published_maps"; }

// Pith distances (mm) at which knot axes are compared: inside the knot and inside [0, rmin],
// the range the knot maps cover.
std::vector<double> probe_radii(const Knot& k, double rmin) {
  std::vector<double> out;
  const double top = std::min(k.r_end, rmin);
  for (double f : {0.1, 0.3, 0.6, 0.9}) out.push_back(std::max(1.0, f * top));
  return out;
}

struct Bounds {
  double rmin, rmax, hmax;
};

Bounds bounds_of(const LogModel& log) {
  return {min_radius(log.stem), max_radius(log.stem), log.stem.length_mm()};
}

// Checks `got` (imported) against `want` knot by knot within the maps' quantisation. When
// `exact_sidecar_fields` the fields the sidecar carries must be exact.
void expect_knots_within_quantisation(const LogModel& want, const LogModel& got, double z_shift,
                                      bool exact_sidecar_fields, double fit_slack_mm,
                                      double fit_slack_rad) {
  const Bounds q = bounds_of(want);
  ASSERT_EQ(got.knots.size(), want.knots.size());
  for (size_t i = 0; i < want.knots.size(); ++i) {
    const Knot& a = want.knots[i];
    const Knot& b = got.knots[i];
    SCOPED_TRACE("knot " + std::to_string(i));
    EXPECT_NEAR(b.z0 - z_shift, a.z0, q.hmax / 510.0 + 1e-9);
    EXPECT_LE(std::abs(angle_diff(b.omega0, a.omega0)), kPi / 255.0 + 1e-12);
    for (double r : probe_radii(a, q.rmin)) {
      const double rise_a = a.height_at(r) - a.z0, rise_b = b.height_at(r) - b.z0;
      EXPECT_NEAR(rise_b, rise_a, q.rmin / 255.0 + fit_slack_mm) << "rise at r = " << r;
      const double tw_a = a.twist * std::log(std::max(r, 1.0));
      const double tw_b = b.twist * std::log(std::max(r, 1.0));
      EXPECT_NEAR(tw_b, tw_a, 0.5 * kPi / 255.0 + fit_slack_rad) << "twist term at r = " << r;
      EXPECT_LE(std::abs(angle_diff(b.azimuth_at(r), a.azimuth_at(r))),
                kPi / 255.0 + 0.5 * kPi / 255.0 + fit_slack_rad)
          << "azimuth at r = " << r;
    }
    if (exact_sidecar_fields) {
      EXPECT_EQ(b.id, a.id);
      EXPECT_EQ(b.r_end, a.r_end);
      EXPECT_EQ(b.r_dead, a.r_dead);
      EXPECT_EQ(b.diameter.d_dead, a.diameter.d_dead);
      EXPECT_EQ(b.diameter.exponent, a.diameter.exponent);
      EXPECT_EQ(b.fit_rms_mm, a.fit_rms_mm);
      EXPECT_EQ(b.support, a.support);
    }
  }
}

// ---- round trips -------------------------------------------------------------------------------

TEST(PublishedMaps, RoundTripWithSidecarKeepsValuesWithinQuantisation) {
  const LogModel want = smooth_log();
  test::TempDir tmp;
  const fs::path dir = tmp / "maps";
  PublishedMapExportSummary es;
  Status st = export_published_maps(want, dir, {}, &es);
  ASSERT_TRUE(st) << st.error().message();
  EXPECT_EQ(es.clamped_pith_rows + es.clamped_knot_starts + es.clamped_rise_texels +
                es.clamped_twist_texels,
            0);
  PublishedMapImportSummary is;
  Result<LogModel> r = import_published_maps(dir, &is);
  ASSERT_TRUE(r) << r.error().message();
  EXPECT_TRUE(is.sidecar);
  const LogModel& got = r.value();
  const Bounds q = bounds_of(want);

  EXPECT_EQ(got.id, want.id);
  EXPECT_EQ(got.species, want.species);
  EXPECT_EQ(got.source, want.source);
  const Stem& a = want.stem;
  const Stem& b = got.stem;
  ASSERT_EQ(b.slice_count(), a.slice_count());
  EXPECT_EQ(b.n_angles, a.n_angles);
  EXPECT_NEAR(b.dz_mm, a.dz_mm, 1e-12);
  EXPECT_NEAR(b.z0_mm, a.z0_mm, 1e-9);
  EXPECT_FALSE(b.has_heartwood()) << "the published maps have no heartwood";
  double worst_pith = 0, worst_radius = 0;
  for (int i = 0; i < a.slice_count(); ++i) {
    worst_pith = std::max(
        {worst_pith, std::abs(b.pith[i].x - a.pith[i].x), std::abs(b.pith[i].y - a.pith[i].y)});
    for (int k = 0; k < a.n_angles; ++k)
      worst_radius = std::max(worst_radius, std::abs(b.radius[i][k] - a.radius[i][k]));
  }
  EXPECT_LE(worst_pith, q.rmin / 510.0 + 1e-9);
  // Quantisation, which the Catmull-Rom resampling of 180 columns to 360 angles can amplify by
  // up to 1.25 between column centres (weights −1/16, 9/16, 9/16, −1/16), plus the resampling
  // error of a smooth outline (well under 0.01 mm).
  EXPECT_LE(worst_radius, 1.25 * (q.rmax - q.rmin) / 510.0 + 0.01);

  expect_knots_within_quantisation(want, got, 0.0, true, 0.05, 0.002);
}

TEST(PublishedMaps, RoundTripWithoutSidecarStaysWithinTheMapsAlone) {
  const LogModel want = smooth_log();
  test::TempDir tmp;
  const fs::path dir = tmp / "smooth_maps";
  PublishedMapOptions o;
  o.write_sidecar = false;
  ASSERT_TRUE(export_published_maps(want, dir, o));
  ASSERT_FALSE(fs::exists(dir / "sawyer_maps.json"));
  Result<LogModel> r = import_published_maps(dir);
  ASSERT_TRUE(r) << r.error().message();
  const LogModel& got = r.value();
  const Bounds q = bounds_of(want);
  const Stem& a = want.stem;
  const Stem& b = got.stem;

  // Without the sidecar the maps' own frame: height 0 at the butt face, pith offsets from the
  // mid pith, 360 angles.
  EXPECT_NEAR(b.z0_mm, 0.5 * a.dz_mm, 1e-9);
  EXPECT_EQ(b.n_angles, 360);
  EXPECT_EQ(got.id, "smooth_maps");
  EXPECT_THAT(got.source, HasSubstr("published maps"));
  const int mid = a.slice_count() / 2;
  for (int i = 0; i < a.slice_count(); ++i) {
    const Vec2 da = a.pith[i] - a.pith[mid];
    EXPECT_NEAR(b.pith[i].x, da.x, q.rmin / 510.0 + 1e-9);
    EXPECT_NEAR(b.pith[i].y, da.y, q.rmin / 510.0 + 1e-9);
  }
  const double z_shift = b.z_begin() - a.z_begin();
  ASSERT_EQ(got.knots.size(), want.knots.size());
  expect_knots_within_quantisation(want, got, z_shift, false, 0.05, 0.002);
  for (size_t i = 0; i < want.knots.size(); ++i) {
    const Knot& ka = want.knots[i];
    const Knot& kb = got.knots[i];
    SCOPED_TRACE("knot " + std::to_string(i));
    EXPECT_EQ(kb.id, static_cast<int>(i));
    // r_end from the state map's blue (our extension), clamped at rmax.
    EXPECT_NEAR(kb.r_end, std::min(ka.r_end, q.rmax), q.rmax / 510.0 + 1e-9);
    // r_dead from green in units of rmin; saturated green means "sound to r_end or rmin".
    if (ka.r_dead < q.rmin * 254.5 / 255.0)
      EXPECT_NEAR(kb.r_dead, ka.r_dead, q.rmin / 510.0 + 1e-9);
    else
      EXPECT_DOUBLE_EQ(kb.r_dead, std::max(q.rmin, kb.r_end));
    // Diameters from the published renderer's growth rule: positive and plausible.
    EXPECT_GT(kb.max_diameter(), 0.0);
    EXPECT_LT(kb.max_diameter(), 60.0);
  }
}

TEST(PublishedMaps, OtherMapSizesRoundTrip) {
  const LogModel want = smooth_log();
  test::TempDir tmp;
  PublishedMapOptions o;
  o.stem_columns = 96;
  o.knot_columns = 20;
  o.rows_per_knot = 2;
  for (bool sidecar : {true, false}) {
    SCOPED_TRACE(sidecar ? "with sidecar" : "without sidecar");
    o.write_sidecar = sidecar;
    const fs::path dir = tmp / (sidecar ? "a" : "b");
    ASSERT_TRUE(export_published_maps(want, dir, o));
    const Bmp pm = read_bmp(dir / "pith_and_radius_map.bmp");
    const Bmp hm = read_bmp(dir / "knot_height_map.bmp");
    EXPECT_EQ(pm.w, 96);
    EXPECT_EQ(hm.w, 20);
    EXPECT_EQ(hm.h, 2 * static_cast<int>(want.knots.size()));
    PublishedMapImportSummary is;
    Result<LogModel> r = import_published_maps(dir, &is);
    ASSERT_TRUE(r) << r.error().message();
    EXPECT_EQ(is.stem_columns, 96);
    EXPECT_EQ(is.knot_columns, 20);
    EXPECT_EQ(is.rows_per_knot, 2);
    const double z_shift = r.value().stem.z_begin() - want.stem.z_begin();
    expect_knots_within_quantisation(want, r.value(), z_shift, sidecar, 0.05, 0.002);
  }
}

TEST(PublishedMaps, LogWithoutKnotsRoundTrips) {
  LogModel want = smooth_log();
  want.knots.clear();
  test::TempDir tmp;
  ASSERT_TRUE(export_published_maps(want, tmp / "m"));
  // The renderer still finds knot maps to load (one empty block), and N = 0 in map_params.
  EXPECT_EQ(read_bmp(tmp / "m" / "knot_state_map.bmp").h, 4);
  Result<std::string> params = read_text_file(tmp / "m" / "map_params.json");
  ASSERT_TRUE(params);
  EXPECT_EQ(Json::parse(params.value())[3], 0);
  Result<LogModel> r = import_published_maps(tmp / "m");
  ASSERT_TRUE(r) << r.error().message();
  EXPECT_TRUE(r.value().knots.empty());
  EXPECT_EQ(r.value().stem.slice_count(), want.stem.slice_count());
}

// Gran_1 from its CT-derived source (1° radii) through the maps: the stem error is quantisation
// plus resampling the outline to 180 columns and back; measured 0.37 mm worst and 0.034 mm
// mean, bounded here at 0.6 and 0.06 mm (docs/maps.md).
TEST(PublishedMaps, RealisticLogRoundTripStaysWithinDocumentedBounds) {
  const LogModel& want = gran1();
  ASSERT_EQ(want.knots.size(), 108u);
  test::TempDir tmp;
  PublishedMapExportSummary es;
  ASSERT_TRUE(export_published_maps(want, tmp / "g", {}, &es));
  Result<LogModel> r = import_published_maps(tmp / "g");
  ASSERT_TRUE(r) << r.error().message();
  const LogModel& got = r.value();
  const Bounds q = bounds_of(want);
  EXPECT_DOUBLE_EQ(es.rmin, 104.06);
  EXPECT_DOUBLE_EQ(es.rmax, 143.375);
  EXPECT_DOUBLE_EQ(es.hmax, 4000.0);
  double worst = 0, sum = 0, worst_pith = 0;
  size_t count = 0;
  for (int i = 0; i < want.stem.slice_count(); ++i) {
    worst_pith = std::max({worst_pith, std::abs(got.stem.pith[i].x - want.stem.pith[i].x),
                           std::abs(got.stem.pith[i].y - want.stem.pith[i].y)});
    for (int k = 0; k < 360; ++k) {
      const double e = std::abs(got.stem.radius[i][k] - want.stem.radius[i][k]);
      worst = std::max(worst, e);
      sum += e;
      ++count;
    }
  }
  EXPECT_LE(worst_pith, q.rmin / 510.0 + 1e-9);
  EXPECT_LE(worst, 0.6);
  EXPECT_LE(sum / count, 0.06);
  std::cout << "Gran_1 radius round trip: worst " << worst << " mm, mean " << sum / count
            << " mm\n";
  expect_knots_within_quantisation(want, got, 0.0, true, 0.1, 0.004);
}

// ---- the exporter's pixels follow the renderer's rules -----------------------------------------

TEST(PublishedMaps, ExportedPixelsFollowTheRendererRules) {
  const LogModel log = smooth_log();
  test::TempDir tmp;
  ASSERT_TRUE(export_published_maps(log, tmp / "m"));
  const Bounds q = bounds_of(log);
  const Stem& s = log.stem;

  Result<std::string> text = read_text_file(tmp / "m" / "map_params.json");
  ASSERT_TRUE(text);
  const Json params = Json::parse(text.value());
  ASSERT_TRUE(params.is_array());
  ASSERT_EQ(params.size(), 4u) << "the renderer unpacks exactly four numbers";
  EXPECT_DOUBLE_EQ(params[0].get<double>(), q.rmin);
  EXPECT_DOUBLE_EQ(params[1].get<double>(), q.rmax);
  EXPECT_DOUBLE_EQ(params[2].get<double>(), q.hmax);
  EXPECT_EQ(params[3].get<int>(), 7);

  // Stem map: row 0 (top of the image) is the butt, column c is at the renderer's azimuth
  // φ = 2π(c + ½)/W from +y towards +x, i.e. our ω = π/2 − φ.
  const Bmp pm = read_bmp(tmp / "m" / "pith_and_radius_map.bmp");
  ASSERT_EQ(pm.w, 180);
  ASSERT_EQ(pm.h, s.slice_count());
  const Vec2 mid = s.pith[s.slice_count() / 2];
  for (int i : {0, 1, 57, s.slice_count() - 1}) {
    for (int c : {0, 22, 45, 90, 135, 179}) {
      const double phi = kTwoPi * (c + 0.5) / 180.0;
      // A point at pith distance R along φ: dx = R sin φ, dy = R cos φ.
      const double omega = std::atan2(std::cos(phi), std::sin(phi));
      const double want_b = (s.radius_at(omega, s.z_at(i)) - q.rmin) / (q.rmax - q.rmin) * 255.0;
      EXPECT_NEAR(pm.at(c, i, 2), want_b, 0.5 + 1e-9) << "row " << i << " column " << c;
      EXPECT_NEAR(pm.at(c, i, 0), ((s.pith[i].x - mid.x) / q.rmin + 0.5) * 255.0, 0.5 + 1e-9);
      EXPECT_NEAR(pm.at(c, i, 1), ((s.pith[i].y - mid.y) / q.rmin + 0.5) * 255.0, 0.5 + 1e-9);
    }
  }
  // The log tapers: the butt row is wider than the top row.
  EXPECT_GT(pm.at(40, 0, 2), pm.at(40, pm.h - 1, 2));

  // Knot maps: 32 columns at r_j = (j + ½)·rmin/32, 4 identical rows per knot. The renderer
  // computes height = R·hmax − G·rmin + B·rmin and azimuth = 2π·R + (−G + B)·π/2.
  const Bmp hm = read_bmp(tmp / "m" / "knot_height_map.bmp");
  const Bmp om = read_bmp(tmp / "m" / "knot_orientation_map.bmp");
  const Bmp sm = read_bmp(tmp / "m" / "knot_state_map.bmp");
  ASSERT_EQ(hm.w, 32);
  ASSERT_EQ(hm.h, 4 * 7);
  for (size_t i = 0; i < log.knots.size(); ++i) {
    const Knot& k = log.knots[i];
    for (int j = 0; j < 32; ++j) {
      const double r = (j + 0.5) * q.rmin / 32.0;
      for (int row = 4 * static_cast<int>(i); row < 4 * static_cast<int>(i) + 4; ++row)
        for (int c = 0; c < 3; ++c) {
          EXPECT_EQ(hm.at(j, row, c), hm.at(j, 4 * i, c));
          EXPECT_EQ(sm.at(j, row, c), sm.at(j, 4 * i, c));
        }
      const int row = 4 * static_cast<int>(i);
      const double h = hm.at(j, row, 0) / 255.0 * q.hmax - hm.at(j, row, 1) / 255.0 * q.rmin +
                       hm.at(j, row, 2) / 255.0 * q.rmin;
      EXPECT_NEAR(h, k.height_at(r) - s.z_begin(), q.hmax / 510.0 + q.rmin / 510.0 + 1e-9)
          << "knot " << i << " column " << j;
      const double w = om.at(j, row, 0) / 255.0 * kTwoPi +
                       (om.at(j, row, 2) - om.at(j, row, 1)) / 255.0 * 0.5 * kPi;
      EXPECT_LE(std::abs(angle_diff(w, k.azimuth_at(r))), kPi / 255.0 + kPi / 510.0 + 1e-9)
          << "knot " << i << " column " << j;
      // State: red = alive (r < r_dead), green = r_dead/rmin, blue = r_end/rmax (ours).
      EXPECT_EQ(sm.at(j, row, 0), r < k.r_dead ? 255 : 0);
      EXPECT_NEAR(sm.at(j, row, 1), std::min(k.r_dead / q.rmin, 1.0) * 255.0, 0.5 + 1e-9);
      EXPECT_NEAR(sm.at(j, row, 2), std::max(1.0, std::min(k.r_end / q.rmax, 1.0) * 255.0),
                  0.5 + 1e-9);
    }
  }
}

TEST(PublishedMaps, ExportSummaryCountsWhatDoesNotFit) {
  LogModel log = smooth_log();
  log.stem.pith[0].x += 200.0;  // far beyond ±rmin/2 from the mid pith
  log.knots[0].b = 3.0;         // rises more than rmin within the map
  log.knots[1].twist = 1.0;     // more than π/2 of twist
  log.knots[2].z0 = -500.0;     // below the butt
  test::TempDir tmp;
  PublishedMapExportSummary es;
  ASSERT_TRUE(export_published_maps(log, tmp / "m", {}, &es));
  EXPECT_EQ(es.clamped_pith_rows, 1);
  EXPECT_EQ(es.clamped_knot_starts, 1);
  EXPECT_GT(es.clamped_rise_texels, 0);
  EXPECT_GT(es.clamped_twist_texels, 0);
  EXPECT_EQ(es.saturated_r_dead, 2);  // knots 2 and 4 have r_dead ≥ rmin
  EXPECT_EQ(es.clamped_r_end, 1);     // knot 3 ends beyond rmax
  std::ostringstream os;
  es.print(os);
  EXPECT_THAT(os.str(), HasSubstr("clamped"));
}

// ---- the shipped Gran_1 maps -----------------------------------------------------------------

const LogModel& shipped() {
  static const LogModel log = [] {
    Result<LogModel> r = import_published_maps(shipped_maps());
    EXPECT_TRUE(r) << r.error().message();
    return r ? r.value() : LogModel{};
  }();
  return log;
}

TEST(PublishedMapsGran1, ImportGives108KnotsAndTheMapParams) {
  PublishedMapImportSummary is;
  Result<LogModel> r = import_published_maps(shipped_maps(), &is);
  ASSERT_TRUE(r) << r.error().message();
  const LogModel& log = r.value();
  EXPECT_FALSE(is.sidecar);
  EXPECT_EQ(log.knots.size(), 108u);
  EXPECT_EQ(log.id, "gran1_spruce");
  EXPECT_EQ(log.stem.slice_count(), 400);
  EXPECT_DOUBLE_EQ(log.stem.dz_mm, 10.0);
  EXPECT_DOUBLE_EQ(log.stem.z0_mm, 5.0);
  EXPECT_DOUBLE_EQ(log.stem.length_mm(), 4000.0);
  EXPECT_EQ(log.stem.n_angles, 360);
  EXPECT_DOUBLE_EQ(is.rmin, 104.06);
  EXPECT_DOUBLE_EQ(is.rmax, 143.375);
  EXPECT_EQ(is.knot_columns, 32);
  EXPECT_EQ(is.rows_per_knot, 4);
  // Radii stay inside [rmin, rmax] and reach close to both ends (the shipped radii were box
  // filtered over 11 slices × 5 degrees before quantisation, which shaves the extremes).
  const double lo = min_radius(log.stem), hi = max_radius(log.stem);
  EXPECT_GE(lo, 104.06);
  EXPECT_LE(hi, 143.375);
  EXPECT_LT(lo - 104.06, 2.0);
  EXPECT_LT(143.375 - hi, 2.0);
}

TEST(PublishedMapsGran1, StemAgreesWithTheSourceData) {
  const LogModel& maps = shipped();
  const LogModel& src = gran1();
  ASSERT_EQ(maps.stem.slice_count(), src.stem.slice_count());
  const double rmin = 104.06;
  // Pith offsets from the mid pith (row 200), truncated to 8 bits by the shipped writer.
  const Vec2 mid = src.stem.pith[200];
  for (int i = 0; i < 400; ++i) {
    const Vec2 d = src.stem.pith[i] - mid;
    EXPECT_NEAR(maps.stem.pith[i].x, d.x, rmin / 255.0 + 1e-9) << i;
    EXPECT_NEAR(maps.stem.pith[i].y, d.y, rmin / 255.0 + 1e-9) << i;
  }
  // Radii: the shipped map's smoothing (11 slices × 5 degrees) and 8 bits leave a mean error
  // of about 0.4 mm. Reading the columns as our ω instead of the renderer's φ (from +y towards
  // +x) would be a mirror image, several times worse.
  double sum = 0, mirrored = 0;
  for (int i = 0; i < 400; ++i)
    for (int k = 0; k < 360; ++k) {
      sum += std::abs(maps.stem.radius[i][k] - src.stem.radius[i][k]);
      mirrored += std::abs(maps.stem.radius[i][(450 - k) % 360] - src.stem.radius[i][k]);
    }
  EXPECT_LT(sum / (400 * 360), 0.6);
  EXPECT_GT(mirrored, 3 * sum);
}

// An independent port of the published renderer's decode of the raw pixels: knot axis height
// (mm, from the butt face) and azimuth at pith distance r, linear between column centres.
struct RendererKnotDecode {
  Bmp hm, om, sm;
  double rmin, rmax, hmax;
  int n;

  double channel(const Bmp& img, int knot, double r, int c) const {
    const int rows = img.h / n;
    const int row = knot * rows + rows / 2;
    double x = r / rmin * img.w - 0.5;
    x = std::clamp(x, 0.0, img.w - 1.0);
    const int j = std::min(static_cast<int>(x), img.w - 2);
    const double t = x - j;
    return ((1 - t) * img.at(j, row, c) + t * img.at(j + 1, row, c)) / 255.0;
  }
  double height(int knot, double r) const {
    return channel(hm, knot, r, 0) * hmax - channel(hm, knot, r, 1) * rmin +
           channel(hm, knot, r, 2) * rmin;
  }
  double azimuth(int knot, double r) const {
    return channel(om, knot, r, 0) * kTwoPi +
           (-channel(om, knot, r, 1) + channel(om, knot, r, 2)) * 0.5 * kPi;
  }
  double r_dead(int knot) const { return channel(sm, knot, 0, 1) * rmin; }
};

RendererKnotDecode renderer_decode(const fs::path& dir) {
  RendererKnotDecode d;
  Result<std::string> text = read_text_file(dir / "map_params.json");
  EXPECT_TRUE(text);
  const Json p = Json::parse(text.value());
  d.rmin = p[0], d.rmax = p[1], d.hmax = p[2], d.n = p[3];
  d.hm = read_bmp(dir / "knot_height_map.bmp");
  d.om = read_bmp(dir / "knot_orientation_map.bmp");
  d.sm = read_bmp(dir / "knot_state_map.bmp");
  return d;
}

TEST(PublishedMapsGran1, KnotsAgreeWithAnIndependentDecodeOfTheRenderer) {
  const LogModel& log = shipped();
  const RendererKnotDecode d = renderer_decode(shipped_maps());
  ASSERT_EQ(d.n, 108);
  ASSERT_EQ(log.knots.size(), 108u);
  double worst_h = 0, worst_w = 0, worst_lateral = 0;
  for (int i = 0; i < d.n; ++i) {
    const Knot& k = log.knots[i];
    EXPECT_NEAR(k.r_dead, d.r_dead(i), 1e-9);
    // Column centres and points between them, over the map's range [rmin/64, rmin].
    for (double r : {2.0, 6.5, 10.0, 25.0, 47.0, 70.0, 100.0}) {
      // Our model's z is the maps' height (no sidecar: z_begin = 0).
      worst_h = std::max(worst_h, std::abs(k.height_at(r) - d.height(i, r)));
      const double dw = std::abs(angle_diff(k.azimuth_at(r), d.azimuth(i, r)));
      worst_w = std::max(worst_w, dw);
      worst_lateral = std::max(worst_lateral, r * dw);  // sideways offset of the axis, mm
    }
  }
  std::cout << "Gran_1 shipped maps vs renderer decode: height " << worst_h << " mm, azimuth "
            << worst_w << " rad, sideways " << worst_lateral << " mm\n";
  // Fit of the knot formula to truncated 8-bit columns that were computed over a stretched
  // radial axis (rp = r·rmax/rmin, docs/maps.md), plus linear interpolation between columns
  // 3.25 mm apart. Azimuth errors are largest near the pith, where ln r changes fastest and an
  // angle moves the axis least; hence also the bound on the sideways offset r·Δω.
  EXPECT_LT(worst_h, 1.0) << "mm";
  EXPECT_LT(worst_w, 0.12) << "rad";
  EXPECT_LT(worst_lateral, 1.0) << "mm";
}

TEST(PublishedMapsGran1, KnotsShowTheShippedWritersQuirks) {
  // The source rows [A..I] and what the shipped maps made of them (docs/maps.md):
  //  - start height and r_dead truncated to 8 bits; r_dead written over rmax, read over rmin;
  //  - start azimuth through the precedence slip ((F + 2π) mod 2)·π instead of F;
  //  - rise at column j computed at rp = j·rmax/32 with the sign flipped by the renderer.
  Result<std::string> text = read_text_file(test::gran1_source_dir() / "Gran_1_knots.json");
  ASSERT_TRUE(text);
  const Json rows = Json::parse(text.value());
  const LogModel& log = shipped();
  ASSERT_EQ(rows.size(), log.knots.size());
  const double rmin = 104.06, rmax = 143.375, hmax = 4000;
  int slipped = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    const Knot& k = log.knots[i];
    const double C = rows[i][2], D = rows[i][3], E = rows[i][4], F = rows[i][5], I = rows[i][8];
    SCOPED_TRACE("knot " + std::to_string(i));
    EXPECT_LE(k.z0, C + 1e-9);
    EXPECT_GT(k.z0, C - hmax / 255.0);
    const double slip = std::fmod(F + kTwoPi, 2.0) * kPi;
    EXPECT_LE(std::abs(angle_diff(k.omega0, slip)), kTwoPi / 255.0 + 1e-9);
    if (std::abs(angle_diff(k.omega0, F)) > 0.1) ++slipped;
    EXPECT_LE(k.r_dead, I * rmin / rmax + 1e-9);
    EXPECT_GT(k.r_dead, I * rmin / rmax - rmin / 255.0);
    EXPECT_DOUBLE_EQ(k.r_end, rmax) << "no r_end in the shipped maps: knots reach the bark";
    for (int j : {4, 10, 20, 28}) {
      const double r = (j + 0.5) * rmin / 32.0;
      const double rp = j * rmax / 32.0;
      const double shown = -(D * std::sqrt(rp) + E * rp);
      EXPECT_NEAR(k.height_at(r) - k.z0, shown, rmin / 255.0 + 0.25) << "column " << j;
    }
  }
  EXPECT_GE(slipped, 100) << "most start azimuths differ from Gran_1_knots.json (107 of 108)";
}

// ---- bad input
// ------------------------------------------------------------------------------------

// A fresh copy of the shipped maps (no sidecar) in a temp folder, to break.
struct BrokenMaps {
  test::TempDir tmp;
  fs::path dir = tmp / "maps";
  BrokenMaps() { fs::copy(shipped_maps(), dir, fs::copy_options::recursive); }
  std::string import_error() const {
    Result<LogModel> r = import_published_maps(dir);
    EXPECT_FALSE(r) << "import should fail";
    return r ? std::string() : r.error().message();
  }
};

TEST(PublishedMapsBadInput, MissingFolder) {
  test::TempDir tmp;
  Result<LogModel> r = import_published_maps(tmp / "nothing");
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr("no such folder"));
}

TEST(PublishedMapsBadInput, MissingMapParams) {
  BrokenMaps m;
  fs::remove(m.dir / "map_params.json");
  const std::string e = m.import_error();
  EXPECT_THAT(e, HasSubstr((m.dir / "map_params.json").string()));
  EXPECT_THAT(e, HasSubstr("no such file"));
}

TEST(PublishedMapsBadInput, MapParamsWithThreeNumbers) {
  BrokenMaps m;
  test::write_file(m.dir / "map_params.json", "[104.06, 143.375, 4000]");
  const std::string e = m.import_error();
  EXPECT_THAT(e, HasSubstr("map_params.json: expected 4 numbers [rmin, rmax, hmax, N], found 3"));
}

TEST(PublishedMapsBadInput, MapParamsWithNegativeRmin) {
  BrokenMaps m;
  test::write_file(m.dir / "map_params.json", "[-104.06, 143.375, 4000, 108]");
  EXPECT_THAT(m.import_error(), HasSubstr("map_params.json: rmin must be positive"));
}

TEST(PublishedMapsBadInput, MapParamsWithRminNotBelowRmax) {
  BrokenMaps m;
  test::write_file(m.dir / "map_params.json", "[150, 143.375, 4000, 108]");
  EXPECT_THAT(m.import_error(),
              HasSubstr("map_params.json: rmax (143.375) must be greater than rmin (150)"));
}

TEST(PublishedMapsBadInput, MapParamsMalformedOrFractionalCount) {
  BrokenMaps m;
  test::write_file(m.dir / "map_params.json", "[104.06, 143.375, 4000, 108.5]");
  EXPECT_THAT(m.import_error(), HasSubstr("map_params.json: knot count N must be a whole number"));
  test::write_file(m.dir / "map_params.json", "[104.06, 143.375, ");
  EXPECT_THAT(m.import_error(), HasSubstr("map_params.json: malformed JSON"));
}

TEST(PublishedMapsBadInput, MissingBmp) {
  BrokenMaps m;
  fs::remove(m.dir / "knot_orientation_map.bmp");
  const std::string e = m.import_error();
  EXPECT_THAT(e, HasSubstr((m.dir / "knot_orientation_map.bmp").string() + ": no such file"));
}

TEST(PublishedMapsBadInput, KnotMapWithWrongWidth) {
  BrokenMaps m;
  const Bmp img = read_bmp(m.dir / "knot_orientation_map.bmp");
  write_bmp(m.dir / "knot_orientation_map.bmp", resized(img, 31, img.h));
  EXPECT_THAT(m.import_error(),
              HasSubstr("knot_orientation_map.bmp: expected 32 columns, found 31"));
}

TEST(PublishedMapsBadInput, KnotMapWithWrongHeight) {
  BrokenMaps m;
  const Bmp img = read_bmp(m.dir / "knot_state_map.bmp");
  write_bmp(m.dir / "knot_state_map.bmp", resized(img, img.w, img.h - 4));
  EXPECT_THAT(m.import_error(), HasSubstr("knot_state_map.bmp: expected 432 rows, found 428"));
}

TEST(PublishedMapsBadInput, KnotRowsNotAMultipleOfTheKnotCount) {
  BrokenMaps m;
  const Bmp img = read_bmp(m.dir / "knot_height_map.bmp");
  write_bmp(m.dir / "knot_height_map.bmp", resized(img, img.w, img.h + 1));
  EXPECT_THAT(m.import_error(),
              HasSubstr("knot_height_map.bmp: 433 rows are not a multiple of the knot count 108"));
}

TEST(PublishedMapsBadInput, SizesCheckedAgainstTheSidecar) {
  test::TempDir tmp;
  const fs::path dir = tmp / "m";
  ASSERT_TRUE(export_published_maps(smooth_log(), dir));
  const Bmp hm = read_bmp(dir / "knot_height_map.bmp");
  write_bmp(dir / "knot_height_map.bmp", resized(hm, 31, hm.h));
  Result<LogModel> r = import_published_maps(dir);
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(), HasSubstr((dir / "knot_height_map.bmp").string() +
                                             ": expected 32 columns, found 31"));

  ASSERT_TRUE(export_published_maps(smooth_log(), dir));
  const Bmp pm = read_bmp(dir / "pith_and_radius_map.bmp");
  write_bmp(dir / "pith_and_radius_map.bmp", resized(pm, pm.w, pm.h - 1));
  r = import_published_maps(dir);
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(),
              HasSubstr("pith_and_radius_map.bmp: expected 240 rows, found 239"));
}

TEST(PublishedMapsBadInput, SidecarWithWrongTagOrKnotCount) {
  test::TempDir tmp;
  const fs::path dir = tmp / "m";
  ASSERT_TRUE(export_published_maps(smooth_log(), dir));
  Result<std::string> text = read_text_file(dir / "sawyer_maps.json");
  ASSERT_TRUE(text);
  Json j = Json::parse(text.value());
  Json bad = j;
  bad["format"] = "sawyer-maps/9";
  test::write_file(dir / "sawyer_maps.json", bad.dump());
  Result<LogModel> r = import_published_maps(dir);
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(),
              HasSubstr("sawyer_maps.json: format: is 'sawyer-maps/9', expected 'sawyer-maps/1'"));
  bad = j;
  bad["knots"].erase(0);
  test::write_file(dir / "sawyer_maps.json", bad.dump());
  r = import_published_maps(dir);
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(),
              HasSubstr("sawyer_maps.json: lists 6 knots, map_params.json says 7"));
  bad = j;
  bad["knots"][2]["r_end"] = "far";
  test::write_file(dir / "sawyer_maps.json", bad.dump());
  r = import_published_maps(dir);
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error().message(),
              HasSubstr("sawyer_maps.json: knots[2].r_end: expected a number, got string"));
}

TEST(PublishedMapsBadInput, CorruptBmp) {
  BrokenMaps m;
  test::write_file(m.dir / "knot_state_map.bmp", "this is not an image at all");
  const std::string e = m.import_error();
  EXPECT_THAT(e,
              HasSubstr((m.dir / "knot_state_map.bmp").string() + ": cannot read as a BMP image"));
  EXPECT_EQ(e.find('\n'), std::string::npos) << "one line";
}

TEST(PublishedMapsBadInput, TruncatedBmp) {
  BrokenMaps m;
  const fs::path p = m.dir / "pith_and_radius_map.bmp";
  fs::resize_file(p, fs::file_size(p) / 2);
  EXPECT_THAT(m.import_error(), HasSubstr(p.string() + ": corrupt or truncated image data"));
  fs::resize_file(p, 20);  // not even a whole header
  EXPECT_THAT(m.import_error(), HasSubstr(p.string() + ": cannot read as a BMP image"));
}

TEST(PublishedMapsBadInput, FolderWhereAFileShouldBe) {
  BrokenMaps m;
  const fs::path p = m.dir / "knot_height_map.bmp";
  fs::remove(p);
  fs::create_directory(p);
  EXPECT_THAT(m.import_error(), HasSubstr(p.string() + ": is a folder, expected a BMP image"));
}

TEST(PublishedMapsBadInput, FileWithoutReadPermission) {
  if (::geteuid() == 0) GTEST_SKIP() << "running as root: permissions do not stop reading";
  BrokenMaps m;
  const fs::path p = m.dir / "knot_height_map.bmp";
  fs::permissions(p, fs::perms::none);
  EXPECT_THAT(m.import_error(), HasSubstr(p.string() + ": cannot read as a BMP image"));
}

// ---- failed exports leave nothing behind -------------------------------------------------------

std::set<std::string> entries(const fs::path& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) out.insert(e.path().string());
  return out;
}

TEST(PublishedMapsExport, FailureLeavesNoPartialFolder) {
  test::TempDir tmp;
  // Late failure: the sidecar cannot be serialised (invalid UTF-8) after the four BMPs and
  // map_params.json were written to the temporary folder.
  LogModel bad = smooth_log();
  bad.source = "scanner \xff\xfe";
  const auto before = entries(tmp.path());
  Status st = export_published_maps(bad, tmp / "maps");
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr((tmp / "maps" / "sawyer_maps.json").string()));
  EXPECT_THAT(st.error().message(), HasSubstr("UTF-8"));
  EXPECT_EQ(entries(tmp.path()), before) << "no folder, no temporary folder left";

  // An existing folder stays as it was when the export fails.
  ASSERT_TRUE(export_published_maps(smooth_log(), tmp / "maps"));
  Result<std::string> old_params = read_text_file(tmp / "maps" / "map_params.json");
  ASSERT_TRUE(old_params);
  const auto with_old = entries(tmp.path());
  bad.stem.radius[3].pop_back();  // invalid model
  st = export_published_maps(bad, tmp / "maps");
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr("stem.radius[3]"));
  EXPECT_EQ(entries(tmp.path()), with_old);
  bad = smooth_log();
  bad.id = "\xc3";
  ASSERT_FALSE(export_published_maps(bad, tmp / "maps"));
  EXPECT_EQ(entries(tmp.path()), with_old);
  EXPECT_EQ(read_text_file(tmp / "maps" / "map_params.json").value(), old_params.value());

  // A destination whose parent is a file.
  test::write_file(tmp / "file", "x");
  st = export_published_maps(smooth_log(), tmp / "file" / "maps");
  ASSERT_FALSE(st);
  EXPECT_FALSE(fs::exists(tmp / "file" / "maps"));
}

TEST(PublishedMapsExport, NonFinitePithIsRejected) {
  LogModel log = smooth_log();
  log.stem.pith[5].y = std::nan("");
  test::TempDir tmp;
  Status st = export_published_maps(log, tmp / "m");
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr("m: stem.pith[5]: not a finite position"));
  EXPECT_FALSE(fs::exists(tmp / "m"));
}

TEST(PublishedMapsExport, BadOptionsAreRejected) {
  test::TempDir tmp;
  PublishedMapOptions o;
  o.stem_columns = 2;
  Status st = export_published_maps(smooth_log(), tmp / "m", o);
  ASSERT_FALSE(st);
  EXPECT_THAT(st.error().message(), HasSubstr("stem_columns"));
  EXPECT_FALSE(fs::exists(tmp / "m"));
}

}  // namespace
}  // namespace sawyer
