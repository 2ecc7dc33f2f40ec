// The maps library's only door to OpenImageIO (docs/style.md 5: third-party types stay at the
// edges). Images here are plain row-major arrays, top scanline first (row 0 is the top row as an
// image viewer shows it, which is the first texture row an OpenGL upload of the file's pixels
// gets).
//
// Every function catches what OpenImageIO may throw and returns one-line errors that name
// `shown` (the path the user knows; writers run inside a temporary folder whose name means
// nothing to the user).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/core/result.h"

namespace sawyer::maps_detail {

// 8-bit RGB, 3 bytes per pixel.
struct Rgb8Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;  // size width·height·3

  Rgb8Image() = default;
  Rgb8Image(int w, int h) : width(w), height(h), pixels(static_cast<size_t>(w) * h * 3, 0) {}
  std::uint8_t& at(int x, int y, int c) {
    return pixels[(static_cast<size_t>(y) * width + x) * 3 + c];
  }
  std::uint8_t at(int x, int y, int c) const {
    return pixels[(static_cast<size_t>(y) * width + x) * 3 + c];
  }
};

// Float32 with named channels, interleaved.
struct FloatImage {
  int width = 0, height = 0;
  std::vector<std::string> channels;
  std::vector<float> pixels;  // size width·height·channels

  FloatImage() = default;
  FloatImage(int w, int h, std::vector<std::string> names)
      : width(w),
        height(h),
        channels(std::move(names)),
        pixels(static_cast<size_t>(w) * h * channels.size(), 0.0f) {}
  float& at(int x, int y, int c) {
    return pixels[(static_cast<size_t>(y) * width + x) * channels.size() + c];
  }
  float at(int x, int y, int c) const {
    return pixels[(static_cast<size_t>(y) * width + x) * channels.size() + c];
  }
};

// Reads any image OpenImageIO knows as 8-bit RGB (the first three channels; other pixel types
// are converted). Errors: missing file, a folder, unreadable or corrupt or truncated data, fewer
// than three channels.
Result<Rgb8Image> read_rgb8(const std::filesystem::path& path);

// Writes an uncompressed 24-bit BMP at `path`.
Status write_bmp_rgb8(const std::filesystem::path& path, const Rgb8Image& image,
                      const std::string& shown);

// Reads the channels named `wanted` (in that order) as float32. Errors name a missing channel.
Result<FloatImage> read_float_channels(const std::filesystem::path& path,
                                       const std::vector<std::string>& wanted);

// Writes a float32 OpenEXR image (lossless compression) with the image's channel names.
Status write_exr_float(const std::filesystem::path& path, const FloatImage& image,
                       const std::string& shown);

}  // namespace sawyer::maps_detail
