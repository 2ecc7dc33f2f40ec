// Cairo helpers (see canvas.h).
#include "canvas.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

namespace sawyer::report {

void set_color(cairo_t* cr, Rgb c, double alpha) {
  cairo_set_source_rgba(cr, c.r, c.g, c.b, alpha);
}

void set_font(cairo_t* cr, double size, bool bold) {
  cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
}

double text_width(cairo_t* cr, const std::string& text) {
  cairo_text_extents_t e;
  cairo_text_extents(cr, text.c_str(), &e);
  return e.x_advance;
}

double draw_text(cairo_t* cr, const std::string& text, double x, double y, double align) {
  const double w = text_width(cr, text);
  cairo_move_to(cr, x - align * w, y);
  cairo_show_text(cr, text.c_str());
  return w;
}

SurfacePtr new_raster(int w, int h) {
  SurfacePtr s(cairo_image_surface_create(CAIRO_FORMAT_RGB24, w, h));
  ContextPtr cr = new_context(s.get());
  cairo_set_source_rgb(cr.get(), 1, 1, 1);
  cairo_paint(cr.get());
  return s;
}

ContextPtr new_context(cairo_surface_t* s) { return ContextPtr(cairo_create(s)); }

SurfacePtr to_surface(const render::Image& img) {
  SurfacePtr s(cairo_image_surface_create(CAIRO_FORMAT_RGB24, img.width, img.height));
  cairo_surface_flush(s.get());
  unsigned char* data = cairo_image_surface_get_data(s.get());
  const int stride = cairo_image_surface_get_stride(s.get());
  for (int y = 0; y < img.height; ++y) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<size_t>(y) * stride);
    for (int x = 0; x < img.width; ++x) {
      const size_t i = (static_cast<size_t>(y) * img.width + x) * img.channels;
      const std::uint32_t r =
          img.is_float() ? std::uint32_t(img.value(x, y, 0) * 255.0f + 0.5f) : img.u8[i];
      const std::uint32_t g =
          img.is_float() ? std::uint32_t(img.value(x, y, 1) * 255.0f + 0.5f) : img.u8[i + 1];
      const std::uint32_t b =
          img.is_float() ? std::uint32_t(img.value(x, y, 2) * 255.0f + 0.5f) : img.u8[i + 2];
      row[x] = 0xff000000u | (r << 16) | (g << 8) | b;  // cairo: native-endian xRGB
    }
  }
  cairo_surface_mark_dirty(s.get());
  return s;
}

namespace {

// Encodes the surface's pixels as 8-bit RGB through OpenImageIO into memory, a row at a time
// (no copy of the whole image: the detailed board strips, as long as the log at 8 px/cm, are the
// report's largest images; issue 24). `name` picks the format by its extension; `attributes`
// gives the format's settings.
Result<std::string> encode(const char* what, const char* name, cairo_surface_t* s,
                           const OIIO::ImageSpec& attributes) {
  cairo_surface_flush(s);
  const int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
  const int stride = cairo_image_surface_get_stride(s);
  const unsigned char* data = cairo_image_surface_get_data(s);
  if (!data || w <= 0 || h <= 0) return Error(what, "not an image surface");
  OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
  spec.extra_attribs = attributes.extra_attribs;
  std::vector<unsigned char> file;
  OIIO::Filesystem::IOVecOutput vec(file);
  auto out = OIIO::ImageOutput::create(name);
  if (!out) return Error(what, std::string("OpenImageIO has no ") + what + " writer");
  if (!out->set_ioproxy(&vec) || !out->open(name, spec))
    return Error(what, "cannot encode: " + out->geterror());
  std::vector<unsigned char> row(3 * static_cast<size_t>(w));
  for (int y = 0; y < h; ++y) {
    const auto* px = reinterpret_cast<const std::uint32_t*>(data + static_cast<size_t>(y) * stride);
    for (int x = 0; x < w; ++x) {  // cairo: native-endian xRGB
      row[3 * static_cast<size_t>(x)] = static_cast<unsigned char>(px[x] >> 16);
      row[3 * static_cast<size_t>(x) + 1] = static_cast<unsigned char>(px[x] >> 8);
      row[3 * static_cast<size_t>(x) + 2] = static_cast<unsigned char>(px[x]);
    }
    if (!out->write_scanline(y, 0, OIIO::TypeDesc::UINT8, row.data()))
      return Error(what, "cannot encode: " + out->geterror());
  }
  if (!out->close()) return Error(what, "cannot encode: " + out->geterror());
  return std::string(file.begin(), file.end());
}

}  // namespace

// An 8-bit RGB PNG in memory through OpenImageIO, at zlib's fastest level: the PNGs are encoded
// once for the files and reused in the HTML page, on the report's time budget.
Result<std::string> encode_png(cairo_surface_t* s) {
  OIIO::ImageSpec spec;
  spec.attribute("png:compressionLevel", 1);
  return encode("PNG", "report.png", s, spec);
}

// Baseline JPEG, 4:2:0 chroma: the board faces at full resolution for the HTML page.
Result<std::string> encode_jpeg(cairo_surface_t* s, int quality) {
  OIIO::ImageSpec spec;
  quality = std::clamp(quality, 1, 100);
  spec.attribute("Compression", "jpeg:" + std::to_string(quality));
  spec.attribute("CompressionQuality", quality);
  return encode("JPEG", "report.jpg", s, spec);
}

}  // namespace sawyer::report
