// What the writers share (staging.cpp): the staging folder that makes a write all-or-nothing,
// and the rounding of HU to stored values. Internal.
#pragma once

#include <cmath>
#include <filesystem>

#include "sawyer/core/result.h"

namespace sawyer::ct::detail {

// A temporary sibling folder ".<name>.tmp<random>" next to `out` that a writer fills slice by
// slice; commit() moves it into place (replacing an existing `out` whole), and the destructor
// removes it when commit() never ran, so a failed or abandoned write leaves nothing behind.
class StagingDir {
 public:
  static Result<StagingDir> create(const std::filesystem::path& out);
  StagingDir(StagingDir&& other) noexcept;
  StagingDir& operator=(StagingDir&&) = delete;
  StagingDir(const StagingDir&) = delete;
  StagingDir& operator=(const StagingDir&) = delete;
  ~StagingDir();

  const std::filesystem::path& path() const { return tmp_; }
  const std::filesystem::path& out() const { return out_; }
  Status commit();

 private:
  StagingDir(std::filesystem::path out, std::filesystem::path tmp)
      : out_(std::move(out)), tmp_(std::move(tmp)) {}
  std::filesystem::path out_;
  std::filesystem::path tmp_;  // empty once committed or moved from
};

// The stack and volume writers store HU as round((hu - intercept) / slope) clamped to [lo, hi]
// (callers refuse non-finite HU first; NaN would map to lo).
inline double stored_value(float hu, double slope, double intercept, double lo, double hi) {
  const double v = (static_cast<double>(hu) - intercept) / slope;
  if (!(v > lo)) return lo;  // also NaN
  if (v >= hi) return hi;
  return std::nearbyint(v);
}

}  // namespace sawyer::ct::detail
