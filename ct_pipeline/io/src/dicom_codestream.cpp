// The codestream checks of encapsulated DICOM pixel data and the JPEG-LS decoder over CharLS.
//
// GDCM's codecs size their output from the compressed stream's own header, and some of them
// leak or assert when that header is inconsistent. These checks read the frame header of the
// first fragment and require it to describe exactly the image the DICOM header promised (one
// component, the same width and height, at most 16 bits), so a corrupt stream cannot make a
// codec allocate more than one slice.
#include "dicom_codestream.h"

#include <dlfcn.h>

#include <cstring>
#include <memory>

#include "dicom_structure.h"

namespace sawyer::ct::detail {

namespace {

uint16_t be16(const unsigned char* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }

// JPEG and JPEG-LS: walks the marker segments from SOI to the first SOS and fills precision,
// height, width and component count from the one frame header (a marker that satisfies
// `is_sof`). Strict on purpose: GDCM's libjpeg wrapper asserts when reading the header raised
// any warning other than a precision mismatch, so a stream with stray bytes between segments,
// a second frame header, an unknown marker or a JFIF version other than 1.x is refused here.
bool jpeg_frame_header(const unsigned char* p, size_t n, bool (*is_sof)(unsigned char),
                       int& precision, int& height, int& width, int& components) {
  if (n < 4 || p[0] != 0xff || p[1] != 0xd8) return false;
  size_t pos = 2;
  bool have_frame = false;
  while (pos + 4 <= n) {
    if (p[pos] != 0xff) return false;         // stray bytes between segments
    while (pos < n && p[pos] == 0xff) ++pos;  // fill bytes are allowed
    if (pos + 3 > n) return false;
    const unsigned char m = p[pos++];
    const size_t len = be16(p + pos);
    if (len < 2 || pos + len > n) return false;
    if (m == 0xda) return have_frame;  // start of scan: the header is complete
    if (is_sof(m)) {
      if (have_frame || len < 8) return false;
      precision = p[pos + 2];
      height = be16(p + pos + 3);
      width = be16(p + pos + 5);
      components = p[pos + 7];
      have_frame = true;
    } else if (m == 0xe0 && len >= 7 && std::memcmp(p + pos + 2, "JFIF", 5) == 0) {
      if (len < 8 || p[pos + 7] != 1) return false;  // JFIF major version
    } else {
      // Tables, restart interval, application data, comments, JPEG-LS parameters; nothing else.
      const bool known = m == 0xc4 || m == 0xcc || m == 0xdb || m == 0xdd || m == 0xfe ||
                         m == 0xf8 || (m >= 0xe0 && m <= 0xef);
      if (!known) return false;
    }
    pos += len;
  }
  return false;
}

bool is_jpeg_sof(unsigned char m) {
  return m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc;
}
bool is_jpeg_ls_sof(unsigned char m) { return m == 0xf7; }

}  // namespace

std::string check_codestream(const std::string& ts, const gdcm::SequenceOfFragments& frags,
                             int width, int height, int bits_allocated, int& precision) {
  precision = 0;
  if (frags.GetNumberOfFragments() == 0) return "no pixel data fragments";
  const gdcm::ByteValue* bv = frags.GetFragment(0).GetByteValue();
  if (!bv || bv->GetLength() == 0) return "an empty pixel data fragment";
  const auto* p = reinterpret_cast<const unsigned char*>(bv->GetPointer());
  const size_t n = bv->GetLength();
  const auto mismatch = [&](int w, int h, int c, int bits) -> std::string {
    if (w != width || h != height || c != 1 || bits < 1 || bits > 16)
      return "the compressed stream describes a " + std::to_string(w) + " x " + std::to_string(h) +
             " image with " + std::to_string(c) + " component(s) of " + std::to_string(bits) +
             " bits, the header " + std::to_string(width) + " x " + std::to_string(height) +
             " grey-scale";
    return {};
  };
  if (ts == "1.2.840.10008.1.2.5") {
    // RLE: a 64-byte header, one segment per byte of a sample, offsets inside the fragment.
    if (n < 64) return "the RLE header is truncated";
    const uint32_t segments = le32(p);
    if (segments != static_cast<uint32_t>(bits_allocated / 8))
      return "the RLE stream has " + std::to_string(segments) + " segments, expected " +
             std::to_string(bits_allocated / 8);
    uint32_t previous = 64;
    for (uint32_t k = 0; k < segments; ++k) {
      const uint32_t offset = le32(p + 4 + 4 * k);
      if (offset < previous || offset > n || (k == 0 && offset != 64))
        return "the RLE segment offsets are corrupt";
      previous = offset;
    }
    return {};
  }
  int h = 0, w = 0, c = 0;
  if (ts == "1.2.840.10008.1.2.4.80" || ts == "1.2.840.10008.1.2.4.81") {
    if (!jpeg_frame_header(p, n, is_jpeg_ls_sof, precision, h, w, c))
      return "no JPEG-LS frame header";
    // GDCM's single-fragment JPEG-LS path looks for the end-of-image marker byte and asserts
    // when there is none.
    bool has_eoi = false;
    for (size_t k = n; k > 0 && !has_eoi; --k) has_eoi = p[k - 1] == 0xd9;
    if (!has_eoi) return "the JPEG-LS stream has no end-of-image marker";
    return mismatch(w, h, c, precision);
  }
  if (ts == "1.2.840.10008.1.2.4.90" || ts == "1.2.840.10008.1.2.4.91") {
    // JPEG 2000 codestream: SOC, then SIZ (possibly after a JP2 wrapper: search the start).
    size_t pos = 0;
    while (pos + 4 <= n && pos < 4096 &&
           !(p[pos] == 0xff && p[pos + 1] == 0x4f && p[pos + 2] == 0xff && p[pos + 3] == 0x51))
      ++pos;
    if (pos + 4 + 38 > n || pos >= 4096) return "no JPEG 2000 codestream header";
    const unsigned char* siz = p + pos + 4;  // Lsiz, Rsiz, Xsiz, Ysiz, XOsiz, YOsiz, ...
    const auto u32 = [](const unsigned char* q) {
      return (static_cast<uint32_t>(q[0]) << 24) | (q[1] << 16) | (q[2] << 8) | q[3];
    };
    const uint32_t xsiz = u32(siz + 4), ysiz = u32(siz + 8), xo = u32(siz + 12), yo = u32(siz + 16),
                   xt = u32(siz + 20), yt = u32(siz + 24), xto = u32(siz + 28), yto = u32(siz + 32);
    const int csiz = be16(siz + 36);
    if (xo >= xsiz || yo >= ysiz || xt == 0 || yt == 0 || xto > xo || yto > yo)
      return "the JPEG 2000 image and tile sizes are corrupt";
    const uint64_t tiles =
        ((xsiz - xto + uint64_t{xt} - 1) / xt) * ((ysiz - yto + uint64_t{yt} - 1) / yt);
    if (tiles > 4096) return "the JPEG 2000 stream has too many tiles";
    if (pos + 4 + 38 + 3 > n) return "no JPEG 2000 component size";
    precision = (siz[38] & 0x7f) + 1;
    return mismatch(static_cast<int>(xsiz - xo), static_cast<int>(ysiz - yo), csiz, precision);
  }
  if (!jpeg_frame_header(p, n, is_jpeg_sof, precision, h, w, c)) return "no JPEG frame header";
  return mismatch(w, h, c, precision);
}

// ---------------------------------------------------------------------------------------------
// JPEG-LS through CharLS's C API

namespace {

// GDCM's JPEGLSCodec leaks its copy of the compressed stream whenever CharLS rejects it, and
// sizes its output from the stream's header before comparing it with the DICOM header. CharLS
// itself is fine and already loaded (GDCM links it), so JPEG-LS slices are decoded by calling
// CharLS's stable C API (CharLS 2.x), looked up at run time so that no build dependency is
// added. Without those symbols the GDCM codec is used.
struct CharlsFrameInfo {
  uint32_t width;
  uint32_t height;
  int32_t bits_per_sample;
  int32_t component_count;
};
struct CharlsApi {
  void* (*create)() = nullptr;
  void (*destroy)(const void*) = nullptr;
  int (*set_source_buffer)(void*, const void*, size_t) = nullptr;
  int (*read_header)(void*) = nullptr;
  int (*get_frame_info)(const void*, CharlsFrameInfo*) = nullptr;
  int (*decode_to_buffer)(const void*, void*, size_t, uint32_t) = nullptr;
  bool ok() const {
    return create && destroy && set_source_buffer && read_header && get_frame_info &&
           decode_to_buffer;
  }
};

const CharlsApi& charls_api() {
  static const CharlsApi api = [] {
    CharlsApi a;
    const auto find = [](const char* name) { return dlsym(RTLD_DEFAULT, name); };
    a.create = reinterpret_cast<void* (*)()>(find("charls_jpegls_decoder_create"));
    a.destroy = reinterpret_cast<void (*)(const void*)>(find("charls_jpegls_decoder_destroy"));
    a.set_source_buffer = reinterpret_cast<int (*)(void*, const void*, size_t)>(
        find("charls_jpegls_decoder_set_source_buffer"));
    a.read_header = reinterpret_cast<int (*)(void*)>(find("charls_jpegls_decoder_read_header"));
    a.get_frame_info = reinterpret_cast<int (*)(const void*, CharlsFrameInfo*)>(
        find("charls_jpegls_decoder_get_frame_info"));
    a.decode_to_buffer = reinterpret_cast<int (*)(const void*, void*, size_t, uint32_t)>(
        find("charls_jpegls_decoder_decode_to_buffer"));
    return a;
  }();
  return api;
}

}  // namespace

bool charls_available() { return charls_api().ok(); }

std::variant<int, std::string> decode_jpeg_ls(const gdcm::SequenceOfFragments& frags, int width,
                                              int height, std::vector<uint8_t>& raw) {
  const CharlsApi& api = charls_api();
  std::vector<char> stream;
  for (unsigned k = 0; k < frags.GetNumberOfFragments(); ++k) {
    const gdcm::ByteValue* bv = frags.GetFragment(k).GetByteValue();
    if (bv) stream.insert(stream.end(), bv->GetPointer(), bv->GetPointer() + bv->GetLength());
  }
  std::unique_ptr<void, void (*)(void*)> decoder(api.create(),
                                                 [](void* d) { charls_api().destroy(d); });
  if (!decoder) return std::string("CharLS cannot create a decoder");
  CharlsFrameInfo info{};
  if (api.set_source_buffer(decoder.get(), stream.data(), stream.size()) != 0 ||
      api.read_header(decoder.get()) != 0 || api.get_frame_info(decoder.get(), &info) != 0)
    return std::string("not a valid JPEG-LS stream");
  if (info.width != static_cast<uint32_t>(width) || info.height != static_cast<uint32_t>(height) ||
      info.component_count != 1 || info.bits_per_sample < 2 || info.bits_per_sample > 16)
    return "the JPEG-LS stream describes a " + std::to_string(info.width) + " x " +
           std::to_string(info.height) + " image with " + std::to_string(info.component_count) +
           " component(s) of " + std::to_string(info.bits_per_sample) + " bits";
  const size_t bytes = static_cast<size_t>(width) * height * (info.bits_per_sample > 8 ? 2 : 1);
  raw.resize(bytes);
  if (api.decode_to_buffer(decoder.get(), raw.data(), bytes, 0) != 0)
    return std::string("the JPEG-LS stream is corrupt");
  return static_cast<int>(info.bits_per_sample);
}

}  // namespace sawyer::ct::detail
