// Images from the renderer: a board face written through OpenImageIO and read back has the size
// asked for and real content (knots darker than clear wood where the model puts a knot on the
// face, heartwood darker than sapwood); the render job checks and draws as the views do; `sawyer
// render` writes images and rejects bad input with one line and no output file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

#include "sawyer/model/log_generator.h"
#include "sawyer/model/log_json.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/render/render_job.h"
#include "sawyer/render/views.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/test/render_context.h"
#include "sawyer/test/test_util.h"

namespace sawyer::render {
namespace {

namespace fs = std::filesystem;

float luminance(const Image& img, int x, int y) {
  return 0.2126f * img.value(x, y, 0) + 0.7152f * img.value(x, y, 1) + 0.0722f * img.value(x, y, 2);
}

TEST(RenderImage, BoardFaceIsWrittenAndShowsTheKnots) {
  test::ensure_headless_context();
  const LogModel& log = test::sample_model("gran1_spruce");
  auto r = WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  const Vec3 c = r.value()->pith_point(0);
  BoardBox b;
  b.cx = c.x;
  b.cy = c.y + 45;
  b.width = 150;
  b.thickness = 30;
  b.z0 = 1000;
  b.z1 = 2500;
  const int w = 1500;
  Result<Image> img = render_board_faces(*r.value(), b, static_cast<unsigned>(Face::kTop), {w, 0});
  ASSERT_TRUE(img.ok()) << img.error().message();
  ASSERT_EQ(img.value().width, w);
  ASSERT_EQ(img.value().height, 150);  // 1 px per mm across, as along

  test::TempDir dir;
  ASSERT_TRUE(write_image(dir / "face.png", img.value()).ok());
  Result<Image> back = read_image(dir / "face.png");
  ASSERT_TRUE(back.ok()) << back.error().message();
  const Image& im = back.value();
  ASSERT_EQ(im.width, w);
  ASSERT_EQ(im.height, 150);

  const PlaneRect face = board_face(b, Face::kTop);
  double knot_sum = 0, wood_sum = 0, sum = 0, sum2 = 0;
  int knots = 0, wood = 0, opaque = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const Vec3 p = face.at((x + 0.5) / im.width, 1.0 - (y + 0.5) / im.height);
      const MaterialSample m = log.material_at(p);
      const float l = luminance(im, x, y);
      if (im.value(x, y, 3) > 0.5f) {
        ++opaque;
        sum += l;
        sum2 += l * l;
      }
      if (m.material == Material::kSoundKnot || m.material == Material::kDeadKnot) {
        knot_sum += l;
        ++knots;
      } else if (m.material == Material::kWood) {
        wood_sum += l;
        ++wood;
      }
    }
  ASSERT_GT(opaque, im.width * im.height * 9 / 10) << "the face lies inside the log";
  const double mean = sum / opaque, sd = std::sqrt(std::max(0.0, sum2 / opaque - mean * mean));
  EXPECT_GT(sd, 0.03) << "rings and knots, not a flat colour";
  EXPECT_GT(mean, 0.3);
  ASSERT_GT(knots, 200) << "the model puts knots on this face";
  EXPECT_LT(knot_sum / knots, wood_sum / wood - 0.1)
      << "knots " << knot_sum / knots << " vs clear wood " << wood_sum / wood;
}

TEST(RenderImage, FailedWriteLeavesNothing) {
  Image img;
  img.width = 4;
  img.height = 3;
  img.u8.assign(4 * 3 * 4, 200);
  test::TempDir dir;
  test::write_file(dir / "file", "not a folder");
  const Status st = write_image(dir / "file" / "x.png", img);  // parent is a file
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message().find("file"), std::string::npos) << st.error().message();
  const Status bad = write_image(dir / "x.bmpx", img);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message().find("x.bmpx"), std::string::npos);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator{}), 1);
  // And a good write round-trips exactly (8-bit PNG).
  ASSERT_TRUE(write_image(dir / "ok.png", img).ok());
  Result<Image> back = read_image(dir / "ok.png");
  ASSERT_TRUE(back.ok()) << back.error().message();
  EXPECT_EQ(back.value().u8, img.u8);
}

// `sawyer render`'s job (render_job.h): its checks name the job's fields, and what it draws is
// what the view functions draw for the same request on a context of one's own.
TEST(RenderJob, ChecksNameTheFieldsAndTheJobDrawsWhatTheViewDraws) {
  const LogModel& log = test::sample_model("gran1_spruce");
  RenderJob two;
  two.section_z = 1500;
  two.longitudinal_deg = 20;
  const Status modes = check_render_job(two);
  ASSERT_FALSE(modes.ok());
  EXPECT_NE(modes.error().message().find("RenderJob: give exactly one of RenderJob::boards"),
            std::string::npos)
      << modes.error().message();
  RenderJob far;
  far.section_z = log.stem.z_end() + 100;
  ASSERT_TRUE(check_render_job(far).ok());
  const Status outside = check_render_job(far, log);
  ASSERT_FALSE(outside.ok());
  EXPECT_NE(outside.error().message().find("RenderJob::section_z: z = "), std::string::npos)
      << outside.error().message();
  RenderJob noisy;
  noisy.section_z = 1500;
  noisy.renderer.field.knot_noise = 0.9;
  EXPECT_FALSE(check_render_job(noisy).ok());

  RenderJob job;
  job.section_z = 1500;
  job.size = {160, 0};
  ASSERT_TRUE(check_render_job(job).ok());
  ASSERT_TRUE(check_render_job(job, log).ok());
  Image direct;
  {
    test::ensure_headless_context();
    auto r = WoodRenderer::create(log, job.renderer);
    ASSERT_TRUE(r.ok()) << r.error().message();
    Result<Image> img = render_cross_section(*r.value(), 1500, job.size, job.shade, job.layout);
    ASSERT_TRUE(img.ok()) << img.error().message();
    direct = img.value();
  }
  Result<RenderedImage> out = run_render_job(log, job);
  ASSERT_TRUE(out.ok()) << out.error().message();
  EXPECT_EQ(out.value().what, "cross-section z = 1500 mm");
  EXPECT_FALSE(out.value().context.empty());
  const Image& im = out.value().image;
  ASSERT_EQ(im.width, direct.width);
  ASSERT_EQ(im.height, direct.height);
  ASSERT_EQ(im.u8.size(), direct.u8.size());
  int far_off = 0;
  for (size_t i = 0; i < im.u8.size(); ++i)
    if (std::abs(int(im.u8[i]) - int(direct.u8[i])) > 2) ++far_off;
  EXPECT_EQ(far_off, 0);
}

TEST(RenderImage, HeartwoodIsDarkerThanSapwood) {
  test::ensure_headless_context();
  GeneratorOptions o;
  o.species = Species::kPine;
  o.seed = 11;
  o.length_mm = 2000;
  auto log = generate_log(o);
  ASSERT_TRUE(log.ok()) << log.error().message();
  ASSERT_TRUE(log.value().stem.has_heartwood());
  auto r = WoodRenderer::create(log.value());
  ASSERT_TRUE(r.ok()) << r.error().message();
  ShadeOptions flat;
  flat.lighting = false;
  ShadeOptions no_tint = flat;
  no_tint.heartwood_tint = false;
  const double z = 1000;
  Result<Image> a = render_cross_section(*r.value(), z, {300, 300}, flat);
  Result<Image> b = render_cross_section(*r.value(), z, {300, 300}, no_tint);
  ASSERT_TRUE(a.ok() && b.ok());
  const PlaneRect rect = cross_section_rect(*r.value(), z);
  const Stem& st = log.value().stem;
  double heart_ratio = 0, sap_ratio = 0;
  int heart = 0, sap = 0;
  for (int y = 0; y < 300; ++y)
    for (int x = 0; x < 300; ++x) {
      const Vec3 p = rect.at((x + 0.5) / 300, 1.0 - (y + 0.5) / 300);
      if (!st.contains(p) || log.value().material_at(p).material != Material::kWood) continue;
      const float la = luminance(a.value(), x, y), lb = luminance(b.value(), x, y);
      if (lb <= 0.05f) continue;
      double rr, w;
      st.polar(p, &rr, &w);
      const double H = st.heartwood_at(w, z);
      if (rr < H - 3) {
        heart_ratio += la / lb;
        ++heart;
      } else if (rr > H + 3) {
        sap_ratio += la / lb;
        ++sap;
      }
    }
  ASSERT_GT(heart, 500);
  ASSERT_GT(sap, 500);
  EXPECT_LT(heart_ratio / heart, 0.95);
  EXPECT_NEAR(sap_ratio / sap, 1.0, 0.01);
}

TEST(RenderCli, WritesABoardImage) {
  test::TempDir dir;
  std::string out;
  const fs::path png = dir / "board.png";
  const int rc = test::run_sawyer(
      "render " + test::quoted(test::sample_log("gran1_spruce") / "log.json") + " -o " +
          test::quoted(png) + " --board 0,40,150,40,0,500,1500 --face top,bottom --size 1000",
      &out);
  ASSERT_EQ(rc, 0) << out;
  Result<Image> img = read_image(png);
  ASSERT_TRUE(img.ok()) << img.error().message();
  EXPECT_EQ(img.value().width, 1000);
  EXPECT_EQ(img.value().height, 150 + 8 + 150);  // two 150 mm faces at 1 px/mm and a gap
}

TEST(RenderCli, WritesTheRawFieldAsFloatExr) {
  test::TempDir dir;
  std::string out;
  const fs::path exr = dir / "field.exr";
  const int rc =
      test::run_sawyer("render " + test::quoted(test::sample_log("gran1_spruce") / "log.json") +
                           " -o " + test::quoted(exr) + " --section 2000 --size 200 --field",
                       &out);
  ASSERT_EQ(rc, 0) << out;
  Result<Image> img = read_image(exr, true);
  ASSERT_TRUE(img.ok()) << img.error().message();
  ASSERT_EQ(img.value().width, 200);
  // The centre pixel is near the pith: small time; the stem time grows outwards.
  EXPECT_LT(img.value().value(100, 100, 1), 0.1f);
  EXPECT_GT(img.value().value(100, 10, 1), img.value().value(100, 60, 1));
}

TEST(RenderCli, BadInputGetsOneLineAndNoOutput) {
  test::TempDir dir;
  const std::string log = test::quoted(test::sample_log("gran1_spruce") / "log.json");
  const fs::path png = dir / "x.png";
  const std::string o = " -o " + test::quoted(png);
  struct Case {
    std::string args, expect;
  };
  const Case cases[] = {
      {"render " + test::quoted(dir / "missing.json") + o + " --section 100", "missing.json"},
      {"render " + log + o + " --board 1,2,3", "--board"},
      {"render " + log + o + " --board 0,0,100,-5,0,0,100", "thickness"},
      {"render " + log + o + " --board 0,0,100,50,0,0,100 --face middle", "--face"},
      {"render " + log + " -o " + test::quoted(dir / "x.bmpx") + " --section 100", "x.bmpx"},
      {"render " + log + o + " --section 99999", "outside the log"},
      {"render " + log + o + " --board 0,40,150,40,0,5000,5500", "misses the log"},
      {"render " + log + o, "exactly one of"},
      {"render " + log + o + " --section 100 --size 0x10", "--size"},
      {"render " + log + o + " --section 100 --field", ".exr"},
  };
  for (const Case& c : cases) {
    std::string out;
    const int rc = test::run_sawyer(c.args, &out);
    EXPECT_NE(rc, 0) << c.args;
    EXPECT_NE(out.find(c.expect), std::string::npos) << c.args << "\n" << out;
    while (!out.empty() && out.back() == '\n') out.pop_back();
    EXPECT_EQ(out.find('\n'), std::string::npos) << c.args << "\n" << out;
    EXPECT_FALSE(fs::exists(png)) << c.args;
  }
  // A file that is not a log.
  test::write_file(dir / "bad.json", "{\"format\": \"nonsense\"}");
  std::string out;
  EXPECT_NE(
      test::run_sawyer("render " + test::quoted(dir / "bad.json") + o + " --section 10", &out), 0);
  EXPECT_NE(out.find("bad.json"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(png));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator{}), 1)
      << "only bad.json: no temporary files left";
}

}  // namespace
}  // namespace sawyer::render
