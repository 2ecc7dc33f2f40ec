// The report's figures: wood images from the knotted-wood renderer with cairo overlays, and the
// plots drawn with cairo alone. Each returns an opaque raster surface (canvas.h).
#pragma once

#include <string>
#include <vector>

#include "canvas.h"
#include "sawyer/render/wood_renderer.h"
#include "sawyer/report/run_folder.h"
#include "sawyer/sawing/placement.h"
#include "sawyer/sawing/sawing.h"

namespace sawyer::report {

// The boards at the chosen position, as libs/sawing describes them (centre, size, axis, z).
struct BoardSet {
  std::vector<sawing::Board> boards;  // parallel to RunFolder::sawing.boards
  bool rebuilt = false;               // sawn again with the pattern, names checked
  std::string note;                   // why not, when not
};

// Saws the log again at the chosen position with the pattern named in run.json (or the bundled
// pattern whose name sawing.json gives) and checks the boards' names, widths and lengths against
// sawing.json; a board that sawing.json lists cross-cut to value (shorter, within its sawn
// length) is cut to that piece (sawing::cut_board: its knots and wane). If the pattern cannot be
// found or the boards differ, takes the boards' places from sawing.json (without their knots).
BoardSet place_boards(const RunFolder& run, const sawing::SawLog& log);

// "Nice" axis tick positions covering [lo, hi] (steps of 1, 2, 2.5 or 5 times a power of ten),
// about `n` of them.
std::vector<double> ticks(double lo, double hi, int n);

// The cross-section at height z as the log lies on the saw (turned to the chosen position, seen
// from the top end, the pattern frame's u to the right and v up), the boards outlined and
// numbered, every knot's axis projected onto the section (sound part green, dead part red).
Result<SurfacePtr> end_view(render::WoodRenderer& r, const RunFolder& run,
                            const sawing::SawLog& log, const BoardSet& boards, double z, int px);

// The log in 3D (render::render_cut_view): the boards at the chosen position as wood blocks
// inside the log drawn translucent over its bark, the knots as cones (green sound, red dead), seen
// from above the top end; cropped to its content.
Result<SurfacePtr> log_view(render::WoodRenderer& r, const sawing::SawLog& log,
                            const RunFolder& run, const BoardSet& boards, int w, int h);

// The optimiser's expected value over rotation × x offset (at the chosen y offset), with the
// chosen, best and horns-down positions marked and a colour bar in the currency. Empty surface
// (nullptr) when sawing.json has no grid.
SurfacePtr value_map(const SawingRecord& s, int w);

// The pith track (x, y) and the diameter (equal-area, with the min–max band) along the log, the
// boards' length shaded.
SurfacePtr log_profile(const LogModel& log, const BoardSet& boards, int w);

// For a log that was not sawn (RunInfo::not_sawn): its top end (the end with the smaller mean
// radius) as scanned, seen from the top end in the scanner's x, y, with the circle of its usable
// diameter about the pith line (green) and the circle the pattern needs (red, dashed), and the
// pattern's boards about the same centre at rotation 0 when `pattern` is given. A square of px.
SurfacePtr top_end_fit(const LogModel& log, const NotSawn& why, const sawing::Pattern* pattern,
                       int px);

}  // namespace sawyer::report
