// The report's documents from its content: the PDF (cairo), the self-contained HTML page,
// boards.csv and report.json (formats in docs/report.md).
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "board_detail.h"
#include "canvas.h"
#include "figures.h"
#include "sawyer/model/log_summary.h"
#include "sawyer/report/report.h"

namespace sawyer::report {

struct Figure {
  std::string file;     // under images/, e.g. "end_view.png"
  std::string title;    // short, e.g. "End view"
  std::string caption;  // a sentence or two for the reader
  SurfacePtr surface;
  std::string png;  // encoded
};

// One board in detail: the knots that decide its grade, its faces at the detail resolution for
// the HTML page's zoom, and the PDF's crops around the knots.
struct BoardDetail {
  std::vector<sawing::LimitingKnot> knots;  // limiting_knots(), largest excess first
  std::vector<std::string> texts;           // describe() of each (with its confidence, scans)
  // Per knot: the chance it is a knot at all (Knot::confidence), for a log from a scan; else
  // empty.
  std::vector<double> confidences;
  std::string grade_above;      // the grade whose rules they break
  std::vector<FaceMark> marks;  // those located on the faces
  std::string note;             // why no knots are listed, when none are
  std::string strip_file;       // under images/, e.g. "board_01_faces.jpg"
  std::string strip_jpeg;       // the faces at detail_px_per_cm, labelled
  StripLayout strip;            // where the rows lie in it
  double detail_px_per_cm = 0;
  std::vector<Figure> crops;  // around each mark, as marks (the PDF's page of decisions)
};

struct Content {
  const RunFolder* run = nullptr;
  LogSummary summary;
  BoardSet boards;
  double end_view_z = 0;
  std::vector<Figure> figures;        // end view, 3D view, value map (if any), profile
  std::vector<Figure> board_figures;  // one per board, as run->sawing.boards
  std::vector<BoardDetail> details;   // one per board, as run->sawing.boards
  std::string grading_note;           // why no board has its limiting knots, when none has
  double boards_volume_m3 = 0, boards_value = 0;
  double volume_yield() const {
    return summary.volume_m3 > 0 ? boards_volume_m3 / summary.volume_m3 : 0.0;
  }
  const Figure* figure(const std::string& file) const;
};

using Rows = std::vector<std::pair<std::string, std::string>>;
// Label/value rows of the header: the log, and the chosen position and its value.
Rows log_rows(const Content& c);
Rows position_rows(const Content& c);

// Writes the PDF to `path` (A4 pages); *pages gets the page count.
Status write_pdf(const Content& c, const std::filesystem::path& path, int* pages);
std::string report_html(const Content& c);
std::string boards_csv(const Content& c);
std::string report_json(const Content& c, const ReportFiles& files);

}  // namespace sawyer::report
