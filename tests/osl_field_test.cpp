// The OSL shader's wood field (shaders/osl/sawyer_wood.h, compiled here as C++ through
// tests/osl_shim.h) evaluated from the tables `sawyer export --osl-data` writes, read back from
// their float EXR files, agrees with the GLSL renderer's field on board faces of the real spruce
// log and of a generated pine: the time field within 2e-3 at 99 % of the pixels, the ring index
// and the knot masks (knot and dead part) as the GLSL/C++ agreement test (render_field_test.cpp)
// asks. Through the knot index it is the field of every knot at random points, visiting a
// fraction of the knots; its colour of wood and knots is the GLSL look's. And the data folder's
// rules.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "osl_shim.h"
#include "sawyer/export/osl_data.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/render/scene.h"
#include "sawyer/render/views.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/test/test_util.h"

namespace sawyer::osl_shim {
#include "../shaders/osl/sawyer_wood.h"
}  // namespace sawyer::osl_shim

namespace sawyer::exporter {
namespace {

namespace fs = std::filesystem;

// The shader's inputs from a folder write_osl_data wrote: its scalars from sawyer_osl.json and
// its tables registered with the shim under the names the shader is given; the look's
// parameters; the colour strip's middle row (what the shader's texture lookup reads).
struct OslLog {
  std::string files[6];
  osl_shim::SwLog lg{};
  osl_shim::SwLook look{};
  render::Image strip;
};

void load(const fs::path& dir, OslLog& out) {
  std::ifstream f(dir / "sawyer_osl.json");
  const nlohmann::json j = nlohmann::json::parse(f);
  ASSERT_EQ(j["format"], kOslFormatTag);
  const nlohmann::json& p = j["parameters"];
  const char* names[6] = {"pith.exr",   "stem.exr",       "knots.exr",
                          "tracks.exr", "cell_start.exr", "cell_knots.exr"};
  for (int i = 0; i < 6; ++i) {
    out.files[i] = (dir / names[i]).string();
    Result<render::Image> img = render::read_image(out.files[i], true);
    ASSERT_TRUE(img.ok()) << img.error().message();
    osl_shim::tables()[out.files[i].c_str()] = std::move(img).value();
  }
  osl_shim::SwLog& lg = out.lg;
  lg.pith_file = out.files[0].c_str();
  lg.stem_file = out.files[1].c_str();
  lg.knot_file = out.files[2].c_str();
  lg.track_file = out.files[3].c_str();
  lg.cell_start_file = out.files[4].c_str();
  lg.cell_knot_file = out.files[5].c_str();
  lg.cell_start_rows = p["CellStartRows"];
  lg.cell_knot_rows = p["CellKnotRows"];
  lg.cell_z0 = p["CellZ0"];
  lg.cell_dz = p["CellDz"];
  lg.cell_nz = p["CellNz"];
  lg.cell_dr = p["CellDr"];
  lg.cell_nr = p["CellNr"];
  lg.cell_ns = p["CellNs"];
  osl_shim::SwLook& k = out.look;
  const auto rgb = [&](const char* name, float& r, float& g, float& b) {
    r = p[name][0];
    g = p[name][1];
    b = p[name][2];
  };
  rgb("KnotSound", k.knot_sound_r, k.knot_sound_g, k.knot_sound_b);
  rgb("KnotDead", k.knot_dead_r, k.knot_dead_g, k.knot_dead_b);
  rgb("BarkRing", k.bark_ring_r, k.bark_ring_g, k.bark_ring_b);
  rgb("HeartTint", k.heart_tint_r, k.heart_tint_g, k.heart_tint_b);
  k.knot_rings = p["KnotRings"];
  k.strip_luma = p["StripLuma"];
  k.heartwood_tint = p["HeartwoodTint"];
  k.knot_darkening = p["KnotDarkening"];
  k.dead_outline = p["DeadOutline"];
  Result<render::Image> strip = render::read_image(dir / "wood_bar_color.bmp");
  ASSERT_TRUE(strip.ok()) << strip.error().message();
  out.strip = std::move(strip).value();
  lg.pith_z0 = p["PithZ0"];
  lg.pith_step = p["PithStep"];
  lg.pith_count = p["PithCount"];
  lg.stem_z0 = p["StemZ0"];
  lg.stem_step = p["StemStep"];
  lg.stem_cols = p["StemCols"];
  lg.stem_rows = p["StemRows"];
  lg.knot_count = p["KnotCount"];
  lg.track_rows = p["TrackRows"];
  lg.track_step = p["TrackStep"];
  lg.r_ref = p["RRef"];
  lg.knot_noise = p["KnotNoise"];
}

struct Agreement {
  int pixels = 0, close = 0, ring_agree = 0, knot_pixels = 0, knot_agree = 0, dead_pixels = 0;
  double sum = 0;
};

// The OSL field against the GLSL renderer's raw field over the top and bottom faces of `b`.
void compare_faces(const LogModel& log, const BoardBox& b, Agreement& out) {
  test::TempDir dir;
  Status st = write_osl_data(dir / "osl", log, {});
  ASSERT_TRUE(st.ok()) << st.error().message();
  OslLog osl;
  load(dir / "osl", osl);
  if (::testing::Test::HasFatalFailure()) return;
  EXPECT_EQ(osl.lg.knot_count, static_cast<int>(log.knots.size()));
  auto ctx = render::create_headless_context();
  ASSERT_TRUE(ctx.ok()) << ctx.error().message();
  auto r = render::WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  constexpr double kRings = 60;  // ring index: floor(t × 60), about the logs' annual rings
  for (render::Face f : {render::Face::kTop, render::Face::kBottom}) {
    const render::PlaneRect rect = render::board_face(b, f);
    const int w = 400, h = 64;
    render::ShadeOptions field;
    field.mode = render::ShadeMode::kTimeField;
    render::FaceLayout layout;
    layout.stretch = true;
    Result<render::Image> img =
        render::render_board_faces(*r.value(), b, static_cast<unsigned>(f), {w, h}, field, layout);
    ASSERT_TRUE(img.ok()) << img.error().message();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const Vec3 p = rect.at((x + 0.5) / w, 1.0 - (y + 0.5) / h);
        float t_stem = 0;
        int knot = -1, dead = 0;
        const float t =
            osl_shim::sw_wood_field(osl.lg, static_cast<float>(p.x), static_cast<float>(p.y),
                                    static_cast<float>(p.z), t_stem, knot, dead);
        if (t_stem > 1.0f) continue;  // beyond the wood
        const float t_gl = img.value().value(x, y, 0);
        const float code = img.value().value(x, y, 3);
        const int gl_knot = code < 0 ? -1 : static_cast<int>(code);
        ++out.pixels;
        const double d = std::abs(static_cast<double>(t) - t_gl);
        out.sum += d;
        out.close += d <= 2e-3;
        out.ring_agree += std::floor(t * kRings) == std::floor(t_gl * kRings) ||
                          std::abs(t * kRings - std::round(t * kRings)) < 0.01;  // on a border
        if (knot >= 0 || gl_knot >= 0) {
          ++out.knot_pixels;
          out.dead_pixels += dead != 0;
          out.knot_agree += knot == gl_knot && dead == (code - std::floor(code) > 0.25f);
        }
      }
  }
}

void expect_agreement(const Agreement& a, const std::string& what) {
  std::cout << "[ info ] " << what << ": OSL vs GLSL " << a.pixels << " px, "
            << 100.0 * a.close / a.pixels << " % within 2e-3, mean " << a.sum / a.pixels
            << "; ring index agrees at " << 100.0 * a.ring_agree / a.pixels << " %; knot px "
            << a.knot_pixels << " (dead " << a.dead_pixels << "), agree (knot and dead) "
            << a.knot_agree << "\n";
  ASSERT_GT(a.pixels, 20000) << what;
  EXPECT_GE(a.close, a.pixels * 99 / 100) << what;
  EXPECT_LT(a.sum / a.pixels, 2e-4) << what;
  EXPECT_GE(a.ring_agree, a.pixels * 99 / 100) << what;
  EXPECT_GT(a.knot_pixels, 100) << what;
  EXPECT_GE(a.knot_agree, a.knot_pixels * 97 / 100) << what;
}

// ---- the knot index (issue 44) ----------------------------------------------------------------

struct IndexCheck {
  int points = 0, same_t = 0, in_knots = 0;
  long long visits_indexed = 0, visits_all = 0;
  double max_dt = 0;
  double seconds_indexed = 0, seconds_all = 0;  // the C++ twin's time, for information only
};

// The field through the knot index against the field of every knot at `n` random points: half
// anywhere in and around the log, half within 12 mm of a knot's axis along each axis.
void check_index(const LogModel& log, int n, IndexCheck& out) {
  test::TempDir dir;
  Status st = write_osl_data(dir / "osl", log, {});
  ASSERT_TRUE(st.ok()) << st.error().message();
  OslLog osl;
  load(dir / "osl", osl);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_GT(osl.lg.cell_nz, 0);
  const Stem& stem = log.stem;
  double r_max = 0;
  for (int i = 0; i < stem.slice_count(); ++i) r_max = std::max(r_max, stem.mean_radius(i));
  std::mt19937 rng(44);
  std::uniform_real_distribution<double> u01(0, 1);
  for (int i = 0; i < n; ++i) {
    Vec3 p;
    if (i % 2 == 0 || log.knots.empty()) {
      const double z = stem.z_begin() + u01(rng) * (stem.z_end() - stem.z_begin());
      const double r = 1.3 * r_max * std::sqrt(u01(rng)), a = kTwoPi * u01(rng);
      const Vec2 c = stem.pith_at(z);
      p = {c.x + r * std::cos(a), c.y + r * std::sin(a), z};
    } else {
      const Knot& k = log.knots[static_cast<size_t>(rng() % log.knots.size())];
      const Vec3 a = k.axis_point(u01(rng) * (k.r_end + 20.0), stem);
      p = {a.x + 24 * (u01(rng) - 0.5), a.y + 24 * (u01(rng) - 0.5), a.z + 24 * (u01(rng) - 0.5)};
    }
    osl_shim::SwSample a{}, b{};
    const float x = static_cast<float>(p.x), y = static_cast<float>(p.y),
                z = static_cast<float>(p.z);
    const auto t0 = std::chrono::steady_clock::now();
    const float t_index = osl_shim::sw_wood_sample(osl.lg, x, y, z, 1, a);
    const auto t1 = std::chrono::steady_clock::now();
    const float t_all = osl_shim::sw_wood_sample(osl.lg, x, y, z, 0, b);
    out.seconds_indexed += std::chrono::duration<double>(t1 - t0).count();
    out.seconds_all += std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    ++out.points;
    const double dt = std::abs(static_cast<double>(t_index) - t_all);
    out.max_dt = std::max(out.max_dt, dt);
    out.same_t += t_index == t_all;
    out.in_knots += b.knot >= 0;
    out.visits_indexed += a.visits;
    out.visits_all += b.visits;
    EXPECT_LE(dt, 1e-5) << "at " << p.x << ", " << p.y << ", " << p.z;
    EXPECT_EQ(a.knot, b.knot);
    EXPECT_EQ(a.dead, b.dead);
    EXPECT_EQ(a.t_stem, b.t_stem);
    EXPECT_NEAR(std::min(a.near_depth, 100.f), std::min(b.near_depth, 100.f), 1e-5);
    EXPECT_NEAR(std::min(a.dead_depth, 100.f), std::min(b.dead_depth, 100.f), 1e-5);
  }
}

void expect_index(const IndexCheck& c, const std::string& what) {
  std::cout << "[ info ] " << what << ": " << c.points << " points, t equal at " << c.same_t
            << " (max |diff| " << c.max_dt << "), " << c.in_knots << " in knots; knots visited "
            << c.visits_indexed << " through the index, " << c.visits_all << " without ("
            << static_cast<double>(c.visits_all) / std::max<long long>(1, c.visits_indexed)
            << " x fewer); the C++ twin " << 1e6 * c.seconds_indexed / c.points
            << " us a point through the index, " << 1e6 * c.seconds_all / c.points << " without\n";
  EXPECT_GT(c.in_knots, c.points / 50) << what;
  // The work a point costs: the knots it visits. The index lists a point's cell's knots only.
  EXPECT_LT(c.visits_indexed * 5, c.visits_all) << what;
}

TEST(OslIndex, TheIndexedFieldIsTheFieldOfEveryKnotOnGran1) {
  IndexCheck c;
  check_index(test::sample_model("gran1_spruce"), 20000, c);
  if (HasFatalFailure()) return;
  expect_index(c, "gran1");
}

TEST(OslIndex, TheIndexedFieldIsTheFieldOfEveryKnotOnAGeneratedPine) {
  GeneratorOptions o;
  o.species = Species::kPine;
  o.seed = 5;
  o.length_mm = 3000;
  Result<LogModel> log = generate_log(o);
  ASSERT_TRUE(log.ok()) << log.error().message();
  IndexCheck c;
  check_index(log.value(), 20000, c);
  if (HasFatalFailure()) return;
  expect_index(c, "generated pine");
}

// ---- the colour (issue 44: the OSL knots were the ring colour darkened, greyer than the GLSL
// look's) ---------------------------------------------------------------------------------------

// The strip's middle row as GL samples it with textureGrad: trilinear between box-filtered
// mipmap levels at level log2(rate × width) (GL_LINEAR_MIPMAP_LINEAR, GL_CLAMP_TO_EDGE).
struct StripSampler {
  std::vector<std::vector<std::array<float, 3>>> levels;
  explicit StripSampler(const render::Image& img) {
    std::vector<std::array<float, 3>> row(static_cast<size_t>(img.width));
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c) row[static_cast<size_t>(x)][c] = img.value(x, img.height / 2, c);
    levels.push_back(row);
    // Each level half the last (rounded down), its texels the last level sampled linearly at
    // their centres (Mesa's mipmap generation by a linear blit: a box filter for even widths).
    while (levels.back().size() > 1) {
      const size_t n = levels.back().size() / 2;
      std::vector<std::array<float, 3>> b(n);
      for (size_t j = 0; j < n; ++j)
        b[j] = linear(levels.size() - 1, (j + 0.5) / static_cast<double>(n));
      levels.push_back(b);
    }
  }
  std::array<float, 3> linear(size_t level, double t) const {
    const auto& l = levels[std::min(level, levels.size() - 1)];
    const double u = std::clamp(t, 0.0, 1.0) * static_cast<double>(l.size()) - 0.5;
    const double f = std::floor(u);
    const long i0 = std::clamp(static_cast<long>(f), 0L, static_cast<long>(l.size()) - 1);
    const long i1 = std::clamp(static_cast<long>(f) + 1, 0L, static_cast<long>(l.size()) - 1);
    const double a = u - f;
    std::array<float, 3> out{};
    for (int c = 0; c < 3; ++c)
      out[c] = static_cast<float>((1 - a) * l[static_cast<size_t>(i0)][c] +
                                  a * l[static_cast<size_t>(i1)][c]);
    return out;
  }
  std::array<float, 3> at(double t, double rate) const {
    const double lod = std::log2(std::max(rate * static_cast<double>(levels[0].size()), 1e-30));
    if (lod <= 0) return linear(0, t);
    const size_t d = static_cast<size_t>(std::floor(lod));
    const double f = lod - std::floor(lod);
    const std::array<float, 3> a = linear(d, t), b = linear(d + 1, t);
    std::array<float, 3> out{};
    for (int c = 0; c < 3; ++c) out[c] = static_cast<float>((1 - f) * a[c] + f * b[c]);
    return out;
  }
};

struct ColourCheck {
  int pixels = 0, close = 0, knot_pixels = 0, knot_close = 0;
  double sum = 0, knot_sum = 0, knot_sum_old = 0;
};

// The OSL colour (sw_wood_color of the indexed sample, the strip filtered as the renderer does)
// against the renderer's own unlit colour of the top and bottom faces of `b`.
void compare_colours(const LogModel& log, const BoardBox& b, ColourCheck& out) {
  test::TempDir dir;
  Status st = write_osl_data(dir / "osl", log, {});
  ASSERT_TRUE(st.ok()) << st.error().message();
  OslLog osl;
  load(dir / "osl", osl);
  if (::testing::Test::HasFatalFailure()) return;
  const StripSampler strip(osl.strip);
  auto ctx = render::create_headless_context();
  ASSERT_TRUE(ctx.ok()) << ctx.error().message();
  auto r = render::WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  render::ShadeOptions shade;
  shade.lighting = false;
  render::FaceLayout layout;
  layout.stretch = true;
  for (render::Face f : {render::Face::kTop, render::Face::kBottom}) {
    const render::PlaneRect rect = render::board_face(b, f);
    const int w = 800, h = 64;
    Result<render::Image> img =
        render::render_board_faces(*r.value(), b, static_cast<unsigned>(f), {w, h}, shade, layout);
    ASSERT_TRUE(img.ok()) << img.error().message();
    const Vec3 dx = (rect.width / w) * rect.u, dy = (rect.height / h) * rect.v;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const Vec3 p = rect.at((x + 0.5) / w, 1.0 - (y + 0.5) / h);
        osl_shim::SwSample s{};
        const float t =
            osl_shim::sw_wood_sample(osl.lg, static_cast<float>(p.x), static_cast<float>(p.y),
                                     static_cast<float>(p.z), 1, s);
        if (s.t_stem > 0.98f) continue;  // the outline's pixels are the renderer's to blend
        // The rate wood.frag filters the strip at: the stem's, or in a knot its own.
        const Vec2 c = log.stem.pith_at(p.z);
        const Vec3 radial =
            s.r > 0 ? Vec3{(p.x - c.x) / s.r, (p.y - c.y) / s.r, 0.0} : Vec3{1.0, 0.0, 0.0};
        const double R = s.r / std::max(s.t_stem, 1e-6f);
        double rx = std::abs(dot(radial, dx)) / std::max(R, 1.0);
        double ry = std::abs(dot(radial, dy)) / std::max(R, 1.0);
        if (s.near_depth < 1.1f) {
          rx = std::max(rx, s.knot_rate * dx.norm());
          ry = std::max(ry, s.knot_rate * dy.norm());
        }
        const std::array<float, 3> ring = strip.at(std::clamp(t, 0.0f, 1.0f), std::max(rx, ry));
        float cr = 0, cg = 0, cb = 0;
        osl_shim::sw_wood_color(osl.look, s, ring[0], ring[1], ring[2], cr, cg, cb);
        const float mine[3] = {cr, cg, cb};
        double d = 0, d_old = 0;
        for (int k = 0; k < 3; ++k) {
          const double gl = img.value().value(x, y, k);
          d = std::max(d, std::abs(std::min(1.0, static_cast<double>(mine[k])) - gl));
          // What the shader gave before: the ring colour times 0.7 (sound) or 0.45 (dead).
          const double old = ring[k] * (s.knot < 0 ? 1.0 : s.dead ? 0.45 : 0.7);
          d_old = std::max(d_old, std::abs(old - gl));
        }
        ++out.pixels;
        out.sum += d;
        out.close += d <= 4.0 / 255;
        if (s.knot >= 0) {
          ++out.knot_pixels;
          out.knot_sum += d;
          out.knot_sum_old += d_old;
          out.knot_close += d <= 4.0 / 255;
        }
      }
  }
}

void expect_colours(const ColourCheck& c, const std::string& what) {
  std::cout << "[ info ] " << what << ": OSL vs GLSL colour " << c.pixels << " px, "
            << 100.0 * c.close / c.pixels << " % within 4/255, mean max-channel |diff| "
            << c.sum / c.pixels << "; knot px " << c.knot_pixels << ": "
            << 100.0 * c.knot_close / std::max(1, c.knot_pixels) << " % within 4/255, mean "
            << c.knot_sum / std::max(1, c.knot_pixels)
            << " (the former OSL knot colour: " << c.knot_sum_old / std::max(1, c.knot_pixels)
            << ")\n";
  ASSERT_GT(c.pixels, 20000) << what;
  ASSERT_GT(c.knot_pixels, 100) << what;
  EXPECT_GE(c.close, c.pixels * 99 / 100) << what;
  EXPECT_GE(c.knot_close, c.knot_pixels * 90 / 100) << what;
  EXPECT_LT(c.knot_sum, 0.2 * c.knot_sum_old) << what;
}

// The real spruce: render_field_test's board, 160 x 40 mm, 20 mm above the pith.
BoardBox gran1_board(const LogModel& log) {
  const Vec2 c = log.stem.pith_at(1500);
  BoardBox b;
  b.cx = c.x;
  b.cy = c.y + 20;
  b.width = 160;
  b.thickness = 40;
  b.z0 = 1000;
  b.z1 = 2000;
  return b;
}

// A generated pine (dead knots, heartwood) and a thin board through its pith, whose faces cross
// every knot near their start.
LogModel generated_pine() {
  GeneratorOptions o;
  o.species = Species::kPine;
  o.seed = 5;
  o.length_mm = 3000;
  Result<LogModel> log = generate_log(o);
  EXPECT_TRUE(log.ok()) << log.error().message();
  return log.ok() ? std::move(log.value()) : LogModel{};
}
BoardBox pine_board(const LogModel& log) {
  const Vec2 c = log.stem.pith_at(1200);
  BoardBox b;
  b.cx = c.x;
  b.cy = c.y;
  b.width = 240;
  b.thickness = 12;
  b.z0 = 600;
  b.z1 = 1800;
  return b;
}

TEST(OslColour, KnotsAndWoodHaveTheGlslLookOnGran1) {
  const LogModel& log = test::sample_model("gran1_spruce");
  ColourCheck check;
  compare_colours(log, gran1_board(log), check);
  if (HasFatalFailure()) return;
  expect_colours(check, "gran1 board 160 x 40");
}

TEST(OslColour, KnotsAndHeartwoodHaveTheGlslLookOnAGeneratedPine) {
  const LogModel log = generated_pine();
  ASSERT_FALSE(log.knots.empty());
  ColourCheck check;
  compare_colours(log, pine_board(log), check);
  if (HasFatalFailure()) return;
  expect_colours(check, "pine board through the pith");
}

TEST(OslField, AgreesWithTheGlslRendererOnGran1BoardFaces) {
  const LogModel& log = test::sample_model("gran1_spruce");
  Agreement a;
  compare_faces(log, gran1_board(log), a);
  if (HasFatalFailure()) return;
  expect_agreement(a, "gran1 board 160 x 40");
}

TEST(OslField, AgreesWithTheGlslRendererOnAPineThroughThePith) {
  const LogModel log = generated_pine();
  ASSERT_FALSE(log.knots.empty());
  Agreement a;
  compare_faces(log, pine_board(log), a);
  if (HasFatalFailure()) return;
  expect_agreement(a, "pine board through the pith");
}

// The hash the knot outlines' noise rests on gives the same bits as the GLSL one
// (wood_field.glsl's wf_hash, whose constants and shifts it restates).
TEST(OslField, HashMatchesTheGlslHash) {
  auto ref = [](std::uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
  };
  for (std::uint32_t x : {0u, 1u, 17u, 7919u * 108u + 17u, 0xdeadbeefu, 0xffffffffu})
    EXPECT_EQ(osl_shim::sw_hash(x), ref(x)) << x;
}

TEST(OslData, RefusesWhatItDidNotWrite) {
  test::TempDir dir;
  test::write_file(dir / "file", "x");
  Status st = check_osl_data_dir(dir / "file", "--osl-data");
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message().find("--osl-data: "), std::string::npos);
  EXPECT_NE(st.error().message().find("not a folder"), std::string::npos);
  fs::create_directories(dir / "mine");
  test::write_file(dir / "mine" / "notes.txt", "keep me");
  st = write_osl_data(dir / "mine", test::sample_model("gran1_spruce"), {});
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message().find("did not write"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "mine" / "notes.txt"));
  // Its own folder is replaced whole.
  ASSERT_TRUE(write_osl_data(dir / "osl", test::sample_model("gran1_spruce"), {}).ok());
  ASSERT_TRUE(write_osl_data(dir / "osl", test::sample_model("gran1_spruce"), {}).ok());
  EXPECT_TRUE(fs::exists(dir / "osl" / "tracks.exr"));
}

}  // namespace
}  // namespace sawyer::exporter
