// The log model: what the CT pipeline produces, the renderer draws, the sawing optimiser cuts
// and the phantom turns back into CT (docs/architecture.md section 4).
//
// Frames and units: millimetres and radians. x, y are the CT scanner's x and y (mm, exactly as
// the CT file places its pixels) in the slice plane; z runs along the log from the first slice
// (docs/formats.md, "The scanner frame"); ScannerFrame maps z back to the scanner's z (and, for a
// coronal or sagittal scan, whose x and y stay in the slices' own axes, every point). Azimuth ω =
// atan2(y − pith_y, x − pith_x) in [0, 2π), counter-clockwise from +x seen from +z. Pith distance r
// = horizontal distance from the pith at that height.
//
//   LogModel log = ...;
//   double R = log.stem.radius_at(omega, z);           // outer radius under bark, mm
//   Vec3 p = log.knots[0].axis_point(50.0, log.stem);  // knot axis 50 mm from the pith
//   Material m = log.material_at({x, y, z});           // air / wood / sound or dead knot
//
// Thread safety: all const member functions are safe to call concurrently.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/vec.h"

namespace sawyer {

// The stem, sampled along z at a fixed step. Sample i stands for the slab of thickness dz_mm
// centred on z_i = z0_mm + i·dz_mm, so the log spans [z0 − dz/2, z0 + (n − ½)·dz] and its
// length is n·dz.
struct Stem {
  double z0_mm = 0.0;      // height of sample 0
  double dz_mm = 10.0;     // sample step along z (> 0)
  int n_angles = 360;      // angular samples per height; angle k is at ω = 2πk / n_angles
  std::vector<Vec2> pith;  // pith (x, y) per height, mm
  std::vector<std::vector<double>> radius;  // outer radius under bark [height][angle], mm
  // Optional heartwood radius [height][angle], mm; empty when unknown.
  std::vector<std::vector<double>> heartwood;
  // Optional bark thickness per height, mm; empty when unknown.
  std::vector<double> bark_mm;
  // Optional bark thickness at every angle [height][angle], mm, where the scan measured it
  // around the log (a butt log's bark runs 2-10 mm round one section); bark_mm is then each
  // row's median. Empty when only bark_mm is known.
  std::vector<std::vector<double>> bark;

  int slice_count() const { return static_cast<int>(pith.size()); }
  double z_at(int i) const { return z0_mm + i * dz_mm; }
  double length_mm() const { return slice_count() * dz_mm; }
  double z_begin() const { return z0_mm - 0.5 * dz_mm; }
  double z_end() const { return z0_mm + (slice_count() - 0.5) * dz_mm; }
  bool has_heartwood() const { return !heartwood.empty(); }

  // Pith at height z: cubic (Catmull-Rom) interpolation between samples, clamped at the ends.
  Vec2 pith_at(double z) const;
  // d(pith)/dz at height z (mm per mm), consistent with pith_at.
  Vec2 pith_slope_at(double z) const;
  // Outer radius at azimuth ω and height z: bicubic Catmull-Rom, periodic in ω, clamped in z.
  double radius_at(double omega, double z) const;
  // Heartwood radius, same interpolation; 0 when the stem has no heartwood.
  double heartwood_at(double omega, double z) const;
  // Mean outer radius of sample i.
  double mean_radius(int i) const;
  // Cross-section area of sample i (mm²), exact for the piecewise-linear polar outline.
  double area(int i) const;

  // Pith distance and azimuth of a point, measured from the pith at the point's height.
  void polar(const Vec3& p, double* r, double* omega) const;
  // True when p lies inside the outer surface and within the log's z extent.
  bool contains(const Vec3& p) const;
};

// The diameter profile of a knot: d(r) = d_dead · (r / r_dead)^exponent for r ≤ r_dead (the
// knot thickens while it lives), and d_dead from r_dead to r_end (a dead knot stops growing).
struct KnotDiameter {
  double d_dead = 0.0;    // diameter at the sound/dead border, mm
  double exponent = 1.0;  // growth exponent p (> 0)
};

// One knot, the knot formula of docs/architecture.md section 4, in the stem's frame:
//   axis height   z(r) = z0 + a·√r + b·r
//   axis azimuth  ω(r) = omega0 + twist·ln(r)        (r in mm, ln taken at max(r, 1))
// The knot starts at the pith (r = 0) and ends at r_end; it is sound (intergrown) for
// r ≤ r_dead and dead beyond. A knot with r_dead ≥ r_end is sound over its whole length.
struct Knot {
  int id = 0;
  double z0 = 0.0;      // mm
  double a = 0.0;       // mm / √mm
  double b = 0.0;       // mm / mm
  double omega0 = 0.0;  // rad
  double twist = 0.0;   // rad per ln(mm)
  double r_dead = 0.0;  // mm
  double r_end = 0.0;   // mm
  KnotDiameter diameter;
  // Fit quality from the CT pipeline; 0 for knots that were not fitted.
  double fit_rms_mm = 0.0;
  int support = 0;  // supporting voxels or slices

  double height_at(double r) const;
  double azimuth_at(double r) const;
  double diameter_at(double r) const;
  bool dead_at(double r) const { return r > r_dead; }
  bool has_dead_part() const { return r_dead < r_end; }
  // Largest diameter over the knot's length.
  double max_diameter() const { return diameter_at(std::min(r_dead, r_end)); }
  // The chance (0..1) that a knot the CT pipeline fitted is a real knot and not something else
  // taken for one (a streak, a pocket, a ring fragment), from its fit (axis RMS, support, length,
  // diameter); 1 for a knot that was not fitted (support 0: a measured or generated log). Its
  // figures are those of Sawyer's own knot fit: use it for the knots of a scan (LogModel::qa
  // set), not for knots imported with other fit figures (published maps). See log_model.cpp
  // for where the figures come from.
  double confidence() const;

  // Axis point at pith distance r (mm), using the stem's pith at the axis height.
  Vec3 axis_point(double r, const Stem& stem) const;
  // Unit tangent of the axis at pith distance r, pointing away from the pith.
  Vec3 axis_direction(double r, const Stem& stem) const;
  // Lowest and highest z the knot occupies (axis range widened by half the largest diameter).
  void z_range(double* zmin, double* zmax) const;
};

enum class Material { kAir, kWood, kSoundKnot, kDeadKnot };

struct MaterialSample {
  Material material = Material::kAir;
  int knot = -1;           // index into LogModel::knots when inside a knot
  bool heartwood = false;  // inside the heartwood radius (when the stem has one)
};

// Where the model lies in the CT scanner (log.json "scanner_frame", optional).
//
// Axial scans (slices across the scanner's z; slice_dir (0, 0, ±1)): the model's x and y are the
// scanner's; its z starts at the first slice and runs along the slices, so the scanner's z of a
// model height z is z0_mm + z_dir·z. The file's own origin and row/column directions are kept as
// the CT file gave them, for the record (the scan mirrors or transposes slices whose rows do not
// run along +x; docs/ct_input.md).
//
// Coronal and sagittal scans (slices across the scanner's y or x: the log lay along that axis)
// are not turned, since no turn of the slices puts x and y on the scanner's x and y: the model
// stays in the slices' own axes, x = column·pixel and y = row·pixel from pixel (0, 0) and z along
// slice_dir from the first slice, so that model point p lies at origin_mm + p.x·row_dir +
// p.y·col_dir + p.z·slice_dir (to_scanner()). z0_mm and z_dir then describe the scanner axis
// slice_dir runs along (the first slice's coordinate on it and the direction z grows in).
struct ScannerFrame {
  Vec3 origin_mm;         // scanner position of the centre of pixel (0, 0) of the first slice
  Vec3 row_dir{1, 0, 0};  // the file's direction along a row (increasing column)
  Vec3 col_dir{0, 1, 0};  // the file's direction down a column (increasing row)
  // The scanner direction in which the model's z grows (the slices' normal, signed as they are
  // ordered); (0, 0, z_dir) for an axial scan.
  Vec3 slice_dir{0, 0, 1};
  double z0_mm = 0.0;  // scanner coordinate of the model's z = 0 (the first slice) on slice_axis()
  double z_dir = 1.0;  // +1: z grows with that scanner coordinate; -1: against it

  // The scanner axis slice_dir runs along (0 = x, 1 = y, 2 = z): its largest component.
  int slice_axis() const {
    const double ax = std::abs(slice_dir.x), ay = std::abs(slice_dir.y);
    const double az = std::abs(slice_dir.z);
    return az >= ax && az >= ay ? 2 : ay >= ax ? 1 : 0;
  }
  // Slices across the scanner's z: the model's x and y are the scanner's.
  bool axial() const { return slice_axis() == 2; }
  // The scanner coordinate on slice_axis() of model height z (axial: the scanner's z).
  double scanner_z(double z) const { return z0_mm + z_dir * z; }
  // The scanner position of model point p.
  Vec3 to_scanner(const Vec3& p) const {
    if (axial()) return {p.x, p.y, scanner_z(p.z)};
    return origin_mm + p.x * row_dir + p.y * col_dir + p.z * slice_dir;
  }
};

// The scan's own verdict on what it measured (log.json "qa", optional; made by
// ct_pipeline/scan's assess_scan, docs/scan.md "QA verdict"). A model that did not come from a
// scan has none.
struct ScanQa {
  struct Stage {
    std::string name;                // "levels", "pith", "outline", "heartwood", "knots"
    bool ok = true;                  // false: this stage's result is not to be trusted
    double confidence = 1.0;         // 0..1
    std::vector<std::string> notes;  // what was seen, one line each
  };
  bool trusted = true;  // false: at least one stage failed its checks
  // "fine" or "coarse" (the QA's scan class: pixels and slice spacing, docs/scan.md); empty in
  // older files. The scan's knot errors differ by class (sawing/uncertainty.h).
  std::string scan_class;
  std::vector<std::string> warnings;  // the lines a reader must see first, worst first
  std::vector<Stage> stages;
};

struct LogModel {
  std::string id;       // e.g. "gran1_spruce"
  std::string species;  // "spruce", "pine", ... free text
  std::string source;   // provenance: where the model came from
  Stem stem;
  std::vector<Knot> knots;
  // Absent for models that did not come from a CT scan (or older log.json files): then the
  // frame is the identity at 0 (x, y, z as stored).
  std::optional<ScannerFrame> scanner_frame;
  // Absent for models that did not come from a scan (and for older log.json files).
  std::optional<ScanQa> qa;

  // What is at point p. Inside a knot means: within half the knot's diameter of its axis
  // point at the same pith distance (the paper's pseudo-nearest point), with r ≤ r_end.
  MaterialSample material_at(const Vec3& p) const;
};

// The stem with its samples at most max_step_mm apart along z, for a scan whose slices are
// finer than its outline needs (issue 24: a 1 mm scan of a 6 m log is 6 000 samples, and every
// table built on the stem grows with them). Each new sample covers an equal share of the stem's
// length (z_begin() and z_end() stay) and is the mean of the old samples under it, weighted by
// how much of each old sample's step it covers: pith, outer and heartwood radius per angle,
// and bark (over the old samples that have one, > 0). A stem already that coarse, or
// max_step_mm <= 0, comes back as it is.
Stem resample_stem(const Stem& stem, double max_step_mm);
// How many samples resample_stem gives a stem of n samples dz_mm apart (n when it keeps them).
int resampled_count(int n, double dz_mm, double max_step_mm);

// Moves a model measured in a CT image's own axes (x = column·pixel, y = row·pixel from the
// centre of pixel (0, 0), z from the first slice) into the scanner frame and records `frame`.
// For an axial frame (rows turned along the scanner's +x and columns along +y) it adds `pixel0`
// (the scanner x, y of pixel (0, 0)) to every pith sample; a coronal or sagittal frame keeps the
// image's own axes (ScannerFrame), so nothing is added. Knots are relative to the pith and the
// heights keep their origin, so nothing else moves.
void place_in_scanner_frame(LogModel& log, const Vec2& pixel0, const ScannerFrame& frame);

}  // namespace sawyer
