// Decoding of the common CT PNG (8- or 16-bit grey, not interlaced) without libpng/OpenImageIO:
// with libdeflate's inflate it takes about half the CPU per slice, and PNG decoding is what limits
// reading a PNG stack. Every other PNG goes through OpenImageIO (image_stack_reader.cpp).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

struct libdeflate_decompressor;

namespace sawyer::ct::detail {

class PngGreyDecoder {
 public:
  enum class Outcome {
    kDecoded,     // `out` holds the samples
    kNotHandled,  // not a PNG this decoder takes (or its chunks look wrong): use OpenImageIO
    kCorrupt,     // a grey PNG whose image data is bad; `detail` says how
  };

  PngGreyDecoder() = default;
  PngGreyDecoder(const PngGreyDecoder&) = delete;
  PngGreyDecoder& operator=(const PngGreyDecoder&) = delete;
  ~PngGreyDecoder();

  // Decodes `file` when it is a width x height grey PNG of `bits` (8 or 16) bits per sample:
  // `out` gets width * height samples in row order, 16-bit ones in native byte order.
  Outcome decode(const std::filesystem::path& file, int width, int height, int bits,
                 std::vector<unsigned char>& out, std::string& detail);

  // The same on a file already in memory (decode() reads the file and calls this).
  Outcome decode_bytes(const unsigned char* data, size_t size, int width, int height, int bits,
                       std::vector<unsigned char>& out, std::string& detail);

 private:
  libdeflate_decompressor* inflater_ = nullptr;
  // Reused from slice to slice (one decoder per reading thread).
  std::vector<unsigned char> file_, idat_, rows_, zeros_;
};

}  // namespace sawyer::ct::detail
