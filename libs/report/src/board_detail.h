// The boards in detail: each board's four long faces rendered once at the detail resolution, and
// what the report makes of them: the labelled board figure (PNG, PDF), the HTML page's zoomable
// strip, the knots that decide the grade marked on the faces, and the PDF's crops around them.
#pragma once

#include <string>
#include <vector>

#include "canvas.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/sawing.h"

namespace sawyer::report {

struct BoardFaces {
  struct Row {
    std::string label;       // "face +", "face −", "edge +", "edge −"
    render::PlaneRect rect;  // the face in the log frame: image x along rect.u, image y down
                             // is −rect.v (top row at rect.v's far edge)
    SurfacePtr image;        // the face, length × across at px_per_mm
  };
  std::vector<Row> rows;  // face +, face −, edge +, edge −: in sawing::Side's order
  double px_per_mm = 0;   // of the row images
  double length_mm = 0;
};

// Renders the four long faces of `board` (as sawing::board_placement puts it at `pos`) at
// `px_per_cm`, lowered where needed so that no image side passes the renderer's limit.
Result<BoardFaces> render_faces(render::WoodRenderer& r, const sawing::SawLog& log,
                                const sawing::LogPosition& pos, const sawing::Board& board,
                                double px_per_cm, int supersample);

// A knot marked on the faces: row and pixel position in that row's image (BoardFaces::px_per_mm).
struct FaceMark {
  int row = 0;
  double x_px = 0, y_px = 0, radius_px = 0;
  double width_mm = 0;  // across the side, as graded
  bool dead = false;
  int knot_id = 0;
  std::string text;  // the knot's line (texts[i] of limiting_marks)
};

// The limiting knots of a board located on its faces (a knot whose crossing lies on no face, by
// more than a few millimetres, is left out); texts[i] is knots[i]'s line.
std::vector<FaceMark> limiting_marks(const BoardFaces& faces, const LogModel& log,
                                     const sawing::Board& board,
                                     const std::vector<sawing::LimitingKnot>& knots,
                                     const std::vector<std::string>& texts);

// Where the row images lie in a composed strip: row pixel (x, y) is strip pixel
// (x0 + scale·x, row_y[row] + scale·y).
struct StripLayout {
  double scale = 1;
  int x0 = 0;
  std::vector<int> row_y, row_h;  // top and height of each row
  int length_px = 0;              // of the rows
  int width = 0, height = 0;
};

// The faces stacked top to bottom with their labels and a scale in metres from the butt end, at
// `px_per_cm` (scaled from the rendered rows), text and lines `ui` times their size at 3 px/cm;
// `marks` drawn as rings (dead red, sound green) with their knot ids when `draw_marks`.
SurfacePtr compose_faces(const BoardFaces& faces, double px_per_cm, double ui,
                         const std::vector<FaceMark>& marks, bool draw_marks,
                         StripLayout* layout = nullptr);

// A crop of a composed strip (compose_faces, `layout`) around a mark: all four faces over
// `half_mm` either side of it along the board (clipped to the board), with its ring drawn.
SurfacePtr crop_around(cairo_surface_t* strip, const StripLayout& layout, double px_per_mm,
                       const FaceMark& mark, double half_mm);

}  // namespace sawyer::report
