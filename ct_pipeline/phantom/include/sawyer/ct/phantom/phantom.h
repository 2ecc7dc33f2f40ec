// The phantom synthesiser: synthetic CT of a log model (docs/architecture.md 6), with ground truth.
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
// Frames (docs/architecture.md 3). The *log frame* is the model's own (mm). The *scanner frame*
// here is the CT image's: x = column · pixel, y = row · pixel (y down the image, from the centre of
// pixel (0, 0)), z = 0 at the first slice, increasing with slice index; the file places pixel (0,
// 0) of the first slice at geometry().origin (centred on the isocentre, z 1000 mm), so the scanner
// proper is this frame shifted by the origin, which truth/log.json is in. A log point P maps to the
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
#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"
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
  // Defects (used only when PhantomOptions asks for them).
  double resin = 80;        // resin pocket: resin 1050-1100 kg/m³
  double rot = -750;        // rot pocket: decayed wood, 40-60 % of its density lost
  double resin_knot = 250;  // resin-soaked (pitch) dead knot: 1100-1300 kg/m³
};

// The CT numbers of a dried log (about −600 HU throughout, no wet sapwood): `green` with the
// wood, knot and bark entries replaced; air, the bed and the defects' entries are kept.
HuTable dried_hu_table(const HuTable& green);

// Moisture state of the log.
enum class Moisture {
  kGreen,  // wet sapwood, dry heartwood (HuTable as given)
  kDried,  // dried_hu_table(): the wood reads about −600 HU throughout
};
const char* moisture_name(Moisture m);

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
  // A second log in the field of view: the same model end for end, on the +x side, touching this
  // one at their closest slice (it may reach beyond the image, as on a real bed).
  bool second_log = false;
  int drop_slices = 0;  // missing slices (never the first or the last)
  // A log larger than the field of view (or placed off it) is refused unless this is set; then
  // the image's edge cuts it, as a scanner too small for the log does.
  bool allow_clipped = false;

  // The condition space (docs/phantom.md "Condition space"). Every default is the phantom's
  // original behaviour, so existing scans are unchanged.
  // Ring width profile: `juvenile_ring_width_mm` at the pith, changing linearly to
  // `ring_width_mm` at `juvenile_radius_mm` (in the field's reference radius), constant beyond.
  double juvenile_ring_width_mm = 0;  // 0: every ring ring_width_mm wide
  double juvenile_radius_mm = 50;
  // Ring contrast as the standard deviation of the ring modulation (HU, before blur and
  // noise); 0: the modulation is ring_amplitude × dry_wood_density peak to peak.
  double ring_contrast_hu = 0;
  // Latewood share of a ring (a dense plateau before the sharp drop to the next earlywood);
  // 0: the original profile (a cubic rise through the ring, no plateau).
  double latewood_fraction = 0;
  double density_drift_hu_per_m = 0;  // wood CT numbers change by this per metre along the log
  Moisture moisture = Moisture::kGreen;
  int wet_pockets = 0;  // irregular wet patches in the heartwood (spruce), at sapwood HU
  // Scanner calibration: reported HU = hu_offset + hu_slope × HU.
  double hu_offset = 0;
  double hu_slope = 1;
  double cupping_hu = 0;  // beam hardening: the log's centre reads this much lower than its rim
  // Metal streaks from the clutter's steel (needs clutter): amplitude at the steel, HU; 0: none.
  double metal_streak_hu = 0;
  // Windowed 8-bit export (previews): stored = the window's 256 levels; width 0: 16-bit HU.
  double window_centre_hu = -400;
  double window_width_hu = 0;
  // Defects, placed from the seed (their own stream) and listed in truth/phantom.json.
  int cracks = 0;               // radial cracks: heart checks from the pith, checks from the bark
  double crack_width_mm = 2;    // opening of a crack at its widest
  int resin_pockets = 0;        // lens-shaped resin pockets between rings
  int rot_pockets = 0;          // decayed columns in the heartwood
  double compression_wood = 0;  // 0-1: one side denser (+150 HU at 1) with wider rings (×1.6)
  int bark_missing = 0;         // patches where the bark is gone (the wood is exposed)
  int bark_loose = 0;           // patches where the bark stands off the wood by an air gap
  double knot_bark_mm = 1.0;    // bark ring encased around dead knots
  double resin_knots = 0;       // share of the dead knots that are resin-soaked (HuTable)
  HuTable hu;
  int threads = 0;  // write_phantom: worker threads; 0 = hardware concurrency

  double thickness() const {
    return slice_thickness_mm > 0 ? slice_thickness_mm : slice_spacing_mm;
  }
  // Checks the ranges (one line naming the option on failure). Log-dependent checks (field of
  // view, z range) happen in Phantom::create.
  Status validate() const;
  Status validate_conditions() const;  // the condition space's options (part of validate)
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
  kClutter,
  kWetPocket,
  kCrack,
  kResinPocket,
  kRot,
};
const char* region_name(Region r);

struct PhantomPoint {
  float hu = -1000;  // noise-free, blur-free HU at the point
  Region region = Region::kAir;
  Vec3 log_point;              // the point in the log frame
  FieldSample field;           // the wood field there (meaningful inside the log and bark)
  float heartwood_radius = 0;  // heartwood radius used at this azimuth and height, mm
  float bark_mm = 0;           // bark thickness used at this azimuth and height, mm
  bool second_log = false;     // the point is in the second log (log_point in its log frame)
};

// A defect of the condition space, as drawn (truth/phantom.json "defects"), in the log frame
// around the model's pith: its centre at pith distance r_mm, azimuth omega (rad), height z_mm.
// Pockets (wet_pocket, rot, resin_pocket) are ellipsoids with semi-axes radial_mm and
// tangential_mm across the grain and half the z range along it (wet pockets with an irregular
// outline inside that); a crack is a radial slit r_min..r_max along omega, width_mm open at one
// end tapering to nothing at the other and at its z ends; bark patches (bark_missing,
// bark_loose) and compression_wood cover omega ± half_angle over z_min..z_max.
struct Defect {
  std::string kind;  // wet_pocket, crack, resin_pocket, rot, compression_wood, bark_missing,
                     // bark_loose, resin_knot
  double r_mm = 0, omega = 0, z_mm = 0;
  double radial_mm = 0, tangential_mm = 0;
  double r_min = 0, r_max = 0, half_angle = 0, z_min = 0, z_max = 0;
  double width_mm = 0;     // crack: opening at its widest; bark_loose: the air gap
  bool from_bark = false;  // crack: a check open at the bark (else a heart check at the pith)
  int knot_id = -1;        // resin_knot: the knot's id
};

// Streaks of one steel object in the slices it crosses (rendered slices only; sample_point has
// none): lines through its centre, alternately dark and bright,
// ±amplitude · exp(−d² / 2σ²) · exp(−L / decay) at distance d from a line and L along it.
struct MetalStreaks {
  Vec2 centre;  // scanner frame, mm
  double z_min = 0, z_max = 0;
  std::vector<double> angles;  // rad; the first is dark, then alternately bright and dark
  double amplitude_hu = 0, sigma_mm = 1.5, decay_mm = 150;
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
  // The written volume: kept slices only, origin (-(W-1)/2·pixel, -(W-1)/2·pixel, 1000 mm),
  // axis-aligned orientation.
  const VolumeGeometry& geometry() const { return geometry_; }
  int sub_slices() const { return sub_slices_; }
  double ring_count() const { return ring_count_; }
  const std::vector<ClutterObject>& clutter() const { return clutter_; }
  const std::vector<Defect>& defects() const { return defects_; }
  const std::vector<MetalStreaks>& streaks() const { return streaks_; }
  // The second log (options().second_log): its log-frame point for a scanner point, and its
  // pith at nominal slice i (scanner frame). Its log frame is the model's, end for end:
  // log xy = A − (scanner xy − C2), log z = A.z − (scanner z − T.z).
  bool has_second_log() const { return has_second_; }
  Vec3 second_to_log(const Vec3& scanner_point) const;
  Vec2 second_pith(int i) const;
  int second_touch_slice() const { return second_touch_; }
  // The HU table used (the options' own, or the dried one).
  const HuTable& hu() const { return hu_; }
  // Rings from the pith to the field's reference radius (t = 1) along azimuth omega (log frame).
  double rings_at(double t, double omega) const;

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
    void render_second_log(double zs, int x0, int x1, int y0, int y1);
    struct Cache;
    const Phantom& ph_;
    std::unique_ptr<Cache> cache_;
  };

  // The ground truth: the log model in the image frame above (truth_log(); truth/log.json holds
  // it moved by the origin into the scanner's x, y with its scanner_frame, as `sawyer scan`
  // writes log.json) and every parameter, the placement and the per-slice pith in the image
  // frame (truth/phantom.json). See docs/phantom.md.
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
  double bark_gap(double omega, double z) const;  // air under loose bark
  // Pockets at a log-frame point (r, omega, z) of wood: replaces *v and *region inside one;
  // `sap` is the sapwood share there (0..1).
  void apply_pockets(double r, double omega, double z, double sap, double* v, Region* region) const;
  void draw_defects();
  void place_second_log();
  float material_hu(const FieldSample& fs, double z, float H, float B, Region* region) const;
  bool in_crack(double r, double omega, double z) const;
  // The scanner's calibration: the HU it reports for a true `v`.
  float calibrated(float v) const;
  static void add_streaks(const Phantom& ph, double z, std::vector<float>& img);
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
  std::vector<Defect> defects_;
  std::vector<MetalStreaks> streaks_;
  bool has_second_ = false;
  Vec2 second_c_;                 // C2
  int second_touch_ = -1;         // nominal slice where the two logs are closest
  std::vector<char> resin_knot_;  // per knot index: resin-soaked dead part
  HuTable hu_;
  double ring_amp_hu_ = 0;  // peak-to-peak ring modulation, HU
  double ring_mean_ = 0;    // mean of the ring profile
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
