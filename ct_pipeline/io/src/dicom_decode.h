// One DICOM slice's pixel data to HU (dicom_decode.cpp): native data read at its offset, or
// encapsulated data decoded by GDCM's codecs (CharLS for JPEG-LS), then a stored value -> HU
// table. Internal.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "sawyer/core/result.h"

namespace sawyer::ct::detail {

// Everything read() needs for one slice, in z order.
struct SliceFile {
  std::filesystem::path path;
  double z = 0;
  double slope = 1, intercept = 0;
  int bits_allocated = 16, bits_stored = 16, high_bit = 15;
  bool pixel_signed = false;
  bool native = true;
  bool big_endian = false;
  int64_t pixel_offset = 0;
  std::string transfer_syntax;
};

// Per-thread decoding state: the raw bytes and the stored value -> HU table, rebuilt only when
// the pixel format or the rescale changes.
class SliceDecoder {
 public:
  Status decode(const SliceFile& s, int width, int height, std::vector<float>& hu);

 private:
  struct PixelLayout {
    int bits_allocated, bits_stored, high_bit;
    bool pixel_signed, big_endian;
    bool operator==(const PixelLayout&) const = default;
  };

  Status decode_with_gdcm(const SliceFile& s, int width, int height, PixelLayout& layout);
  void build_lut(const PixelLayout& layout, double slope, double intercept);

  std::vector<uint8_t> raw_;
  std::vector<float> lut_;
  bool has_lut_ = false;
  PixelLayout lut_layout_{};
  double lut_slope_ = 0, lut_intercept_ = 0;
};

}  // namespace sawyer::ct::detail
