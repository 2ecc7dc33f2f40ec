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

std::string fit_text(cairo_t* cr, const std::string& text, double width) {
  if (text_width(cr, text) <= width) return text;
  const std::string ellipsis = "\u2026";
  // The longest head that fits, by bisection over byte counts, then back to a character's start.
  size_t lo = 0, hi = text.size();
  while (hi - lo > 1) {
    const size_t mid = (lo + hi) / 2;
    (text_width(cr, text.substr(0, mid) + ellipsis) <= width ? lo : hi) = mid;
  }
  while (lo > 0 && (static_cast<unsigned char>(text[lo]) & 0xC0) == 0x80) --lo;
  while (lo > 0 && text[lo - 1] == ' ') --lo;
  return text.substr(0, lo) + ellipsis;
}

std::vector<std::string> wrapped_lines(cairo_t* cr, const std::string& text, double width,
                                       int max_lines) {
  std::vector<std::string> lines;
  std::string line;
  size_t at = 0;
  // Words separated by spaces; each line takes as many as fit.
  auto next_word = [&]() -> std::string {
    while (at < text.size() && text[at] == ' ') ++at;
    const size_t end = std::min(text.find(' ', at), text.size());
    std::string w = text.substr(at, end - at);
    at = end;
    return w;
  };
  for (std::string word = next_word(); !word.empty(); word = next_word()) {
    std::string cand = line.empty() ? word : line + " " + word;
    if (text_width(cr, cand) <= width) {
      line = std::move(cand);
      continue;
    }
    if (!line.empty()) lines.push_back(line);
    // A word wider than a line: its longest head that fits, at a character's start.
    while (text_width(cr, word) > width && static_cast<int>(lines.size()) < max_lines) {
      size_t cut = word.size() - 1;
      while (cut > 1 && text_width(cr, word.substr(0, cut)) > width) --cut;
      while (cut > 1 && (static_cast<unsigned char>(word[cut]) & 0xC0) == 0x80) --cut;
      lines.push_back(word.substr(0, cut));
      word = word.substr(cut);
    }
    line = word;
    if (static_cast<int>(lines.size()) == max_lines) break;
  }
  if (static_cast<int>(lines.size()) < max_lines) {
    if (!line.empty()) lines.push_back(line);
    return lines;
  }
  while (at < text.size() && text[at] == ' ') ++at;
  if (line.empty() && at >= text.size()) return lines;
  // Text left over: the last line ends in "…" to say so.
  lines.back() = fit_text(cr, lines.back() + (line.empty() ? "" : " " + line) + " \u2026", width);
  return lines;
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
