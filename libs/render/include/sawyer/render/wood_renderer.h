// The knotted-wood renderer (Larsson et al. 2022, sections 4.1-4.4; docs/render.md): draws boards,
// the log's outer surface, cross-sections and longitudinal sections of a LogModel into the bound
// framebuffer, coloured by the wood time field of shaders/wood_field.glsl (the same formulas as
// sawyer::field's WoodField, proven equal by tests/render_field_test.cpp).
//
// Headless:
//   auto ctx = create_headless_context();                       // gl_context.h
//   auto r = WoodRenderer::create(log, {});                       // uploads the log, compiles
//   Result<Image> img = render_board_faces(*r.value(), board, kLongFaces, {1200, 800});  // views.h
// In a viewer, each frame, with the window's context current:
//   bind_default_framebuffer({0, 0, w, h});   clear;
//   renderer.draw(scene, camera, {0, 0, w, h});
//
// The log's data live on the GPU at float precision: per knot its axis sampled along the pith
// distance, its diameter profile, r_dead, r_end and noise seed; the stem's pith and outer (and
// heartwood) radius; and a knot index by (height, pith distance, azimuth) so that a fragment
// visits only the knots that can reach it.
//
// Needs a current OpenGL 4.3+ context for create(), draw() and the destructor; `log` must outlive
// the renderer. Not thread safe (OpenGL).
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/field/wood_field.h"
#include "sawyer/model/log_model.h"
#include "sawyer/render/camera.h"
#include "sawyer/render/framebuffer.h"
#include "sawyer/render/scene.h"

namespace sawyer::render {

// How a species' wood looks beyond its colour strip: its knots, heartwood and bark (display RGB,
// 0-1). The strip gives the rings of clear wood; a knot takes its own colour with its own rings
// (the strip's ring pattern at the knot's time, contrast raised by `knot_rings`); a dead knot is
// ringed by encased bark. wood_look() holds the presets and docs/render.md ("Species looks")
// what they were compared with.
struct WoodLook {
  std::string name;
  std::array<float, 3> knot_sound{};  // sound (live) knot wood, mid-ring
  std::array<float, 3> knot_dead{};   // dead knot wood, mid-ring
  std::array<float, 3> bark_ring{};   // encased bark around a dead knot
  std::array<float, 3> heart_tint{};  // multiplies the ring colour in heartwood
  std::array<float, 3> bark_inner{};  // inner bark (phloem), next to the wood
  std::array<float, 3> bark_outer{};  // outer bark
  float knot_rings = 3.5f;            // exponent on the strip's ring contrast inside knots
  bool heartwood_visible = false;     // spruce: no coloured heartwood
  double bark_default_mm = 0;         // bark drawn where the model has none
};

// The look for a species: "pine" (Scots pine) or "spruce" (Norway spruce); other names and ""
// get the spruce look, with `known` (when given) set false.
WoodLook wood_look(const std::string& species, bool* known = nullptr);

// What wood.frag is told of the colour strip (u_strip_rings, u_strip_luma): its annual rings
// (dark latewood bands) and its mean luminance, 0-1.
struct ColorStripStats {
  float rings = 40;
  float luma = 0.8f;
};

struct RenderOptions {
  // The field's parameters, the same as the CPU WoodField's (knot outline noise, reference radius).
  WoodFieldParams field;
  // Folder with wood_bar_color.bmp, wood_bar_normal.bmp and wood_bar_specular.bmp (1D strips
  // from pith to bark, the paper's format). Empty: the bundled sample_logs/wood_color_maps when
  // the source tree is there, else a built-in strip.
  std::filesystem::path color_maps;
  // The per-fragment knot index. Off: every fragment visits every knot (the straightforward port
  // of the published loop; for benchmarks and tests).
  bool knot_index = true;
  // Index cells: height step (mm), pith-distance step (mm) and azimuth sectors.
  double index_dz_mm = 20.0;
  double index_dr_mm = 20.0;
  int index_sectors = 16;
  // The look: a species preset by name (wood_look); empty: the log model's species.
  std::string species;

  Status validate() const;
};

// The figures of the colour strip a renderer with `options` uses (RenderOptions::color_maps, the
// bundled strip, or the built-in one); errors name the file.
Result<ColorStripStats> color_strip_stats(const RenderOptions& options);

struct ShadeOptions {
  ShadeMode mode = ShadeMode::kWood;
  // Towards the light, in the camera's frame (x right, y up, z towards the viewer; normalised
  // when used): the light moves with the camera, so every face of a board is lit alike.
  Vec3 light_dir{-0.3, 0.45, 0.85};
  float ambient = 0.75f, diffuse = 0.35f, specular = 0.35f;
  float knot_darkening = 1.0f;  // 0 = knots in the plain ring colour
  float dead_outline = 1.0f;    // 0 = no outline around dead knots
  bool heartwood_tint = true;   // heartwood tint where the model has a heartwood radius and the
                                // species shows it (WoodLook::heartwood_visible)
  bool lighting = true;
  // Bark outside the wood, from the model's bark thickness (or the look's default): on board
  // faces where they leave the log (wane), on sections, and the log's surface drawn with it.
  bool bark = false;
  // Anti-aliasing: pixels where the field changes within the pixel (knot edges, bark rings, the
  // outline, crowded rings) take n x n samples; the others one (wood.frag). 1: one everywhere.
  int supersample = 1;
};

// Figures about the knot index, for reports and benchmarks.
struct KnotIndexStats {
  int cells = 0;
  double mean_per_cell = 0;  // knots listed per cell
  int max_per_cell = 0;
  long long entries = 0;
  double gpu_bytes = 0;  // all of the log's data on the GPU
};

class WoodRenderer {
 public:
  // Uploads `log` and compiles the shaders. Errors: a bad option, colour strips that cannot be
  // read (naming the file), a shader that does not compile (naming shader file and line).
  static Result<std::unique_ptr<WoodRenderer>> create(const LogModel& log,
                                                      const RenderOptions& options = {});
  ~WoodRenderer();
  WoodRenderer(const WoodRenderer&) = delete;
  WoodRenderer& operator=(const WoodRenderer&) = delete;

  // Draws `scene` seen by `camera` into the bound framebuffer's `viewport`, with depth test; does
  // not clear. Fragments outside the log are discarded (transparent where the target is).
  void draw(const Scene& scene, const Camera& camera, const Viewport& viewport,
            const ShadeOptions& shade = {});
  // Draws one rectangle filling `viewport` exactly (Camera::plane_view): a board face, a section.
  void draw_plane(const PlaneRect& rect, const Viewport& viewport, const ShadeOptions& shade = {});

  const LogModel& log() const;
  const RenderOptions& options() const;
  KnotIndexStats index_stats() const;
  // The mean pith line: a point on it at z and its direction (for sections and cameras).
  Vec3 pith_point(double z) const;
  // Largest outer radius over the whole log, mm.
  double max_radius() const;
  // The look in use (RenderOptions::species or the log's species).
  const WoodLook& look() const;

 private:
  struct Impl;
  explicit WoodRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace sawyer::render
