// How the renderer draws wood beyond the time field (issue 23): knots with their own rings and
// colour, dead knots ringed by dark encased bark with no pale band inside it, the species looks,
// bark outside the wood, and adaptive anti-aliasing that matches samples taken in every pixel.
// Each pixel is classified by the CPU's WoodField (the same field, tests/render_field_test.cpp)
// at the point the pixel shows.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "sawyer/field/wood_field.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/render/shader_program.h"
#include "sawyer/render/views.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/test/render_context.h"
#include "sawyer/test/test_util.h"

namespace sawyer::render {
namespace {

float luma(const Image& img, int x, int y) {
  return 0.299f * img.value(x, y, 0) + 0.587f * img.value(x, y, 1) + 0.114f * img.value(x, y, 2);
}

// Redness: (R - B) over the sum of the channels.
float redness(const Image& img, int x, int y) {
  const float r = img.value(x, y, 0), g = img.value(x, y, 1), b = img.value(x, y, 2);
  return (r - b) / std::max(1e-3f, r + g + b);
}

struct Stats {
  double sum = 0, sum2 = 0, red = 0;
  int n = 0;
  void add(double l, double r) {
    sum += l;
    sum2 += l * l;
    red += r;
    ++n;
  }
  double mean() const { return n ? sum / n : 0; }
  double sd() const { return n ? std::sqrt(std::max(0.0, sum2 / n - mean() * mean())) : 0; }
  double redness() const { return n ? red / n : 0; }
};

// A 100 mm stretch of a 150 mm wide board 45 mm above gran1's pith, where its top face cuts one
// sound and one dead knot (docs/render.md's gallery crop), 6 px per mm, flat colour.
struct KnotFace {
  BoardBox board;
  PlaneRect face;
  Image image;
};

KnotFace render_knot_face(WoodRenderer& r, const FaceLayout& layout = {}, double z0 = 1880,
                          double z1 = 1980, int width_px = 600) {
  KnotFace k;
  const Vec3 c = r.pith_point(0);
  k.board.cx = c.x;
  k.board.cy = c.y + 45;
  k.board.width = 150;
  k.board.thickness = 40;
  k.board.z0 = z0;
  k.board.z1 = z1;
  k.face = board_face(k.board, Face::kTop);
  ShadeOptions flat;
  flat.lighting = false;
  Result<Image> img = render_board_faces(r, k.board, static_cast<unsigned>(Face::kTop),
                                         {width_px, 0}, flat, layout);
  EXPECT_TRUE(img.ok()) << img.error().message();
  if (img) k.image = std::move(img).value();
  return k;
}

TEST(RenderLook, KnotsShowTheirOwnRingsInTheirOwnColourAndDeadKnotsABarkRing) {
  test::ensure_headless_context();
  const LogModel& log = test::sample_model("gran1_spruce");
  auto r = WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  EXPECT_EQ(r.value()->look().name, "spruce");
  KnotFace k = render_knot_face(*r.value());
  const Image& im = k.image;
  ASSERT_EQ(im.width, 600);
  ASSERT_EQ(im.height, 900);
  WoodField field(log);
  Stats clear, sound, dead_core, dead_inner_band, dead_rim;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const FieldSample s =
          field.sample(k.face.at((x + 0.5) / im.width, 1.0 - (y + 0.5) / im.height));
      const double l = luma(im, x, y), red = redness(im, x, y);
      if (s.knot < 0) {
        if (std::abs(s.t - s.t_stem) < 0.005f) clear.add(l, red);
      } else if (!s.dead) {
        if (s.knot_depth < 0.8f) sound.add(l, red);
      } else if (s.knot_depth < 0.6f) {
        dead_core.add(l, red);
      } else if (s.knot_depth > 0.75f && s.knot_depth < 0.85f) {
        dead_inner_band.add(l, red);
      } else if (s.knot_depth > 0.93f && s.knot_depth < 0.98f) {
        dead_rim.add(l, red);
      }
    }
  ASSERT_GT(clear.n, 20000);
  ASSERT_GT(sound.n, 1000) << "the crop cuts a sound knot";
  ASSERT_GT(dead_core.n, 500) << "the crop cuts a dead knot";
  ASSERT_GT(dead_rim.n, 100);
  // Knots darker and redder than clear wood, dead knots darker than sound ones.
  EXPECT_LT(sound.mean(), clear.mean() - 0.12) << sound.mean() << " vs " << clear.mean();
  EXPECT_GT(sound.redness(), clear.redness() + 0.03)
      << sound.redness() << " vs " << clear.redness();
  EXPECT_LT(dead_core.mean(), sound.mean() - 0.05);
  // Their own rings: the knot's wood varies as much as clear wood's rings do, not a flat fill.
  EXPECT_GT(sound.sd(), 0.5 * clear.sd()) << sound.sd() << " vs clear wood " << clear.sd();
  EXPECT_GT(dead_core.sd(), 0.015);
  // The encased bark: a dark ring at the dead knot's outline, and no band lighter than the
  // knot's own wood just inside it.
  EXPECT_LT(dead_rim.mean(), 0.6 * dead_core.mean())
      << dead_rim.mean() << " vs " << dead_core.mean();
  EXPECT_LT(dead_inner_band.mean(), dead_core.mean() + 0.04)
      << "a pale band inside the bark ring: " << dead_inner_band.mean() << " vs core "
      << dead_core.mean();
}

TEST(RenderLook, AdaptiveSamplesAgreeWithSamplesInEveryPixel) {
  test::ensure_headless_context();
  const LogModel& log = test::sample_model("gran1_spruce");
  auto r = WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  FaceLayout one, adaptive, every;
  adaptive.supersample = every.supersample = 2;
  every.adaptive = false;
  // 1.2 m of the board at 1 px per mm, the report's scale, where one sample aliases.
  const Image a = render_knot_face(*r.value(), one, 1000, 2200, 1200).image;
  const Image b = render_knot_face(*r.value(), adaptive, 1000, 2200, 1200).image;
  const Image c = render_knot_face(*r.value(), every, 1000, 2200, 1200).image;
  ASSERT_EQ(a.u8.size(), c.u8.size());
  ASSERT_EQ(b.u8.size(), c.u8.size());
  // Knot edges: pixels whose centre and a neighbour's lie on either side of a knot's outline
  // (by the CPU field). There one sample aliases; the adaptive image took the samples there.
  const KnotFace geometry = render_knot_face(*r.value(), one, 1000, 2200, 1200);
  const int w = c.width, h = c.height;
  WoodField field(log);
  std::vector<int> knot(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      knot[static_cast<size_t>(y) * w + x] =
          field.sample(geometry.face.at((x + 0.5) / w, 1.0 - (y + 0.5) / h)).knot;
  double edge_one = 0, edge_adaptive = 0, all_adaptive = 0, all_one = 0;
  int edges = 0, pixels = 0;
  for (int y = 1; y + 1 < h; ++y)
    for (int x = 1; x + 1 < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const bool edge = knot[i] != knot[i - 1] || knot[i] != knot[i + 1] ||
                        knot[i] != knot[i - w] || knot[i] != knot[i + w];
      double d1 = 0, d2 = 0;
      for (int ch = 0; ch < 3; ++ch) {
        d1 += std::abs(int(a.u8[4 * i + ch]) - int(c.u8[4 * i + ch])) / 3.0;
        d2 += std::abs(int(b.u8[4 * i + ch]) - int(c.u8[4 * i + ch])) / 3.0;
      }
      all_one += d1;
      all_adaptive += d2;
      ++pixels;
      if (edge) {
        edge_one += d1;
        edge_adaptive += d2;
        ++edges;
      }
    }
  ASSERT_GT(edges, 300) << "the face cuts knots";
  edge_one /= edges;
  edge_adaptive /= edges;
  // Differences from the reference, per channel in 0-255.
  EXPECT_LT(edge_adaptive, 0.5 * edge_one)
      << "at knot edges: adaptive " << edge_adaptive << ", one sample " << edge_one;
  EXPECT_LT(all_adaptive / pixels, 3.0) << "one sample: " << all_one / pixels;
}

TEST(RenderLook, SpeciesLooksDifferWhereTheWoodDoes) {
  test::ensure_headless_context();
  bool known = true;
  EXPECT_EQ(wood_look("Pine", &known).name, "pine");
  EXPECT_TRUE(known);
  EXPECT_EQ(wood_look("larch", &known).name, "spruce");
  EXPECT_FALSE(known);
  RenderOptions bad;
  bad.species = "oak";
  Status st = bad.validate();
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message().find("RenderOptions::species: 'oak' is not a known look"),
            std::string::npos)
      << st.error().message();

  // Pine heartwood is darker than its sapwood; spruce shows none, on the same log.
  GeneratorOptions o;
  o.species = Species::kPine;
  o.seed = 5;
  o.length_mm = 1200;
  auto log = generate_log(o);
  ASSERT_TRUE(log.ok()) << log.error().message();
  ASSERT_TRUE(log.value().stem.has_heartwood());
  auto ratio = [&](const std::string& species) {
    RenderOptions ro;
    ro.species = species;
    auto r = WoodRenderer::create(log.value(), ro);
    EXPECT_TRUE(r.ok());
    ShadeOptions flat;
    flat.lighting = false;
    ShadeOptions no_tint = flat;
    no_tint.heartwood_tint = false;
    const double z = 600;
    Result<Image> a = render_cross_section(*r.value(), z, {240, 240}, flat);
    Result<Image> b = render_cross_section(*r.value(), z, {240, 240}, no_tint);
    EXPECT_TRUE(a.ok() && b.ok());
    const PlaneRect rect = cross_section_rect(*r.value(), z);
    const Stem& s = log.value().stem;
    double sum = 0;
    int n = 0;
    for (int y = 0; y < 240; ++y)
      for (int x = 0; x < 240; ++x) {
        const Vec3 p = rect.at((x + 0.5) / 240, 1.0 - (y + 0.5) / 240);
        if (!s.contains(p) || log.value().material_at(p).material != Material::kWood) continue;
        double rr, w;
        s.polar(p, &rr, &w);
        if (rr > s.heartwood_at(w, z) - 3 || luma(b.value(), x, y) < 0.05f) continue;
        sum += luma(a.value(), x, y) / luma(b.value(), x, y);
        ++n;
      }
    EXPECT_GT(n, 300);
    return sum / std::max(n, 1);
  };
  EXPECT_LT(ratio("pine"), 0.92);
  EXPECT_NEAR(ratio("spruce"), 1.0, 0.01);
}

TEST(RenderLook, BarkIsDrawnOutsideTheWoodOnlyWhenAsked) {
  test::ensure_headless_context();
  const LogModel& log = test::sample_model("pine_8");
  ASSERT_FALSE(log.stem.bark_mm.empty());
  auto r = WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  const double z = 1000;
  ShadeOptions plain, bark;
  plain.lighting = bark.lighting = false;
  bark.bark = true;
  FaceLayout layout;
  layout.background[0] = layout.background[1] = layout.background[2] = 0.0f;
  Result<Image> without = render_cross_section(*r.value(), z, {400, 400}, plain, layout);
  Result<Image> with = render_cross_section(*r.value(), z, {400, 400}, bark, layout);
  ASSERT_TRUE(without.ok() && with.ok());
  const PlaneRect rect = cross_section_rect(*r.value(), z);
  const Stem& s = log.stem;
  const int i =
      std::clamp(static_cast<int>(std::lround((z - s.z0_mm) / s.dz_mm)), 0, s.slice_count() - 1);
  const double bark_mm = log.stem.bark_mm[i];
  ASSERT_GT(bark_mm, 5.0);
  Stats in_bark_with, in_bark_without, wood, beyond;
  for (int y = 0; y < 400; ++y)
    for (int x = 0; x < 400; ++x) {
      const Vec3 p = rect.at((x + 0.5) / 400, 1.0 - (y + 0.5) / 400);
      double rr, w;
      s.polar(p, &rr, &w);
      const double R = s.radius_at(w, z);
      if (rr > R + 1.5 && rr < R + bark_mm - 1.5) {
        in_bark_with.add(luma(with.value(), x, y), 0);
        in_bark_without.add(luma(without.value(), x, y), 0);
      } else if (rr < R - 5 && rr > 0.6 * R) {
        wood.add(luma(with.value(), x, y), 0);
      } else if (rr > R + bark_mm + 3) {
        beyond.add(luma(with.value(), x, y), 0);
      }
    }
  ASSERT_GT(in_bark_with.n, 1000);
  EXPECT_LT(in_bark_without.mean(), 0.01) << "no bark unless asked: the background";
  EXPECT_GT(in_bark_with.mean(), 0.15) << "bark is drawn";
  EXPECT_LT(in_bark_with.mean(), wood.mean() - 0.2) << "bark darker than the wood";
  EXPECT_LT(beyond.mean(), 0.01) << "nothing beyond the bark";
}

// SAWYER_SHADER_DIR: a file there takes the embedded one's place (the gallery's "before" images
// are drawn that way); the others stay embedded, and without the variable nothing changes.
TEST(RenderLook, AShaderFolderReplacesTheEmbeddedFileItHolds) {
  test::ensure_headless_context();
  const LogModel& log = test::sample_model("gran1_spruce");
  test::TempDir dir;
  std::string frag = embedded_shader("wood.frag");
  const std::string write = "out_color = vec4(wood_shade(s, v_pos, sh), 1.0);";
  int replaced_writes = 0;
  for (size_t at = frag.find(write); at != std::string::npos; at = frag.find(write, at)) {
    frag.replace(at, write.size(), "out_color = vec4(0.0, 1.0, 0.0, 1.0);");
    ++replaced_writes;
  }
  ASSERT_GT(replaced_writes, 0) << "wood.frag's one-sample write moved; update this test";
  test::write_file(dir / "wood.frag", frag);
  const auto render = [&]() {
    auto r = WoodRenderer::create(log);
    EXPECT_TRUE(r.ok()) << r.error().message();
    return r ? render_knot_face(*r.value()).image : Image{};
  };
  const Image embedded = render();
  ::setenv("SAWYER_SHADER_DIR", dir.path().c_str(), 1);
  const Image replaced = render();
  ::unsetenv("SAWYER_SHADER_DIR");
  const Image again = render();
  ASSERT_GT(embedded.width, 0);
  ASSERT_EQ(replaced.width, embedded.width);
  ASSERT_EQ(again.height, embedded.height);
  int green = 0, same = 0;
  for (int y = 0; y < embedded.height; ++y)
    for (int x = 0; x < embedded.width; ++x) {
      green += replaced.value(x, y, 0) < 0.01f && replaced.value(x, y, 1) > 0.99f;
      same += embedded.value(x, y, 0) == again.value(x, y, 0);
    }
  const int n = embedded.width * embedded.height;
  EXPECT_GT(green, n / 2) << "the folder's wood.frag drew most pixels (one sample each)";
  EXPECT_EQ(same, n) << "without the variable the embedded shader is back";
}

}  // namespace
}  // namespace sawyer::render
