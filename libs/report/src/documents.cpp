// The report's documents (see documents.h).
#include "documents.h"

#include <cairo-pdf.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <sstream>

#include "sawyer/sawing/sawing_file.h"
#include "sawyer/sawing/sawing_job.h"

namespace sawyer::report {
namespace {

const std::string kNone = "—";

// The HTML page's script and style (libs/report/web, embedded at build time).
struct WebFile {
  const char* name;
  const char* text;
};
const WebFile kWebFiles[] = {
#include "report_web.inc"
};
std::string web_file(const std::string& name) {
  for (const WebFile& f : kWebFiles)
    if (name == f.name) return f.text;
  return "";
}

std::string fmt(const char* f, double v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}
std::string fmt2(const char* f, double a, double b) {
  char buf[128];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}
std::string or_none(const std::string& s) { return s.empty() ? kNone : s; }

std::string money(double v, const std::string& currency) {
  return fmt("%.2f", v) + (currency.empty() ? "" : " " + currency);
}
std::string percent(double f) { return fmt("%+.1f %%", 100 * f); }

// Gains of the chosen position: the optimiser's (expected values) for the best position, at the
// positions themselves for a given one (sawing.json has no expected value for it).
double gain(const SawingRecord& s, const PositionValue& ref, double best_gain) {
  if (!s.chosen_given) return best_gain;
  return ref.value > 0 ? s.chosen.value / ref.value - 1.0 : 0.0;
}

std::string board_size(const BoardRecord& b) {
  return fmt2("%.0f × %.0f", b.thickness_mm, b.width_mm);
}

// The log's rows and its scan's QA verdict, for a log that was not sawn (no sawing column).
Rows not_sawn_log_rows(const Content& c) {
  Rows rows = log_rows(c);
  const auto& qa = c.run->log.qa;
  std::string verdict = !qa           ? kNone
                        : qa->trusted ? std::string("passed (QA images in scan/qa/)")
                                      : std::string("FAILED: the figures are not to be trusted");
  if (qa && !qa->trusted)
    for (const std::string& w : qa->warnings) verdict += "; " + w;
  rows.push_back({"Scan QA", verdict});
  return rows;
}

// The caption of the needed diameter's tile: a pattern's, or with a pattern set its smallest
// candidate's or its smallest class's start.
std::string needed_label(const NotSawn& ns) {
  if (ns.pattern_set.empty()) return "diameter the pattern needs";
  return ns.pattern.empty() ? "where the set's smallest class starts"
                            : "diameter the set's smallest candidate needs";
}

// Why a log was not sawn, in plain words: the first line the diameters (or run.json's reason
// when they are not known), then what the engineer can do about it.
std::vector<std::string> not_sawn_text(const RunFolder& r) {
  const NotSawn& ns = *r.run.not_sawn;
  std::vector<std::string> t;
  const bool set = !ns.pattern_set.empty();
  // With a pattern set: no candidate for its class fits (the smallest named), or the log is
  // below the set's smallest class.
  const std::string pattern =
      !set ? "pattern '" + or_none(ns.pattern) + "'"
      : ns.pattern.empty()
          ? "no pattern of pattern set '" + ns.pattern_set +
                "' fits: its smallest class starts at " + fmt("%.1f mm", ns.needed_diameter_mm) +
                ";"
          : "no pattern of pattern set '" + ns.pattern_set +
                "' fits: the smallest of its candidates for the log's class, pattern '" +
                ns.pattern + "',";
  const bool too_small = ns.pattern_too_large();
  if (too_small && set && ns.pattern.empty())
    t.push_back("The log was scanned but not sawn: " + pattern + " this log's usable diameter is " +
                fmt("%.1f mm", ns.usable_diameter_mm) +
                " (the largest circle about the pith line inside its top end, under bark): " +
                fmt("%.1f mm", ns.needed_diameter_mm - ns.usable_diameter_mm) + " short.");
  else if (too_small)
    t.push_back("The log was scanned but not sawn: " + pattern + " needs a log at least " +
                fmt("%.1f mm", ns.needed_diameter_mm) +
                " across, and this log's usable "
                "diameter is " +
                fmt("%.1f mm", ns.usable_diameter_mm) +
                " (the largest circle "
                "about the pith line inside its top end, under bark): " +
                fmt("%.1f mm", ns.needed_diameter_mm - ns.usable_diameter_mm) + " short.");
  else
    t.push_back("The log was scanned but not sawn: " + or_none(ns.reason) + ".");
  if (too_small && set)
    t.push_back(
        "The scan is complete and kept in scan/ (log.json, the maps and the QA images). "
        "To saw this log, give a pattern set with patterns for smaller logs, or one pattern "
        "(a through-and-through pattern, tt, edges every board to the log and fits any log): "
        "`sawyer saw scan/log.json -o sawing.json --pattern-set S` (or `--pattern P`) saws the "
        "scanned model without scanning again.");
  else if (too_small || ns.needed_diameter_mm < 0)
    t.push_back(
        "The scan is complete and kept in scan/ (log.json, the maps and the QA images). "
        "To saw this log, choose a pattern for smaller logs (a through-and-through "
        "pattern, tt, edges every board to the log and fits any log): `sawyer saw "
        "scan/log.json -o sawing.json --pattern P` saws the scanned model without "
        "scanning again; `sawyer run --pattern P` scans and saws it again.");
  else
    t.push_back(
        "The scan is complete and kept in scan/ (log.json, the maps and the QA images). "
        "To saw this log, give a position or offsets within its wood: `sawyer saw "
        "scan/log.json -o sawing.json` with them saws the scanned model without scanning "
        "again.");
  if (r.log.qa && !r.log.qa->trusted)
    t.push_back(
        "The scan's QA verdict failed: the log's outline or pith, and so its usable "
        "diameter, may be wrong; check the QA images in scan/qa/ before setting the log "
        "aside.");
  return t;
}

// ---------------------------------------------------------------------------------------------
// PDF

constexpr double kPageW = 595.28, kPageH = 841.89, kMargin = 42;
constexpr double kContentW = kPageW - 2 * kMargin;

class PdfWriter {
 public:
  PdfWriter(const Content& c, cairo_t* cr) : c_(c), cr_(cr) {}

  void header() {
    set_color(cr_, kAccent);
    cairo_rectangle(cr_, 0, 0, kPageW, 6);
    cairo_fill(cr_);
    set_font(cr_, 20, true);
    set_color(cr_, kInk);
    const double title_w = draw_text(cr_, "Cutting report", kMargin, 52);
    // The log's id to the right of the title, smaller or shortened when it is long: everything
    // in the header stays inside the page's margins (issue 44).
    const double id_w = kContentW - title_w - 16;
    double id_size = 20;
    set_font(cr_, id_size);
    while (id_size > 11 && text_width(cr_, c_.run->log.id) > id_w) set_font(cr_, id_size -= 1);
    set_color(cr_, kAccent);
    draw_text(cr_, fit_text(cr_, c_.run->log.id, id_w), kPageW - kMargin, 52, 1.0);
    set_color(cr_, kMuted);
    const RunInfo& r = c_.run->run;
    // The scan's description (the DICOM series' words, a folder's name) is wrapped to the page,
    // at most three lines: a longer one is cut there (run.json has it whole).
    constexpr double kLead = 11;
    constexpr int kMaxLines = 3;
    set_font(cr_, 8.5);
    const std::string line = "Run " + or_none(r.date) + " · scan: " + or_none(r.scan_description) +
                             " · Sawyer " + or_none(r.sawyer_version);
    const std::vector<std::string> lines = wrapped_lines(cr_, line, kContentW, kMaxLines);
    for (size_t i = 0; i < lines.size(); ++i) draw_text(cr_, lines[i], kMargin, 68 + kLead * i);
    const double h = kLead * static_cast<double>(lines.size());
    rule(76 + h - kLead);
    y_ = 96 + h - kLead;
    // What the scan's reader had to do (e.g. slices interpolated over a gap) is part of what
    // the figures below rest on: stated on every page, under the header.
    if (!r.scan_notes.empty()) {
      set_font(cr_, 7, true);
      set_color(cr_, kInk);
      constexpr size_t kMaxNotes = 3;
      for (size_t i = 0; i < r.scan_notes.size() && i < kMaxNotes; ++i) {
        std::string n = "Scan: " + r.scan_notes[i];
        if (i + 1 == kMaxNotes && r.scan_notes.size() > kMaxNotes)
          n += "  (and " + std::to_string(r.scan_notes.size() - kMaxNotes) + " more in run.json)";
        draw_text(cr_, fit_text(cr_, n, kContentW), kMargin, y_ - 6);
        y_ += 12;
      }
      y_ += 6;
    }
    // The scan's QA verdict: when it failed, every page says so; the first lists why.
    if (const auto& qa = c_.run->log.qa; qa && !qa->trusted) {
      set_font(cr_, 8.5, true);
      set_color(cr_, kWarn);
      draw_text(cr_,
                c_.run->sawn() ? "NOT TO BE TRUSTED: the scan's QA verdict failed; the position "
                                 "below rests on an uncertain model"
                               : "NOT TO BE TRUSTED: the scan's QA verdict failed; the log's "
                                 "figures below rest on an uncertain model",
                kMargin, y_ - 6);
      y_ += 13;
      if (page_ == 1) {
        set_font(cr_, 7.5);
        for (size_t i = 0; i < qa->warnings.size() && i < 4; ++i) {
          draw_text(cr_, fit_text(cr_, "QA: " + qa->warnings[i], kContentW), kMargin, y_ - 6);
          y_ += 11;
        }
      }
      y_ += 6;
    }
  }

  void footer() {
    set_font(cr_, 7.5);
    set_color(cr_, kMuted);
    draw_text(cr_, fit_text(cr_, "Sawyer cutting report · log " + c_.run->log.id, kContentW - 60),
              kMargin, kPageH - 24);
    draw_text(cr_, "page " + std::to_string(page_), kPageW - kMargin, kPageH - 24, 1.0);
  }

  void new_page() {
    footer();
    cairo_show_page(cr_);
    ++page_;
    set_color(cr_, kAccent);
    cairo_rectangle(cr_, 0, 0, kPageW, 6);
    cairo_fill(cr_);
    y_ = 48;
  }
  // Starts a new page unless `h` points still fit.
  void need(double h) {
    if (y_ + h > kPageH - 48) new_page();
  }

  void heading(const std::string& text) {
    need(40);
    set_font(cr_, 12, true);
    set_color(cr_, kAccent);
    draw_text(cr_, text, kMargin, y_);
    y_ += 14;
  }

  void rule(double y) {
    set_color(cr_, kRule);
    cairo_set_line_width(cr_, 0.6);
    cairo_move_to(cr_, kMargin, y);
    cairo_line_to(cr_, kPageW - kMargin, y);
    cairo_stroke(cr_);
  }

  // Label/value rows in a column; returns the height used.
  double rows(const Rows& rs, double x, double y, double w, double label_w) {
    double yy = y;
    for (const auto& [label, value] : rs) {
      set_font(cr_, 8.5);
      set_color(cr_, kMuted);
      draw_text(cr_, label, x, yy);
      set_color(cr_, kInk);
      yy += wrap(value, x + label_w, yy, w - label_w, 8.5, 11);
      yy += 3;
    }
    return yy - y;
  }

  // Draws `text` wrapped to `w` from baseline y; returns the height of its lines.
  double wrap(const std::string& text, double x, double y, double w, double size, double lead) {
    set_font(cr_, size);
    std::istringstream words(text);
    std::string word, line;
    double yy = y;
    int lines = 0;
    while (words >> word) {
      // A word wider than the column (a long path) is broken after a '/' or anywhere.
      while (text_width(cr_, word) > w && word.size() > 1) {
        size_t cut = word.size() - 1;
        while (cut > 1 && text_width(cr_, word.substr(0, cut)) > w) --cut;
        const size_t slash = word.rfind('/', cut - 1);
        if (slash != std::string::npos && slash > cut / 2) cut = slash + 1;
        if (!line.empty()) {
          draw_text(cr_, line, x, yy);
          yy += lead;
          ++lines;
          line.clear();
        }
        draw_text(cr_, word.substr(0, cut), x, yy);
        yy += lead;
        ++lines;
        word = word.substr(cut);
      }
      const std::string cand = line.empty() ? word : line + " " + word;
      if (!line.empty() && text_width(cr_, cand) > w) {
        draw_text(cr_, line, x, yy);
        yy += lead;
        ++lines;
        line = word;
      } else {
        line = cand;
      }
    }
    if (!line.empty()) {
      draw_text(cr_, line, x, yy);
      ++lines;
    }
    return std::max(1, lines) * lead;
  }

  // An image scaled to width w at (x, y).
  double image(cairo_surface_t* s, double x, double y, double w) {
    const double iw = cairo_image_surface_get_width(s), ih = cairo_image_surface_get_height(s);
    const double k = w / iw;
    cairo_save(cr_);
    cairo_translate(cr_, x, y);
    cairo_scale(cr_, k, k);
    cairo_set_source_surface(cr_, s, 0, 0);
    cairo_pattern_set_filter(cairo_get_source(cr_), CAIRO_FILTER_GOOD);
    cairo_paint(cr_);
    cairo_restore(cr_);
    return ih * k;
  }

  void figure(const Figure& f, double w) {
    const double iw = cairo_image_surface_get_width(f.surface.get());
    const double ih = cairo_image_surface_get_height(f.surface.get());
    need(ih * w / iw + 34);
    y_ += image(f.surface.get(), kMargin + (kContentW - w) / 2, y_, w) + 12;
    set_color(cr_, kMuted);
    y_ += wrap(f.caption, kMargin, y_, kContentW, 8, 10.5) + 8;
  }

  // A tile with a big figure and a label.
  void tile(double x, double y, double w, const std::string& value, const std::string& label) {
    set_color(cr_, {0.95, 0.96, 0.95});
    cairo_rectangle(cr_, x, y, w, 46);
    cairo_fill(cr_);
    set_color(cr_, kAccent);
    cairo_rectangle(cr_, x, y, 3, 46);
    cairo_fill(cr_);
    set_font(cr_, 16, true);
    set_color(cr_, kInk);
    draw_text(cr_, value, x + 12, y + 23);
    set_font(cr_, 8);
    set_color(cr_, kMuted);
    draw_text(cr_, label, x + 12, y + 37);
  }

  void board_table() {
    const SawingRecord& s = c_.run->sawing;
    struct Col {
      const char* title;
      double w;
      double align;
    };
    const Col cols[] = {{"#", 16, 0},        {"board", 58, 0},     {"size mm", 54, 0},
                        {"length m", 42, 1}, {"volume m³", 50, 1}, {"grade", 40, 0.0},
                        {"value", 50, 1},    {"limited by", 0, 0}};
    double widths[8];
    double used = 0;
    for (int i = 0; i < 7; ++i) used += (widths[i] = cols[i].w + 6);
    widths[7] = kContentW - used;
    need(40);
    auto cell_x = [&](int i) {
      double x = kMargin;
      for (int k = 0; k < i; ++k) x += widths[k];
      return x;
    };
    set_font(cr_, 7.5, true);
    set_color(cr_, kMuted);
    for (int i = 0; i < 8; ++i)
      draw_text(cr_, i == 6 ? "value " + s.currency : cols[i].title,
                cols[i].align > 0 ? cell_x(i) + cols[i].w : cell_x(i), y_, cols[i].align);
    y_ += 5;
    rule(y_);
    y_ += 11;
    for (size_t b = 0; b < s.boards.size(); ++b) {
      const BoardRecord& r = s.boards[b];
      need(26);
      const std::string cells[7] = {
          std::to_string(b + 1),    r.name,  board_size(r),       fmt("%.2f", r.length_mm() * 1e-3),
          fmt("%.4f", r.volume_m3), r.grade, fmt("%.2f", r.value)};
      set_color(cr_, kInk);
      for (int i = 0; i < 7; ++i) {
        set_font(cr_, 8.5, i == 5);
        draw_text(cr_, cells[i], cols[i].align > 0 ? cell_x(i) + cols[i].w : cell_x(i), y_,
                  cols[i].align);
      }
      set_color(cr_, kMuted);
      const double h = wrap(r.limit_and_offcuts(), cell_x(7), y_, widths[7], 7.5, 9.5);
      y_ += std::max(13.0, h + 3);
      rule(y_ - 9);
    }
    if (s.boards.empty()) {
      set_font(cr_, 8.5);
      set_color(cr_, kInk);
      draw_text(cr_,
                "No boards: pattern '" + s.pattern +
                    "' gives no board from this log at this "
                    "position (too short or too thin for the pattern's sizes and wane rules).",
                kMargin, y_);
      y_ += 16;
    }
    set_font(cr_, 8.5, true);
    set_color(cr_, kInk);
    draw_text(cr_, "total", cell_x(1), y_);
    draw_text(cr_, std::to_string(s.boards.size()) + " boards", cell_x(2), y_);
    draw_text(cr_, fmt("%.4f", c_.boards_volume_m3), cell_x(4) + cols[4].w, y_, 1.0);
    draw_text(cr_, fmt("%.2f", c_.boards_value), cell_x(6) + cols[6].w, y_, 1.0);
    y_ += 14;
    set_font(cr_, 8.5);
    set_color(cr_, kMuted);
    draw_text(cr_,
              "Volume yield " + fmt("%.1f %%", 100 * c_.volume_yield()) + ": boards' " +
                  fmt("%.4f m³", c_.boards_volume_m3) + " of the log's " +
                  fmt("%.3f m³", c_.summary.volume_m3) + " under bark.",
              kMargin, y_);
    y_ += 20;
  }

  void page_one() {
    header();
    const double col = (kContentW - 20) / 2;
    set_font(cr_, 12, true);
    set_color(cr_, kAccent);
    draw_text(cr_, "The log", kMargin, y_);
    draw_text(cr_, "The sawing", kMargin + col + 20, y_);
    y_ += 16;
    const double h1 = rows(log_rows(c_), kMargin, y_, col, 92);
    const double h2 = rows(position_rows(c_), kMargin + col + 20, y_, col, 104);
    y_ += std::max(h1, h2) + 6;

    // End view on the left, the key figures on the right.
    const Figure* ev = c_.figure("end_view.png");
    const double ew = 250;
    need(ew + 40);
    const double y0 = y_;
    if (ev) image(ev->surface.get(), kMargin, y0, ew);
    const SawingRecord& s = c_.run->sawing;
    const double tx = kMargin + ew + 16, tw = kContentW - ew - 16;
    const double half = (tw - 8) / 2;
    tile(tx, y0, half, money(s.chosen.value, s.currency), "value of the boards");
    tile(tx + half + 8, y0, half, percent(gain(s, s.horns_down, s.gain_over_horns_down)),
         "gain over horns-down");
    tile(tx, y0 + 54, half, fmt("%.1f %%", 100 * c_.volume_yield()), "volume yield");
    tile(tx + half + 8, y0 + 54, half, std::to_string(s.boards.size()) + " boards",
         fmt("%.4f m³ sawn", c_.boards_volume_m3));
    set_color(cr_, kMuted);
    if (ev) wrap(ev->caption, tx, y0 + 126, tw, 8, 10.5);
    y_ = y0 + ew + 16;
    heading("Boards at the chosen position");
    y_ += 4;
    board_table();
  }

  void page_two() {
    new_page();
    heading("The log and its boards");
    y_ += 4;
    if (const Figure* f = c_.figure("log_view.png")) figure(*f, kContentW);
    heading("Board faces");
    set_font(cr_, 8);
    set_color(cr_, kMuted);
    y_ += wrap(
              "Each board's four long sides rendered from the log model: the wide faces (face +, "
              "face −) and the edges, butt end on the left. Grey: wane (outside the log). "
              "Ringed and numbered: the knots that decide the board's grade (red dead, green "
              "sound), shown larger on the next page.",
              kMargin, y_ + 2, kContentW, 8, 10.5) +
          8;
    const SawingRecord& s = c_.run->sawing;
    for (size_t i = 0; i < c_.board_figures.size(); ++i) {
      const Figure& f = c_.board_figures[i];
      const double iw = cairo_image_surface_get_width(f.surface.get());
      const double ih = cairo_image_surface_get_height(f.surface.get());
      need(ih * kContentW / iw + 22);
      const BoardRecord& b = s.boards[i];
      set_font(cr_, 9, true);
      set_color(cr_, kInk);
      draw_text(cr_, std::to_string(i + 1) + "  " + b.name, kMargin, y_ + 2);
      set_font(cr_, 8.5);
      set_color(cr_, kMuted);
      draw_text(cr_,
                board_size(b) + " mm · " + fmt("%.2f m", b.length_mm() * 1e-3) + " · grade " +
                    b.grade + " · " + money(b.value, s.currency),
                kPageW - kMargin, y_ + 2, 1.0);
      y_ += 8;
      y_ += image(f.surface.get(), kMargin, y_, kContentW) + 14;
    }
  }

  // "Where the grades are decided": per board, crops of its faces around the knots that keep it
  // out of the grade above, each labelled with its description.
  void page_decisions() {
    const SawingRecord& s = c_.run->sawing;
    bool any = false;
    for (const BoardDetail& d : c_.details) any = any || !d.crops.empty();
    new_page();
    heading("Where the grades are decided");
    set_color(cr_, kMuted);
    y_ += wrap(any ? "For each board, its faces around the knots whose size keeps it out of the "
                     "grade above (ringed: red dead, green sound), the largest excess first."
                   : "No board's grade is decided by a knot's size.",
               kMargin, y_ + 2, kContentW, 8, 10.5) +
          8;
    constexpr int kCols = 3;
    const double gap = 12, cw = (kContentW - (kCols - 1) * gap) / kCols;
    for (size_t i = 0; i < c_.details.size() && i < s.boards.size(); ++i) {
      const BoardDetail& d = c_.details[i];
      const BoardRecord& b = s.boards[i];
      need(40);
      set_font(cr_, 9, true);
      set_color(cr_, kInk);
      draw_text(cr_, std::to_string(i + 1) + "  " + b.name + "  ·  grade " + b.grade, kMargin,
                y_ + 2);
      y_ += 14;
      if (d.crops.empty()) {
        set_color(cr_, kMuted);
        const std::string why = !d.note.empty() ? d.note : "limited by " + b.limited_by;
        y_ += wrap("No knot decides it: " + why + ".", kMargin, y_, kContentW, 8, 10.5) + 6;
        continue;
      }
      for (size_t k = 0; k < d.crops.size(); k += kCols) {
        // One row of crops: as tall as the tallest, captions under each.
        double row_h = 0;
        for (size_t j = k; j < d.crops.size() && j < k + kCols; ++j) {
          cairo_surface_t* img = d.crops[j].surface.get();
          row_h = std::max(
              row_h, cw * cairo_image_surface_get_height(img) / cairo_image_surface_get_width(img));
        }
        need(row_h + 40);
        double caption_h = 0;
        for (size_t j = k; j < d.crops.size() && j < k + kCols; ++j) {
          const double x = kMargin + (j - k) * (cw + gap);
          image(d.crops[j].surface.get(), x, y_, cw);
          set_color(cr_, kInk);
          caption_h =
              std::max(caption_h, wrap(d.crops[j].caption, x, y_ + row_h + 10, cw, 7.5, 9.5));
        }
        y_ += row_h + 10 + caption_h + 8;
      }
      if (d.knots.size() > d.crops.size()) {
        set_color(cr_, kMuted);
        y_ += wrap(std::to_string(d.knots.size() - d.crops.size()) +
                       " more knots over the limit (listed in report.json and the HTML page).",
                   kMargin, y_, kContentW, 7.5, 9.5) +
              6;
      }
    }
  }

  // A heading kept on the same page as the figure under it.
  void figure_section(const std::string& title, const Figure* f) {
    if (!f) return;
    const double iw = cairo_image_surface_get_width(f->surface.get());
    const double ih = cairo_image_surface_get_height(f->surface.get());
    need(22 + ih * kContentW / iw + 40);
    y_ += 8;
    heading(title);
    y_ += 4;
    figure(*f, kContentW);
  }

  // The run's stages and their times, one line: "scan 3.70 s, saw 0.23 s, ...".
  std::string stages_text() const {
    std::string stages;
    for (const RunInfo::Stage& st : c_.run->run.stages)
      stages += (stages.empty() ? "" : ", ") + st.name +
                (st.seconds >= 0 ? fmt(" %.2f s", st.seconds) : std::string());
    return stages;
  }

  void page_three() {
    figure_section("Positioning: expected value over rotation and offset",
                   c_.figure("value_map.png"));
    figure_section("The log along its length", c_.figure("log_profile.png"));
    heading("Notes");
    set_color(cr_, kMuted);
    const std::string stages = stages_text();
    const std::string notes[] = {
        c_.boards.note + ".",
        "Scan source: " + or_none(c_.run->run.scan_source) +
            (c_.run->run.scan_checksum.empty() ? "" : " (" + c_.run->run.scan_checksum + ")") + ".",
        "Run stages: " + or_none(stages) + ".",
        "Values are board volume × the price per m³ of its grade and size in price list '" +
            c_.run->sawing.prices +
            "'; expected values average over the positioning error of "
            "the saw line. Grades follow rule set '" +
            c_.run->sawing.grading + "'."};
    for (const std::string& n : notes) {
      need(24);
      y_ += wrap(n, kMargin, y_ + 2, kContentW, 8, 10.5) + 4;
    }
    footer();
  }

  // The one page of a log that was not sawn: why, the diameters, the log's figures, its top
  // end with both circles and its profile, and the notes.
  void not_sawn_pages() {
    const NotSawn& ns = *c_.run->run.not_sawn;
    header();
    set_font(cr_, 16, true);
    set_color(cr_, kWarn);
    draw_text(cr_, "NOT SAWN", kMargin, y_ + 4);
    y_ += 22;
    const std::vector<std::string> text = not_sawn_text(*c_.run);
    set_color(cr_, kInk);
    y_ += wrap(text[0], kMargin, y_, kContentW, 10, 13) + 8;
    const double tw = (kContentW - 3 * 8) / 4;
    auto mm = [](double v) { return v >= 0 ? fmt("%.1f mm", v) : kNone; };
    tile(kMargin, y_, tw, mm(ns.needed_diameter_mm), needed_label(ns));
    tile(kMargin + tw + 8, y_, tw, mm(ns.usable_diameter_mm), "usable diameter of the log");
    tile(kMargin + 2 * (tw + 8), y_, tw, fmt("%.2f m", c_.summary.length_mm * 1e-3), "length");
    tile(kMargin + 3 * (tw + 8), y_, tw, fmt("%.3f m³", c_.summary.volume_m3), "volume");
    y_ += 62;
    const double col = (kContentW - 20) / 2;
    set_font(cr_, 12, true);
    set_color(cr_, kAccent);
    draw_text(cr_, "The log", kMargin, y_);
    draw_text(cr_, "The top end", kMargin + col + 20, y_);
    y_ += 16;
    const double y0 = y_;
    const double h1 = rows(not_sawn_log_rows(c_), kMargin, y_, col, 92);
    double h2 = 0;
    if (const Figure* f = c_.figure("top_end.png")) {
      h2 = image(f->surface.get(), kMargin + col + 20, y0, col) + 6;
      set_color(cr_, kMuted);
      h2 += wrap(f->caption, kMargin + col + 20, y0 + h2 + 6, col, 7.5, 9.5) + 6;
    }
    y_ = y0 + std::max(h1, h2) + 6;
    figure_section("The log along its length", c_.figure("log_profile.png"));
    heading("Notes");
    set_color(cr_, kMuted);
    const std::string stages = stages_text();
    std::vector<std::string> notes(text.begin() + 1, text.end());
    notes.push_back("Sawyer: " + or_none(ns.reason) + ".");
    notes.push_back(
        (c_.run->run.pattern_set.empty() ? "Pattern " + or_none(c_.run->run.pattern)
                                         : "Pattern set " + c_.run->run.pattern_set) +
        ", grading " + or_none(c_.run->run.grading) +
        ". Scan source: " + or_none(c_.run->run.scan_source) +
        (c_.run->run.scan_checksum.empty() ? "" : " (" + c_.run->run.scan_checksum + ")") +
        ". Run stages: " + or_none(stages) + ".");
    for (const std::string& n : notes) {
      need(24);
      y_ += wrap(n, kMargin, y_ + 2, kContentW, 8, 10.5) + 4;
    }
    footer();
  }

  int pages() const { return page_; }

 private:
  const Content& c_;
  cairo_t* cr_;
  double y_ = 0;
  int page_ = 1;
};

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"') out += '"';
    out += ch;
  }
  return out + "\"";
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char ch : s) {
    switch (ch) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += ch;
    }
  }
  return out;
}

std::string base64(const std::string& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned n = (static_cast<unsigned char>(bytes[i]) << 16) |
                       (static_cast<unsigned char>(bytes[i + 1]) << 8) |
                       static_cast<unsigned char>(bytes[i + 2]);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += kAlphabet[(n >> 6) & 63];
    out += kAlphabet[n & 63];
  }
  if (i < bytes.size()) {
    unsigned n = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) n |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string html_rows(const Rows& rows) {
  std::string out = "<table class=\"kv\">";
  for (const auto& [k, v] : rows)
    out += "<tr><th>" + html_escape(k) + "</th><td>" + html_escape(v) + "</td></tr>";
  return out + "</table>";
}

std::string html_img(const Figure& f, const std::string& cls = "") {
  return "<img" + (cls.empty() ? "" : " class=\"" + cls + "\"") + " alt=\"" + html_escape(f.title) +
         "\" src=\"data:image/png;base64," + base64(f.png) + "\">";
}

std::string html_figure(const Figure& f) {
  return "<figure>" + html_img(f) + "<figcaption>" + html_escape(f.caption) +
         "</figcaption></figure>";
}

// A board's faces at full resolution in the pan-and-zoom viewer (web/board_zoom.js), its
// limiting knots as rings with their descriptions, and the list of them with links that open
// the board zoomed on each.
std::string html_zoom(const BoardDetail& d, size_t board, const std::string& title) {
  const StripLayout& L = d.strip;
  std::ostringstream h;
  h << "<div class=\"zoom\" data-board=\"" << board << "\" data-w=\"" << L.width << "\" data-h=\""
    << L.height << "\"><div class=\"zoom-bar\">"
    << "<button data-zoom=\"in\" title=\"zoom in\">+</button>"
    << "<button data-zoom=\"out\" title=\"zoom out\">−</button>"
    << "<button data-zoom=\"fit\" title=\"the whole board\">fit</button>"
    << "<button data-zoom=\"full\" title=\"the whole window (Esc closes)\">⤢</button>"
    << "<span class=\"zoom-level\">× 1.0</span><span>" << fmt("%.1f px/cm", d.detail_px_per_cm)
    << "</span></div><div class=\"zoom-view\"><div class=\"zoom-layer\" style=\"width:" << L.width
    << "px;height:" << L.height << "px\"><img alt=\"" << html_escape(title) << "\" width=\""
    << L.width << "\" height=\"" << L.height << "\" src=\"data:image/jpeg;base64,"
    << base64(d.strip_jpeg) << "\"><svg width=\"" << L.width << "\" height=\"" << L.height
    << "\" viewBox=\"0 0 " << L.width << " " << L.height << "\">";
  for (const FaceMark& m : d.marks) {
    const double x = L.x0 + m.x_px * L.scale, y = L.row_y[m.row] + m.y_px * L.scale;
    const double r = std::max(6.0, m.radius_px * L.scale);
    char pos[160];
    std::snprintf(pos, sizeof pos, "cx=\"%.1f\" cy=\"%.1f\" r=\"%.1f\"", x, y, r);
    h << "<g class=\"knot " << (m.dead ? "dead" : "sound") << "\" data-knot=\"" << m.knot_id
      << "\" data-x=\"" << fmt("%.1f", x) << "\" data-y=\"" << fmt("%.1f", y) << "\"><title>"
      << html_escape(m.text) << "</title><circle class=\"halo\" " << pos << "/><circle " << pos
      << "/><text x=\"" << fmt("%.1f", x) << "\" y=\"" << fmt("%.1f", y - r - 4) << "\">"
      << m.knot_id << "</text></g>";
  }
  h << "</svg></div></div></div>";
  if (!d.marks.empty()) {
    h << "<ul class=\"limits\">";
    for (const FaceMark& m : d.marks)
      h << "<li><a href=\"#board=" << board << "&amp;zoom=6&amp;knot=" << m.knot_id << "\">"
        << html_escape(m.text) << "</a></li>";
    h << "</ul>";
  } else if (!d.note.empty()) {
    h << "<p class=\"limits\">No knot decides the grade: " << html_escape(d.note) << ".</p>";
  }
  return h.str();
}

}  // namespace

const Figure* Content::figure(const std::string& file) const {
  for (const Figure& f : figures)
    if (f.file == file) return &f;
  return nullptr;
}

Rows log_rows(const Content& c) {
  const RunFolder& r = *c.run;
  const LogSummary& s = c.summary;
  std::string largest = kNone;
  if (s.largest_knot >= 0)
    largest = fmt("%.0f mm", s.largest_knot_diameter_mm) + " (knot " +
              std::to_string(r.log.knots[s.largest_knot].id) + ")";
  return {{"Log id", r.log.id},
          {"Species", or_none(!r.run.species.empty() ? r.run.species : r.log.species)},
          {"Scan source", or_none(r.run.scan_source)},
          {"Date", or_none(r.run.date)},
          {"Length", fmt("%.2f m", s.length_mm * 1e-3)},
          {"Diameter", fmt2("butt %.0f / top %.0f", s.butt_diameter_mm, s.top_diameter_mm) +
                           fmt(" / mean %.0f mm", s.mean_diameter_mm)},
          {"Volume", fmt("%.3f m³ under bark", s.volume_m3)},
          {"Taper", fmt("%.1f mm/m", s.taper_mm_per_m)},
          {"Pith wander", fmt("%.1f mm", s.pith_wander_mm)},
          {"Knots", std::to_string(s.knot_count) + " (" + std::to_string(s.dead_knots) +
                        " with a dead part)"},
          {"Largest knot", largest}};
}

// How horns-down was found: from the bow, or a convention for a log too straight to have one.
std::string horns_note(const BowRecord& b) {
  if (!b.present) return "";
  if (b.straight)
    return fmt(" (log straight: arc bow %.1f mm", b.arc_sagitta_mm) +
           fmt(" < %.0f mm, so horns-down is the orientation in the scanner)", b.min_bow_mm);
  return fmt(" (arc bow %.1f mm", b.arc_sagitta_mm) + fmt(", sweep %.1f mm)", b.chord_sweep_mm);
}

// The chosen position as the log turner and the set-works execute it.
std::string scanner_setup(const PositionValue& p, bool scanner_frame) {
  return p.has_scanner ? sawing::saw_setup_text(p.turn_deg, p.centre_at_ends, scanner_frame) : "—";
}

Rows position_rows(const Content& c) {
  const SawingRecord& s = c.run->sawing;
  const std::string expected =
      s.chosen.has_smoothed ? " (expected " + money(s.chosen.smoothed_value, s.currency) + ")" : "";
  const char* basis = s.chosen_given ? " (at the positions)" : " (expected values)";
  auto ref = [&](const PositionValue& p) {
    return money(p.value, s.currency) +
           (p.has_smoothed ? " (expected " + fmt("%.2f)", p.smoothed_value) : "");
  };
  Rows rows = {
      {"Pattern", or_none(s.pattern)},
      {"Grading", or_none(s.grading)},
      {"Prices", or_none(s.prices) + (s.currency.empty() ? "" : " (" + s.currency + ")")},
      {"Position", s.chosen_given ? "given by the operator" : "best found by the optimiser"},
      {"Rotation", fmt("%.1f° from horns-down", s.chosen.pos.rotation_deg) + horns_note(s.bow)},
      {"Offset",
       fmt2("x %+.1f mm, y %+.1f mm", s.chosen.pos.offset_x_mm, s.chosen.pos.offset_y_mm) +
           " from the pith line"},
      {"Saw set-up", scanner_setup(s.chosen, c.run->log.scanner_frame.has_value())},
      // Which frame the log's coordinates (and so a saw's setting) are in.
      {"Frame", c.run->log.scanner_frame
                    ? fmt("scanner x, y; z from %.1f mm", c.run->log.scanner_frame->z0_mm)
                    : std::string("log model (no scanner frame)")},
      {"Scan QA", !c.run->log.qa           ? std::string("—")
                  : c.run->log.qa->trusted ? std::string("passed")
                                           : std::string("FAILED: position not to be trusted")},
      {"Value", money(s.chosen.value, s.currency) + expected},
      {"Horns-down", ref(s.horns_down)},
      {"Horns-up", ref(s.horns_up)},
      {"Gain", percent(gain(s, s.horns_down, s.gain_over_horns_down)) + " over horns-down, " +
                   percent(gain(s, s.horns_up, s.gain_over_horns_up)) + " over horns-up" + basis}};
  // Under the scan's uncertainty: the claim held out from the draws that chose the position.
  if (s.claim && !s.chosen_given)
    rows.push_back({"Claim", sawing::claim_text(*s.claim) +
                                 " over horns-down, held out from the scan-uncertainty draws "
                                 "that chose the position"});
  // With a pattern set: which pattern won, from which class, and the next best's value.
  if (s.pattern_choice)
    rows.insert(rows.begin() + 1,
                {"Pattern choice", sawing::pattern_choice_line(*s.pattern_choice, s.currency)});
  return rows;
}

Status write_pdf(const Content& c, const std::filesystem::path& path, int* pages) {
  SurfacePtr pdf(cairo_pdf_surface_create(path.c_str(), kPageW, kPageH));
  if (cairo_surface_status(pdf.get()) != CAIRO_STATUS_SUCCESS)
    return Error(path.string(), "cannot create the PDF");
  cairo_pdf_surface_set_metadata(pdf.get(), CAIRO_PDF_METADATA_TITLE,
                                 ("Cutting report, log " + c.run->log.id).c_str());
  cairo_pdf_surface_set_metadata(pdf.get(), CAIRO_PDF_METADATA_CREATOR, "Sawyer");
  {
    ContextPtr cr = new_context(pdf.get());
    PdfWriter w(c, cr.get());
    if (!c.run->sawn()) {
      w.not_sawn_pages();
    } else {
      w.page_one();
      w.page_two();
      w.page_decisions();
      w.page_three();
    }
    *pages = w.pages();
    if (cairo_status(cr.get()) != CAIRO_STATUS_SUCCESS)
      return Error(path.string(), cairo_status_to_string(cairo_status(cr.get())));
  }
  cairo_surface_finish(pdf.get());
  if (cairo_surface_status(pdf.get()) != CAIRO_STATUS_SUCCESS)
    return Error(path.string(), cairo_status_to_string(cairo_surface_status(pdf.get())));
  return Status::Ok();
}

std::string report_html(const Content& c) {
  const RunFolder& r = *c.run;
  const SawingRecord& s = r.sawing;
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
    << "<title>Cutting report: log " << html_escape(r.log.id) << "</title>\n<style>\n"
    << "body{font-family:'DejaVu Sans',Arial,sans-serif;color:#22242a;margin:0;background:#f4f5f3}"
       "main{max-width:1100px;margin:0 auto;background:#fff;padding:28px 40px 40px;"
       "border-top:6px solid #1c5e4c}"
       "h1{font-size:26px;margin:8px 0 2px}h1 span{color:#1c5e4c;font-weight:normal;float:right}"
       "h2{color:#1c5e4c;font-size:18px;margin:30px 0 10px;border-bottom:1px solid #d0d2d4;"
       "padding-bottom:4px}.meta{color:#6b7079;font-size:13px}"
       ".cols{display:flex;gap:32px;flex-wrap:wrap}.cols>div{flex:1;min-width:300px}"
       "table.kv{border-collapse:collapse;font-size:14px}table.kv th{text-align:left;"
       "color:#6b7079;font-weight:normal;padding:3px 16px 3px 0;vertical-align:top}"
       "table.kv td{padding:3px 0}"
       ".tiles{display:grid;grid-template-columns:1fr 1fr;gap:10px;align-content:start}"
       ".tile{background:#f2f4f2;border-left:4px solid #1c5e4c;padding:10px 14px}"
       ".tile b{display:block;font-size:24px}.tile small{color:#6b7079}"
       "table.boards{border-collapse:collapse;width:100%;font-size:14px}"
       "table.boards th{color:#6b7079;font-weight:normal;text-align:left;border-bottom:1px solid "
       "#999;padding:4px 8px}table.boards td{border-bottom:1px solid #e3e4e6;padding:4px 8px;"
       "vertical-align:top}table.boards td.n{text-align:right;font-variant-numeric:tabular-nums}"
       "table.boards tr.total td{font-weight:bold;border-bottom:none}"
       "td.lim{color:#6b7079;font-size:12px}"
       "figure{margin:10px 0 22px}figure img{max-width:100%;display:block;border:1px solid "
       "#e3e4e6}figcaption{color:#6b7079;font-size:13px;margin-top:6px}"
       ".endview{display:flex;gap:24px;flex-wrap:wrap}.endview figure{flex:0 0 420px;margin:0}"
       ".endview .tiles{flex:1;min-width:280px}"
       ".board h3{font-size:15px;margin:18px 0 6px}.board h3 small{color:#6b7079;"
       "font-weight:normal;margin-left:12px}.board img{width:100%}"
       "footer{color:#6b7079;font-size:12px;margin-top:30px}\n"
    << web_file("board_zoom.css") << "</style></head><body><main>\n";
  h << "<h1>Cutting report <span>" << html_escape(r.log.id) << "</span></h1>\n"
    << "<div class=\"meta\">Run " << html_escape(or_none(r.run.date))
    << " · scan: " << html_escape(or_none(r.run.scan_description)) << " · Sawyer "
    << html_escape(or_none(r.run.sawyer_version)) << "</div>\n";
  for (const std::string& n : r.run.scan_notes)
    h << "<div class=\"meta\"><b>Scan: " << html_escape(n) << "</b></div>\n";
  if (const auto& qa = r.log.qa; qa && !qa->trusted) {
    h << "<div class=\"qa-failed\" style=\"color:#bf1a14;font-weight:bold;margin:8px 0\">NOT TO BE "
         "TRUSTED: the scan's QA verdict failed; "
      << (r.sawn() ? "the position rests on an uncertain model"
                   : "the log's figures rest on an uncertain model");
    for (const std::string& w : qa->warnings) h << "<br>QA: " << html_escape(w);
    h << "</div>\n";
  }
  if (!r.sawn()) {
    // A log that was not sawn: why, the diameters, the log, its top end and profile.
    const NotSawn& ns = *r.run.not_sawn;
    const std::vector<std::string> text = not_sawn_text(r);
    auto mm = [](double v) { return v >= 0 ? fmt("%.1f mm", v) : kNone; };
    h << "<h2 class=\"not-sawn\" style=\"color:#bf1a14\">NOT SAWN</h2><p><b>"
      << html_escape(text[0]) << "</b></p>\n<div class=\"tiles\" style=\"grid-template-columns:"
      << "repeat(4,1fr)\">";
    auto tile = [&](const std::string& v, const std::string& l) {
      h << "<div class=\"tile\"><b>" << html_escape(v) << "</b><small>" << html_escape(l)
        << "</small></div>";
    };
    tile(mm(ns.needed_diameter_mm), needed_label(ns));
    tile(mm(ns.usable_diameter_mm), "usable diameter of the log");
    tile(fmt("%.2f m", c.summary.length_mm * 1e-3), "length");
    tile(fmt("%.3f m³", c.summary.volume_m3), "volume");
    h << "</div>\n<div class=\"cols\"><div><h2>The log</h2>" << html_rows(not_sawn_log_rows(c))
      << "</div><div><h2>The top end</h2>";
    if (const Figure* f = c.figure("top_end.png")) h << html_figure(*f);
    h << "</div></div>\n<h2>The log along its length</h2>";
    if (const Figure* f = c.figure("log_profile.png")) h << html_figure(*f);
    h << "<h2>Notes</h2>";
    for (size_t i = 1; i < text.size(); ++i) h << "<p>" << html_escape(text[i]) << "</p>";
    h << "<p class=\"meta\">Sawyer: " << html_escape(or_none(ns.reason)) << ".</p>\n"
      << "<footer>"
      << html_escape(r.run.pattern_set.empty() ? "Pattern " + or_none(r.run.pattern)
                                               : "Pattern set " + r.run.pattern_set)
      << ", grading " << html_escape(or_none(r.run.grading))
      << ". Scan source: " << html_escape(or_none(r.run.scan_source))
      << ".</footer>\n</main>\n</body></html>\n";
    return h.str();
  }
  h << "<div class=\"cols\"><div><h2>The log</h2>" << html_rows(log_rows(c))
    << "</div><div><h2>The sawing</h2>" << html_rows(position_rows(c)) << "</div></div>\n";
  h << "<h2>End view</h2><div class=\"endview\">";
  if (const Figure* f = c.figure("end_view.png")) h << html_figure(*f);
  h << "<div class=\"tiles\">";
  auto tile = [&](const std::string& v, const std::string& l) {
    h << "<div class=\"tile\"><b>" << html_escape(v) << "</b><small>" << html_escape(l)
      << "</small></div>";
  };
  tile(money(s.chosen.value, s.currency), "value of the boards");
  tile(percent(gain(s, s.horns_down, s.gain_over_horns_down)), "gain over horns-down");
  tile(fmt("%.1f %%", 100 * c.volume_yield()), "volume yield");
  tile(std::to_string(s.boards.size()) + " boards", fmt("%.4f m³ sawn", c.boards_volume_m3));
  h << "</div></div>\n";
  h << "<h2>Boards at the chosen position</h2><table class=\"boards\"><tr><th>#</th>"
       "<th>board</th><th>size mm</th><th>length m</th><th>volume m³</th><th>grade</th><th>"
       "value "
    << html_escape(s.currency) << "</th><th>limited by</th></tr>\n";
  for (size_t i = 0; i < s.boards.size(); ++i) {
    const BoardRecord& b = s.boards[i];
    h << "<tr><td>" << i + 1 << "</td><td>" << html_escape(b.name) << "</td><td>" << board_size(b)
      << "</td><td class=\"n\">" << fmt("%.2f", b.length_mm() * 1e-3) << "</td><td class=\"n\">"
      << fmt("%.4f", b.volume_m3) << "</td><td><b>" << html_escape(b.grade)
      << "</b></td><td class=\"n\">" << fmt("%.2f", b.value) << "</td><td class=\"lim\">"
      << html_escape(b.limit_and_offcuts()) << "</td></tr>\n";
  }
  h << "<tr class=\"total\"><td></td><td>total</td><td>" << s.boards.size()
    << " boards</td><td></td><td class=\"n\">" << fmt("%.4f", c.boards_volume_m3)
    << "</td><td></td><td class=\"n\">" << fmt("%.2f", c.boards_value)
    << "</td><td class=\"lim\">volume yield " << fmt("%.1f %%", 100 * c.volume_yield()) << " of "
    << fmt("%.3f m³", c.summary.volume_m3) << " log volume</td></tr></table>\n";
  h << "<h2>The log and its boards</h2>";
  if (const Figure* f = c.figure("log_view.png")) h << html_figure(*f);
  h << "<h2>Board faces</h2><p class=\"meta\">Each board's four long sides rendered from the log "
       "model: the wide faces (face +, face −) and the edges, butt end on the left. Grey: wane "
       "(outside the log). Wheel or + / − to zoom, drag to pan, ⤢ for the whole window; the "
       "knots that decide a board's grade are ringed (red dead, green sound) and named on "
       "hover.</p>\n";
  for (size_t i = 0; i < c.board_figures.size(); ++i) {
    const BoardRecord& b = s.boards[i];
    h << "<div class=\"board\" id=\"board-" << i + 1 << "\"><h3>" << i + 1 << " "
      << html_escape(b.name) << "<small>" << board_size(b) << " mm · "
      << fmt("%.2f m", b.length_mm() * 1e-3) << " · grade " << html_escape(b.grade) << " · "
      << html_escape(money(b.value, s.currency)) << "</small></h3>";
    if (i < c.details.size() && !c.details[i].strip_jpeg.empty())
      h << html_zoom(c.details[i], i + 1, c.board_figures[i].title);
    else
      h << html_img(c.board_figures[i]);
    h << "</div>\n";
  }
  h << "<h2>Positioning</h2>";
  if (const Figure* f = c.figure("value_map.png")) h << html_figure(*f);
  h << "<h2>The log along its length</h2>";
  if (const Figure* f = c.figure("log_profile.png")) h << html_figure(*f);
  h << "<footer>" << html_escape(c.boards.note)
    << ". Scan source: " << html_escape(or_none(r.run.scan_source))
    << ".</footer>\n</main>\n<script>\n"
    << web_file("board_zoom.js") << "</script>\n</body></html>\n";
  return h.str();
}

std::string boards_csv(const Content& c) {
  std::ostringstream o;
  o << "board,name,thickness_mm,width_mm,length_mm,z_begin_mm,z_end_mm,volume_m3,grade,"
       "limited_by,price_per_m3,value,knots,dead_knots,max_wane_mm\n";
  const auto& boards = c.run->sawing.boards;
  for (size_t i = 0; i < boards.size(); ++i) {
    const BoardRecord& b = boards[i];
    char nums[256];
    std::snprintf(nums, sizeof nums, "%.1f,%.1f,%.1f,%.1f,%.1f,%.6f", b.thickness_mm, b.width_mm,
                  b.length_mm(), b.z_begin_mm, b.z_end_mm, b.volume_m3);
    char tail[128];
    std::snprintf(tail, sizeof tail, "%.2f,%.6f,%d,%d,%.1f", b.price_per_m3, b.value, b.knots,
                  b.dead_knots, b.max_wane_mm);
    o << i + 1 << "," << csv_field(b.name) << "," << nums << "," << csv_field(b.grade) << ","
      << csv_field(b.limited_by) << "," << tail << "\n";
  }
  return o.str();
}

std::string report_json(const Content& c, const ReportFiles& files) {
  using Json = nlohmann::ordered_json;
  const RunFolder& r = *c.run;
  const SawingRecord& s = r.sawing;
  const LogSummary& m = c.summary;
  auto pos = [](const PositionValue& p) {
    Json j = {{"rotation_deg", p.pos.rotation_deg},
              {"offset_x_mm", p.pos.offset_x_mm},
              {"offset_y_mm", p.pos.offset_y_mm},
              {"value", p.value}};
    if (p.has_smoothed) j["smoothed_value"] = p.smoothed_value;
    if (p.has_scanner) {
      Json ends = Json::array();
      for (const Vec3& e : p.centre_at_ends) ends.push_back({e.x, e.y, e.z});
      j["scanner"] = {{"turn_deg", p.turn_deg}, {"pattern_centre_at_ends_mm", ends}};
    }
    return j;
  };
  Json j;
  j["format"] = "sawyer-report/1";
  j["log"] = {{"id", r.log.id},
              {"species", !r.run.species.empty() ? r.run.species : r.log.species},
              {"length_mm", m.length_mm},
              {"butt_diameter_mm", m.butt_diameter_mm},
              {"top_diameter_mm", m.top_diameter_mm},
              {"mean_diameter_mm", m.mean_diameter_mm},
              {"volume_m3", m.volume_m3},
              {"taper_mm_per_m", m.taper_mm_per_m},
              {"knots", m.knot_count},
              {"dead_knots", m.dead_knots}};
  j["run"] = {{"scan_source", r.run.scan_source},
              {"scan_description", r.run.scan_description},
              {"scan_checksum", r.run.scan_checksum},
              {"date", r.run.date},
              {"sawyer_version", r.run.sawyer_version}};
  // A log that was not sawn: why, and no position or boards (boards.csv has its header only).
  if (!r.sawn()) {
    const NotSawn& ns = *r.run.not_sawn;
    j["outcome"] = "not sawn";
    j["not_sawn"] = {{"reason", ns.reason},
                     {"pattern", ns.pattern},
                     {"needed_diameter_mm", ns.needed_diameter_mm},
                     {"usable_diameter_mm", ns.usable_diameter_mm}};
    if (!ns.pattern_set.empty()) j["not_sawn"]["pattern_set"] = ns.pattern_set;
    if (r.log.qa) j["qa_trusted"] = r.log.qa->trusted;
    j["sawing"] = {{"pattern", r.run.pattern}, {"grading", r.run.grading}};
    if (!r.run.pattern_set.empty()) j["sawing"]["pattern_set"] = r.run.pattern_set;
    j["boards"] = Json::array();
    j["totals"] = {{"boards", 0},
                   {"volume_m3", 0.0},
                   {"value", 0.0},
                   {"log_volume_m3", m.volume_m3},
                   {"volume_yield", 0.0}};
    Json images = Json::array();
    for (const auto& p : files.images) images.push_back("images/" + p.filename().string());
    j["images"] = images;
    j["pages"] = files.pages;
    return j.dump(1) + "\n";
  }
  j["outcome"] = "sawn";
  j["sawing"] = {{"pattern", s.pattern},
                 {"grading", s.grading},
                 {"prices", s.prices},
                 {"currency", s.currency}};
  // The pattern chosen from a set and the next best, with the values they give.
  if (const auto& pc = s.pattern_choice) {
    j["sawing"]["pattern_choice"] = {
        {"set", pc->set},
        {"class", pc->class_label},
        {"chosen", sawing::pattern_candidate_value_json(*pc, pc->chosen)},
        {"next_best", sawing::pattern_candidate_value_json(*pc, pc->next_best)},
        {"line", sawing::pattern_choice_line(*pc, s.currency)}};
  }
  j["chosen"] = s.chosen_given ? "given" : "best";
  j["position"] = pos(s.chosen);
  j["horns_down"] = pos(s.horns_down);
  j["horns_up"] = pos(s.horns_up);
  j["gain_over_horns_down"] = gain(s, s.horns_down, s.gain_over_horns_down);
  j["gain_over_horns_up"] = gain(s, s.horns_up, s.gain_over_horns_up);
  j["gain_basis"] = s.chosen_given ? "value at the positions" : "expected values";
  if (s.claim && !s.chosen_given)
    j["claim"] = {{"gain_over_horns_down", s.claim->gain},
                  {"low", s.claim->low},
                  {"high", s.claim->high},
                  {"line", sawing::claim_text(*s.claim)}};
  Json boards = Json::array();
  for (size_t i = 0; i < s.boards.size(); ++i) {
    const BoardRecord& b = s.boards[i];
    Json limiting = Json::array();
    if (i < c.details.size())
      for (size_t k = 0; k < c.details[i].knots.size(); ++k) {
        const sawing::LimitingKnot& l = c.details[i].knots[k];
        limiting.push_back({{"knot", l.knot_id},
                            {"side", sawing::side_name(l.side)},
                            {"z_mm", l.z_mm},
                            {"along_mm", l.along_mm},
                            {"across_mm", l.across_mm},
                            {"width_mm", l.width_mm},
                            {"dead", l.dead},
                            {"rule", l.dead ? "dead knot" : "sound knot"},
                            {"grade", c.details[i].grade_above},
                            {"allowed_mm", l.allowed_mm},
                            {"text", c.details[i].texts[k]}});
        if (k < c.details[i].confidences.size())
          limiting.back()["confidence"] = c.details[i].confidences[k];
      }
    boards.push_back({{"name", b.name},
                      {"thickness_mm", b.thickness_mm},
                      {"width_mm", b.width_mm},
                      {"length_mm", b.length_mm()},
                      {"z_begin_mm", b.z_begin_mm},
                      {"z_end_mm", b.z_end_mm},
                      {"volume_m3", b.volume_m3},
                      {"grade", b.grade},
                      {"limited_by", b.limited_by},
                      {"price_per_m3", b.price_per_m3},
                      {"value", b.value},
                      {"knots", b.knots},
                      {"dead_knots", b.dead_knots},
                      {"limiting_knots", limiting}});
  }
  j["boards"] = boards;
  j["totals"] = {{"boards", s.boards.size()},
                 {"volume_m3", c.boards_volume_m3},
                 {"value", c.boards_value},
                 {"log_volume_m3", m.volume_m3},
                 {"volume_yield", c.volume_yield()}};
  j["boards_rebuilt"] = c.boards.rebuilt;
  j["boards_note"] = c.boards.note;
  Json images = Json::array();
  for (const auto& p : files.images) images.push_back("images/" + p.filename().string());
  j["images"] = images;
  j["pages"] = files.pages;
  return j.dump(1) + "\n";
}

}  // namespace sawyer::report
