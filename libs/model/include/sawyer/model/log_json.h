// log.json, format tag "sawyer-log/1": the log model on disk.
//
// {
//   "format": "sawyer-log/1",
//   "id": "gran1_spruce", "species": "spruce", "source": "...",
//   "stem": { "z0_mm": 0, "dz_mm": 10, "n_angles": 360,
//             "pith": [[x, y], ...], "radius": [[r per angle], ...],
//             "heartwood": [[...], ...] (optional),
//             "bark_mm": [mm per sample] or [[mm per angle], ...] (optional) },
//   "knots": [ { "id": 0, "z0": .., "a": .., "b": .., "omega0": .., "twist": .., "r_dead": ..,
//                "r_end": .., "d_dead": .., "d_exp": .., "fit_rms_mm": .., "support": .. }, ... ],
//   "scanner_frame": { "origin_mm": [x, y, z], "row_dir": [..], "col_dir": [..], "z0_mm": ..,
//                      "z_dir": 1, "slice_dir": [..] (coronal and sagittal scans only) }
//                    (optional; absent: the identity at 0)
// }
//
// Units: millimetres and radians. Numbers are written with enough digits to read back exactly.
// The reader checks every key and names the first problem: the key path, and what is wrong.
// Every number must be finite and within the plausible ranges of log_limits below (checked by
// validate(), so by every reader and writer of a log model).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"

namespace sawyer {

inline constexpr const char* kLogFormatTag = "sawyer-log/1";

// What a log model may hold. The ranges are far wider than any log a sawmill or a lab will see
// (the biggest tropical logs are about 1.5 m across and 20-30 m long; CT slices are 0.1-10 mm
// apart), so that no real log is refused, yet narrow enough that no value can make a length,
// an allocation or a loop blow up (a dz of 1e12 mm would price boards 3.6e8 km long).
namespace log_limits {
// log.json files: a 40 m log sampled every 2 mm at 360 angles with heartwood is about 250 MB.
inline constexpr std::uintmax_t kMaxFileBytes = std::uintmax_t{512} << 20;
// Heights (stem z0, knot z0): the scanner frame's origin is at most metres from the log.
inline constexpr double kMaxAbsZMm = 100000.0;
// Stem sample step: CT slices from 0.01 mm (micro-CT) to 1 m (coarse mill scanners, hand data).
inline constexpr double kMinDzMm = 0.01, kMaxDzMm = 1000.0;
// Log length (samples × dz): twice the longest logs hauled.
inline constexpr double kMaxLengthMm = 40000.0;
// Stem samples along z (40 m at 0.2 mm), angles per sample (0.05° steps), and their product
// per grid (radius, heartwood: 20 million values, 160 MB of doubles).
inline constexpr int kMaxSlices = 200000;
inline constexpr int kMinAngles = 3, kMaxAngles = 7200;
inline constexpr long long kMaxStemValues = 20'000'000;
// Pith position in the scanner frame: the log lies inside the scanner's field of view.
inline constexpr double kMaxAbsPithMm = 10000.0;
// Outer and heartwood radius: 3 m diameter under bark, twice the biggest logs sawn.
inline constexpr double kMaxRadiusMm = 1500.0;
inline constexpr double kMaxBarkMm = 500.0;  // the thickest barks (sequoia) are about 300 mm
// Knots: real logs have 10-30 a metre (the bundled spruce 27/m), at most a few hundred; a 40 m
// log at 50/m has 2000. 10 000 keeps a wide margin and bounds what every stage does per knot
// (the sawing optimiser turns each knot's axis at every position: 100 000 knots ran for minutes).
inline constexpr int kMaxKnots = 10000;
// Knot length from the pith (r_dead, r_end): to the bark of the largest log and beyond it for
// branch stubs.
inline constexpr double kMaxKnotLengthMm = 2000.0;
inline constexpr double kMaxKnotDiameterMm = 1000.0;  // d_dead: a branch as thick as a log
// Knot axis: z(r) = z0 + a·√r + b·r. The CT fit keeps a in [-10, 25] and b in [-1, 2.5]; |b| =
// 100 is a knot running almost along the stem.
inline constexpr double kMaxAbsA = 1000.0, kMaxAbsB = 100.0;
// Angles: azimuths are written in [0, 2π); two turns either side is any unwrapped value. The
// twist of real knots is below 0.5 rad per ln(mm).
inline constexpr double kMaxAbsOmegaRad = 4.0 * kPi;
inline constexpr double kMaxAbsTwist = 10.0;
inline constexpr double kMaxExponent = 10.0;  // d_exp; the CT fit keeps it ≤ 3
inline constexpr double kMaxFitRmsMm = 10000.0;
// The scan's QA verdict ("qa"): a few stages with a few lines each.
inline constexpr int kMaxQaStages = 32, kMaxQaLines = 200;
inline constexpr size_t kMaxQaLineChars = 1000;
}  // namespace log_limits

// Serialises and parses the JSON text. Parse errors name the key path (e.g.
// "knots[3].r_end: expected a number").
std::string log_to_json(const LogModel& log);
// The "qa" object alone (run.json carries the same), and back.
std::string qa_json_text(const ScanQa& qa);
Result<ScanQa> qa_from_json_text(const std::string& text);
// The "scanner_frame" object alone (sawing.json and run.json carry the same).
std::string scanner_frame_json_text(const ScannerFrame& frame);
Result<LogModel> log_from_json(const std::string& text);

// File versions; errors are prefixed with the file name. write_log_json is atomic. The reader
// refuses what is not a regular file or is larger than log_limits::kMaxFileBytes before reading.
Result<LogModel> read_log_json(const std::filesystem::path& path);
Status write_log_json(const LogModel& log, const std::filesystem::path& path);

// Checks the model's invariants (sizes agree, finite values, positive radii and step, every
// number within log_limits). Returns the first problem found, naming the key, the value and the
// allowed range, e.g. "knots[12].d_dead: 2000 mm is outside 0-1000 mm".
Status validate(const LogModel& log);

}  // namespace sawyer
