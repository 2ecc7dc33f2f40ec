// Images the renderer reads back, and writing them through OpenImageIO.
//
//   Image img = ...;                              // from Framebuffer::read() or a view
//   Status st = write_image("out/board.png", img);  // PNG, TIFF, EXR, JPEG by extension
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "sawyer/core/result.h"

namespace sawyer::render {

// Rows top to bottom, channels interleaved (RGBA). Either 8-bit (u8) or float (f32) holds the
// pixels, the other is empty.
struct Image {
  int width = 0, height = 0, channels = 4;
  std::vector<std::uint8_t> u8;
  std::vector<float> f32;
  bool is_float() const { return !f32.empty(); }
  float value(int x, int y, int c) const;  // 8-bit values scaled to [0, 1]
};

// Writes `image` to `path`, format from the extension (.png, .tif/.tiff, .exr, .jpg). Atomic:
// a temporary file beside it, then a rename; on failure nothing is left under `path`. Float
// images go to EXR as float, to other formats as 8-bit (clamped to [0, 1]).
Status write_image(const std::filesystem::path& path, const Image& image);

// Reads an image as 8-bit or float RGBA (alpha 1 when the file has none); errors name the file.
Result<Image> read_image(const std::filesystem::path& path, bool as_float = false);

// The mean of each n x n block of an 8-bit image (supersampled framebuffers); n = 1 returns it.
Image downsample(const Image& big, int n);

// True when the extension names a format write_image knows.
bool is_image_extension(const std::filesystem::path& path);

}  // namespace sawyer::render
