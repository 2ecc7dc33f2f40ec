// Float maps: the log model at full float32 precision as images, for Sawyer's own GLSL
// renderer (one texture fetch per stem sample or knot, no 8-bit quantisation).
//
// A folder holding:
//   float_maps.json  {"format": "sawyer-float-maps/1", "id", "species", "source", "z0_mm",
//                     "dz_mm", "n_angles", "n_slices", "n_knots", "has_heartwood",
//                     "bark_mm" (only when the model has it), "layout": {...description...}}
//   stem.exr         width n_angles, height n_slices, float32 channels pith_x, pith_y, radius,
//                    heartwood. Texel (k, i): angle k at ω = 2πk/n_angles, stem sample i at
//                    z0_mm + i·dz_mm (row 0 = top scanline). pith_x/pith_y: the sample's pith in
//                    scanner mm (the same in every column); radius and heartwood in mm
//                    (heartwood 0 when the model has none).
//   knots.exr        width 3, height n_knots, float32 R, G, B, A (omitted when n_knots is 0):
//                    texel 0 = (z0, a, b, omega0), texel 1 = (twist, r_dead, r_end, d_dead),
//                    texel 2 = (d_exp, id, fit_rms_mm, support).
// Units: mm and rad (docs/architecture.md 3). The JSON keeps its numbers at full double precision;
// the images at float32. See docs/maps.md.
//
//   Status st = export_float_maps(log, "out/float_maps");
//   Result<LogModel> back = import_float_maps("out/float_maps");  // equal to float32 rounding
//
// Failure behaviour: one-line errors naming the file and the problem; nothing throws. The
// writer replaces `dir` atomically (no half-written folder on failure).
#pragma once

#include <filesystem>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"

namespace sawyer {

inline constexpr const char* kFloatMapsFormatTag = "sawyer-float-maps/1";

// Reads a float-maps folder. Checks the format tag, the image sizes against the JSON, the
// channel names, and the resulting model (validate()).
Result<LogModel> import_float_maps(const std::filesystem::path& dir);

// Writes `log` as float maps into `dir`. Knot ids and support counts must be exactly
// representable in float32 (|value| ≤ 2^24), or the export fails naming the knot.
Status export_float_maps(const LogModel& log, const std::filesystem::path& dir);

}  // namespace sawyer
