// A board's six faces baked into PBR textures for other tools (glTF, docs/export.md): the
// knotted-wood renderer's colour of every face (unlit), a tangent-space normal map and a
// roughness map, each face in its own rectangle of one atlas per map.
//
//   auto ctx = render::create_headless_context();
//   auto r = render::WoodRenderer::create(log, {});
//   Result<BakedBoard> b = bake_board(*r.value(), box, {/*px_per_mm*/ 1.0});
//   // b.value().base_color, .normal, .roughness: RGBA8 atlases; .rects: where each face lies
//
// Maps (all 8-bit RGBA, rows top to bottom, equal sizes):
//   base_color  the renderer's wood colour without lighting (display sRGB), bark on wane;
//   normal      tangent space (+x along the face's PlaneRect::u, +y along its v, +z out of the
//               face; glTF's convention): the tilt of wood.frag's normal strip across the rings,
//               none inside knots, the mean of each texel's samples;
//   roughness   glTF's metallicRoughness layout: G = roughness from the specular strip at t
//               (its shiniest band 0.55, its dullest 0.85: the published strip varies only
//               from 41 to 53 of 255, so its range is stretched over a planed softwood's satin
//               to matt), 0.95 on bark; B = 0 (no metal), R = 1.
// Needs a current OpenGL context (the renderer's). Not thread safe.
#pragma once

#include <array>
#include <filesystem>

#include "sawyer/core/result.h"
#include "sawyer/model/board_box.h"
#include "sawyer/render/camera.h"
#include "sawyer/render/image.h"
#include "sawyer/render/wood_renderer.h"

namespace sawyer::exporter {

struct BakeOptions {
  double px_per_mm = 1.0;  // texture resolution on every face (0.05 .. 8)
  // Base colour: n x n samples where the wood changes within a texel (the renderer's adaptive
  // supersampling); normal and roughness: n x n samples in every texel, averaged. 1..4.
  int supersample = 2;
  bool bark = true;  // bark on wane (where a face leaves the log)
  // Folder with wood_bar_normal.bmp and wood_bar_specular.bmp (the renderer's strips). Empty:
  // the bundled sample_logs/wood_color_maps when the source tree is there; without strips the
  // normal map is flat and the roughness 0.7.
  std::filesystem::path color_maps;

  Status validate() const;  // errors name "BakeOptions::<field>"
};

// The faces in atlas order: top, bottom, left, right, butt, end (render::Face bits 1..32).
inline constexpr int kBoardFaces = 6;
// Texels of edge copy around each face in the atlas, so filtering never reads a neighbour.
inline constexpr int kAtlasPad = 2;

struct AtlasRect {
  int x = 0, y = 0, w = 0, h = 0;  // pixels, from the atlas's top-left corner
};

struct BakedBoard {
  BoardBox box;  // scanner frame, mm
  // Face i spans faces[i] (a PlaneRect: point at(a, b), outward normal u × v) and lies in the
  // atlas at rects[i], texel (x + a·w, y + (1 − b)·h).
  std::array<render::PlaneRect, kBoardFaces> faces;
  std::array<AtlasRect, kBoardFaces> rects;
  render::Image base_color, normal, roughness;
  bool strips = false;  // the normal and specular strips were found (else flat maps)
};

// Bakes `box` (scanner frame). Errors: a bad option, an atlas over the image limits
// (render::kMaxImageSide, naming BakeOptions::px_per_mm), a strip file that cannot be read.
Result<BakedBoard> bake_board(render::WoodRenderer& renderer, const BoardBox& box,
                              const BakeOptions& options);

}  // namespace sawyer::exporter
