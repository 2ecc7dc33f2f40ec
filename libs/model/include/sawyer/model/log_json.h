// log.json, format tag "sawyer-log/1": the log model on disk.
//
// {
//   "format": "sawyer-log/1",
//   "id": "gran1_spruce", "species": "spruce", "source": "...",
//   "stem": { "z0_mm": 0, "dz_mm": 10, "n_angles": 360,
//             "pith": [[x, y], ...], "radius": [[r per angle], ...],
//             "heartwood": [[...], ...] (optional), "bark_mm": [...] (optional) },
//   "knots": [ { "id": 0, "z0": .., "a": .., "b": .., "omega0": .., "twist": .., "r_dead": ..,
//                "r_end": .., "d_dead": .., "d_exp": .., "fit_rms_mm": .., "support": .. }, ... ]
// }
//
// Units: millimetres and radians. Numbers are written with enough digits to read back exactly.
// The reader checks every key and names the first problem: the key path, and what is wrong.
#pragma once

#include <filesystem>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"

namespace sawyer {

inline constexpr const char* kLogFormatTag = "sawyer-log/1";

// Serialises and parses the JSON text. Parse errors name the key path (e.g.
// "knots[3].r_end: expected a number").
std::string log_to_json(const LogModel& log);
Result<LogModel> log_from_json(const std::string& text);

// File versions; errors are prefixed with the file name. write_log_json is atomic.
Result<LogModel> read_log_json(const std::filesystem::path& path);
Status write_log_json(const LogModel& log, const std::filesystem::path& path);

// Checks the model's invariants (sizes agree, finite values, positive radii and step, knot
// ranges). Returns the first problem found, naming where.
Status validate(const LogModel& log);

}  // namespace sawyer
