// make_uniform_z(): puts any SliceSource on an even z grid, or refuses.
//
// Real series are not always even: a scanner drops slices, a log is scanned in two passes, the
// table moves with a little jitter. Downstream stages (pith tracking, knot fitting, the stem
// model's fixed dz) assume an even grid, so every reader's output goes through here:
//  - duplicate or backwards positions (|dz| < 1e-3 mm) are always an error;
//  - every gap within 1% of the median spacing: pass through, z snapped to i * spacing;
//  - otherwise kReject lists the uneven gaps, and kResample interpolates linearly along z onto
//    an even grid at the median spacing, keeping only the two bracketing source slices;
//  - but kResample refuses, unless allow_gaps, to invent more than max_invented_fraction of the
//    output slices or to fill a gap wider than max_gap_mm (limits.h says why 10 % and 50 mm).
//    What it did is in geometry().z_resampling, and resampling_summary() says it in one line.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "readers.h"
#include "sawyer/ct/io/slice_source.h"
#include "text_parse.h"

namespace sawyer::ct {

namespace {

constexpr double kDuplicateTolerance = 1e-3;  // mm
constexpr double kEvenTolerance = 0.01;       // fraction of the median spacing
// A grid that is even gap by gap may still drift from i * spacing over thousands of slices;
// beyond this fraction of a spacing the positions are resampled rather than relabelled.
constexpr double kMaxSnap = 0.1;

using detail::fixed;

// Notes and messages print one decimal for ordinary spacings, more for sub-millimetre ones.
int decimals_for(double spacing) { return spacing >= 1.0 ? 1 : 3; }

// Forwards a source whose positions are already even to within kEvenTolerance, reporting the
// exact grid i * spacing.
class SnappedSource final : public SliceSource {
 public:
  SnappedSource(std::unique_ptr<SliceSource> src, double spacing)
      : src_(std::move(src)), geometry_(src_->geometry()), notes_(src_->notes()) {
    for (size_t i = 0; i < geometry_.z.size(); ++i)
      geometry_.z[i] = static_cast<double>(i) * spacing;
  }
  Format format() const override { return src_->format(); }
  const VolumeGeometry& geometry() const override { return geometry_; }
  std::string description() const override { return src_->description(); }
  const std::vector<std::string>& notes() const override { return notes_; }
  Status read(int i, Slice& out) override {
    if (Status st = src_->read(i, out); !st) return st;
    out.index = i;
    out.z = geometry_.z[static_cast<size_t>(i)];
    return Status::Ok();
  }

 private:
  std::unique_ptr<SliceSource> src_;
  VolumeGeometry geometry_;
  std::vector<std::string> notes_;
};

// Linear interpolation along z onto k * spacing. Streaming: two cached source slices, which
// are the bracketing pair for ascending reads, so each source slice is read once.
class ResampledSource final : public SliceSource {
 public:
  ResampledSource(std::unique_ptr<SliceSource> src, double spacing, int count,
                  std::vector<std::string> extra_notes, const ZResampling& info)
      : src_(std::move(src)),
        geometry_(src_->geometry()),
        source_z_(src_->geometry().z),
        notes_(src_->notes()) {
    geometry_.z_resampling = info;
    geometry_.z.resize(static_cast<size_t>(count));
    for (int k = 0; k < count; ++k) geometry_.z[static_cast<size_t>(k)] = k * spacing;
    for (auto& n : extra_notes) notes_.push_back(std::move(n));
  }
  Format format() const override { return src_->format(); }
  const VolumeGeometry& geometry() const override { return geometry_; }
  std::string description() const override { return src_->description(); }
  const std::vector<std::string>& notes() const override { return notes_; }

  Status read(int k, Slice& out) override {
    const int count = geometry_.slice_count();
    if (k < 0 || k >= count)
      return Error(src_->description(), "slice " + std::to_string(k) + " is out of range 0.." +
                                            std::to_string(count - 1));
    const int n = static_cast<int>(source_z_.size());
    // Source z is relative to its first slice; the output grid starts there too.
    const double z = source_z_.front() + geometry_.z[static_cast<size_t>(k)];
    int j = static_cast<int>(std::upper_bound(source_z_.begin(), source_z_.end(), z) -
                             source_z_.begin()) -
            1;
    j = std::clamp(j, 0, n - 2);
    const double z0 = source_z_[static_cast<size_t>(j)];
    const double z1 = source_z_[static_cast<size_t>(j) + 1];
    const double t = std::clamp((z - z0) / (z1 - z0), 0.0, 1.0);

    const size_t pixels = static_cast<size_t>(geometry_.width) * geometry_.height;
    out.hu.resize(pixels);
    if (t < 1e-9 || t > 1.0 - 1e-9) {
      const Slice* s = nullptr;
      if (Status st = fetch(t < 0.5 ? j : j + 1, -1, &s); !st) return st;
      std::copy(s->hu.begin(), s->hu.end(), out.hu.begin());
    } else {
      const Slice* a = nullptr;
      const Slice* b = nullptr;
      if (Status st = fetch(j, j + 1, &a); !st) return st;
      if (Status st = fetch(j + 1, j, &b); !st) return st;
      const float wa = static_cast<float>(1.0 - t), wb = static_cast<float>(t);
      const float* pa = a->hu.data();
      const float* pb = b->hu.data();
      float* po = out.hu.data();
      for (size_t p = 0; p < pixels; ++p) po[p] = wa * pa[p] + wb * pb[p];
    }
    out.index = k;
    out.z = geometry_.z[static_cast<size_t>(k)];
    out.width = geometry_.width;
    out.height = geometry_.height;
    return Status::Ok();
  }

 private:
  // Makes source slice `i` available in a cache slot, never evicting slice `keep` (-1: none).
  Status fetch(int i, int keep, const Slice** out) {
    for (Slice& s : cache_) {
      if (s.index == i) {
        *out = &s;
        return Status::Ok();
      }
    }
    // Evict the slot that is not `keep`; of two candidates, the lower index (reads ascend).
    Slice* victim = nullptr;
    for (Slice& s : cache_) {
      if (keep >= 0 && s.index == keep) continue;
      if (!victim || s.index < victim->index) victim = &s;
    }
    assert(victim);
    if (Status st = src_->read(i, *victim); !st) {
      victim->index = -1;
      return st;
    }
    if (victim->hu.size() != static_cast<size_t>(geometry_.width) * geometry_.height) {
      victim->index = -1;
      return Error(src_->description(), "slice " + std::to_string(i) + " has the wrong size");
    }
    victim->index = i;
    *out = victim;
    return Status::Ok();
  }

  std::unique_ptr<SliceSource> src_;
  VolumeGeometry geometry_;
  std::vector<double> source_z_;
  std::vector<std::string> notes_;
  Slice cache_[2];
};

struct Gap {
  double z0, z1;  // the positions on either side, relative to the first slice
  int missing;    // slices missing (0: uneven but not a missing slice)
};

// Interpolating across a few missing slices is harmless; inventing a large share of the log, or
// filling one gap a knot whorl fits in, makes up wood nobody scanned. Both need allow_gaps.
// One invented slice alone is always accepted (a scanner drops one now and then, and in a short
// section that one alone can be more than 10 %), as long as its gap is not too wide.
Status check_invented(const std::string& where, const ZResampling& info, int count, double median,
                      const OpenOptions& options) {
  if (options.allow_gaps || info.invented_slices == 0) return Status::Ok();
  const double fraction = static_cast<double>(info.invented_slices) / count;
  const bool too_many = info.invented_slices > 1 && fraction > options.max_invented_fraction;
  if (!too_many && info.widest_gap_mm <= options.max_gap_mm) return Status::Ok();
  const int dec = decimals_for(median);
  return Error(
      where,
      "slices missing along z: resampling would invent " + std::to_string(info.invented_slices) +
          " of " + std::to_string(count) + " slices (" + fixed(100.0 * fraction, 1) + " %, limit " +
          fixed(100.0 * options.max_invented_fraction, 0) + " %) in " + std::to_string(info.gaps) +
          " gap" + (info.gaps == 1 ? "" : "s") + ", widest z=" + fixed(info.widest_gap_z0, dec) +
          ".." + fixed(info.widest_gap_z0 + info.widest_gap_mm, dec) + " mm (" +
          fixed(info.widest_gap_mm, dec) + " mm, limit " + fixed(options.max_gap_mm, 0) +
          " mm); OpenOptions::allow_gaps resamples anyway");
}

}  // namespace

Result<std::unique_ptr<SliceSource>> make_uniform_z(std::unique_ptr<SliceSource> source,
                                                    const OpenOptions& options) {
  return detail::make_uniform_z(std::move(source), options, "");
}

Result<std::unique_ptr<SliceSource>> detail::make_uniform_z(std::unique_ptr<SliceSource> source,
                                                            const OpenOptions& options,
                                                            const std::string& file) {
  assert(source);
  const VolumeGeometry& g = source->geometry();
  const std::vector<double>& z = g.z;
  const int n = g.slice_count();
  if (n < 2) return source;
  // Messages name the path the user gave (the series description alone does not say which
  // folder); a source made without one is named by its description.
  const std::string where = file.empty() ? source->description() : file;
  if (!(options.gap_tolerance > 1.0))
    return Error(where, "gap tolerance must be more than 1 median spacing, got " +
                            fixed(options.gap_tolerance, 2));
  if (!(options.max_invented_fraction >= 0 && options.max_invented_fraction <= 1))
    return Error(where, "the share of invented slices allowed must be 0-1, got " +
                            fixed(options.max_invented_fraction, 3));
  if (!(options.max_gap_mm > 0) || !std::isfinite(options.max_gap_mm))
    return Error(where, "the widest gap allowed must be a positive number of mm, got " +
                            fixed(options.max_gap_mm, 1));

  for (double v : z) {
    if (!std::isfinite(v) || std::abs(v) > 1e9)
      return Error(where, "slice positions are not usable numbers");
  }
  for (int i = 1; i < n; ++i) {
    const double d = z[static_cast<size_t>(i)] - z[static_cast<size_t>(i) - 1];
    if (std::abs(d) < kDuplicateTolerance)
      return Error(where, "duplicate slice positions: slices " + std::to_string(i - 1) + " and " +
                              std::to_string(i) +
                              " both at z=" + fixed(z[static_cast<size_t>(i)] - z[0], 3) + " mm");
    if (d < 0)
      return Error(where, "slice positions go backwards: slice " + std::to_string(i) +
                              " at z=" + fixed(z[static_cast<size_t>(i)] - z[0], 3) +
                              " mm after slice " + std::to_string(i - 1) +
                              " at z=" + fixed(z[static_cast<size_t>(i) - 1] - z[0], 3) + " mm");
  }

  const double median = g.slice_spacing();
  const int dec = decimals_for(median);
  std::vector<Gap> gaps;
  double worst_jitter = 0;
  int jitter_count = 0;
  for (int i = 1; i < n; ++i) {
    const double z0 = z[static_cast<size_t>(i) - 1] - z[0];
    const double z1 = z[static_cast<size_t>(i)] - z[0];
    const double d = z1 - z0;
    if (d > options.gap_tolerance * median) {
      gaps.push_back({z0, z1, std::max(1, static_cast<int>(std::lround(d / median)) - 1)});
    } else if (std::abs(d - median) > kEvenTolerance * median) {
      gaps.push_back({z0, z1, 0});
      worst_jitter = std::max(worst_jitter, std::abs(d - median));
      ++jitter_count;
    }
  }

  const double extent = z.back() - z.front();
  if (gaps.empty()) {
    // Even gap by gap. Snap onto the mean spacing, which keeps both ends exact, unless the
    // positions wander too far from that grid.
    const double spacing = extent / (n - 1);
    double drift = 0;
    for (int i = 0; i < n; ++i)
      drift = std::max(drift, std::abs(z[static_cast<size_t>(i)] - z[0] - i * spacing));
    if (drift < 1e-6 && z[0] == 0.0) return source;
    if (drift <= kMaxSnap * spacing)
      return std::unique_ptr<SliceSource>(new SnappedSource(std::move(source), spacing));
    worst_jitter = drift;  // resample below, reported as unevenness
  }

  if (options.z_policy == ZPolicy::kReject) {
    std::string list;
    constexpr size_t kMaxListed = 8;
    for (size_t k = 0; k < gaps.size() && k < kMaxListed; ++k) {
      // A gap that prints like the median at the usual precision gets more digits.
      const double width = gaps[k].z1 - gaps[k].z0;
      const int wdec = fixed(width, dec) == fixed(median, dec) ? 3 : dec;
      list += (k ? ", " : "") + std::string("z=") + fixed(gaps[k].z0, dec) + ".." +
              fixed(gaps[k].z1, dec) + " mm (" + fixed(width, wdec) + " mm)";
    }
    if (gaps.size() > kMaxListed)
      list += " and " + std::to_string(gaps.size() - kMaxListed) + " more";
    if (gaps.empty())
      return Error(where, "uneven slice spacing: positions drift up to " + fixed(worst_jitter, 3) +
                              " mm from an even " + fixed(extent / (n - 1), dec) + " mm grid");
    // One gap reads "gaps at z=a..b mm (d mm, median m mm)"; several end with "; median m mm".
    if (gaps.size() == 1) {
      list.pop_back();
      list += ", median " + fixed(median, dec) + " mm)";
    } else {
      list += "; median " + fixed(median, dec) + " mm";
    }
    return Error(where, "uneven slice spacing: gaps at " + list);
  }

  std::vector<std::string> notes;
  int missing_gaps = 0;
  constexpr int kMaxNotes = 10;
  for (const Gap& gap : gaps) {
    if (gap.missing == 0) continue;
    if (++missing_gaps <= kMaxNotes) {
      notes.push_back("resampled along z: " + std::to_string(gap.missing) + " missing slice" +
                      (gap.missing == 1 ? "" : "s") + " between z=" + fixed(gap.z0, dec) +
                      " and z=" + fixed(gap.z1, dec) + " mm");
    }
  }
  if (missing_gaps > kMaxNotes)
    notes.push_back("resampled along z: " + std::to_string(missing_gaps - kMaxNotes) +
                    " more gaps with missing slices");
  if (jitter_count > 0 || gaps.empty()) {
    notes.push_back("resampled along z: " +
                    (gaps.empty() ? std::string("positions drift")
                                  : std::to_string(jitter_count) + " uneven gap" +
                                        (jitter_count == 1 ? "" : "s")) +
                    " (up to " + fixed(worst_jitter, 3) + " mm off the median " +
                    fixed(median, dec) + " mm) interpolated onto an even grid");
  }
  // Output slices cover the source extent; a grid point within 1% of a spacing past the last
  // slice is kept (it reads the last slice).
  const double grid = std::floor(extent / median + 0.01) + 1;
  // A few far-off positions in a dense series would ask for an absurd grid: refuse rather than
  // allocate it.
  if (grid > 10.0 * n + 1000.0)
    return Error(where, "slice positions span " + fixed(extent, dec) +
                            " mm at a median spacing of " + fixed(median, 3) + " mm; resampling " +
                            std::to_string(n) + " slices would need " + fixed(grid, 0) +
                            " output slices (positions corrupt?)");
  const int count = static_cast<int>(grid);

  ZResampling info;
  info.resampled = true;
  info.source_slices = n;
  for (const Gap& gap : gaps) {
    if (gap.missing == 0) continue;
    info.invented_slices += gap.missing;
    ++info.gaps;
    if (gap.z1 - gap.z0 > info.widest_gap_mm) {
      info.widest_gap_mm = gap.z1 - gap.z0;
      info.widest_gap_z0 = gap.z0;
    }
  }
  if (Status st = check_invented(where, info, count, median, options); !st) return st.error();
  return std::unique_ptr<SliceSource>(
      new ResampledSource(std::move(source), median, count, std::move(notes), info));
}

std::string resampling_summary(const VolumeGeometry& g) {
  const ZResampling& r = g.z_resampling;
  if (!r.resampled) return "";
  const double spacing = g.slice_spacing();
  const int dec = decimals_for(spacing);
  std::string s = "resampled along z: " + std::to_string(r.source_slices) +
                  " slices in the files, " + std::to_string(g.slice_count()) + " out at " +
                  fixed(spacing, dec) + " mm; ";
  if (r.invented_slices == 0) return s + "uneven spacing interpolated, no slice invented";
  return s + std::to_string(r.invented_slices) + " invented (" +
         fixed(100.0 * r.invented_slices / std::max(1, g.slice_count()), 1) + " %) in " +
         std::to_string(r.gaps) + " gap" + (r.gaps == 1 ? "" : "s") + ", widest " +
         fixed(r.widest_gap_mm, dec) + " mm at z=" + fixed(r.widest_gap_z0, dec) + ".." +
         fixed(r.widest_gap_z0 + r.widest_gap_mm, dec) + " mm";
}

}  // namespace sawyer::ct
