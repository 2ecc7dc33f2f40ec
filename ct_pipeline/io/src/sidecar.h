// The image-stack sidecar (sawyer_stack.json): its parser and its writer (sidecar.cpp). Internal.
//
// A TIFF or PNG slice carries no trustworthy geometry, so a stack comes with a small JSON file
// beside it (docs/ct_input.md lists the keys):
//
//   {"format": "sawyer-stack/1", "pixel_spacing_mm": [0.5, 0.5], "slice_spacing_mm": 2.0,
//    "rescale_slope": 1, "rescale_intercept": -1024}
//
// parse_stack_sidecar() checks every key it knows and names the key in its errors; keys it does
// not know are listed (the reader turns them into notes) rather than refused, so a hand-written
// sidecar with a comment still opens.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/core/vec.h"
#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct::detail {

inline constexpr const char* kStackSidecarName = "sawyer_stack.json";
inline constexpr const char* kStackFormatTag = "sawyer-stack/1";

struct StackSidecar {
  std::optional<double> pixel_spacing_x;  // mm between columns
  std::optional<double> pixel_spacing_y;  // mm between rows
  std::optional<double> slice_spacing;    // mm
  std::vector<double> z_mm;               // per-slice positions; empty when not given
  std::optional<double> rescale_slope;
  std::optional<double> rescale_intercept;
  std::optional<Vec3> origin;
  std::optional<std::array<double, 6>> orientation;
  std::vector<std::string> files;         // slice file names in z order; empty when not given
  std::vector<std::string> unknown_keys;  // for notes
};

// Parses sidecar text. `where` (the file name) leads every error: "<where>: "key" must be ...".
Result<StackSidecar> parse_stack_sidecar(const std::string& text, const std::string& where);

// Reads and parses `file`.
Result<StackSidecar> read_stack_sidecar(const std::filesystem::path& file);

// The sidecar the stack writer puts beside its slices: every key, z positions exactly as given.
std::string format_stack_sidecar(const VolumeGeometry& geometry, double rescale_slope,
                                 double rescale_intercept, const std::vector<std::string>& files);

}  // namespace sawyer::ct::detail
