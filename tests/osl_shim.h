// OSL's built-ins and types as C++, enough to compile shaders/osl/sawyer_wood.h (the OSL
// shader's field code) into a test: the float math OSL gives, strings, output parameters as
// references, and sw_fetch reading the exported tables (float EXR files read back into memory)
// exactly as the shader's closest-texel texture() lookup does. Test-only; include it, then
// sawyer_wood.h, inside a namespace of your own.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>

#include "sawyer/render/image.h"

namespace sawyer::osl_shim {

// OSL's string; the test keeps the text alive (a table's name is its file's path).
using string = const char*;

inline float min(float a, float b) { return a < b ? a : b; }
inline float max(float a, float b) { return a > b ? a : b; }
inline int min(int a, int b) { return a < b ? a : b; }
inline int max(int a, int b) { return a > b ? a : b; }
inline float clamp(float x, float lo, float hi) { return min(max(x, lo), hi); }
inline int clamp(int x, int lo, int hi) { return min(max(x, lo), hi); }
inline float abs(float x) { return std::fabs(x); }
inline float floor(float x) { return std::floor(x); }
inline float sqrt(float x) { return std::sqrt(x); }
inline float pow(float a, float b) { return std::pow(a, b); }
inline float sin(float x) { return std::sin(x); }
inline float cos(float x) { return std::cos(x); }
inline float atan2(float y, float x) { return std::atan2(y, x); }
inline float mix(float a, float b, float t) { return a * (1.0f - t) + b * t; }
inline float smoothstep(float e0, float e1, float x) {
  if (x < e0) return 0.0f;
  if (x >= e1) return 1.0f;
  const float t = (x - e0) / (e1 - e0);
  return t * t * (3.0f - 2.0f * t);
}

// The tables by file name, as the shader's texture() finds them (looked up by the name's
// address: the test hands the shader the same strings it registered).
inline std::map<const char*, render::Image>& tables() {
  static std::map<const char*, render::Image> t;
  return t;
}

inline void sw_fetch(string file, int x, int y, int w, int h, float& a, float& b, float& c,
                     float& d) {
  const render::Image& im = tables().at(file);
  const int cx = clamp(x, 0, w - 1), cy = clamp(y, 0, h - 1);
  a = im.value(cx, cy, 0);
  b = im.value(cx, cy, 1);
  c = im.value(cx, cy, 2);
  d = im.value(cx, cy, 3);
}

}  // namespace sawyer::osl_shim

#define SW_UINT std::uint32_t
#define SW_SHR(x, n) ((x) >> (n))
#define SW_K(hex, signed_value) (static_cast<std::uint32_t>(hex##u))
#define SW_TO_UINT(x) (static_cast<std::uint32_t>(x))
#define SW_OUT(type) type&
