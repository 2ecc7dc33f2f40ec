// The boards in detail (see board_detail.h).
#include "board_detail.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "figures.h"
#include "sawyer/render/views.h"
#include "sawyer/sawing/placement.h"

namespace sawyer::report {
namespace {

void ring(cairo_t* cr, double x, double y, double r, bool dead, double width) {
  cairo_new_sub_path(cr);
  cairo_arc(cr, x, y, r, 0, 2 * kPi);
  set_color(cr, {1, 1, 1}, 0.9);
  cairo_set_line_width(cr, width * 2.2);
  cairo_stroke_preserve(cr);
  set_color(cr, dead ? kDead : kSound);
  cairo_set_line_width(cr, width);
  cairo_stroke(cr);
}

}  // namespace

Result<BoardFaces> render_faces(render::WoodRenderer& r, const sawing::SawLog& log,
                                const sawing::LogPosition& pos, const sawing::Board& b,
                                double px_per_cm, int supersample) {
  const BoardBox rb = sawing::board_placement(log, b, pos);
  // BoardBox's top (+v) is the pattern's −u side for a board cut with its thickness along u
  // (placement.cpp turns it 90°), the +v side otherwise; its right (+u) side is edge+ in both.
  const bool thick_u = b.thickness_axis == sawing::ThicknessAxis::kU;
  struct Spec {
    render::Face face;
    const char* label;
  };
  const Spec specs[] = {{thick_u ? render::Face::kBottom : render::Face::kTop, "face +"},
                        {thick_u ? render::Face::kTop : render::Face::kBottom, "face −"},
                        {render::Face::kRight, "edge +"},
                        {render::Face::kLeft, "edge −"}};
  BoardFaces out;
  out.length_mm = b.length_mm();
  double k = px_per_cm / 10.0;
  const double longest = std::max({b.length_mm(), b.width_mm, b.thickness_mm, 1.0});
  k = std::min(k, (render::kMaxImageSide - 8) / longest);
  out.px_per_mm = k;
  const int len_px = std::max(16, static_cast<int>(std::lround(b.length_mm() * k)));
  render::FaceLayout layout;
  layout.stretch = true;
  layout.supersample = supersample;
  // The wane (outside the log) stays a pale grey, so a face's missing corners show.
  layout.background[0] = layout.background[1] = layout.background[2] = 0.90f;
  for (const Spec& s : specs) {
    BoardFaces::Row row;
    row.label = s.label;
    row.rect = render::board_face(rb, s.face);
    const int hpx = std::max(6, static_cast<int>(std::lround(row.rect.height * k)));
    Result<render::Image> img =
        render::render_board_faces(r, rb, static_cast<unsigned>(s.face), {len_px, hpx}, {}, layout);
    if (!img) return img.error();
    row.image = to_surface(img.value());
    out.rows.push_back(std::move(row));
  }
  return out;
}

std::vector<FaceMark> limiting_marks(const BoardFaces& f, const LogModel& log,
                                     const sawing::Board& board,
                                     const std::vector<sawing::LimitingKnot>& knots,
                                     const std::vector<std::string>& texts) {
  std::vector<FaceMark> out;
  for (size_t i = 0; i < knots.size(); ++i) {
    const sawing::LimitingKnot& l = knots[i];
    const sawing::KnotOnSide& k = board.knots[l.index];
    if (k.knot < 0 || k.knot >= static_cast<int>(log.knots.size())) continue;
    const Vec3 p = log.knots[k.knot].axis_point(k.r_mm, log.stem);
    // The row of the knot's side (rows are in Side's order), else the face whose plane the
    // crossing lies in (near a corner).
    int best = -1;
    double best_d = 1e300, s = 0, t = 0;
    const int own = static_cast<int>(l.side);
    for (size_t i = 0; i < f.rows.size(); ++i) {
      const render::PlaneRect& rc = f.rows[i].rect;
      const double d = std::abs(dot(p - rc.origin, rc.normal())) - (int(i) == own ? 2.0 : 0.0);
      if (d < best_d) {
        best_d = d;
        best = static_cast<int>(i);
        s = dot(p - rc.origin, rc.u) / rc.width;
        t = dot(p - rc.origin, rc.v) / rc.height;
      }
    }
    if (best < 0 || best_d > 5.0) continue;
    const int w = cairo_image_surface_get_width(f.rows[best].image.get());
    const int h = cairo_image_surface_get_height(f.rows[best].image.get());
    FaceMark m;
    m.row = best;
    m.x_px = std::clamp(s, 0.0, 1.0) * w;
    m.y_px = (1.0 - std::clamp(t, 0.0, 1.0)) * h;
    m.radius_px = 0.5 * std::max(k.width_mm, k.length_mm) * f.px_per_mm + 4;
    m.width_mm = l.width_mm;
    m.dead = l.dead;
    m.knot_id = l.knot_id;
    m.text = texts[i];
    out.push_back(std::move(m));
  }
  return out;
}

SurfacePtr compose_faces(const BoardFaces& f, double px_per_cm, double ui,
                         const std::vector<FaceMark>& marks, bool draw_marks, StripLayout* layout) {
  const double k = px_per_cm / 10.0;  // px per mm of the strip
  const double scale = f.px_per_mm > 0 ? k / f.px_per_mm : 1.0;
  const int len_px = std::max(16, static_cast<int>(std::lround(f.length_mm * k)));
  const int label_w = static_cast<int>(std::lround(84 * ui)), pad = static_cast<int>(6 * ui);
  const int gap = static_cast<int>(std::lround(6 * ui)), scale_h = static_cast<int>(30 * ui);
  std::vector<int> hs;
  int total_h = pad;
  for (const BoardFaces::Row& row : f.rows) {
    hs.push_back(std::max(
        6, static_cast<int>(std::lround(cairo_image_surface_get_height(row.image.get()) * scale))));
    total_h += hs.back() + gap;
  }
  total_h += scale_h;
  SurfacePtr surf = new_raster(label_w + len_px + 2 * pad, total_h);
  ContextPtr ctx = new_context(surf.get());
  cairo_t* cr = ctx.get();
  StripLayout lay;
  lay.scale = scale;
  lay.x0 = label_w;
  int y = pad;
  for (size_t i = 0; i < f.rows.size(); ++i) {
    const BoardFaces::Row& row = f.rows[i];
    const int hpx = hs[i];
    lay.row_y.push_back(y);
    lay.row_h.push_back(hpx);
    cairo_save(cr);
    cairo_rectangle(cr, label_w, y, len_px, hpx);
    cairo_clip(cr);
    cairo_translate(cr, label_w, y);
    cairo_scale(cr, static_cast<double>(len_px) / cairo_image_surface_get_width(row.image.get()),
                static_cast<double>(hpx) / cairo_image_surface_get_height(row.image.get()));
    cairo_set_source_surface(cr, row.image.get(), 0, 0);
    cairo_pattern_set_filter(cairo_get_source(cr),
                             scale < 0.999 ? CAIRO_FILTER_GOOD : CAIRO_FILTER_FAST);
    cairo_paint(cr);
    cairo_restore(cr);
    set_color(cr, kMuted);
    cairo_set_line_width(cr, std::max(1.0, ui));
    cairo_rectangle(cr, label_w - 0.5, y - 0.5, len_px + 1, hpx + 1);
    cairo_stroke(cr);
    const double fs = std::clamp(hpx + gap - 1.0, 10.0 * ui, 17.0 * ui);  // thin edges: smaller
    set_font(cr, fs);
    set_color(cr, kInk);
    draw_text(cr, row.label, label_w - 8 * ui, y + hpx / 2.0 + 0.36 * fs, 1.0);
    y += hpx + gap;
  }
  // Metres from the board's butt end (z_begin).
  set_font(cr, 16 * ui);
  cairo_set_line_width(cr, std::max(1.0, ui));
  for (double t : ticks(0.0, f.length_mm * 1e-3, 8)) {
    const double x = label_w + t * 1e3 * k;
    set_color(cr, kMuted);
    cairo_move_to(cr, std::round(x) + 0.5, y - 2 * ui);
    cairo_line_to(cr, std::round(x) + 0.5, y + 4 * ui);
    cairo_stroke(cr);
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f m", t);
    draw_text(cr, buf, x, y + 21 * ui, t == 0 ? 0.0 : 0.5);
  }
  if (draw_marks)
    for (const FaceMark& m : marks) {
      const double x = label_w + m.x_px * scale, yy = lay.row_y[m.row] + m.y_px * scale;
      ring(cr, x, yy, std::max(4.0 * ui, m.radius_px * scale), m.dead, 1.5 * ui);
      set_font(cr, 11 * ui, true);
      set_color(cr, m.dead ? kDead : kSound);
      draw_text(cr, std::to_string(m.knot_id), x,
                yy - std::max(4.0 * ui, m.radius_px * scale) - 3 * ui, 0.5);
    }
  lay.length_px = len_px;
  lay.width = cairo_image_surface_get_width(surf.get());
  lay.height = total_h;
  if (layout) *layout = lay;
  return surf;
}

SurfacePtr crop_around(cairo_surface_t* strip, const StripLayout& L, double px_per_mm,
                       const FaceMark& m, double half_mm) {
  const double x = L.x0 + m.x_px * L.scale, y = L.row_y[m.row] + m.y_px * L.scale;
  const int half = std::max(8, static_cast<int>(std::lround(half_mm * px_per_mm)));
  const int lo = L.x0, hi = L.x0 + L.length_px;
  int x0 = std::max(lo, static_cast<int>(std::lround(x)) - half);
  const int x1 = std::min(hi, x0 + 2 * half);
  x0 = std::max(lo, x1 - 2 * half);
  const int y0 = std::max(0, L.row_y.front() - 2);
  const int y1 = std::min(L.height, L.row_y.back() + L.row_h.back() + 2);
  SurfacePtr out = new_raster(std::max(1, x1 - x0), std::max(1, y1 - y0));
  ContextPtr ctx = new_context(out.get());
  cairo_t* cr = ctx.get();
  cairo_set_source_surface(cr, strip, -x0, -y0);
  cairo_paint(cr);
  ring(cr, x - x0, y - y0, std::max(5.0, m.radius_px * L.scale), m.dead, 2.0);
  return out;
}

}  // namespace sawyer::report
