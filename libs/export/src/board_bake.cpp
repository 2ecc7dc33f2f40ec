#include "sawyer/export/board_bake.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "sawyer/render/scene.h"
#include "sawyer/render/views.h"

namespace sawyer::exporter {
namespace fs = std::filesystem;
using render::Image;
using render::PlaneRect;

namespace {

// One strip (pith -> bark) as RGBA floats 0..1: the middle row of the image.
struct Strip {
  std::vector<float> rgba;
  int width = 0;
  float lo = 0, hi = 1;  // channel 0's range along the strip
  bool empty() const { return width == 0; }
  // Linear filtering with clamped ends, as the renderer's texture() at (t, 0.5).
  float at(float t, int c) const {
    const float x = std::clamp(t, 0.0f, 1.0f) * width - 0.5f;
    const int i0 = std::clamp(static_cast<int>(std::floor(x)), 0, width - 1);
    const int i1 = std::min(i0 + 1, width - 1);
    const float a = std::clamp(x - std::floor(x), 0.0f, 1.0f);
    return (1 - a) * rgba[i0 * 4 + c] + a * rgba[i1 * 4 + c];
  }
};

Result<Strip> load_strip(const fs::path& path) {
  Result<Image> img = render::read_image(path);
  if (!img) return img.error();
  const Image& im = img.value();
  Strip s;
  s.width = im.width;
  const int row = im.height / 2;
  s.rgba.resize(static_cast<size_t>(im.width) * 4);
  for (int x = 0; x < im.width; ++x)
    for (int c = 0; c < 4; ++c) s.rgba[x * 4 + c] = im.value(x, row, c);
  s.lo = s.hi = s.rgba[0];
  for (int x = 0; x < im.width; ++x) {
    s.lo = std::min(s.lo, s.rgba[x * 4]);
    s.hi = std::max(s.hi, s.rgba[x * 4]);
  }
  return s;
}

fs::path strip_folder(const BakeOptions& o) {
  if (!o.color_maps.empty()) return o.color_maps;
#ifdef SAWYER_EXPORT_DATA_DIR
  std::error_code ec;
  if (fs::is_directory(SAWYER_EXPORT_DATA_DIR, ec)) return SAWYER_EXPORT_DATA_DIR;
#endif
  return {};
}

// Roughness of the strip's dullest and shiniest bands (planed softwood: a satin surface).
constexpr float kRoughDull = 0.85f, kRoughShiny = 0.55f;

std::uint8_t to_u8(float v) {
  return static_cast<std::uint8_t>(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f);
}

Image blank_atlas(int w, int h) {
  Image im;
  im.width = w;
  im.height = h;
  im.channels = 4;
  im.u8.assign(static_cast<size_t>(w) * h * 4, 0);
  return im;
}

// Copies `face` (w x h RGBA8) into `atlas` at r, and its edge texels kAtlasPad further out.
void place(Image& atlas, const Image& face, const AtlasRect& r) {
  for (int y = -kAtlasPad; y < r.h + kAtlasPad; ++y)
    for (int x = -kAtlasPad; x < r.w + kAtlasPad; ++x) {
      const int sx = std::clamp(x, 0, r.w - 1), sy = std::clamp(y, 0, r.h - 1);
      const std::uint8_t* src = &face.u8[(static_cast<size_t>(sy) * face.width + sx) * 4];
      std::uint8_t* dst = &atlas.u8[(static_cast<size_t>(r.y + y) * atlas.width + r.x + x) * 4];
      std::copy(src, src + 4, dst);
    }
}

}  // namespace

Status BakeOptions::validate() const {
  if (!(px_per_mm >= 0.05 && px_per_mm <= 8.0))
    return Error("BakeOptions::px_per_mm", std::to_string(px_per_mm) + " is outside 0.05..8");
  if (supersample < 1 || supersample > 4)
    return Error("BakeOptions::supersample", std::to_string(supersample) + " is outside 1..4");
  return Status::Ok();
}

Result<BakedBoard> bake_board(render::WoodRenderer& renderer, const BoardBox& box,
                              const BakeOptions& o) {
  if (Status st = o.validate(); !st) return st.error();
  if (Status st = box.validate(); !st) return st.error();
  BakedBoard out;
  out.box = box;

  // The atlas: faces stacked top to bottom, each with its padding.
  int atlas_w = 0, atlas_h = 0;
  for (int i = 0; i < kBoardFaces; ++i) {
    out.faces[i] = render::board_face(box, static_cast<render::Face>(1u << i));
    AtlasRect& r = out.rects[i];
    r.w = std::max(1, static_cast<int>(std::lround(out.faces[i].width * o.px_per_mm)));
    r.h = std::max(1, static_cast<int>(std::lround(out.faces[i].height * o.px_per_mm)));
    r.x = kAtlasPad;
    r.y = atlas_h + kAtlasPad;
    atlas_h += r.h + 2 * kAtlasPad;
    atlas_w = std::max(atlas_w, r.w + 2 * kAtlasPad);
  }
  if (atlas_w > render::kMaxImageSide || atlas_h > render::kMaxImageSide)
    return Error("BakeOptions::px_per_mm",
                 "the board's texture atlas would be " + std::to_string(atlas_w) + " x " +
                     std::to_string(atlas_h) + " pixels, more than " +
                     std::to_string(render::kMaxImageSide) + " a side (a lower resolution)");

  Strip normal_strip, specular_strip;
  if (const fs::path dir = strip_folder(o); !dir.empty()) {
    Result<Strip> n = load_strip(dir / "wood_bar_normal.bmp");
    if (!n) return n.error();
    Result<Strip> s = load_strip(dir / "wood_bar_specular.bmp");
    if (!s) return s.error();
    normal_strip = std::move(n).value();
    specular_strip = std::move(s).value();
    out.strips = true;
  }

  out.base_color = blank_atlas(atlas_w, atlas_h);
  out.normal = blank_atlas(atlas_w, atlas_h);
  out.roughness = blank_atlas(atlas_w, atlas_h);

  render::ShadeOptions colour;
  colour.lighting = false;
  colour.bark = o.bark;
  render::FaceLayout layout;
  layout.stretch = true;
  layout.gap_px = 0;
  layout.supersample = o.supersample;
  // What lies beyond the bark (a board wider than the log with its bark): a dull grey-brown.
  const float kBeyond[4] = {0.32f, 0.27f, 0.22f, 1.0f};
  std::copy(kBeyond, kBeyond + 4, layout.background);
  render::ShadeOptions field;
  field.mode = render::ShadeMode::kTimeField;
  render::FaceLayout field_layout = layout;
  // Beyond anything drawn: t = -1 and no knot.
  for (float& b : field_layout.background) b = -1.0f;

  const LogModel& log = renderer.log();
  for (int i = 0; i < kBoardFaces; ++i) {
    const unsigned bit = 1u << i;
    const AtlasRect& r = out.rects[i];
    const PlaneRect& rect = out.faces[i];
    Result<Image> c = render::render_board_faces(renderer, box, bit, {r.w, r.h}, colour, layout);
    if (!c) return c.error();
    Image col = std::move(c).value();
    for (size_t p = 3; p < col.u8.size(); p += 4) col.u8[p] = 255;  // opaque
    place(out.base_color, col, r);

    // The raw field at n x n samples per texel (as many as the framebuffer's side allows): the
    // normals and roughness of a texel are the mean of its samples' (renormalised), so crowded
    // rings blend instead of aliasing.
    const int n = std::max(
        1, std::min(o.supersample, render::kMaxImageSide / std::max(1, std::max(r.w, r.h))));
    const int fw = r.w * n, fh = r.h * n;
    Result<Image> f = render::render_board_faces(renderer, box, bit, {fw, fh}, field, field_layout);
    if (!f) return f.error();
    const Image& fi = f.value();
    Image nrm = blank_atlas(r.w, r.h), rough = blank_atlas(r.w, r.h);
    // The pith at each sample column's height: a board face's v runs across the log (no z),
    // so the height depends on the column alone.
    const bool z_by_column = std::abs(rect.v.z) < 1e-12;
    std::vector<Vec2> column_pith(z_by_column ? fw : 0);
    for (int px = 0; px < static_cast<int>(column_pith.size()); ++px)
      column_pith[px] = log.stem.pith_at(rect.at((px + 0.5) / fw, 0.0).z);
    for (int y = 0; y < r.h; ++y)
      for (int x = 0; x < r.w; ++x) {
        double sx = 0, sy = 0, sz = 0, sr = 0;
        for (int sj = 0; sj < n; ++sj)
          for (int si = 0; si < n; ++si) {
            const int px = x * n + si, py = y * n + sj;
            const float t = fi.value(px, py, 0), t_stem = fi.value(px, py, 1),
                        code = fi.value(px, py, 3);
            const bool wood = t >= 0.0f && t_stem <= 1.0f;
            float nx = 0, ny = 0, nz = 1, roughness = 0.7f;
            if (wood && out.strips) {
              // wood.frag's tilt: along the radial direction projected onto the face (not
              // normalised), by the normal strip's x at t, none in knots.
              const Vec3 p = rect.at((px + 0.5) / fw, 1.0 - (py + 0.5) / fh);
              const Vec2 c0 = z_by_column ? column_pith[px] : log.stem.pith_at(p.z);
              Vec3 radial{p.x - c0.x, p.y - c0.y, 0};
              radial = radial.normalized();
              const double tu = dot(radial, rect.u), tv = dot(radial, rect.v);
              const float tilt = code >= 0.0f ? 0.0f : 2.0f * normal_strip.at(t, 0) - 1.0f;
              const float up = std::abs(2.0f * normal_strip.at(t, 2) - 1.0f);
              const double len = std::sqrt(tilt * tilt * (tu * tu + tv * tv) + up * up);
              if (len > 0) {
                nx = static_cast<float>(tilt * tu / len);
                ny = static_cast<float>(tilt * tv / len);
                nz = static_cast<float>(up / len);
              }
              const float shine = (specular_strip.at(t, 0) - specular_strip.lo) /
                                  std::max(specular_strip.hi - specular_strip.lo, 1e-3f);
              roughness = kRoughDull - (kRoughDull - kRoughShiny) * shine;
            } else if (!wood) {
              roughness = 0.95f;  // bark and beyond
            }
            sx += nx;
            sy += ny;
            sz += nz;
            sr += roughness;
          }
        const double len = std::sqrt(sx * sx + sy * sy + sz * sz);
        const Vec3 nm = len > 0 ? Vec3{sx / len, sy / len, sz / len} : Vec3{0, 0, 1};
        std::uint8_t* nt = &nrm.u8[(static_cast<size_t>(y) * r.w + x) * 4];
        nt[0] = to_u8(static_cast<float>(0.5 * nm.x + 0.5));
        nt[1] = to_u8(static_cast<float>(0.5 * nm.y + 0.5));
        nt[2] = to_u8(static_cast<float>(0.5 * nm.z + 0.5));
        nt[3] = 255;
        std::uint8_t* g = &rough.u8[(static_cast<size_t>(y) * r.w + x) * 4];
        g[0] = 255;
        g[1] = to_u8(static_cast<float>(sr / (n * n)));
        g[2] = 0;
        g[3] = 255;
      }
    place(out.normal, nrm, r);
    place(out.roughness, rough, r);
  }
  return out;
}

}  // namespace sawyer::exporter
