// Just enough of GLSL's types and built-ins to compile shaders/wood_field.glsl as C++, so the
// renderer and the CPU code (the phantom's density, tests) share one source of the wood field.
// Everything is float, as on the GPU, and follows the GLSL 4.50 definitions (mod, fract,
// smoothstep, clamp, mix). Include this inside a namespace, then the .glsl file; calls in the
// .glsl file then resolve to these overloads only (no std:: or ::math functions take part).
#pragma once

#include <cmath>
#include <cstdint>

namespace sawyer::glsl {

using uint = std::uint32_t;

inline float min(float a, float b) { return b < a ? b : a; }
inline float max(float a, float b) { return a < b ? b : a; }
inline float abs(float a) { return std::fabs(a); }
inline float clamp(float x, float lo, float hi) { return min(max(x, lo), hi); }
inline float mix(float a, float b, float t) { return a + (b - a) * t; }
inline float floor(float x) { return std::floor(x); }
inline float fract(float x) { return x - std::floor(x); }
inline float mod(float x, float y) { return x - y * std::floor(x / y); }
inline float sqrt(float x) { return std::sqrt(x); }
inline float pow(float x, float y) { return std::pow(x, y); }
inline float exp(float x) { return std::exp(x); }
inline float log(float x) { return std::log(x); }
inline float sin(float x) { return std::sin(x); }
inline float cos(float x) { return std::cos(x); }
inline float atan(float y, float x) { return std::atan2(y, x); }
inline float smoothstep(float e0, float e1, float x) {
  const float t = clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

}  // namespace sawyer::glsl
