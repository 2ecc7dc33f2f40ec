// A small, independent port of the RULES of the reference paper's published renderer (Larsson et
// al. 2022, github.com/marialarsson/procedural_knots), written from their description (paper
// sections 4.1-4.4, docs/architecture.md section 8, docs/maps.md), not from its code. Test-only: it
// says what that renderer would show at a point of a log given by its published maps, so that a
// test can hold Sawyer's importer + GLSL renderer against it (tests/published_render_test.cpp).
//
// It reads the maps itself (its own 24-bit BMP reader and JSON parse; nothing of libs/maps), and
// evaluates:
//   - the stem time t_s = r / R: pith from pith_and_radius_map R, G at u = 1/2 decoded
//     (v − ½)·rmin; outer radius from its B channel, rmin + v·(rmax − rmin), at the azimuth
//     φ = atan2(dx, dy) (from +y turning towards +x), u = φ/2π (columns wrap), v = h/hmax;
//   - each knot's axis at the point's pith distance r: knot-map column u = r/rmin (clamped),
//     height h = red·hmax − green·rmin + blue·rmin, azimuth ω = 2π·red + (−green + blue)·π/2
//     (from +x, counter-clockwise), read as shipped: no undoing of the start-azimuth slip;
//   - the knot time t_b = dist / (rmin · (0.2 − 0.1·√(r/rmin))) (no noise term); dead where
//     r/rmin exceeds the state map's green, after which the knot stops thickening;
//   - the union t = min(t_s, t_b...) + Σ δ'_i with the power smooth minimum and an adaptive k
//     (paper Eq. 2-6), at most 20 knots in range per point (within 0.2·rmin + r of the axis
//     point), δ unfaded within that range (the published fade slip), no butterfly (β unused);
//   - which knot's wood the point is (the knot with the smallest t_b, where t_b < t_s), and
//     whether it is in its dead part.
// Every texture read uses the published "bicubic" filter, a uniform cubic B-spline over texel
// centres with the edges clamped (docs/maps.md 2.9).
//
// Frame: the maps' own frame in millimetres: x, y from the origin the pith offsets are measured
// from, h from the butt face (0) to hmax. This is the frame import_published_maps returns when
// there is no sidecar (z = h).
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/core/vec.h"

namespace sawyer::test {

// How the port reads each quirk. The defaults are the published renderer's rules; each other
// setting is "the quirk handled the other way", so a test can show that it would notice.
struct PublishedRules {
  // Knot-map columns over [0, rmin] (the renderer) or over [0, rmax] (the Python writer's intent).
  bool knot_axis_over_rmin = true;
  // The renderer subtracts green and adds blue in the height map; false: the other sign.
  bool height_green_negative = true;
  // The same for the twist terms of the orientation map.
  bool twist_green_negative = true;
  // Stem azimuth from +y towards +x (the renderer); false: from +x counter-clockwise.
  bool stem_azimuth_from_y = true;
  // State-map green compared with r/rmin (the renderer); false: with r/rmax.
  bool death_over_rmin = true;
  // The published range fade lands on the next knot slot, so each knot's δ counts in full out to
  // the edge of its range (the renderer); false: faded as meant (port and docs/render.md).
  bool range_fade_slip = true;
  // When not empty: start azimuths (rad, one per knot) used instead of the map's red channel,
  // e.g. the stem-bank file's F, i.e. the start-azimuth slip undone.
  std::vector<double> start_azimuth_override;
};

// What the published renderer would show at one point.
struct PublishedSample {
  double t = 0;          // merged time (paper Eq. 6)
  double t_stem = 0;     // r / R
  double t_knot = 1e30;  // smallest knot time
  double r = 0;          // pith distance, mm
  double radius = 0;     // outer radius R at the point's azimuth and height, mm
  int knot = -1;         // knot whose wood this is (map row order), -1 outside knots
  bool dead = false;     // in that knot's dead part
  bool inside() const { return r <= radius; }
};

class PublishedRendererPort {
 public:
  // Reads map_params.json and the four BMP maps in `dir`, to be read by `rules`. Errors name
  // the file.
  static Result<PublishedRendererPort> load(const std::filesystem::path& dir,
                                            const PublishedRules& rules = {});

  // What the published renderer shows at p (maps' frame, mm). Knot axes come from tables of
  // knot_axis() every 0.1 mm of pith distance, linear between (the B-spline varies over 3 mm).
  PublishedSample sample(const Vec3& p) const;

  // Pith (mm) at height h.
  Vec2 pith(double h) const;
  // Outer radius (mm) at height h and the published azimuth φ (from +y towards +x).
  double radius(double h, double phi) const;
  // Knot i's axis at pith distance r: height h (mm) and azimuth ω (rad, from +x).
  void knot_axis(int i, double r, double* h, double* omega) const;
  // Pith distance (mm) beyond which knot i is dead.
  double death_r(int i) const;

  double rmin() const { return rmin_; }
  double rmax() const { return rmax_; }
  double hmax() const { return hmax_; }
  int knot_count() const { return n_; }

 private:
  struct Map {
    int w = 0, h = 0;
    std::vector<float> rgb;  // [row][col][3] in [0, 1], row 0 = the top row of the image
    float at(int c, int r, int ch) const { return rgb[(static_cast<size_t>(r) * w + c) * 3 + ch]; }
  };
  static Result<Map> read_bmp(const std::filesystem::path& path);
  // Cubic B-spline filtered read at texture coordinates (u, v) in [0, 1]; u wraps or clamps.
  static std::array<double, 3> filtered(const Map& m, double u, double v, bool wrap_u);

  double rmin_ = 0, rmax_ = 0, hmax_ = 0;
  int n_ = 0;
  Map stem_, height_, orient_, state_;
  PublishedRules rules_;
  // Per knot: axis height and unwrapped azimuth every kTableStep mm of r, its death border and
  // the lowest and highest axis height (to skip knots far from a point).
  struct KnotTable {
    std::vector<double> h, w;
    double r_death = 0, h_lo = 0, h_hi = 0;
  };
  std::vector<KnotTable> tables_;
};

}  // namespace sawyer::test
