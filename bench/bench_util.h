// Shared by the benches that scan phantoms in memory (robustness, decision): a seeded random
// stream per condition and a SliceSource of a phantom's slices rendered up front.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"
#include "sawyer/ct/phantom/phantom.h"

namespace sawyer::bench {

// SplitMix64: one stream per condition, so a condition does not depend on the others drawn.
struct Rng {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform(double a, double b) { return a + (b - a) * (next() >> 11) * 0x1.0p-53; }
  // Log-uniform: as many draws per factor of two (pixels, spacing, noise span a wide ratio).
  double log_uniform(double a, double b) { return a * std::exp(uniform(0, std::log(b / a))); }
  bool chance(double p) { return uniform(0, 1) < p; }
  int integer(int a, int b) { return a + static_cast<int>(next() % (b - a + 1)); }
};

// The kept slices rendered up front by `threads` Renderers (PhantomSource renders on one), as
// float HU, or quantised to the 256 levels of the windowed 8-bit export exactly as
// write_phantom stores them (stored = round((HU - intercept) / slope), clipped to 0-255) and read
// back (HU = stored x slope + intercept).
class MemorySource final : public ct::SliceSource {
 public:
  MemorySource(const ct::Phantom& p, int threads, bool windowed) : p_(p) {
    const std::vector<int>& kept = p.kept();
    slices_.resize(kept.size());
    std::vector<std::thread> pool;
    const int n = static_cast<int>(kept.size());
    for (int t = 0; t < threads; ++t)
      pool.emplace_back([&, t] {
        ct::Phantom::Renderer renderer(p);  // ascending slices per thread: the fast path
        for (int i = n * t / threads; i < n * (t + 1) / threads; ++i)
          renderer.render(kept[static_cast<size_t>(i)], slices_[static_cast<size_t>(i)]);
      });
    for (std::thread& th : pool) th.join();
    if (windowed) {
      const ct::PhantomOptions& o = p.options();
      const double slope = o.window_width_hu / 255.0;
      const double icpt = o.window_centre_hu - 0.5 * o.window_width_hu;
      for (ct::Slice& s : slices_)
        for (float& v : s.hu)
          v = static_cast<float>(std::clamp(std::round((v - icpt) / slope), 0.0, 255.0) * slope +
                                 icpt);
    }
  }
  ct::Format format() const override { return ct::Format::kDicom; }
  const ct::VolumeGeometry& geometry() const override { return p_.geometry(); }
  std::string description() const override { return "phantom of " + p_.log().id; }
  const std::vector<std::string>& notes() const override { return notes_; }
  Status read(int i, ct::Slice& out) override {
    if (i < 0 || i >= static_cast<int>(slices_.size()))
      return Error("phantom in memory", "slice index");
    out = slices_[static_cast<size_t>(i)];
    out.index = i;
    return Status::Ok();
  }

 private:
  const ct::Phantom& p_;
  std::vector<ct::Slice> slices_;
  std::vector<std::string> notes_;
};

}  // namespace sawyer::bench
