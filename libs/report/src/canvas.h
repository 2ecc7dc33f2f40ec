// Cairo at the edge of the report library (docs/style.md 5): owned surfaces and contexts, the
// report's fonts and colours, text helpers, and conversions to and from the renderer's images and
// PNG.
#pragma once

#include <cairo.h>

#include <memory>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/render/image.h"

namespace sawyer::report {

struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextDeleter {
  void operator()(cairo_t* c) const { cairo_destroy(c); }
};
using SurfacePtr = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using ContextPtr = std::unique_ptr<cairo_t, ContextDeleter>;

struct Rgb {
  double r = 0, g = 0, b = 0;
};
// The report's palette.
inline constexpr Rgb kInk{0.13, 0.14, 0.16};        // text
inline constexpr Rgb kMuted{0.42, 0.44, 0.48};      // captions, axes
inline constexpr Rgb kRule{0.80, 0.81, 0.83};       // grid lines, table rules
inline constexpr Rgb kAccent{0.11, 0.37, 0.30};     // headings: a forest green
inline constexpr Rgb kBoardLine{0.05, 0.45, 0.85};  // board outlines
inline constexpr Rgb kSound{0.20, 0.62, 0.25};      // sound knots
inline constexpr Rgb kDead{0.80, 0.12, 0.10};       // dead knots
inline constexpr Rgb kWarn{0.75, 0.10, 0.08};       // the scan's QA verdict failed

void set_color(cairo_t* cr, Rgb c, double alpha = 1.0);
// DejaVu Sans (fonts-dejavu-core) at `size` in user units.
void set_font(cairo_t* cr, double size, bool bold = false);
// Draws `text` with its baseline at (x, y); align 0 = left, 0.5 = centre, 1 = right. Returns the
// advance width.
double draw_text(cairo_t* cr, const std::string& text, double x, double y, double align = 0.0);
double text_width(cairo_t* cr, const std::string& text);
// `text` as it is when it is at most `width` wide in the current font, else its longest head
// (whole UTF-8 characters) that fits with "…" after it.
std::string fit_text(cairo_t* cr, const std::string& text, double width);
// `text` in lines at most `width` wide in the current font, broken between words (a word wider
// than a line is broken where it must), at most `max_lines` of them: the last one ends in "…"
// when some text is left over.
std::vector<std::string> wrapped_lines(cairo_t* cr, const std::string& text, double width,
                                       int max_lines);

// An opaque RGB24 surface of w x h, filled white, and a context on it.
SurfacePtr new_raster(int w, int h);
ContextPtr new_context(cairo_surface_t* s);
// The renderer's RGBA image as an opaque RGB24 surface (alpha dropped: images are opaque).
SurfacePtr to_surface(const render::Image& img);
// PNG bytes of a raster surface.
Result<std::string> encode_png(cairo_surface_t* s);
// JPEG bytes of a raster surface at `quality` (1..100).
Result<std::string> encode_jpeg(cairo_surface_t* s, int quality);

}  // namespace sawyer::report
