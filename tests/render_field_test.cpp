// The GLSL wood field (shaders/wood_log_data.glsl + wood_field.glsl, on the GPU or llvmpipe)
// agrees with the C++ WoodField: the raw time field rendered into a 32-bit float target over
// sections and board faces of the real spruce log and of a generated pine log, compared pixel by
// pixel with WoodField::sample at the same 3D points; and the knot index changes nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "sawyer/field/wood_field.h"
#include "sawyer/model/log_generator.h"
#include "sawyer/render/gl_context.h"
#include "sawyer/render/views.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/test/render_context.h"
#include "sawyer/test/test_util.h"

namespace sawyer::render {
namespace {

const LogModel& generated_pine() {
  static const LogModel log = [] {
    GeneratorOptions o;
    o.species = Species::kPine;
    o.seed = 5;
    o.length_mm = 3000;
    auto r = generate_log(o);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message());
    return r.ok() ? r.value() : LogModel{};
  }();
  return log;
}

// The field drawn over `rect` (filling a w x h float target): pixel (x, y), rows top to bottom.
Image render_field(WoodRenderer& r, const PlaneRect& rect, int w, int h) {
  Result<Framebuffer> fb = Framebuffer::create(w, h, Framebuffer::Format::kRgba32f);
  EXPECT_TRUE(fb.ok());
  fb.value().bind();
  ShadeOptions s;
  s.mode = ShadeMode::kTimeField;
  r.draw_plane(rect, fb.value().viewport(), s);
  return fb.value().read();
}

Vec3 pixel_point(const PlaneRect& rect, int x, int y, int w, int h) {
  return rect.at((x + 0.5) / w, 1.0 - (y + 0.5) / h);
}

struct Agreement {
  int pixels = 0, close = 0, knot_pixels = 0, knot_agree = 0;
  double worst = 0, sum = 0;
};

// Compares GPU and CPU at every pixel inside the log.
Agreement compare(const LogModel& log, const WoodField& field, const Image& img,
                  const PlaneRect& rect, double tol) {
  Agreement a;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const Vec3 p = pixel_point(rect, x, y, img.width, img.height);
      if (!log.stem.contains(p)) continue;
      const FieldSample c = field.sample(p);
      const float t = img.value(x, y, 0);
      const float code = img.value(x, y, 3);
      const double d = std::abs(static_cast<double>(t) - c.t);
      ++a.pixels;
      a.close += d <= tol;
      a.worst = std::max(a.worst, d);
      a.sum += d;
      const int gpu_knot = code < 0 ? -1 : static_cast<int>(code);
      if (gpu_knot >= 0 || c.knot >= 0) {
        ++a.knot_pixels;
        a.knot_agree += gpu_knot == c.knot;
      }
    }
  return a;
}

void expect_agreement(const Agreement& a, const std::string& what) {
  ASSERT_GT(a.pixels, 1000) << what;
  EXPECT_GE(a.close, a.pixels * 99 / 100)
      << what << ": " << a.close << " of " << a.pixels << " pixels within tolerance; worst "
      << a.worst << ", mean " << a.sum / a.pixels;
  EXPECT_LT(a.sum / a.pixels, 2e-4) << what;
  if (a.knot_pixels > 0) {
    EXPECT_GE(a.knot_agree, a.knot_pixels * 97 / 100)
        << what << ": knot masks agree at " << a.knot_agree << " of " << a.knot_pixels;
  }
  std::cout << "[ info ] " << what << ": " << a.pixels << " px, " << 100.0 * a.close / a.pixels
            << " % within tol, worst " << a.worst << ", mean " << a.sum / a.pixels << "; knot px "
            << a.knot_pixels << ", agree " << a.knot_agree << "\n";
}

constexpr double kTol = 2e-3;  // of the stem's growth (1 = pith to bark)

TEST(RenderField, Gran1CrossSectionsAgreeWithWoodField) {
  test::ensure_headless_context();
  const LogModel& log = test::sample_model("gran1_spruce");
  ASSERT_GT(log.knots.size(), 100u);
  auto r = WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  WoodField field(log);
  int total_knot_pixels = 0;
  for (int n : {3, 40, 77}) {  // heights through knots
    const Knot& k = log.knots[n];
    const double z = k.height_at(0.4 * k.r_end);
    const PlaneRect rect = cross_section_rect(*r.value(), z);
    const Image img = render_field(*r.value(), rect, 256, 256);
    const Agreement a = compare(log, field, img, rect, kTol);
    expect_agreement(a, "gran1 cross-section z=" + std::to_string(z));
    total_knot_pixels += a.knot_pixels;
  }
  EXPECT_GT(total_knot_pixels, 50);
}

TEST(RenderField, Gran1BoardFaceAgreesWithWoodField) {
  test::ensure_headless_context();
  const LogModel& log = test::sample_model("gran1_spruce");
  auto r = WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  WoodField field(log);
  const Vec2 c = log.stem.pith_at(1500);
  BoardBox b;
  b.cx = c.x;
  b.cy = c.y + 20;
  b.width = 160;
  b.thickness = 40;
  b.z0 = 1000;
  b.z1 = 2000;
  int knot_pixels = 0;
  for (Face f : {Face::kTop, Face::kBottom}) {
    const PlaneRect rect = board_face(b, f);
    const Image img = render_field(*r.value(), rect, 800, 128);
    const Agreement a = compare(log, field, img, rect, kTol);
    expect_agreement(a, std::string("gran1 board face ") + face_name(f));
    knot_pixels += a.knot_pixels;
  }
  EXPECT_GT(knot_pixels, 100);
}

TEST(RenderField, GeneratedPineAgreesWithWoodField) {
  test::ensure_headless_context();
  const LogModel& log = generated_pine();
  ASSERT_GT(log.knots.size(), 20u);
  ASSERT_TRUE(log.stem.has_heartwood());
  auto r = WoodRenderer::create(log);
  ASSERT_TRUE(r.ok()) << r.error().message();
  WoodField field(log);
  // A longitudinal section through the pith (every whorl's knots cut along their axes) and a
  // cross-section through a whorl.
  LongitudinalSection s;
  s.angle = log.knots[0].omega0;
  const PlaneRect lr = longitudinal_rect(*r.value(), s);
  const Image li = render_field(*r.value(), lr, 1024, 128);
  expect_agreement(compare(log, field, li, lr, kTol), "pine longitudinal section");
  const Knot& k = log.knots[log.knots.size() / 2];
  const PlaneRect cr = cross_section_rect(*r.value(), k.height_at(0.5 * k.r_end));
  const Image ci = render_field(*r.value(), cr, 256, 256);
  expect_agreement(compare(log, field, ci, cr, kTol), "pine cross-section");
}

TEST(RenderField, KnotIndexChangesNothing) {
  test::ensure_headless_context();
  const LogModel& log = test::sample_model("gran1_spruce");
  RenderOptions all;
  all.knot_index = false;
  auto indexed = WoodRenderer::create(log);
  auto every = WoodRenderer::create(log, all);
  ASSERT_TRUE(indexed.ok()) << indexed.error().message();
  ASSERT_TRUE(every.ok()) << every.error().message();
  const Vec2 c = log.stem.pith_at(2000);
  BoardBox b;
  b.cx = c.x + 10;
  b.cy = c.y - 30;
  b.width = 200;
  b.thickness = 50;
  b.rotation = 0.7;
  b.z0 = 0;
  b.z1 = 4000;
  int differ = 0, n = 0;
  for (Face f : {Face::kTop, Face::kLeft}) {
    const PlaneRect rect = board_face(b, f);
    const Image a = render_field(*indexed.value(), rect, 1200, 64);
    const Image e = render_field(*every.value(), rect, 1200, 64);
    for (size_t i = 0; i < a.f32.size(); i += 4) {
      ++n;
      differ += a.f32[i] != e.f32[i] || a.f32[i + 3] != e.f32[i + 3];
    }
  }
  // Cross-sections of the generated pine, through whorls.
  const LogModel& pine = generated_pine();
  auto pi = WoodRenderer::create(pine);
  auto pe = WoodRenderer::create(pine, all);
  ASSERT_TRUE(pi.ok() && pe.ok());
  for (size_t k = 0; k < pine.knots.size(); k += 7) {
    const double z = pine.knots[k].height_at(20.0);
    const PlaneRect rect = cross_section_rect(*pi.value(), z);
    const Image a = render_field(*pi.value(), rect, 160, 160);
    const Image e = render_field(*pe.value(), rect, 160, 160);
    for (size_t i = 0; i < a.f32.size(); i += 4) {
      ++n;
      differ += a.f32[i] != e.f32[i] || a.f32[i + 3] != e.f32[i + 3];
    }
  }
  EXPECT_EQ(differ, 0) << "of " << n << " pixels";
  const KnotIndexStats st = indexed.value()->index_stats();
  EXPECT_LT(st.mean_per_cell, 0.25 * log.knots.size());
}

}  // namespace
}  // namespace sawyer::render
