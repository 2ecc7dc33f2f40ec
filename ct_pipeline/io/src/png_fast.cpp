// PNG facts used here (PNG specification, 3rd edition): the 8-byte signature, then chunks of
// (4-byte big-endian length, 4-byte type, data, 4-byte CRC); IHDR first with width, height, bit
// depth, colour type, compression, filter and interlace methods; the IDAT payloads together are
// one zlib stream holding, per row, a filter-type byte and the filtered row; 16-bit samples are
// big-endian.
#include "png_fast.h"

#include <fcntl.h>
#include <libdeflate.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>

namespace sawyer::ct::detail {

namespace {

uint32_t be32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

bool is_type(const unsigned char* p, const char* t) { return std::memcmp(p, t, 4) == 0; }

// Ancillary chunks that OpenImageIO turns into metadata only, never into different samples.
// Anything else (tRNS adds an alpha channel, sBIT/gAMA/iCCP may change how samples are read,
// unknown chunks may be critical) sends the file to OpenImageIO.
bool harmless_chunk(const unsigned char* t) {
  for (const char* ok : {"pHYs", "oFFs", "tEXt", "zTXt", "iTXt", "tIME"})
    if (is_type(t, ok)) return true;
  return false;
}

// Reverses one row's filter in place; `prev` is the previous row after reversal (zeros for the
// first row). bpp is the filter's byte distance: bytes per pixel, 1 or 2 here.
void unfilter_row(int filter, unsigned char* cur, const unsigned char* prev, size_t len,
                  size_t bpp) {
  switch (filter) {
    case 0:  // None
      break;
    case 1:  // Sub
      for (size_t i = bpp; i < len; ++i) cur[i] = static_cast<unsigned char>(cur[i] + cur[i - bpp]);
      break;
    case 2:  // Up
      for (size_t i = 0; i < len; ++i) cur[i] = static_cast<unsigned char>(cur[i] + prev[i]);
      break;
    case 3:  // Average (of left and above, in 9 bits)
      for (size_t i = 0; i < bpp && i < len; ++i)
        cur[i] = static_cast<unsigned char>(cur[i] + (prev[i] >> 1));
      for (size_t i = bpp; i < len; ++i)
        cur[i] = static_cast<unsigned char>(cur[i] + ((cur[i - bpp] + prev[i]) >> 1));
      break;
    case 4:  // Paeth; with no left neighbour the predictor is the byte above
      for (size_t i = 0; i < bpp && i < len; ++i)
        cur[i] = static_cast<unsigned char>(cur[i] + prev[i]);
      for (size_t i = bpp; i < len; ++i) {
        const int a = cur[i - bpp], b = prev[i], c = prev[i - bpp];
        const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
        const int pred = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
        cur[i] = static_cast<unsigned char>(cur[i] + pred);
      }
      break;
  }
}

}  // namespace

PngGreyDecoder::~PngGreyDecoder() {
  if (inflater_) libdeflate_free_decompressor(inflater_);
}

PngGreyDecoder::Outcome PngGreyDecoder::decode(const std::filesystem::path& file, int width,
                                               int height, int bits,
                                               std::vector<unsigned char>& out,
                                               std::string& detail) {
  // Read failures are left to OpenImageIO, whose messages the stack's errors already use.
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Outcome::kNotHandled;
  struct stat st {};
  // A grey slice of at most 8192 x 8192 16-bit compresses to far less than 1 GiB.
  if (::fstat(fd, &st) != 0 || st.st_size < 8 || st.st_size > (off_t{1} << 30)) {
    ::close(fd);
    return Outcome::kNotHandled;
  }
  const size_t size = static_cast<size_t>(st.st_size);
  file_.resize(size);
  size_t got = 0;
  while (got < size) {
    const ssize_t r = ::read(fd, file_.data() + got, size - got);
    if (r <= 0) break;
    got += static_cast<size_t>(r);
  }
  ::close(fd);
  if (got != size) return Outcome::kNotHandled;
  return decode_bytes(file_.data(), size, width, height, bits, out, detail);
}

PngGreyDecoder::Outcome PngGreyDecoder::decode_bytes(const unsigned char* data, size_t size,
                                                     int width, int height, int bits,
                                                     std::vector<unsigned char>& out,
                                                     std::string& detail) {
  static const unsigned char kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (width <= 0 || height <= 0 || (bits != 8 && bits != 16)) return Outcome::kNotHandled;
  if (size < 8 || std::memcmp(data, kSig, 8) != 0) return Outcome::kNotHandled;

  // Chunks. Anything unexpected in their structure goes to OpenImageIO, which has the messages
  // for it (check_png_chunks, libpng's). CRCs are not checked: the Adler-32 at the end of the
  // zlib stream covers the image data, and the other chunks' contents are not used.
  const unsigned char* first_idat = nullptr;
  size_t idat_chunks = 0, idat_bytes = 0;
  bool seen_ihdr = false, seen_iend = false, idat_ended = false;
  idat_.clear();
  size_t pos = 8;
  while (!seen_iend) {
    if (size - pos < 12) return Outcome::kNotHandled;  // no room for length, type and CRC
    const unsigned char* head = data + pos;
    const uint32_t length = be32(head);
    if (length > 0x7fffffffu || length > size - pos - 12) return Outcome::kNotHandled;
    const unsigned char* type = head + 4;
    const unsigned char* body = head + 8;
    if (!seen_ihdr) {
      if (!is_type(type, "IHDR") || length != 13) return Outcome::kNotHandled;
      const uint32_t w = be32(body), h = be32(body + 4);
      // Bit depth, colour type 0 (grey), compression 0, filter method 0, interlace 0.
      if (w != static_cast<uint32_t>(width) || h != static_cast<uint32_t>(height) ||
          body[8] != bits || body[9] != 0 || body[10] != 0 || body[11] != 0 || body[12] != 0)
        return Outcome::kNotHandled;
      seen_ihdr = true;
    } else if (is_type(type, "IDAT")) {
      if (idat_ended) return Outcome::kNotHandled;  // IDATs must be consecutive
      // Copied only once a second one shows up: one IDAT is inflated where it lies.
      if (idat_chunks == 1) idat_.assign(first_idat, first_idat + idat_bytes);
      if (idat_chunks == 0)
        first_idat = body;
      else
        idat_.insert(idat_.end(), body, body + length);
      ++idat_chunks;
      idat_bytes += length;
    } else if (is_type(type, "IEND")) {
      seen_iend = true;
    } else if (harmless_chunk(type)) {
      if (idat_chunks > 0) idat_ended = true;
    } else {
      return Outcome::kNotHandled;
    }
    pos += 12 + size_t{length};
  }
  if (idat_chunks == 0) return Outcome::kNotHandled;
  const unsigned char* z = idat_chunks == 1 ? first_idat : idat_.data();

  const size_t bpp = static_cast<size_t>(bits / 8);
  const size_t w = static_cast<size_t>(width), h = static_cast<size_t>(height);
  const size_t row = w * bpp;
  const size_t expected = h * (1 + row);
  rows_.resize(expected);
  if (!inflater_) {
    inflater_ = libdeflate_alloc_decompressor();
    if (!inflater_) throw std::bad_alloc();
  }
  // No actual-size pointer: libdeflate then insists on exactly `expected` bytes.
  switch (libdeflate_zlib_decompress(inflater_, z, idat_bytes, rows_.data(), expected, nullptr)) {
    case LIBDEFLATE_SUCCESS:
      break;
    case LIBDEFLATE_SHORT_OUTPUT:
      detail = "the compressed data holds fewer than the " + std::to_string(height) + " rows";
      return Outcome::kCorrupt;
    case LIBDEFLATE_INSUFFICIENT_SPACE:
      detail = "the compressed data holds more than the " + std::to_string(height) + " rows";
      return Outcome::kCorrupt;
    default:
      detail = "the compressed data is corrupt or truncated";
      return Outcome::kCorrupt;
  }

  zeros_.assign(row, 0);
  out.resize(w * h * bpp);
  const unsigned char* prev = zeros_.data();
  for (size_t y = 0; y < h; ++y) {
    unsigned char* line = rows_.data() + y * (1 + row);
    const int filter = line[0];
    if (filter > 4) {
      detail = "row " + std::to_string(y) + " has filter type " + std::to_string(filter) +
               " (PNG has 0-4)";
      return Outcome::kCorrupt;
    }
    unsigned char* cur = line + 1;
    unfilter_row(filter, cur, prev, row, bpp);
    unsigned char* dst = out.data() + y * row;
    if (bits == 8 || std::endian::native == std::endian::big) {
      std::memcpy(dst, cur, row);
    } else {
      for (size_t x = 0; x < w; ++x) {
        const uint16_t v = static_cast<uint16_t>((cur[2 * x] << 8) | cur[2 * x + 1]);
        std::memcpy(dst + 2 * x, &v, 2);
      }
    }
    prev = cur;
  }
  return Outcome::kDecoded;
}

}  // namespace sawyer::ct::detail
