// The report's figures (see figures.h).
#include "figures.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>

#include "sawyer/render/cut_view.h"
#include "sawyer/render/framebuffer.h"
#include "sawyer/render/views.h"
#include "sawyer/sawing/setup.h"
#include "sawyer/sawing/value.h"

namespace sawyer::report {
namespace {

using sawing::Board;
using sawing::LogPosition;
using sawing::SawLog;

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// The pattern-frame size of a board: (along u, along v).
void board_extent(const Board& b, double* su, double* sv) {
  const bool thick_u = b.thickness_axis == sawing::ThicknessAxis::kU;
  *su = thick_u ? b.thickness_mm : b.width_mm;
  *sv = thick_u ? b.width_mm : b.thickness_mm;
}

// A tick label with as many decimals as the tick step needs.
std::string tick_label(double v, double lo, double hi) {
  const std::vector<double> t = ticks(lo, hi, 4);
  const double step = t.size() > 1 ? t[1] - t[0] : 1.0;
  const int decimals = std::clamp(static_cast<int>(-std::floor(std::log10(step) + 1e-9)), 0, 3);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// A plot area: data (x, y) ranges mapped to a pixel rectangle (y up).
struct Axes {
  double x0, y0, w, h;  // pixels, top-left and size
  double xmin, xmax, ymin, ymax;
  double px(double x) const { return x0 + (x - xmin) / (xmax - xmin) * w; }
  double py(double y) const { return y0 + h - (y - ymin) / (ymax - ymin) * h; }
};

// Frame, grid, tick labels and axis titles.
void draw_axes(cairo_t* cr, const Axes& a, const std::string& xlabel, const std::string& ylabel,
               const char* xfmt, const char* yfmt, bool x_ticks_labelled = true) {
  set_font(cr, 17);
  cairo_set_line_width(cr, 1);
  for (double t : ticks(a.ymin, a.ymax, 4)) {
    set_color(cr, kRule);
    cairo_move_to(cr, a.x0, std::round(a.py(t)) + 0.5);
    cairo_line_to(cr, a.x0 + a.w, std::round(a.py(t)) + 0.5);
    cairo_stroke(cr);
    set_color(cr, kMuted);
    draw_text(cr, yfmt ? fmt(yfmt, t) : tick_label(t, a.ymin, a.ymax), a.x0 - 8, a.py(t) + 6, 1.0);
  }
  for (double t : ticks(a.xmin, a.xmax, 8)) {
    set_color(cr, kRule);
    cairo_move_to(cr, std::round(a.px(t)) + 0.5, a.y0);
    cairo_line_to(cr, std::round(a.px(t)) + 0.5, a.y0 + a.h);
    cairo_stroke(cr);
    if (x_ticks_labelled) {
      set_color(cr, kMuted);
      draw_text(cr, fmt(xfmt, t), a.px(t), a.y0 + a.h + 22, 0.5);
    }
  }
  set_color(cr, kMuted);
  cairo_rectangle(cr, a.x0 + 0.5, a.y0 + 0.5, a.w, a.h);
  cairo_stroke(cr);
  set_color(cr, kInk);
  if (!xlabel.empty()) draw_text(cr, xlabel, a.x0 + a.w / 2, a.y0 + a.h + 46, 0.5);
  if (!ylabel.empty()) {
    cairo_save(cr);
    cairo_translate(cr, a.x0 - 62, a.y0 + a.h / 2);
    cairo_rotate(cr, -kPi / 2);
    draw_text(cr, ylabel, 0, 0, 0.5);
    cairo_restore(cr);
  }
}

// A perceptually ordered ramp from deep blue through teal and green to warm yellow.
Rgb ramp(double t) {
  static const Rgb stops[] = {{0.18, 0.15, 0.42}, {0.16, 0.36, 0.58}, {0.12, 0.56, 0.55},
                              {0.35, 0.72, 0.38}, {0.80, 0.82, 0.25}, {0.99, 0.90, 0.40}};
  const int n = static_cast<int>(std::size(stops)) - 1;
  t = std::clamp(t, 0.0, 1.0) * n;
  const int i = std::min(n - 1, static_cast<int>(t));
  const double f = t - i;
  return {stops[i].r + f * (stops[i + 1].r - stops[i].r),
          stops[i].g + f * (stops[i + 1].g - stops[i].g),
          stops[i].b + f * (stops[i + 1].b - stops[i].b)};
}

// Renders one rectangle filling a w x h image (the end view's turned section).
Result<render::Image> render_rect(render::WoodRenderer& r, const render::PlaneRect& rect, int w,
                                  int h, int supersample, const float background[4]) {
  const int n = std::clamp(supersample, 1, 4);
  Result<render::Framebuffer> fb =
      render::Framebuffer::create(w * n, h * n, render::Framebuffer::Format::kRgba8);
  if (!fb) return fb.error();
  fb.value().bind(background);
  r.draw_plane(rect, {0, 0, w * n, h * n});
  render::Image big = fb.value().read();
  if (n == 1) return big;
  render::Image out;
  out.width = w;
  out.height = h;
  out.u8.resize(static_cast<size_t>(w) * h * 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 4; ++c) {
        int sum = 0;
        for (int dy = 0; dy < n; ++dy)
          for (int dx = 0; dx < n; ++dx)
            sum += big.u8[(static_cast<size_t>(y * n + dy) * big.width + x * n + dx) * 4 + c];
        out.u8[(static_cast<size_t>(y) * w + x) * 4 + c] =
            static_cast<std::uint8_t>((sum + n * n / 2) / (n * n));
      }
  return out;
}

// The image cropped to the pixels that are not the white background, plus a margin: a
// perspective view leaves wide empty bands above and below a long log.
SurfacePtr crop_to_content(SurfacePtr surface, int margin) {
  cairo_surface_t* src = surface.get();
  cairo_surface_flush(src);
  const int w = cairo_image_surface_get_width(src), h = cairo_image_surface_get_height(src);
  const int stride = cairo_image_surface_get_stride(src);
  const unsigned char* data = cairo_image_surface_get_data(src);
  int x0 = w, x1 = -1, y0 = h, y1 = -1;
  for (int y = 0; y < h; ++y) {
    const auto* row =
        reinterpret_cast<const std::uint32_t*>(data + static_cast<size_t>(y) * stride);
    for (int x = 0; x < w; ++x) {
      const std::uint32_t p = row[x];  // xRGB
      if (((p >> 16) & 0xff) < 250 || ((p >> 8) & 0xff) < 250 || (p & 0xff) < 250) {
        x0 = std::min(x0, x);
        x1 = std::max(x1, x);
        y0 = std::min(y0, y);
        y1 = std::max(y1, y);
      }
    }
  }
  if (x1 < 0) return surface;
  x0 = std::max(0, x0 - margin);
  y0 = std::max(0, y0 - margin);
  x1 = std::min(w - 1, x1 + margin);
  y1 = std::min(h - 1, y1 + margin);
  SurfacePtr out(cairo_image_surface_create(CAIRO_FORMAT_RGB24, x1 - x0 + 1, y1 - y0 + 1));
  cairo_t* cr = cairo_create(out.get());
  cairo_set_source_surface(cr, src, -x0, -y0);
  cairo_paint(cr);
  cairo_destroy(cr);
  return out;
}

}  // namespace

std::vector<double> ticks(double lo, double hi, int n) {
  std::vector<double> out;
  if (!(hi > lo)) return {lo};
  const double raw = (hi - lo) / std::max(1, n);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  for (double t = std::ceil(lo / step - 1e-9) * step; t <= hi + 1e-9 * step; t += step)
    out.push_back(std::abs(t) < 1e-9 * step ? 0.0 : t);
  return out;
}

BoardSet place_boards(const RunFolder& run, const SawLog& log) {
  const SawingRecord& s = run.sawing;
  BoardSet set;
  auto from_json = [&](const std::string& why) {
    set.boards.clear();
    for (size_t i = 0; i < s.boards.size(); ++i)
      set.boards.push_back(s.boards[i].board(static_cast<int>(i)));
    set.rebuilt = false;
    set.note = "Boards placed from sawing.json: " + why;
    return set;
  };
  // The pattern chosen from a set, as sawing.json holds it; else the name given to `sawyer saw`,
  // else the bundled pattern that carries sawing.json's name.
  std::vector<std::string> names;
  if (s.chosen_pattern)
    names.push_back("");
  else if (!run.run.pattern.empty())
    names.push_back(run.run.pattern);
  else
    names = {"2ex", "4ex", "tt"};
  std::string why = "pattern '" + s.pattern + "' not found";
  for (const std::string& name : names) {
    Result<sawing::Pattern> p =
        name.empty() ? Result<sawing::Pattern>(*s.chosen_pattern) : sawing::pattern_by_name(name);
    if (!p) {
      why = p.error().message();
      continue;
    }
    if (p.value().name != s.pattern) {
      why = "pattern '" + name + "' is now '" + p.value().name + "', not '" + s.pattern + "'";
      continue;
    }
    sawing::SawResult sawn = sawing::saw(log, p.value(), s.chosen.pos);
    // The same boards, each as sawn or cross-cut to value within its sawn length
    // (trim_to_value): then the piece sold, with its own knots and wane.
    bool same = sawn.boards.size() == s.boards.size();
    for (size_t i = 0; same && i < sawn.boards.size(); ++i) {
      const sawing::Board& b = sawn.boards[i];
      const BoardRecord& rec = s.boards[i];
      same = b.name == rec.name && std::abs(b.width_mm - rec.width_mm) < 0.5 &&
             rec.z_begin_mm > b.z_begin - 0.5 && rec.z_end_mm < b.z_end + 0.5 &&
             rec.z_end_mm > rec.z_begin_mm;
      if (same && (rec.z_begin_mm > b.z_begin + 0.5 || rec.z_end_mm < b.z_end - 0.5))
        sawn.boards[i] = sawing::cut_board(b, std::max(rec.z_begin_mm, b.z_begin),
                                           std::min(rec.z_end_mm, b.z_end));
    }
    const std::string which =
        name.empty() ? "the chosen pattern '" + s.pattern + "'" : "pattern '" + name + "'";
    if (!same) return from_json(which + " saws other boards than sawing.json lists");
    set.boards = std::move(sawn.boards);
    set.rebuilt = true;
    set.note = "Boards sawn again with " + which + ": the same as sawing.json";
    return set;
  }
  return from_json(why);
}

Result<SurfacePtr> end_view(render::WoodRenderer& r, const RunFolder& run, const SawLog& log,
                            const BoardSet& boards, double z, int px) {
  const LogPosition& pos = run.sawing.chosen.pos;
  const double phi = sawing::pattern_rotation(log, pos);
  const double c = std::cos(phi), s = std::sin(phi);
  // The view frame: the log turned by φ about the mean pith line at z, centred on the line.
  const double R = r.max_radius() * 1.06;
  const Vec2 o = log.line_at(z);
  auto to_scanner = [&](double a, double b) {
    return Vec3{o.x + c * a + s * b, o.y - s * a + c * b, z};
  };
  render::PlaneRect rect;
  rect.origin = to_scanner(-R, -R);
  rect.u = {c, -s, 0};
  rect.v = {s, c, 0};
  rect.width = rect.height = 2 * R;
  const float white[4] = {1, 1, 1, 1};
  Result<render::Image> img = render_rect(r, rect, px, px, 1, white);
  if (!img) return img.error();
  SurfacePtr surf = to_surface(img.value());
  ContextPtr ctx = new_context(surf.get());
  cairo_t* cr = ctx.get();
  const double k = px / (2 * R);  // px per mm
  auto X = [&](double a) { return (a + R) * k; };
  auto Y = [&](double b) { return (R - b) * k; };

  // Knot axes seen along the mean pith line: the sound part, then the dead part.
  const LogModel& m = run.log;
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  for (const Knot& kn : m.knots) {
    const int steps = 24;
    for (int part = 0; part < 2; ++part) {
      const double r0 = part == 0 ? 0.0 : std::min(kn.r_dead, kn.r_end);
      const double r1 = part == 0 ? std::min(kn.r_dead, kn.r_end) : kn.r_end;
      if (r1 <= r0) continue;
      for (int i = 0; i <= steps; ++i) {
        const Vec3 p = kn.axis_point(r0 + (r1 - r0) * i / steps, m.stem);
        const Vec2 l = log.line_at(p.z);
        const double dx = p.x - l.x, dy = p.y - l.y;
        const double a = c * dx - s * dy, b = s * dx + c * dy;  // Rot(φ)
        if (i == 0)
          cairo_move_to(cr, X(a), Y(b));
        else
          cairo_line_to(cr, X(a), Y(b));
      }
      set_color(cr, part == 0 ? kSound : kDead, 0.7);
      cairo_set_line_width(cr, std::clamp(0.06 * kn.max_diameter() * k, 1.0, 3.0));
      cairo_stroke(cr);
    }
  }
  // Boards: outline and number, at this height.
  for (size_t i = 0; i < boards.boards.size(); ++i) {
    const Board& b = boards.boards[i];
    double su, sv;
    board_extent(b, &su, &sv);
    const double a = b.u_mm + pos.offset_x_mm, bb = b.v_mm + pos.offset_y_mm;
    cairo_rectangle(cr, X(a - su / 2), Y(bb + sv / 2), su * k, sv * k);
    set_color(cr, {1, 1, 1}, 0.18);
    cairo_fill_preserve(cr);
    cairo_set_line_width(cr, 2.5);
    set_color(cr, kBoardLine);
    cairo_stroke(cr);
    const std::string label = std::to_string(i + 1);
    set_font(cr, std::clamp(0.45 * std::min(su, sv) * k, 11.0, 22.0), true);
    set_color(cr, {1, 1, 1}, 0.85);
    const double fs = std::clamp(0.45 * std::min(su, sv) * k, 11.0, 22.0);
    cairo_arc(cr, X(a), Y(bb), 0.75 * fs, 0, 2 * kPi);
    cairo_fill(cr);
    set_color(cr, kBoardLine);
    draw_text(cr, label, X(a), Y(bb) + 0.36 * fs, 0.5);
  }
  // The pith line and a 50 mm scale bar.
  set_color(cr, kInk);
  cairo_arc(cr, X(0), Y(0), 3, 0, 2 * kPi);
  cairo_fill(cr);
  const double bar = 50 * k, bx = 16, by = px - 18;
  cairo_set_line_width(cr, 3);
  cairo_move_to(cr, bx, by);
  cairo_line_to(cr, bx + bar, by);
  cairo_stroke(cr);
  set_font(cr, 20);
  draw_text(cr, "50 mm", bx + bar / 2, by - 10, 0.5);
  // Legend, top left.
  double ly = 30;
  for (auto [col, text] : {std::pair{kSound, "sound knot"}, std::pair{kDead, "dead knot"},
                           std::pair{kBoardLine, "board"}}) {
    set_color(cr, col);
    cairo_rectangle(cr, 14, ly - 13, 28, 12);
    cairo_fill(cr);
    set_color(cr, kInk);
    draw_text(cr, text, 50, ly);
    ly += 28;
  }
  return surf;
}

Result<SurfacePtr> log_view(render::WoodRenderer& r, const SawLog& log, const RunFolder& run,
                            const BoardSet& boards, int w, int h) {
  std::vector<BoardBox> boxes;
  for (const Board& b : boards.boards)
    boxes.push_back(sawing::board_placement(log, b, run.sawing.chosen.pos));
  render::CutViewOptions o;
  o.width = w;
  o.height = h;
  // One sample a pixel: 2 × 2 triples the step's time (the boards' wood is shaded per sample)
  // for edges that the page shows at about this size anyway.
  o.supersample = 1;
  const render::Camera cam = render::cut_view_camera(r, w, h, o.default_bark_mm);
  Result<render::Image> img = render::render_cut_view(r, boxes, cam, o);
  if (!img) return img.error();
  return crop_to_content(to_surface(img.value()), 16);
}

SurfacePtr value_map(const SawingRecord& s, int w) {
  const ValueSurface& g = s.surface;
  if (g.empty()) return nullptr;
  const size_t nr = g.rotations_deg.size(), nx = g.offsets_x_mm.size(), ny = g.offsets_y_mm.size();
  // The y offset row nearest the chosen position's.
  size_t iy = 0;
  for (size_t j = 1; j < ny; ++j)
    if (std::abs(g.offsets_y_mm[j] - s.chosen.pos.offset_y_mm) <
        std::abs(g.offsets_y_mm[iy] - s.chosen.pos.offset_y_mm))
      iy = j;
  auto at = [&](size_t ir, size_t ix) { return g.smoothed_value[(ir * nx + ix) * ny + iy]; };
  double vmin = 1e300, vmax = -1e300;
  for (size_t ir = 0; ir < nr; ++ir)
    for (size_t ix = 0; ix < nx; ++ix) {
      vmin = std::min(vmin, at(ir, ix));
      vmax = std::max(vmax, at(ir, ix));
    }
  if (!(vmax > vmin)) vmax = vmin + 1;
  const int h = w * 2 / 5;
  SurfacePtr surf = new_raster(w, h);
  ContextPtr ctx = new_context(surf.get());
  cairo_t* cr = ctx.get();
  // Cells centred on the grid values.
  const double drot = nr > 1 ? g.rotations_deg[1] - g.rotations_deg[0] : 1.0;
  const double dx = nx > 1 ? g.offsets_x_mm[1] - g.offsets_x_mm[0] : 1.0;
  Axes a{96,
         20,
         w - 96.0 - 150,
         h - 20.0 - 76,
         g.rotations_deg.front() - drot / 2,
         g.rotations_deg.back() + drot / 2,
         g.offsets_x_mm.front() - dx / 2,
         g.offsets_x_mm.back() + dx / 2};
  for (size_t ir = 0; ir < nr; ++ir)
    for (size_t ix = 0; ix < nx; ++ix) {
      const double r0 = a.px(g.rotations_deg[ir] - drot / 2),
                   r1 = a.px(g.rotations_deg[ir] + drot / 2);
      const double x0 = a.py(g.offsets_x_mm[ix] + dx / 2), x1 = a.py(g.offsets_x_mm[ix] - dx / 2);
      set_color(cr, ramp((at(ir, ix) - vmin) / (vmax - vmin)));
      cairo_rectangle(cr, std::floor(r0), std::floor(x0), std::ceil(r1) - std::floor(r0),
                      std::ceil(x1) - std::floor(x0));
      cairo_fill(cr);
    }
  draw_axes(cr, a, "rotation from horns-down (°)", "x offset (mm)", "%.0f", "%.0f");
  // Markers: horns-down (triangle), best (circle), the chosen given position (diamond).
  auto marker = [&](const sawing::LogPosition& p, int shape) {
    double rot = p.rotation_deg;
    const double range = a.xmax - a.xmin;
    while (rot > a.xmax) rot -= range;
    while (rot < a.xmin) rot += range;
    const double x = a.px(rot), y = a.py(p.offset_x_mm), q = 9;
    if (shape == 0) {
      cairo_move_to(cr, x, y - q);
      cairo_line_to(cr, x + q, y + q * 0.8);
      cairo_line_to(cr, x - q, y + q * 0.8);
      cairo_close_path(cr);
    } else if (shape == 1) {
      cairo_arc(cr, x, y, q, 0, 2 * kPi);
    } else {
      cairo_move_to(cr, x, y - q);
      cairo_line_to(cr, x + q, y);
      cairo_line_to(cr, x, y + q);
      cairo_line_to(cr, x - q, y);
      cairo_close_path(cr);
    }
    set_color(cr, {1, 1, 1});
    cairo_fill_preserve(cr);
    set_color(cr, kInk);
    cairo_set_line_width(cr, 2);
    cairo_stroke(cr);
  };
  marker(s.horns_down.pos, 0);
  marker(s.best.pos, 1);
  if (s.chosen_given) marker(s.chosen.pos, 2);
  // Colour bar with the currency.
  const double bx = a.x0 + a.w + 24, bw = 18;
  for (int i = 0; i < int(a.h); ++i) {
    set_color(cr, ramp(1.0 - i / a.h));
    cairo_rectangle(cr, bx, a.y0 + i, bw, 1.5);
    cairo_fill(cr);
  }
  set_color(cr, kMuted);
  cairo_set_line_width(cr, 1);
  cairo_rectangle(cr, bx + 0.5, a.y0 + 0.5, bw, a.h);
  cairo_stroke(cr);
  set_font(cr, 17);
  const Axes bar{bx, a.y0, bw, a.h, 0, 1, vmin, vmax};
  for (double t : ticks(vmin, vmax, 5)) {
    set_color(cr, kMuted);
    draw_text(cr, fmt("%.1f", t), bx + bw + 6, bar.py(t) + 6);
  }
  set_color(cr, kInk);
  draw_text(cr, s.currency.empty() ? "value" : s.currency, bx, a.y0 + a.h + 46);
  // Key below the plot.
  set_font(cr, 17);
  set_color(cr, kMuted);
  std::string key = "△ horns-down   ○ best";
  if (s.chosen_given) key += "   ◇ chosen";
  if (ny > 1) key += "   (y offset " + fmt("%+.0f mm)", g.offsets_y_mm[iy]);
  draw_text(cr, key, a.x0 + a.w, a.y0 + a.h + 46, 1.0);
  return surf;
}

SurfacePtr log_profile(const LogModel& log, const BoardSet& boards, int w) {
  const Stem& st = log.stem;
  const int n = st.slice_count();
  const int h = w / 2;
  SurfacePtr surf = new_raster(w, h);
  ContextPtr ctx = new_context(surf.get());
  cairo_t* cr = ctx.get();
  if (n < 2) return surf;
  double pmin = 1e300, pmax = -1e300, dmax = 0;
  std::vector<double> dmean(n), dlo(n), dhi(n);
  for (int i = 0; i < n; ++i) {
    pmin = std::min({pmin, st.pith[i].x, st.pith[i].y});
    pmax = std::max({pmax, st.pith[i].x, st.pith[i].y});
    dmean[i] = 2 * std::sqrt(st.area(i) / kPi);
    const auto& rr = st.radius[i];
    dlo[i] = 2 * *std::min_element(rr.begin(), rr.end());
    dhi[i] = 2 * *std::max_element(rr.begin(), rr.end());
    dmax = std::max(dmax, dhi[i]);
  }
  const double pad = std::max(5.0, 0.1 * (pmax - pmin));
  const double zm0 = st.z_begin() * 1e-3, zm1 = st.z_end() * 1e-3;
  const double gap = 40, top = 14, bottom = 64;
  const double ph = (h - top - bottom - gap) * 0.45, dh = (h - top - bottom - gap) * 0.55;
  const Axes pa{100, top, w - 100.0 - 24, ph, zm0, zm1, pmin - pad, pmax + pad};
  const Axes da{100, top + ph + gap, w - 100.0 - 24, dh, zm0, zm1, 0, dmax * 1.08};
  // The boards' length, shaded in both panels.
  double bz0 = 1e300, bz1 = -1e300;
  for (const sawing::Board& b : boards.boards) {
    bz0 = std::min(bz0, b.z_begin);
    bz1 = std::max(bz1, b.z_end);
  }
  if (bz1 > bz0)
    for (const Axes* a : {&pa, &da}) {
      set_color(cr, {0.93, 0.95, 0.91});
      cairo_rectangle(cr, a->px(bz0 * 1e-3), a->y0, a->px(bz1 * 1e-3) - a->px(bz0 * 1e-3), a->h);
      cairo_fill(cr);
    }
  draw_axes(cr, pa, "", "pith (mm)", "%.1f", nullptr, false);
  draw_axes(cr, da, "distance along the log (m)", "diameter (mm)", "%.1f", nullptr);
  auto line = [&](const Axes& a, const std::vector<double>& v, Rgb col, double width) {
    for (int i = 0; i < n; ++i) {
      const double x = a.px(st.z_at(i) * 1e-3), y = a.py(v[i]);
      if (i == 0)
        cairo_move_to(cr, x, y);
      else
        cairo_line_to(cr, x, y);
    }
    set_color(cr, col);
    cairo_set_line_width(cr, width);
    cairo_stroke(cr);
  };
  std::vector<double> px(n), py(n);
  for (int i = 0; i < n; ++i) {
    px[i] = st.pith[i].x;
    py[i] = st.pith[i].y;
  }
  line(pa, px, {0.10, 0.40, 0.75}, 2);
  line(pa, py, {0.85, 0.45, 0.10}, 2);
  // Diameter: the min–max band across angles, then the equal-area diameter.
  for (int i = 0; i < n; ++i) cairo_line_to(cr, da.px(st.z_at(i) * 1e-3), da.py(dhi[i]));
  for (int i = n - 1; i >= 0; --i) cairo_line_to(cr, da.px(st.z_at(i) * 1e-3), da.py(dlo[i]));
  cairo_close_path(cr);
  set_color(cr, kAccent, 0.18);
  cairo_fill(cr);
  line(da, dmean, kAccent, 2);
  // Legends.
  set_font(cr, 17);
  auto key = [&](double x, double y, Rgb col, const char* text) {
    set_color(cr, col);
    cairo_rectangle(cr, x, y - 11, 22, 5);
    cairo_fill(cr);
    set_color(cr, kInk);
    draw_text(cr, text, x + 28, y - 3);
  };
  key(pa.x0 + 10, pa.y0 + 22, {0.10, 0.40, 0.75}, "pith x");
  key(pa.x0 + 110, pa.y0 + 22, {0.85, 0.45, 0.10}, "pith y");
  key(da.x0 + 10, da.y0 + 22, kAccent, "diameter (equal area), band: min–max across angles");
  if (bz1 > bz0) {
    set_color(cr, kMuted);
    draw_text(cr, "shaded: the boards' length", pa.x0 + pa.w - 8, pa.y0 + 20, 1.0);
  }
  return surf;
}

SurfacePtr top_end_fit(const LogModel& log, const NotSawn& why, const sawing::Pattern* pattern,
                       int px) {
  SurfacePtr surf = new_raster(px, px);
  ContextPtr ctx = new_context(surf.get());
  cairo_t* cr = ctx.get();
  const Stem& st = log.stem;
  const int n = st.slice_count();
  if (n < 1 || st.radius.empty()) return surf;
  // The top end as SawLog takes it: the end with the smaller mean radius.
  const int top = st.mean_radius(n - 1) <= st.mean_radius(0) ? n - 1 : 0;
  const std::vector<double>& rad = st.radius[top];
  const Vec2 pith = st.pith[top];
  // The circles' centre: the mean pith line at the top end (SawLog::line_at), which the
  // pattern's centre follows.
  const sawing::SawLog saw_log(log, 0);
  const Vec2 c = saw_log.line_at(st.z_at(top));
  // As run.json states them; from the model and pattern when it does not.
  const double usable =
      why.usable_diameter_mm >= 0 ? why.usable_diameter_mm : saw_log.usable_diameter_mm();
  const double needed = why.needed_diameter_mm >= 0 ? why.needed_diameter_mm
                        : pattern                   ? pattern->required_diameter_mm()
                                                    : 0.0;
  const double need_r = 0.5 * needed, use_r = std::max(0.0, 0.5 * usable);
  double reach = std::max(need_r, use_r);
  for (size_t k = 0; k < rad.size(); ++k) {
    const double w = 2 * kPi * k / rad.size();
    reach = std::max(reach, std::hypot(pith.x + rad[k] * std::cos(w) - c.x,
                                       pith.y + rad[k] * std::sin(w) - c.y));
  }
  if (pattern)
    for (const sawing::BoardSpec& b : pattern->boards)
      reach =
          std::max(reach, std::hypot(std::abs(b.u_mm) + 0.5 * std::max(b.thickness_mm, b.width_mm),
                                     std::abs(b.v_mm)));
  const double margin = 40, legend = 96;
  const double k = (px - 2 * margin - legend) / (2 * std::max(reach, 1.0));
  const double cx = px / 2.0, cy = (px - legend) / 2.0;
  // Scanner x to the right, y up.
  auto to_px = [&](double x, double y) {
    return std::pair<double, double>{cx + (x - c.x) * k, cy - (y - c.y) * k};
  };
  // The outline under bark, filled as wood.
  for (size_t i = 0; i < rad.size(); ++i) {
    const double w = 2 * kPi * i / rad.size();
    const auto [x, y] = to_px(pith.x + rad[i] * std::cos(w), pith.y + rad[i] * std::sin(w));
    if (i == 0)
      cairo_move_to(cr, x, y);
    else
      cairo_line_to(cr, x, y);
  }
  cairo_close_path(cr);
  set_color(cr, {0.91, 0.84, 0.70});
  cairo_fill_preserve(cr);
  set_color(cr, kInk);
  cairo_set_line_width(cr, 2);
  cairo_stroke(cr);
  // The pattern's boards, at rotation 0 about the centre (u along x, v along y).
  if (pattern) {
    cairo_set_line_width(cr, 1.5);
    for (const sawing::BoardSpec& b : pattern->boards) {
      const bool along_u = b.thickness_axis == sawing::ThicknessAxis::kU;
      const double hu = 0.5 * (along_u ? b.thickness_mm : b.width_mm);
      const double hv = 0.5 * (along_u ? b.width_mm : b.thickness_mm);
      const auto [x0, y0] = to_px(c.x + b.u_mm - hu, c.y + b.v_mm + hv);
      cairo_rectangle(cr, x0, y0, 2 * hu * k, 2 * hv * k);
      set_color(cr, kBoardLine, b.edged ? 0.08 : 0.18);
      cairo_fill_preserve(cr);
      set_color(cr, kBoardLine);
      cairo_stroke(cr);
    }
  }
  const auto [ox, oy] = to_px(c.x, c.y);
  // The usable circle, then the one the pattern needs (dashed, over it).
  cairo_set_line_width(cr, 3);
  set_color(cr, kSound);
  cairo_new_path(cr);
  cairo_arc(cr, ox, oy, use_r * k, 0, 2 * kPi);
  cairo_stroke(cr);
  const double dash[] = {12, 8};
  cairo_set_dash(cr, dash, 2, 0);
  set_color(cr, kDead);
  cairo_new_path(cr);
  cairo_arc(cr, ox, oy, need_r * k, 0, 2 * kPi);
  cairo_stroke(cr);
  cairo_set_dash(cr, nullptr, 0, 0);
  // The pith line's centre.
  set_color(cr, kInk);
  cairo_arc(cr, ox, oy, 3, 0, 2 * kPi);
  cairo_fill(cr);
  // Legend, large enough to read where the PDF shows the figure half a page wide.
  set_font(cr, 24);
  auto key = [&](double y, Rgb col, bool dashed, const std::string& text) {
    cairo_set_line_width(cr, 3);
    if (dashed) cairo_set_dash(cr, dash, 2, 0);
    set_color(cr, col);
    cairo_move_to(cr, margin, y - 6);
    cairo_line_to(cr, margin + 36, y - 6);
    cairo_stroke(cr);
    cairo_set_dash(cr, nullptr, 0, 0);
    set_color(cr, kInk);
    draw_text(cr, text, margin + 46, y);
  };
  key(px - legend + 30, kSound, false, "usable diameter " + fmt("%.1f mm", usable));
  key(px - legend + 68, kDead, true, "needed by the pattern " + fmt("%.1f mm", needed));
  return surf;
}

}  // namespace sawyer::report
