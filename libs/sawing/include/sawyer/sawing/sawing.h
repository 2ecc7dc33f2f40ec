// Virtual sawing: a log model at a position, cut by a pattern into boards, each with its length,
// volume, wane and the knots on its four long sides (docs/architecture.md section 9,
// docs/sawing.md).
//
// Frames (mm, degrees in the API): the pattern frame (u, v, z) has z along the log as in the log
// model, origin on the log's mean pith line (the least-squares line through the pith samples),
// v up. The log is turned about that line so that its horns point down at rotation 0:
//   horns direction h = the way the ends of the log's sweep point, from the arc fitted to the
//   centre line of its outline (what a 3-D log scanner sees; detect_bow). A log whose arc bows
//   less than kMinBowMm is straight for this purpose: its "horns-down" is the orientation it had
//   in the scanner (h = −y), a convention, and BowInfo::straight says so.
//   Rotation 0 puts h at −v (horns down, bow down); positive rotations turn the log
//   counter-clockwise seen from +z.
// The pattern is then shifted by the offset: a pattern point (u, v) lies at (u + x, v + y) in the
// turned log's cross-section.
//
// What the saw executes is the same cut in the scanner frame (ScannerPosition): the turn from
// the log's orientation in the CT and the pattern's centre line through the scanner. A SawLog
// built on a ScannerPosition cuts that physical position at LogPosition{}, on any model of the
// same log in the same scanner frame (a scanned model and the true one, say).
//
//   SawLog log(model);                      // precomputation, once per log
//   Pattern p = two_ex_pattern({});
//   if (Status s = check_pattern_fits(p, log.usable_diameter_mm(), model.id); !s) ...;
//   SawResult r = saw(log, p, {.rotation_deg = 0});
//   for (const Board& b : r.boards) ... b.volume_m3, b.knots ...
//
// Thread safety: SawLog is immutable after construction; saw() on one SawLog from many threads is
// safe. The SawLog keeps a pointer to the model, which must outlive it.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "sawyer/core/vec.h"
#include "sawyer/model/log_model.h"
#include "sawyer/sawing/pattern.h"

namespace sawyer::sawing {

// A bow smaller than this is no bow for horns-down: the direction of an arc whose sagitta is
// h moves by asin(e / h) under an error e of the centre line's bow, and 0.5 mm (a good scan's
// centre-line error) must move it by less than 5°: h ≥ 0.5 / sin 5° = 5.7 mm.
inline constexpr double kMinBowMm = 6.0;

// The log's bow (sweep), from the centre line of its outline: per stem sample the area centroid
// of the outline, and the parabola fitted to those centres along z by least squares (in x and y).
struct BowInfo {
  // Sagitta of the fitted arc over the log's length: how far its middle lies from the straight
  // line between its ends, mm. The horns point along the arc's curvature (from the middle
  // towards the chord).
  double height_mm = 0.0;
  // The largest distance of the centre line from the chord between its two end centres (the
  // mills' "sweep"), mm; for information: an S-shaped log has a chord bow but little arc.
  double chord_mm = 0.0;
  bool straight = true;              // height_mm < the threshold: horns-down is a convention
  Vec2 horns_direction{0, -1};       // unit, scanner (x, y); (0, −1) when straight
  double horns_azimuth = 1.5 * kPi;  // atan2 of horns_direction, rad in [0, 2π)
};
BowInfo detect_bow(const Stem& stem, double min_bow_mm = kMinBowMm);

// Area centroid of stem sample i's outline (scanner x, y); the pith where it has no outline.
Vec2 outline_centre(const Stem& stem, int i);

struct LogPosition {
  double rotation_deg = 0.0;  // about the mean pith line; 0 = horns down
  double offset_x_mm = 0.0;   // pattern shift in the turned cross-section
  double offset_y_mm = 0.0;
};

// A position as the log turner and the saw's set-works execute it, in the scanner frame of the
// CT (the model's x, y; heights in the scanner's z, LogModel::scanner_frame): the log turned by
// turn_deg from its orientation in the scanner, counter-clockwise in the scanner's x–y plane
// (a scanner point q, taken from the centre line, lands at Rot(turn)·q in the pattern frame),
// and the pattern's centre (pattern point (0, 0)) on the line centre + slope·(z − centre_z).
struct ScannerPosition {
  double turn_deg = 0.0;  // (−180, 180]
  Vec2 centre;            // pattern centre, scanner x, y at scanner height centre_z, mm
  Vec2 slope;             // d centre / d scanner z
  double centre_z = 0.0;  // scanner z, mm
  Vec2 centre_at(double scanner_z) const {
    return {centre.x + slope.x * (scanner_z - centre_z),
            centre.y + slope.y * (scanner_z - centre_z)};
  }
};

// A log prepared for sawing many times: mean pith line, bow, usable diameter and per-knot axis
// polylines relative to the mean pith line.
class SawLog {
 public:
  explicit SawLog(const LogModel& model, int knot_samples = 48);
  // The log set up at a physical position: its centre line is `at`'s pattern-centre line and
  // LogPosition{} turns it by at.turn_deg, so saw(log, pattern, {}) cuts the boards that
  // position cuts; LogPosition{r, x, y} is that position turned by r more and shifted by (x, y).
  // bow() is still the model's own.
  SawLog(const LogModel& model, const ScannerPosition& at, int knot_samples = 48);

  const LogModel& model() const { return *model_; }
  const BowInfo& bow() const { return bow_; }
  // The turn φ of LogPosition{} (rad): 270° − the horns' azimuth, or the ScannerPosition's turn.
  double turn_at_zero() const { return turn0_; }
  // Diameter of the largest circle about the pith inscribed in the top end (the end with the
  // smaller mean radius), under bark, mm: the median over the stem samples within 20 mm of that
  // end (a scan's very last slice is its least certain).
  double usable_diameter_mm() const { return usable_diameter_mm_; }
  // The centre line at model height z (scanner x, y): the mean pith line, or the pattern-centre
  // line of the ScannerPosition the log was built on.
  Vec2 line_at(double z) const {
    return {line_p_.x + line_s_.x * (z - line_z_), line_p_.y + line_s_.y * (z - line_z_)};
  }

  // Internal tables, read by saw().
  struct KnotPolyline {
    int index = 0;              // into model().knots
    std::vector<Vec3> q;        // axis point minus line_at(z), z kept; from the pith outwards
    std::vector<double> r;      // pith distance of each point
    double reach_mm = 0;        // max |q.xy| + half the largest diameter
    double zmin = 0, zmax = 0;  // z extent widened by half the largest diameter
    double half_dmax = 0;
  };
  const std::vector<KnotPolyline>& knots() const { return knots_; }
  // Distinct for every SawLog constructed in this process (copies keep it: they hold the same
  // tables); saw() keys its per-thread cache on it.
  std::uint64_t serial() const { return serial_; }
  // True when scanner point (x, y) lies inside the outline of stem sample i (linear in angle).
  bool inside(int slice, double x, double y) const;
  // Pith distance of (x, y) minus the outline radius in its direction at stem sample i (mm;
  // > 0 outside).
  double outside_by(int slice, double x, double y) const;
  // The same, and in *d (when not null) its derivative along (ex, ey) (per unit of that vector;
  // within one table entry, where the outline is smooth).
  double outside_by(int slice, double x, double y, double ex, double ey, double* d) const;
  // Squared smallest outline radius of stem sample i (a point nearer the pith is inside).
  double min_radius2(int slice) const { return rmin2_[slice]; }
  // line_at(model().stem.z_at(slice)), precomputed (the same numbers).
  Vec2 line_at_slice(int slice) const { return line_at_slice_[slice]; }
  // Conservative tests of a whole segment A→B (scanner x, y) at stem sample i, from radius
  // bounds per angular sector (no atan2): true only when every point of the segment is inside
  // the outline by more than `margin` mm (pith distance ≤ radius − margin), respectively
  // outside it by more than `margin`. False means "not sure".
  bool segment_surely_inside(int slice, Vec2 a, Vec2 b, double margin) const;
  bool segment_surely_outside(int slice, Vec2 a, Vec2 b, double margin) const;
  // Frees the tables saw() reads (~4 KB a stem sample: 3.3 MB for a 4 m log at 5 mm) once a
  // caller is done sawing; the centre line, bow, turn and usable diameter stay.
  // saw() must not be called on it again.
  void release_tables();

 private:
  const LogModel* model_;
  std::uint64_t serial_ = 0;
  Vec2 line_p_, line_s_;
  double line_z_ = 0;
  BowInfo bow_;
  double turn0_ = 0;
  void build(int knot_samples);  // the tables below, from line_* and the model
  double usable_diameter_mm_ = 0;
  std::vector<KnotPolyline> knots_;
  std::vector<double> rmin2_, rmax2_;  // squared radius range per stem sample
  std::vector<Vec2> line_at_slice_;    // mean pith line per stem sample
  // Radius bounds per stem sample and sector of the "diamond angle" (a cheap monotone stand-in
  // for the azimuth, no atan2): inside() answers from them when a point is clearly in or out and
  // only computes the outline radius in between; the answer is the same either way.
  // 64 sectors: on the through-and-through pattern 256 decided a few more certificates without
  // the exact test, but their tables (21 KB a stem sample) missed the cache more than that
  // saved (wall clock 5 % slower); the answers are the same either way.
  static constexpr int kSectors = 64;  // a power of two
  static constexpr int kLevels = 7;    // 2^(kLevels − 1) = kSectors
  // In single precision, rounded outwards (a bound only ever gets looser, so the answers stay
  // those of the exact test; issue 24: the tables are the sawing model's memory).
  std::vector<float> smin2_, smax2_;  // [slice × kSectors], squared, with a safety margin
  // The sector bounds, not squared (margin 1e-9 relative), over the 2^l sectors from j on
  // (cyclic): [(slice × kLevels + l) × kSectors + j]
  std::vector<float> run_min_, run_max_;
  // The sectors a segment (relative to the pith) sweeps: first sector and count; false when it
  // passes too close to the pith to tell.
  static bool sector_span(double ax, double ay, double bx, double by, int* first, int* count);
  // The outline radius in the direction of (dx, dy) ≠ 0 from the pith, linear in angle between
  // the table entries `rad` (na of them): inside() and outside_by()'s exact look-up.
  // *slope, when given: dR/dω there (mm per radian).
  double radius_towards(const double* rad, int na, double dx, double dy,
                        double* slope = nullptr) const;
  // Without atan2 where every stem sample has na_ angles (na_ ≥ kMinSeriesAngles): the table
  // entry from the diamond angle and the entries' unit directions dir_ (na_ + 1 of them, the
  // last = the first), the angle within the entry from its tangent by a series.
  static constexpr int kMinSeriesAngles = 90;
  static constexpr int kDiamondBins = 1024;
  int na_ = 0;
  std::vector<Vec2> dir_;
  std::vector<int> bin_entry_;  // [kDiamondBins]: the entry at or before the bin's start
};

enum class Side { kFacePlus, kFaceMinus, kEdgePlus, kEdgeMinus };  // + / −: along the axis
const char* side_name(Side s);
enum class KnotKind { kFace, kEdge, kArris };  // arris: the knot's section reaches a corner
const char* knot_kind_name(KnotKind k);

// A knot where its axis crosses the plane of one long side of a board.
struct KnotOnSide {
  int knot = -1;  // index into LogModel::knots
  int knot_id = 0;
  Side side = Side::kFacePlus;
  KnotKind kind = KnotKind::kFace;
  double z_mm = 0;         // height of the crossing (log frame)
  double along_mm = 0;     // z_mm − board z_begin
  double across_mm = 0;    // from the side's centre line, in the pattern frame (+ = +u or +v)
  double r_mm = 0;         // pith distance of the crossing
  double diameter_mm = 0;  // knot diameter there, d(r)
  double minor_mm = 0;     // ellipse axes of the section: minor = d(r),
  double major_mm = 0;     //   major = d(r) / cos(angle between axis and side normal), ≤ 20·d
  double width_mm = 0;     // extent across the side, clipped to the side (what grading measures)
  double length_mm = 0;    // extent along the board
  double angle_deg = 0;    // between the knot axis and the side plane (90 = perpendicular)
  bool dead = false;       // r > r_dead
};

struct SideWane {
  double max_mm = 0;     // largest wane across this side over the board's length
  double length_mm = 0;  // length of board along which this side has wane
};

// One stem sample's share of a board: its z range within the board and the wane there, kept so
// that the board can be cross-cut shorter afterwards (trim_to_value, value.h).
struct BoardSlab {
  double z0 = 0, z1 = 0;        // log frame, within the board's sawn length
  std::array<float, 4> wane{};  // across each Side, mm
  float missing_mm2 = 0;        // cross-section area missing to wane, mm²
};

struct Board {
  int spec = -1;  // index into Pattern::boards
  std::string name;
  double thickness_mm = 0, width_mm = 0;  // nominal (width after edging)
  ThicknessAxis thickness_axis = ThicknessAxis::kU;
  double u_mm = 0, v_mm = 0;      // centre in the pattern frame
  double z_begin = 0, z_end = 0;  // trimmed, log frame
  double length_mm() const { return z_end - z_begin; }
  double box_volume_m3 = 0;       // thickness × width × length
  double volume_m3 = 0;           // box minus wane (corner triangles per stem sample)
  std::array<SideWane, 4> wane;   // by Side
  std::vector<KnotOnSide> knots;  // by Side, then z
  std::vector<int> hidden_knots;  // knot indices inside the board, on no side
  std::vector<BoardSlab> slabs;   // per stem sample, over the sawn length
  // The length saw() left before any cross-cut to value (trim_to_value); z_begin / z_end are
  // the board as sold.
  double sawn_begin = 0, sawn_end = 0;
  bool trimmed() const { return z_begin > sawn_begin + 1e-9 || z_end < sawn_end - 1e-9; }
};

struct DroppedBoard {
  int spec = -1;
  std::string reason;
};

struct SawResult {
  std::vector<Board> boards;
  std::vector<DroppedBoard> dropped;
  double volume_m3 = 0;  // sum over boards
};

// Saws the log at `pos`. Each board is a box along z in the pattern frame; it is trimmed to the
// longest run of stem samples where its wane keeps to pattern.wane (then to the length step,
// centred in the run), edged boards take the standard width giving the most volume, and boards
// shorter than min_length_mm are dropped. Does not check the fit (check_pattern_fits).
SawResult saw(const SawLog& log, const Pattern& pattern, const LogPosition& pos);

// ---- inline definitions (saw()'s innermost tests; defined here so that they inline into it) ----

namespace detail {
// Diamond angle of (x, y) ≠ 0 in [0, 4): same quadrant and order as the azimuth.
inline double diamond(double x, double y) {
  const double ax = std::abs(x), ay = std::abs(y);
  if (y >= 0) return x >= 0 ? ay / (ax + ay) : 1 + ax / (ax + ay);
  return x < 0 ? 2 + ay / (ax + ay) : 3 + ax / (ax + ay);
}
}  // namespace detail

// The entry i0 = floor(ω·na/2π) below the azimuth ω of (dx, dy) and the fraction t of the way
// to the next one, R = (1 − t)·rad[i0] + t·rad[i0 + 1]. With atan2: ω itself. Without: i0 from
// the diamond angle's bin (within 0.002 rad of the azimuth, far less than an entry's width, so
// at most a step either way, by the sign of the cross product with the entries' directions),
// and ω − ω(i0) = atan(x) for x = cross / dot with direction i0: 0 ≤ x ≤ tan(2π/na) ≤ 0.07, so
// the series to x^13 is exact to a relative 1e-18 (the same R as with atan2 to within rounding).
inline double SawLog::radius_towards(const double* rad, int na, double dx, double dy,
                                     double* slope) const {
  if (na == na_ && (dx != 0 || dy != 0)) {
    const int bin =
        std::min(static_cast<int>(detail::diamond(dx, dy) * (kDiamondBins / 4)), kDiamondBins - 1);
    int i0 = bin_entry_[bin];
    const Vec2* d = dir_.data();
    for (int step = 0; step < 4; ++step) {
      if (d[i0].x * dy - d[i0].y * dx < 0) {  // before entry i0
        i0 = i0 == 0 ? na - 1 : i0 - 1;
      } else if (d[i0 + 1].x * dy - d[i0 + 1].y * dx >= 0) {  // at or past entry i0 + 1
        i0 = i0 + 1 == na ? 0 : i0 + 1;
      } else {
        const double x = (d[i0].x * dy - d[i0].y * dx) / (d[i0].x * dx + d[i0].y * dy);
        const double x2 = x * x;
        const double a =
            x *
            (1 + x2 * (-1.0 / 3 +
                       x2 * (1.0 / 5 + x2 * (-1.0 / 7 + x2 * (1.0 / 9 + x2 * (-1.0 / 11 +
                                                                              x2 * (1.0 / 13)))))));
        const double t = std::min(a * (na / kTwoPi), 1.0);
        const int i1 = i0 + 1 == na ? 0 : i0 + 1;
        if (slope) *slope = (rad[i1] - rad[i0]) * (na / kTwoPi);
        return (1 - t) * rad[i0] + t * rad[i1];
      }
    }
  }
  double w = std::atan2(dy, dx);
  if (w < 0) w += kTwoPi;
  const double f = w * na / kTwoPi;
  int i0 = static_cast<int>(f);
  const double t = f - i0;
  if (i0 >= na) i0 -= na;  // w rounded up to 2π
  const int i1 = i0 + 1 == na ? 0 : i0 + 1;
  if (slope) *slope = (rad[i1] - rad[i0]) * (na / kTwoPi);
  return (1 - t) * rad[i0] + t * rad[i1];
}

inline double SawLog::outside_by(int slice, double x, double y) const {
  return outside_by(slice, x, y, 0, 0, nullptr);
}

inline double SawLog::outside_by(int slice, double x, double y, double ex, double ey,
                                 double* d) const {
  const Stem& stem = model_->stem;
  const Vec2 c = stem.pith[slice];
  const double dx = x - c.x, dy = y - c.y;
  const std::vector<double>& rad = stem.radius[slice];
  const int na = static_cast<int>(rad.size());
  const double r = std::sqrt(dx * dx + dy * dy);
  if (na == 0 || !(r > 0)) {  // no outline; at the pith (atan2(0, 0) = 0: the first entry)
    if (d) *d = r > 0 ? (dx * ex + dy * ey) / r : 0.0;
    return na == 0 ? r : r - rad[0];
  }
  if (!d) return r - radius_towards(rad.data(), na, dx, dy);
  double slope = 0;
  const double R = radius_towards(rad.data(), na, dx, dy, &slope);
  // d|p| = p·e / |p|, dω = p × e / |p|².
  *d = (dx * ex + dy * ey) / r - slope * (dx * ey - dy * ex) / (r * r);
  return r - R;
}

inline bool SawLog::inside(int slice, double x, double y) const {
  const Stem& stem = model_->stem;
  const Vec2 c = stem.pith[slice];
  const double dx = x - c.x, dy = y - c.y;
  const double r2 = dx * dx + dy * dy;
  // Fast answers from the slice's radius range before the angle lookup.
  if (r2 <= rmin2_[slice]) return true;
  if (r2 > rmax2_[slice]) return false;
  const std::vector<double>& rad = stem.radius[slice];
  const int na = static_cast<int>(rad.size());
  if (na == 0) return false;
  if (r2 > 0) {
    const int j =
        std::min(static_cast<int>(detail::diamond(dx, dy) * (kSectors / 4)), kSectors - 1);
    const size_t at = static_cast<size_t>(slice) * kSectors + j;
    if (r2 <= smin2_[at]) return true;
    if (r2 > smax2_[at]) return false;
  }
  const double R = radius_towards(rad.data(), na, dx, dy);
  return r2 <= R * R;
}

inline bool SawLog::sector_span(double ax, double ay, double bx, double by, int* first,
                                int* count) {
  const double cr = ax * by - ay * bx;  // > 0: A → B counter-clockwise
  const double la2 = ax * ax + ay * ay, lb2 = bx * bx + by * by;
  const double dot = ax * bx + ay * by;
  // The sweep of a segment not through the pith is below π; refuse near-π sweeps (sin < 1e-3
  // with the ends on opposite sides) and ends at the pith.
  if (!(la2 > 1e-12 && lb2 > 1e-12)) return false;
  if (dot < 0 && cr * cr < 1e-6 * la2 * lb2) return false;
  const int q = kSectors / 4;
  int ja = std::min(static_cast<int>(detail::diamond(ax, ay) * q), kSectors - 1);
  int jb = std::min(static_cast<int>(detail::diamond(bx, by) * q), kSectors - 1);
  if (cr < 0) std::swap(ja, jb);
  *first = ja;
  *count = (jb - ja + kSectors) % kSectors + 1;
  return true;
}

inline bool SawLog::segment_surely_inside(int slice, Vec2 a, Vec2 b, double margin) const {
  const Vec2 c = model_->stem.pith[slice];
  const double ax = a.x - c.x, ay = a.y - c.y, bx = b.x - c.x, by = b.y - c.y;
  // The farthest point of a segment from the pith is an end.
  const double r = std::sqrt(std::max(ax * ax + ay * ay, bx * bx + by * by)) + margin;
  if (r * r <= rmin2_[slice] * (1 - 1e-9)) return true;
  if (r * r > rmax2_[slice]) return false;
  int j0, cnt;
  if (!sector_span(ax, ay, bx, by, &j0, &cnt)) return false;
  const int l = std::bit_width(static_cast<unsigned>(cnt)) - 1;
  const float* lo = &run_min_[(static_cast<size_t>(slice) * kLevels + l) * kSectors];
  return r <= lo[j0] && r <= lo[(j0 + cnt - (1 << l)) & (kSectors - 1)];
}

inline bool SawLog::segment_surely_outside(int slice, Vec2 a, Vec2 b, double margin) const {
  const Vec2 c = model_->stem.pith[slice];
  const double ax = a.x - c.x, ay = a.y - c.y, bx = b.x - c.x, by = b.y - c.y;
  // Nearest point of the segment to the pith.
  const double ex = bx - ax, ey = by - ay, ee = ex * ex + ey * ey;
  const double t = ee > 0 ? std::clamp(-(ax * ex + ay * ey) / ee, 0.0, 1.0) : 0.0;
  const double nx = ax + t * ex, ny = ay + t * ey;
  const double r = std::sqrt(nx * nx + ny * ny) - margin;
  if (r * r > rmax2_[slice] * (1 + 1e-9) && r > 0) return true;
  if (!(r > 0) || r * r <= rmin2_[slice]) return false;
  int j0, cnt;
  if (!sector_span(ax, ay, bx, by, &j0, &cnt)) return false;
  const int l = std::bit_width(static_cast<unsigned>(cnt)) - 1;
  const float* hi = &run_max_[(static_cast<size_t>(slice) * kLevels + l) * kSectors];
  return r > hi[j0] && r > hi[(j0 + cnt - (1 << l)) & (kSectors - 1)];
}

}  // namespace sawyer::sawing
