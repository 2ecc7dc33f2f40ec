// The OSL shader's wood field (shaders/osl/sawyer_wood.h, compiled here as C++ through
// tests/osl_shim.h) evaluated from the tables `sawyer export --osl-data` writes, read back from
// their float EXR files, agrees with the GLSL renderer's field on board faces of the real spruce
// log and of a generated pine: the time field within 2e-3 at 99 % of the pixels, the ring index
// and the knot masks (knot and dead part) as the GLSL/C++ agreement test (render_field_test.cpp)
// asks. And the data folder's rules.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iostream>
#include <string>

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
// its tables registered with the shim under the names the shader is given.
struct OslLog {
  std::string files[4];
  osl_shim::SwLog lg{};
};

void load(const fs::path& dir, OslLog& out) {
  std::ifstream f(dir / "sawyer_osl.json");
  const nlohmann::json j = nlohmann::json::parse(f);
  ASSERT_EQ(j["format"], kOslFormatTag);
  const nlohmann::json& p = j["parameters"];
  const char* names[4] = {"pith.exr", "stem.exr", "knots.exr", "tracks.exr"};
  for (int i = 0; i < 4; ++i) {
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

// The real spruce: render_field_test's board, 160 x 40 mm, 20 mm above the pith.
TEST(OslField, AgreesWithTheGlslRendererOnGran1BoardFaces) {
  const LogModel& log = test::sample_model("gran1_spruce");
  const Vec2 c = log.stem.pith_at(1500);
  BoardBox b;
  b.cx = c.x;
  b.cy = c.y + 20;
  b.width = 160;
  b.thickness = 40;
  b.z0 = 1000;
  b.z1 = 2000;
  Agreement a;
  compare_faces(log, b, a);
  if (HasFatalFailure()) return;
  expect_agreement(a, "gran1 board 160 x 40");
}

// A generated pine (dead knots, heartwood): a thin board through the pith, whose faces cross
// every knot near their start.
TEST(OslField, AgreesWithTheGlslRendererOnAPineThroughThePith) {
  GeneratorOptions o;
  o.species = Species::kPine;
  o.seed = 5;
  o.length_mm = 3000;
  Result<LogModel> log = generate_log(o);
  ASSERT_TRUE(log.ok()) << log.error().message();
  const Vec2 c = log.value().stem.pith_at(1200);
  BoardBox b;
  b.cx = c.x;
  b.cy = c.y;
  b.width = 240;
  b.thickness = 12;
  b.z0 = 600;
  b.z1 = 1800;
  Agreement a;
  compare_faces(log.value(), b, a);
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
