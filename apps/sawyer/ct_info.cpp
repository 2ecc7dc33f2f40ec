// `sawyer info <ct-folder>`: what a CT scan holds, read the way the pipeline will read it.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_checks.h"
#include "cli_error.h"
#include "ct_options.h"
#include "sawyer/ct/io/limits.h"
#include "sawyer/ct/io/scanner_frame.h"

namespace sawyer::app {

void add_ct_options(CLI::App* cmd, CtCliOptions& o) {
  cmd->add_option("--series", o.series,
                  "DICOM: which series of a folder holding several (UID, UID prefix, or number)");
  cmd->add_option("--pixel-spacing", o.pixel_spacing, "image stacks: pixel size in mm")
      ->check(number_in(ct::kMinSpacingMm, ct::kMaxSpacingMm, " mm"));
  cmd->add_option("--slice-spacing", o.slice_spacing, "image stacks: distance between slices, mm")
      ->check(number_in(ct::kMinSpacingMm, ct::kMaxSpacingMm, " mm"));
  cmd->add_option("--rescale-slope", o.rescale_slope,
                  "image stacks: HU = slope * value + intercept")
      ->check(number_in(-ct::kMaxAbsRescaleSlope, ct::kMaxAbsRescaleSlope, "",
                        ct::kMinAbsRescaleSlope));
  cmd->add_option("--rescale-intercept", o.rescale_intercept, "image stacks: see --rescale-slope")
      ->check(number_in(-ct::kMaxAbsRescaleIntercept, ct::kMaxAbsRescaleIntercept, " HU"));
  cmd->add_flag("--strict-z", o.strict_z,
                "refuse uneven slice spacing or missing slices instead of resampling along z");
  cmd->add_flag("--allow-gaps", o.allow_gaps,
                "resample along z even when more than 10 % of the slices would be invented or "
                "one gap is wider than 50 mm (refused without it)");
}

ct::OpenOptions to_open_options(const CtCliOptions& o) {
  ct::OpenOptions r;
  r.series = o.series;
  r.pixel_spacing = o.pixel_spacing;
  r.slice_spacing = o.slice_spacing;
  r.rescale_slope = o.rescale_slope;
  r.rescale_intercept = o.rescale_intercept;
  r.z_policy = o.strict_z ? ct::ZPolicy::kReject : ct::ZPolicy::kResample;
  r.allow_gaps = o.allow_gaps;
  return r;
}

namespace {

// HU histogram in 1 HU bins over the range CT values take; values outside land in the ends.
class HuHistogram {
 public:
  static constexpr int kLo = -3072, kHi = 8191;
  HuHistogram() : bins_(kHi - kLo + 1, 0) {}
  void add(float v) {
    lo_ = std::min(lo_, v);
    hi_ = std::max(hi_, v);
    const int b = std::clamp(static_cast<int>(std::lround(v)), kLo, kHi) - kLo;
    ++bins_[b];
    ++n_;
  }
  std::int64_t count() const { return n_; }
  float min() const { return lo_; }
  float max() const { return hi_; }
  // Value below which fraction q of the samples lie.
  int quantile(double q) const {
    const auto want = static_cast<std::int64_t>(q * static_cast<double>(n_));
    std::int64_t acc = 0;
    for (size_t i = 0; i < bins_.size(); ++i) {
      acc += bins_[i];
      if (acc > want) return static_cast<int>(i) + kLo;
    }
    return kHi;
  }
  double fraction_above(int hu) const {
    std::int64_t acc = 0;
    for (size_t i = static_cast<size_t>(hu - kLo) + 1; i < bins_.size(); ++i) acc += bins_[i];
    return n_ ? static_cast<double>(acc) / static_cast<double>(n_) : 0.0;
  }

 private:
  std::vector<std::int64_t> bins_;
  std::int64_t n_ = 0;
  float lo_ = 1e30f, hi_ = -1e30f;
};

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace

Status print_ct_info(const std::filesystem::path& path, const ct::OpenOptions& options,
                     std::ostream& out, std::ostream& progress) {
  auto opened = ct::open_ct(path, options);
  if (!opened) return opened.error();
  ct::SliceSource& src = *opened.value();
  const ct::VolumeGeometry& g = src.geometry();
  const int n = g.slice_count();

  HuHistogram hist;
  std::int64_t nonfinite = 0;
  ct::Slice s;
  int next_report = 1;
  for (int i = 0; i < n; ++i) {
    if (Status st = src.read(i, s); !st) return st;
    for (float v : s.hu) {
      if (std::isfinite(v)) {
        hist.add(v);
      } else {
        ++nonfinite;
      }
    }
    if (n >= 200 && (i + 1) * 10 >= next_report * n) {
      progress << "sawyer: reading slices " << (i + 1) << "/" << n << "\n";
      ++next_report;
    }
  }

  const auto row = [&out](const char* key, const std::string& value) {
    out << std::left << std::setw(15) << key << value << "\n";
  };
  row("CT scan", path.string());
  row("format", ct::format_name(src.format()));
  row("source", src.description());
  row("slices", std::to_string(n) + " of " + std::to_string(g.width) + " x " +
                    std::to_string(g.height) + " pixels");
  row("pixel spacing", fixed(g.spacing_x, 3) + " x " + fixed(g.spacing_y, 3) +
                           " mm (field of view " + fixed(g.width * g.spacing_x, 1) + " x " +
                           fixed(g.height * g.spacing_y, 1) + " mm)");
  row("slice spacing", fixed(g.slice_spacing(), 3) + " mm");
  row("z extent", fixed(g.z.front(), 1) + " .. " + fixed(g.z.back(), 1) + " mm (" +
                      fixed(g.z_extent() / 1000.0, 3) + " m)");
  row("origin", "(" + fixed(g.origin.x, 2) + ", " + fixed(g.origin.y, 2) + ", " +
                    fixed(g.origin.z, 2) + ") mm");
  const auto& o = g.orientation;
  row("orientation", "row (" + fixed(o[0], 3) + ", " + fixed(o[1], 3) + ", " + fixed(o[2], 3) +
                         ") column (" + fixed(o[3], 3) + ", " + fixed(o[4], 3) + ", " +
                         fixed(o[5], 3) + "): " + ct::slice_orientation_text(g));
  row("stored",
      std::to_string(g.bits_stored) + "-bit " +
          (g.bits_stored == 32 ? "float" : std::string(g.pixel_signed ? "signed" : "unsigned")) +
          ", HU = " + fixed(g.rescale_slope, 4) + " * value + " + fixed(g.rescale_intercept, 2));
  if (hist.count() > 0) {
    row("HU range", fixed(hist.min(), 0) + " .. " + fixed(hist.max(), 0) +
                        " (1st-99th percentile " + std::to_string(hist.quantile(0.01)) + " .. " +
                        std::to_string(hist.quantile(0.99)) + ")");
    row("above -500 HU", fixed(100.0 * hist.fraction_above(-500), 1) +
                             " % of voxels (wood, bark and anything else dense)");
  }
  if (const std::string z = ct::resampling_summary(g); !z.empty()) row("z grid", z);
  std::vector<std::string> problems;
  for (const std::string& n : src.notes()) problems.push_back(with_flags(n));
  if (nonfinite > 0) problems.push_back(std::to_string(nonfinite) + " voxels are NaN or infinite");
  if (problems.empty()) {
    row("problems", "none");
  } else {
    row("problems", problems.front());
    for (size_t i = 1; i < problems.size(); ++i) row("", problems[i]);
  }
  return Status::Ok();
}

}  // namespace sawyer::app
