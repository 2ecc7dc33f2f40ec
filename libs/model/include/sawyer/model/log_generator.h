// A generator of realistic random logs (pine and spruce), deterministic by seed.
//
// Ranges follow docs/architecture.md section 6 and the sawmill literature: logs 3–6 m long, 12–45
// cm in diameter under bark, taper, ovality, sweep, pith wander; pine whorls every 0.3–0.6 m with
// 3–6 knots each, spruce whorls plus smaller interwhorl knots; knots sound near the pith and dead
// further out on the lower log, with realistic diameters. The same options and seed give the
// same log on every machine (no std::uniform_*_distribution, whose output is implementation
// defined). Ranges, their sources, and the rounding of the output are documented at the top of
// src/log_generator.cpp.
//
//   GeneratorOptions o;
//   o.species = Species::kPine;
//   o.seed = 42;
//   Result<LogModel> log = generate_log(o);  // id "pine_s42", 30–120 knots, radii in 0.01 mm
//   if (!log) std::cerr << log.error().message() << "\n";
#pragma once

#include <cstdint>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"

namespace sawyer {

enum class Species { kPine, kSpruce };

// Where in the tree the log was cut: a butt log (with the butt flare; dead knots near the pith,
// many overgrown in pine), a middle log, or a top log (more knots sound out to the bark).
enum class LogPosition { kDrawn, kButt, kMiddle, kTop };

struct GeneratorOptions {
  Species species = Species::kSpruce;
  std::uint64_t seed = 1;
  double length_mm = 0;        // 0: drawn from [3000, 6000] in whole dm; else 1000..12000
  double top_diameter_mm = 0;  // under bark. 0: drawn so that the butt stays within
                               // [120, 450]; else 100..420 (the taper is then reduced if the
                               // butt would pass 450)
  double dz_mm = 10.0;         // stem sample step, 0.5..50 mm
  int n_angles = 360;          // radii per height, 8..3600
  bool heartwood = true;       // also generate a heartwood radius
  LogPosition position = LogPosition::kDrawn;  // kDrawn: butt 40 %, middle 35 %, top 25 %
  bool bark = true;                            // also generate a bark thickness per height
  // Pith eccentricity: the pith's distance from the outline's centre line, as a share of the
  // mean radius. Real piths sit 0–25 % off (wind, compression wood; Lapland pines average
  // 12 %). eccentricity_max < 0 (the default): the original draw, 1–5 % per log (±20 % along
  // it) plus 1–4 mm of pith wander, the same log as ever. Else (0 ≤ min ≤ max ≤ 0.4): the
  // eccentricity changes along the log by eccentricity_change (peak to peak over the log, a
  // share of the radius; at most max − min) within a stretch of [min, max] placed at random,
  // and its direction turns by up to ±eccentricity_turn_rad over the log; no separate wander,
  // so the pith's offset is exactly that eccentricity. Drawn from a stream of its own: the
  // outline, wood and knot draws are the default log's (knots end where the new radii say).
  double eccentricity_min = 0, eccentricity_max = -1;
  double eccentricity_change = 0.05;   // share of the radius, 0..0.4
  double eccentricity_turn_rad = 0.5;  // 0..π
  // The realistic ranges (30–120 knots, butt diameter 120–450 mm, ...) hold for drawn lengths
  // and diameters; explicit ones outside 3–6 m or typical diameters may leave them.

  // Returns an error naming the bad option.
  Status validate() const;
};

// Options are checked first (validate()). The log spans z in [0, length]: stem sample i is at
// z = (i + ½)·dz_mm; the scanner frame's origin is near the log's axis at mid length. Knots are
// sorted by z0 and numbered from 0. The model's id is "<species>_s<seed>", its source the
// `sawyer generate` command that makes it. Deterministic: the same options give the same log,
// bit for bit (own random numbers; output rounded to 0.01 mm, which absorbs last-bit
// differences between libm implementations).
Result<LogModel> generate_log(const GeneratorOptions& options);

const char* species_name(Species s);  // "pine", "spruce"
// Accepts "pine" and "spruce" (any case); the error names the unknown value.
Result<Species> parse_species(const std::string& name);

const char* log_position_name(LogPosition p);  // "drawn", "butt", "middle", "top"
Result<LogPosition> parse_log_position(const std::string& name);

}  // namespace sawyer
