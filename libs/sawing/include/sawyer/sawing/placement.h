// Where a sawn board lies in the scanner frame: the inverse of saw()'s pattern frame, for drawing
// boards over images of the log (the viewer, the cutting report). No rendering dependency.
//
//   SawResult r = saw(log, pattern, pos);
//   BoardBox p = board_placement(log, r.boards[0], pos);   // cx, cy, rotation, z0, z1
//   Vec2 corner = pattern_to_scanner(log, pos, u, v, z);         // any pattern point
#pragma once

#include <array>

#include "sawyer/core/vec.h"
#include "sawyer/model/board_box.h"
#include "sawyer/sawing/sawing.h"

namespace sawyer::sawing {

// The angle φ that turns the log at `pos`: a scanner point q (relative to the mean pith line)
// lands at Rot(φ)·q in the pattern frame (docs/sawing.md, Frames), rad.
double pattern_rotation(const SawLog& log, const LogPosition& pos);

// Scanner (x, y) of the pattern point (u, v) at height z, with the log at `pos`.
Vec2 pattern_to_scanner(const SawLog& log, const LogPosition& pos, double u, double v, double z);

// `pos` on `log` as the saw executes it (sawing.h, ScannerPosition): the turn, and the pattern
// centre's line in scanner x, y against scanner z (its point at the log's mid-length).
ScannerPosition scanner_position(const SawLog& log, const LogPosition& pos);

// The pattern centre of `pos` at the log's two ends (its first and last slab edges): scanner
// x, y, z, the points sawing.json and the summaries state.
std::array<Vec3, 2> pattern_centre_at_ends(const SawLog& log, const LogPosition& pos);

// A model height's scanner z, and back (LogModel::scanner_frame; the identity without one).
double to_scanner_z(const LogModel& model, double z);
double from_scanner_z(const LogModel& model, double scanner_z);

// The board `b` (sawn from `log` at `pos`) as a box in the scanner frame (board_box.h). The box
// follows the mean pith line: (cx, cy) is exact at mid-length, the board's ends are off by the
// line's slope × half the length (a few mm over 4 m).
BoardBox board_placement(const SawLog& log, const Board& b, const LogPosition& pos);

}  // namespace sawyer::sawing
