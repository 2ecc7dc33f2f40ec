// Import of the Luleå stem-bank JSON files shipped with the reference paper's code (the real
// Norway spruce log "Gran_1": <name>_pith.json, <name>_radii.json, <name>_knots.json).
//
// Conventions (documented in docs/formats.md): pith [x, y, z] rows give the stem samples; radii
// row j is taken at azimuth ω = π/2 − j° (the published renderer reads the stem map's azimuth
// from +y towards +x); knot rows [A..I] become z0 = C, a = −D, b = −E, omega0 = F, twist = −G,
// r_end = H, r_dead = I (the signs the published renderer draws). A and B are undocumented and
// not used; the diameter profile is fitted to the paper's renderer growth rule.
#pragma once

#include <filesystem>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"

namespace sawyer {

// `folder` holds <name>_pith.json, <name>_radii.json and <name>_knots.json.
Result<LogModel> import_gran1(const std::filesystem::path& folder,
                              const std::string& name = "Gran_1");

// The paper renderer's knot radius at pith distance r (mm) for a stem of local radius R (mm)
// and map scale rmin (mm): (0.2·rmin − 0.1·√(r·rmin)) · r / R, without its noise term.
double paper_knot_radius(double r, double R, double rmin);

// Least-squares power law d = d_dead·(r/r_dead)^p through the paper rule on (0, r_dead].
KnotDiameter fit_paper_diameter(double r_dead, double R, double rmin);

}  // namespace sawyer
