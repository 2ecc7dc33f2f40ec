// Internal pieces of the phantom shared by its source files: the per-height layer of the wood
// field, the clutter shapes, and the deterministic random numbers.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "sawyer/ct/phantom/phantom.h"

namespace sawyer::ct {

// Azimuth samples of the heartwood radius and bark thickness in a layer (linear between them).
inline constexpr int kLayerAngles = 720;

// Everything that depends only on the log-frame height: the field's Slice plus the phantom's
// own angular tables. Built once per height and shared by every pixel at that height.
struct Phantom::Layer {
  WoodField::Slice field;
  double z = 0;
  std::vector<float> heart;  // kLayerAngles + 1 (wraps)
  std::vector<float> bark;
  float max_outer = 0;  // largest R + bark at this height
};

// A steel object of the clutter, fixed in the scanner frame.
struct Phantom::ClutterShape {
  enum class Kind { kBar, kLink } kind = Kind::kBar;
  // Bar: axis-aligned box [lo, hi].
  Vec3 lo, hi;
  // Chain link: a stadium-shaped wire loop centred at c, long axis along e_u, in the plane of
  // e_u and e_v (normal e_w); straight half-length h, end radius rho, wire radius a.
  Vec3 c, e_u, e_v, e_w;
  double h = 0, rho = 0, a = 0;
  double z_min = 0, z_max = 0;  // scanner z it occupies
  bool contains(const Vec3& p) const;
};

namespace phantom_detail {

// SplitMix64: a small, well-mixed generator whose output is the same on every platform, so a
// seed gives the same noise everywhere (std::normal_distribution is implementation-defined).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : s_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  // Uniform in (0, 1].
  double uniform() { return (static_cast<double>(next() >> 11) + 1.0) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Two independent standard normals (Box-Muller).
  void normal2(double* a, double* b) {
    const double r = std::sqrt(-2.0 * std::log(uniform()));
    const double t = 2.0 * 3.14159265358979323846 * uniform();
    *a = r * std::cos(t);
    *b = r * std::sin(t);
  }

 private:
  std::uint64_t s_;
};

// A seed for one purpose ("noise" of slice i, "drop", "clutter") from the user's seed.
inline std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t purpose, std::uint64_t index) {
  Rng r(seed ^ (purpose * 0xd1b54a32d192ed03ull));
  r.next();
  Rng r2(r.next() ^ (index * 0x8cb92ba72f3d8dd7ull + 0x632be59bd9b4e019ull));
  return r2.next();
}

inline constexpr std::uint64_t kNoiseStream = 1, kDropStream = 2, kClutterStream = 3;
// Defects: one stream per kind (the index), so that asking for one kind moves no other.
inline constexpr std::uint64_t kDefectStream = 4;

}  // namespace phantom_detail
}  // namespace sawyer::ct
