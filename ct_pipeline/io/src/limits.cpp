// The CT input limits of limits.h.
#include "sawyer/ct/io/limits.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "text_parse.h"

namespace sawyer::ct {

namespace {

// Shortest faithful form: 0.4, 1e+300, nan.
using detail::num6;

std::string gib(double bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return buf;
}

bool in_range(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

}  // namespace

Status check_spacing(const std::string& where, const std::string& what, double mm) {
  if (in_range(mm, kMinSpacingMm, kMaxSpacingMm)) return Status::Ok();
  return Error(where, what + " " + num6(mm) + " mm is outside " + num6(kMinSpacingMm) + "-" +
                          num6(kMaxSpacingMm) + " mm");
}

Status check_rescale(const std::string& where, double slope, double intercept,
                     const std::string& what) {
  const double a = std::abs(slope);
  if (!(std::isfinite(slope) && a >= kMinAbsRescaleSlope && a <= kMaxAbsRescaleSlope))
    return Error(where, what + " slope " + num6(slope) + " is outside " +
                            num6(kMinAbsRescaleSlope) + "-" + num6(kMaxAbsRescaleSlope) +
                            " (either sign; HU = slope * stored value + intercept): no CT "
                            "scanner writes it");
  if (!in_range(intercept, -kMaxAbsRescaleIntercept, kMaxAbsRescaleIntercept))
    return Error(where, what + " intercept " + num6(intercept) + " HU is outside " +
                            num6(-kMaxAbsRescaleIntercept) + " to " +
                            num6(kMaxAbsRescaleIntercept) + " HU: no CT scanner writes it");
  return Status::Ok();
}

Status check_geometry_limits(const std::string& where, const VolumeGeometry& g) {
  for (const auto& [what, size] : {std::pair{"columns", g.width}, std::pair{"rows", g.height}}) {
    if (size < 1 || size > kMaxImageSize)
      return Error(where, std::string("image size: ") + std::to_string(size) + " " + what +
                              " is outside 1-" + std::to_string(kMaxImageSize));
  }
  if (Status st = check_spacing(where, "pixel spacing (x)", g.spacing_x); !st) return st;
  if (Status st = check_spacing(where, "pixel spacing (y)", g.spacing_y); !st) return st;
  const double fov_x = g.width * g.spacing_x, fov_y = g.height * g.spacing_y;
  if (fov_x > kMaxFieldOfViewMm || fov_y > kMaxFieldOfViewMm)
    return Error(where, "field of view " + num6(fov_x) + " x " + num6(fov_y) + " mm (" +
                            std::to_string(g.width) + " x " + std::to_string(g.height) +
                            " pixels of " + num6(g.spacing_x) + " x " + num6(g.spacing_y) +
                            " mm) is more than " + num6(kMaxFieldOfViewMm) + " mm across");
  const int n = g.slice_count();
  if (n < 1 || n > kMaxSliceCount)
    return Error(where, "slice count " + std::to_string(n) + " is outside 1-" +
                            std::to_string(kMaxSliceCount));
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(g.z[static_cast<size_t>(i)]))
      return Error(where, "slice " + std::to_string(i) + " position " +
                              num6(g.z[static_cast<size_t>(i)]) + " mm is not a finite number");
  }
  const double extent = g.z.back() - g.z.front();
  if (!(std::abs(extent) <= kMaxZExtentMm))
    return Error(where, "slices span " + num6(extent) + " mm along z, more than " +
                            num6(kMaxZExtentMm) + " mm (" + num6(kMaxZExtentMm / 1000) +
                            " m, longer than any log)");
  if (n >= 2) {
    if (Status st = check_spacing(where, "slice spacing", g.slice_spacing()); !st) return st;
    // Neighbours closer than the minimum spacing; gaps under 1e-3 mm are duplicates, which
    // make_uniform_z names as such.
    for (int i = 1; i < n; ++i) {
      const double d = g.z[static_cast<size_t>(i)] - g.z[static_cast<size_t>(i) - 1];
      if (d >= 1e-3 && d < kMinSpacingMm)
        return Error(where, "slices " + std::to_string(i - 1) + " and " + std::to_string(i) +
                                " are " + num6(d) + " mm apart; slice spacing must be " +
                                num6(kMinSpacingMm) + "-" + num6(kMaxSpacingMm) + " mm");
    }
  }
  if (Status st = check_rescale(where, g.rescale_slope, g.rescale_intercept); !st) return st;
  for (double v : {g.origin.x, g.origin.y, g.origin.z}) {
    if (!in_range(v, -kMaxPositionMm, kMaxPositionMm))
      return Error(where, "origin (" + num6(g.origin.x) + ", " + num6(g.origin.y) + ", " +
                              num6(g.origin.z) + ") mm is not within " + num6(kMaxPositionMm) +
                              " mm of the scanner's origin");
  }
  for (double v : g.orientation) {
    if (!in_range(v, -1.001, 1.001)) {
      std::string o;
      for (double c : g.orientation) {
        if (!o.empty()) o += ' ';
        o += num6(c);
      }
      return Error(where, "orientation (" + o + ") is not two sets of direction cosines");
    }
  }
  return Status::Ok();
}

std::optional<std::uint64_t> available_memory_bytes() {
  std::ifstream in("/proc/meminfo");
  std::string line;
  while (std::getline(in, line)) {
    if (!line.starts_with("MemAvailable:")) continue;
    std::istringstream s(line.substr(13));
    std::uint64_t kib = 0;
    if (s >> kib) return kib * 1024;
    return std::nullopt;
  }
  return std::nullopt;
}

Status check_memory(const std::string& where, const VolumeGeometry& g,
                    std::optional<std::uint64_t> available_bytes) {
  if (!available_bytes) available_bytes = available_memory_bytes();
  if (!available_bytes) return Status::Ok();  // no figure to hold it to (not Linux?)
  // In double: the product of three ints may pass 2^63 only on limits far above ours, but the
  // check must hold even if a caller skipped check_geometry_limits.
  const double need =
      static_cast<double>(g.width) * g.height * static_cast<double>(g.slice_count()) * kVoxelBytes;
  const double budget = kMemoryShare * static_cast<double>(*available_bytes);
  if (need <= budget) return Status::Ok();
  return Error(where, std::to_string(g.width) + " x " + std::to_string(g.height) + " x " +
                          std::to_string(g.slice_count()) + " voxels need " + gib(need) +
                          " as 16-bit voxels, more than " + num6(kMemoryShare * 100) +
                          " % of the " + gib(static_cast<double>(*available_bytes)) +
                          " of memory available");
}

}  // namespace sawyer::ct
