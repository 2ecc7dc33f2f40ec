// The published map format: the four 8-bit BMP maps and map_params.json that the reference
// paper's renderer (Larsson et al. 2022, github.com/marialarsson/procedural_knots) reads, plus
// our optional sidecar sawyer_maps.json. docs/maps.md describes the format, each quirk of the
// published files and renderer, and the choices made here.
//
//   Result<LogModel> log = import_published_maps("sample_logs/gran1_spruce/published_maps");
//   if (!log) { std::cerr << log.error().message() << "\n"; return 1; }
//   PublishedMapExportSummary summary;
//   Status st = export_published_maps(log.value(), "out/maps", {}, &summary);
//
// What the maps carry is quantised to 8 bits: heights to hmax/255, pith offsets and knot rise to
// rmin/255, radii to (rmax − rmin)/255, azimuths to 2π/255 and twist to (π/2)/255 (the importer
// is off by at most half of that for maps we wrote, which round; the shipped Gran_1 maps
// truncate, so up to a whole step there). Knot diameters are not carried: the sidecar keeps
// them, and without it the importer derives them from the published renderer's growth rule.
//
// Frames: the importer returns a model in our frames (docs/architecture.md 3); the stem's z_begin()
// is the maps' height 0 (shifted back to the original frame when the sidecar says where that was).
//
// Failure behaviour: errors are one line naming the file and the problem; nothing throws. The
// exporter writes the whole folder atomically: on failure no folder (and no half-written one)
// is left, and an existing folder at `dir` is left as it was.
// Thread safety: the functions share no state; call them concurrently on different folders.
#pragma once

#include <filesystem>
#include <iosfwd>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"

namespace sawyer {

// Format tag of the sidecar sawyer_maps.json.
inline constexpr const char* kPublishedMapsSidecarTag = "sawyer-maps/1";

struct PublishedMapOptions {
  // Columns of pith_and_radius_map.bmp (azimuth samples; the published maps use 180).
  int stem_columns = 180;
  // Columns of the knot maps (pith-distance samples over [0, rmin]; the published maps use 32).
  int knot_columns = 32;
  // Identical rows per knot in the knot maps. The renderer samples each knot between its middle
  // rows with a filter four texels wide, so fewer than 4 lets neighbouring knots bleed in.
  int rows_per_knot = 4;
  // Also write sawyer_maps.json (ids, diameters, r_end, the original frame, full precision).
  bool write_sidecar = true;

  // An error naming the bad option.
  Status validate() const;
};

// What the exporter wrote and what it had to clamp to fit the 8-bit ranges.
struct PublishedMapExportSummary {
  double rmin = 0, rmax = 0, hmax = 0;  // map_params.json, mm
  int knots = 0;
  int stem_columns = 0, stem_rows = 0, knot_columns = 0, rows_per_knot = 0;
  int clamped_pith_rows = 0;     // pith offset from the mid pith beyond ±rmin/2 (x or y)
  int clamped_knot_starts = 0;   // knot start height z0 outside the log [0, hmax]
  int clamped_rise_texels = 0;   // |a·√r + b·r| > rmin at a knot-map column
  int clamped_twist_texels = 0;  // |twist·ln r| > π/2 at a knot-map column
  int saturated_r_dead = 0;      // r_dead ≥ rmin: only the sidecar keeps its exact value
  int clamped_r_end = 0;         // r_end > rmax: only the sidecar keeps its exact value

  // A few lines for a person.
  void print(std::ostream& os) const;
};

// What the importer found.
struct PublishedMapImportSummary {
  double rmin = 0, rmax = 0, hmax = 0;
  int knots = 0;
  int stem_columns = 0, stem_rows = 0, knot_columns = 0, rows_per_knot = 0;
  bool sidecar = false;              // sawyer_maps.json was present and used
  double max_height_fit_rms_mm = 0;  // worst knot-axis height fit residual over the knots
  double max_azimuth_fit_rms = 0;    // worst knot-azimuth fit residual, rad

  void print(std::ostream& os) const;
};

// Reads a folder holding map_params.json, pith_and_radius_map.bmp and (when the knot count is
// not 0) knot_height_map.bmp, knot_orientation_map.bmp and knot_state_map.bmp, and, when
// present, sawyer_maps.json. The stem gets the sidecar's n_angles, else 360 angles (periodic
// Catmull-Rom resampling of the map's columns); each knot's formula is a least-squares fit to
// its decoded columns. The model reproduces what the published renderer draws from the maps.
Result<LogModel> import_published_maps(const std::filesystem::path& dir,
                                       PublishedMapImportSummary* summary = nullptr);

// Writes `log` as published maps into `dir` (replacing a folder that is there), such that the
// published renderer draws it as we mean it. Heartwood and bark are not carried (the format
// has no place for them). Validates the model and the options first.
Status export_published_maps(const LogModel& log, const std::filesystem::path& dir,
                             const PublishedMapOptions& options = {},
                             PublishedMapExportSummary* summary = nullptr);

}  // namespace sawyer
