// Minimal 2D/3D vectors in millimetres for the model's public API (no Eigen in model headers).
#pragma once

#include <cmath>

namespace sawyer {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kTwoPi = 2.0 * kPi;

struct Vec2 {
  double x = 0, y = 0;
  friend Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
  friend Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
  friend Vec2 operator*(double s, Vec2 a) { return {s * a.x, s * a.y}; }
  friend bool operator==(const Vec2&, const Vec2&) = default;
  double norm() const { return std::hypot(x, y); }
};

struct Vec3 {
  double x = 0, y = 0, z = 0;
  friend Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
  friend Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
  friend Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
  friend bool operator==(const Vec3&, const Vec3&) = default;
  double norm() const { return std::sqrt(x * x + y * y + z * z); }
  Vec3 normalized() const {
    const double n = norm();
    return n > 0 ? Vec3{x / n, y / n, z / n} : Vec3{};
  }
};

inline double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// Wraps an angle to [0, 2π).
inline double wrap_angle(double a) {
  a = std::fmod(a, kTwoPi);
  return a < 0 ? a + kTwoPi : a;
}

// Signed smallest difference a − b, in (−π, π].
inline double angle_diff(double a, double b) {
  double d = wrap_angle(a - b);
  return d > kPi ? d - kTwoPi : d;
}

}  // namespace sawyer
