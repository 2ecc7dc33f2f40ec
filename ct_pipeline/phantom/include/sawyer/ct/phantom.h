// The phantom synthesiser: synthetic CT of a log model (DESIGN.md 6), with ground truth.
//
// A Phantom places a LogModel in a virtual log scanner (offset, tilt, roll), and renders each
// slice as float HU the way a scanner would report it: densities from the wood time field of
// libs/field (the same field the GLSL renderer draws), a bark layer, heartwood and sapwood,
// sound and dead knots, annual rings that follow the field's t (so knots bend them), a scanner
// bed and optional clutter, then slice-thickness averaging, an in-plane Gaussian PSF and
// Gaussian noise. write_phantom() streams the slices into create_ct_writer() with the ground
// truth (truth/log.json, truth/phantom.json) committed atomically beside them.
//
//   PhantomOptions o;                               // defaults: 512², 0.8 mm, 5 mm, σ 20 HU
//   o.placement.offset_x_mm = 12;
//   auto ph = Phantom::create(log, o);              // validates; errors say what is wrong
//   if (!ph) { ... ph.error().message() ... }
//   ct::Slice s = ph.value()->render_slice(0);      // one slice, HU, deterministic
//   auto sum = write_phantom(*ph.value(), "out/phantom", {.format = Format::kDicom});
//
// Frames (DESIGN.md 3). The *log frame* is the model's own (mm). The *scanner frame* is the CT
// file's: x = column · pixel, y = row · pixel (y down the image, the origin of pixel (0, 0) is
// (0, 0, 0)), z = 0 at the first slice, increasing with slice index. A log point P maps to the
// scanner as  S = T + M·(P − A), where A is the model's pith at the middle of the scanned range,
// M = Ry(tilt_y)·Rx(tilt_x)·Rz(roll), and T puts A at the image centre + offset, half way along
// the scanned slices.
//
// Thread safety: a Phantom is immutable after create(); render_slice() and sample_point() may be
// called from many threads.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/core/vec.h"
#include "sawyer/ct/slice_sink.h"
#include "sawyer/ct/slice_source.h"
#include "sawyer/field/wood_field.h"
#include "sawyer/model/log_model.h"

namespace sawyer::ct {

// CT numbers of the materials, HU ≈ density (kg/m³) − 1000 (docs/phantom.md gives sources).
struct HuTable {
  double air = -1000;
  double bark_inner = -450;  // inner bark (phloem, wet): 550 kg/m³
  double bark_outer = -650;  // outer bark (dry, flaky): 350 kg/m³
  double heartwood = -500;   // dry heartwood / spruce dry core: 500 kg/m³
  double sapwood = -50;      // wet sapwood: 950 kg/m³
  double sound_knot = 0;     // sound (intergrown) knot: 1000 kg/m³
  double dead_knot = -180;   // dead (loose) knot: 820 kg/m³
  double knot_bark = -550;   // bark encased around a dead knot: 450 kg/m³
  double bed_belt = 200;     // rubber conveyor belt of the bed: 1200 kg/m³
  double bed_rail = 2200;    // aluminium rails under the belt
  double steel = 3071;       // clutter: steel, saturates the scanner's 12-bit range
  // Dry wood substance density (kg/m³) that the annual rings modulate (earlywood/latewood).
  double dry_wood_density = 420;
  double max_hu = 3071;  // the scanner's top value: everything above is clipped
};

// Where the log lies in the scanner.
struct Placement {
  double offset_x_mm = 0;  // pith at the middle of the scanned range, from the image centre
  double offset_y_mm = 0;
  double tilt_x_deg = 0;  // rotation about the scanner's x axis (|tilt| <= 10)
  double tilt_y_deg = 0;  // rotation about the scanner's y axis
  double roll_deg = 0;    // rotation about the log's axis, counter-clockwise seen from +z
  bool tilted() const { return tilt_x_deg != 0 || tilt_y_deg != 0; }
};

struct PhantomOptions {
  int image_size = 512;           // columns = rows
  double pixel_mm = 0.8;          // pixel spacing, x and y
  double slice_spacing_mm = 5.0;  // between slice centres
  double slice_thickness_mm = 0;  // 0: equal to the spacing
  int sub_slices = 0;             // samples across the thickness; 0: about one per 1.25 mm
  // Scanned range in the log frame (slice centres); unset: the whole log, the first and last
  // slabs just inside its ends.
  std::optional<double> from_mm, to_mm;
  Placement placement;
  double noise_hu = 20;          // Gaussian noise σ, HU
  double blur_px = 0.7;          // Gaussian PSF σ in pixels (0: none)
  std::uint64_t seed = 1;        // noise, dropped slices, clutter placement
  double ring_width_mm = 3.0;    // mean annual ring width (sets the ring count)
  double ring_amplitude = 0.08;  // peak-to-peak ring modulation, fraction of dry density
  double knot_noise = 0.05;      // the field's knot outline noise (0: exact diameters)
  bool bed = true;               // scanner bed (belt and rails) under the log
  double bed_gap_mm = 0.5;       // belt below the log's lowest point; 0: touching
  bool clutter = false;          // steel support bars and a chain in some slices
  int drop_slices = 0;           // missing slices (never the first or the last)
  HuTable hu;
  int threads = 0;  // write_phantom: worker threads; 0 = hardware concurrency

  double thickness() const {
    return slice_thickness_mm > 0 ? slice_thickness_mm : slice_spacing_mm;
  }
  // Checks the ranges (one line naming the option on failure). Log-dependent checks (field of
  // view, z range) happen in Phantom::create.
  Status validate() const;
};

// What a scanner point holds, before blur and noise.
enum class Region {
  kAir,
  kBark,
  kHeartwood,
  kSapwood,
  kSoundKnot,
  kDeadKnot,
  kKnotBark,
  kBed,
  kClutter
};
const char* region_name(Region r);

struct PhantomPoint {
  float hu = -1000;  // noise-free, blur-free HU at the point
  Region region = Region::kAir;
  Vec3 log_point;              // the point in the log frame
  FieldSample field;           // the wood field there (meaningful inside the log and bark)
  float heartwood_radius = 0;  // heartwood radius used at this azimuth and height, mm
  float bark_mm = 0;           // bark thickness used at this azimuth and height, mm
};

// One straight steel bar or chain link of the clutter, for the truth file.
struct ClutterObject {
  std::string kind;  // "bar" or "chain_link"
  Vec3 centre;       // scanner frame, mm
  double z_min = 0, z_max = 0;
};

class Phantom {
 public:
  // Checks the options against the log (z range, field of view) and prepares the placement.
  // The log is copied. Errors: one line, e.g. "log does not fit the field of view ...".
  static Result<std::unique_ptr<Phantom>> create(const LogModel& log,
                                                 const PhantomOptions& options);
  ~Phantom();
  Phantom(const Phantom&) = delete;
  Phantom& operator=(const Phantom&) = delete;

  const PhantomOptions& options() const { return options_; }
  const LogModel& log() const { return log_; }

  // Nominal slices: every slice position of the scan, dropped ones included.
  int nominal_count() const { return static_cast<int>(nominal_z_.size()); }
  double nominal_z(int i) const { return nominal_z_[i]; }  // scanner z, mm
  // The pith at nominal slice i's centre, scanner frame (exact, tilt included).
  Vec2 pith(int i) const { return pith_[i]; }
  // Log-frame height of the pith at nominal slice i.
  double pith_log_z(int i) const { return pith_log_z_[i]; }
  const std::vector<int>& dropped() const { return dropped_; }
  // Nominal indices of the slices written, in order; geometry().z are their positions.
  const std::vector<int>& kept() const { return kept_; }
  // The written volume: kept slices only, origin (0, 0, 0), axis-aligned orientation.
  const VolumeGeometry& geometry() const { return geometry_; }
  int sub_slices() const { return sub_slices_; }
  double ring_count() const { return ring_count_; }
  const std::vector<ClutterObject>& clutter() const { return clutter_; }

  Vec3 to_scanner(const Vec3& log_point) const;
  Vec3 to_log(const Vec3& scanner_point) const;

  // The noise-free, blur-free HU at one scanner point (exact field height, no slab averaging).
  PhantomPoint sample_point(const Vec3& scanner_point) const;

  // Nominal slice i as the scanner gives it (slab averaging, PSF, noise). Deterministic: the
  // noise comes from (seed, i) only. index = i, z = nominal_z(i).
  Slice render_slice(int i) const;

  // Keeps per-thread state (the field's height cache for tilted logs) between slices; faster
  // when a thread renders ascending slices. One Renderer per thread.
  class Renderer {
   public:
    explicit Renderer(const Phantom& phantom);
    ~Renderer();
    void render(int i, Slice& out);

   private:
    struct Cache;
    const Phantom& ph_;
    std::unique_ptr<Cache> cache_;
  };

  // The ground truth: the log model in the scanner frame (truth/log.json) and every parameter,
  // the placement and the per-slice pith (truth/phantom.json). See docs/phantom.md.
  // `output_info_json`, a JSON object (format, rescale), is stored as phantom.json's "output".
  LogModel truth_log() const;
  std::string truth_json(const std::string& output_info_json = {}) const;
  // Writes truth/log.json and truth/phantom.json under `dir`.
  Status write_truth(const std::filesystem::path& dir,
                     const std::string& output_info_json = {}) const;

 private:
  friend class Renderer;
  struct Layer;
  Phantom(const LogModel& log, const PhantomOptions& options);
  Status prepare();

  // Anatomy of the log frame, one source for rendering and truth.
  double heartwood_radius(double omega, double z, double R) const;
  double bark_thickness(double omega, double z, double R) const;
  double max_outer_radius(double z_lo, double z_hi) const;  // R + bark, over a height range
  std::unique_ptr<Layer> make_layer(double z) const;
  // HU of the log (wood, bark, air) at a log-frame point, using a layer at (about) its height.
  float log_hu(const Layer& layer, double x, double y, Region* region) const;
  // HU of the bed (z-invariant) and of the clutter at a scanner point; false where none.
  bool bed_hu(double x, double y, float* hu) const;
  bool clutter_hu(const Vec3& s, float* hu) const;
  // Pith of the scanner slice at height zs: the log-frame height and scanner (x, y).
  void solve_pith(double zs, double* z_log, Vec2* xy) const;
  void refit_tilted_knot(const Knot& k, Knot* q) const;

  LogModel log_;
  PhantomOptions options_;
  std::unique_ptr<WoodField> field_;
  double M_[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  Vec3 A_, T_;
  double from_ = 0, to_ = 0;  // scanned range, log frame
  int sub_slices_ = 1;
  double ring_count_ = 1;
  std::vector<double> nominal_z_, pith_log_z_;
  std::vector<Vec2> pith_;
  std::vector<int> dropped_, kept_;
  VolumeGeometry geometry_;
  std::vector<double> outer_per_sample_;  // max R + bark per stem sample
  double max_outer_ = 0;
  // Bed: belt arc and two rails, fixed in the scanner frame.
  bool has_bed_ = false;
  Vec2 bed_centre_;
  double bed_radius_ = 0, bed_thickness_ = 8, bed_half_angle_ = 0;
  std::array<Vec2, 2> rail_centre_{};
  double rail_half_ = 15, rail_wall_ = 3;
  std::vector<ClutterObject> clutter_;
  struct ClutterShape;
  std::vector<ClutterShape> shapes_;
  std::vector<float> base_;  // the slice without log and clutter: air and the bed, W x W
};

struct PhantomWriteOptions {
  Format format = Format::kDicom;
  // Stored value = round((HU − intercept) / slope). Unset: DICOM signed 16-bit with slope 1,
  // intercept 0 (stored = HU); image stacks unsigned 16-bit with intercept −1024 (air noise
  // below −1024 HU clips); volume files (.mha/.vti/.nrrd) always hold HU, signed 16-bit.
  std::optional<double> rescale_slope, rescale_intercept;
  // Called after each slice is handed to the writer: (slices done, slices in all).
  std::function<void(int, int)> progress;
  // Text put in phantom.json as "input" (e.g. the path of the log.json).
  std::string input_name;
};

struct PhantomSummary {
  int slices = 0;  // written
  int dropped = 0;
  int threads = 1;
  double seconds = 0;
  double slices_per_second() const { return seconds > 0 ? slices / seconds : 0; }
  std::string brief_report() const;
};

// Renders every kept slice (threads in parallel, in order to the writer) and writes the folder
// `out` with truth/ inside, all or nothing. Errors name the output and what failed.
Result<PhantomSummary> write_phantom(const Phantom& phantom, const std::filesystem::path& out,
                                     const PhantomWriteOptions& options);

// "dicom" | "tiff" | "png" | "mha" | "vti" | "nrrd" → Format; an Error names the choices.
Result<Format> parse_phantom_format(const std::string& name);

}  // namespace sawyer::ct
