// The limits every CT input is held to, and the checks that apply them.
//
// A number in a scan's header reaches an allocation or a loop (slices * width * height voxels, a
// z grid of extent / spacing slices), so every reader checks what it read where it read it, and
// open_ct() checks the geometry once more for every format. Each refusal is one line naming the
// file (or option), the value and the allowed range. The ranges are wide enough for every log CT
// we know of (industrial log scanners: 0.2-2 mm pixels, 1-10 mm slices, up to 1 m logs of 20 m)
// and narrow enough that nothing inside them overflows or exhausts memory by itself.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct {

// Pixel and slice spacing, mm. Below 0.01 mm is microtomography of a splinter, not of a log (and
// two slices 0.001 mm apart are one slice twice); above 50 mm a knot whorl fits between slices.
inline constexpr double kMinSpacingMm = 0.01;
inline constexpr double kMaxSpacingMm = 50.0;
// Columns and rows of one slice: 16384 is twice the largest detector we know of.
inline constexpr int kMaxImageSize = 16384;
// Field of view (columns * pixel spacing, rows * pixel spacing), mm: no log is wider than 2 m.
inline constexpr double kMaxFieldOfViewMm = 2000.0;
// Slices in a scan and their z extent: 30 m is longer than any log a mill saws.
inline constexpr int kMaxSliceCount = 100000;
inline constexpr double kMaxZExtentMm = 30000.0;
// Origin coordinates, mm: 10 km from the scanner's origin is a corrupt header.
inline constexpr double kMaxPositionMm = 1e7;
// The rescale to HU (HU = slope * stored value + intercept), from a file's header or given.
// CT scanners write slopes near 1 (0.5-2 for 12-16 bit detectors); a slope under 1e-4 squeezes
// a 16-bit range into 6.5 HU, less than a scanner's noise. Float stacks of attenuation in 1/mm
// need about 1000 / 0.0195 = 5.1e4 (water's attenuation at 70 keV), so 1e5 is twice that. An
// intercept beyond 1e5 HU puts every voxel outside the HU scale (air -1000, metal ~3e4).
inline constexpr double kMinAbsRescaleSlope = 1e-4;
inline constexpr double kMaxAbsRescaleSlope = 1e5;
inline constexpr double kMaxAbsRescaleIntercept = 1e5;
// Resampling onto an even z grid (make_uniform_z): refused, unless OpenOptions::allow_gaps, when
// more than this fraction of the output slices would be invented (the benches drop 5 % of the
// slices at random, a scanner drops single slices; 10 % is twice that) or when one gap between
// slices present is wider than kMaxGapMm (a whole knot whorl fits in 50 mm). One invented
// slice alone never counts as too many (in a 6-slice section it is 17 %).
inline constexpr double kMaxInventedFraction = 0.10;
inline constexpr double kMaxGapMm = 50.0;
// The scan keeps the volume as 16-bit voxels for the knot pass; that must fit in this share of
// MemAvailable (the rest is for the other passes, the maps and the system).
inline constexpr int kVoxelBytes = 2;
inline constexpr double kMemoryShare = 0.75;

// "<what> <value> mm is outside 0.01-50 mm" as an Error for `where`, or Ok.
Status check_spacing(const std::string& where, const std::string& what, double mm);

// The rescale within the limits above, finite: "<what> slope 1e+30 is outside ..." as an Error
// for `where`, or Ok. `what` names it as the file does ("Rescale Slope/Intercept" for DICOM).
Status check_rescale(const std::string& where, double slope, double intercept,
                     const std::string& what = "rescale");

// Every limit above except memory, on a reader's geometry (raw z positions allowed: the limit
// on the gap between neighbouring slices is checked only for gaps over 1e-3 mm, duplicates are
// make_uniform_z's to report).
Status check_geometry_limits(const std::string& where, const VolumeGeometry& g);

// width * height * slices * kVoxelBytes against kMemoryShare of `available_bytes` (default:
// MemAvailable from /proc/meminfo; no check when that cannot be read).
Status check_memory(const std::string& where, const VolumeGeometry& g,
                    std::optional<std::uint64_t> available_bytes = std::nullopt);

// MemAvailable from /proc/meminfo in bytes; nullopt when it cannot be read.
std::optional<std::uint64_t> available_memory_bytes();

}  // namespace sawyer::ct
