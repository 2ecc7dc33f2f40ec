// Command-line options shared by every subcommand that reads a CT scan (info, and later scan):
// DICOM series choice, spacing and rescale for image stacks, and the policy for uneven z.
#pragma once

#include <CLI/CLI.hpp>

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

#include "sawyer/ct/io/slice_source.h"

namespace sawyer::app {

struct CtCliOptions {
  std::string series;
  std::optional<double> pixel_spacing, slice_spacing, rescale_slope, rescale_intercept;
  bool strict_z = false;
  bool allow_gaps = false;
};

// Adds --series, --pixel-spacing, --slice-spacing, --rescale-slope, --rescale-intercept,
// --strict-z and --allow-gaps to `cmd`, bound to `o`. Spacings must be 0.01-50 mm (the readers'
// limits, sawyer/ct/io/limits.h), the rescale slope non-zero within +-1e-4..1e4, the intercept
// within +-1e5: every number finite.
void add_ct_options(CLI::App* cmd, CtCliOptions& o);

ct::OpenOptions to_open_options(const CtCliOptions& o);

// Opens the scan at `path`, reads every slice once and prints what was found: format, slice
// count and size, spacing, z extent, stored type and rescale, HU range, and any problems.
// Progress goes to `progress` (stderr) for long scans. Returns an Error for unreadable input.
Status print_ct_info(const std::filesystem::path& path, const ct::OpenOptions& options,
                     std::ostream& out, std::ostream& progress);

}  // namespace sawyer::app
