// Decoding of one DICOM slice to HU: native pixel data in one pread at the offset found while
// scanning, encapsulated pixel data (JPEG, JPEG-LS, JPEG 2000, RLE) through GDCM's codecs after
// the codestream checks, and the lookup table (stored value -> HU, per slice rescale) that also
// does the byte swap of big endian files and the masking and sign extension of 12-bit data.
#include "dicom_decode.h"

#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmJPEG2000Codec.h>
#include <gdcmJPEGCodec.h>
#include <gdcmJPEGLSCodec.h>
#include <gdcmPhotometricInterpretation.h>
#include <gdcmPixelFormat.h>
#include <gdcmRLECodec.h>
#include <gdcmReader.h>
#include <gdcmSequenceOfFragments.h>

#include <algorithm>
#include <bit>
#include <cfloat>
#include <cstring>
#include <map>
#include <variant>

#include "dicom_codestream.h"
#include "dicom_structure.h"

namespace sawyer::ct::detail {

namespace {

// The lookup-table trick reads 16-bit words in host order; every platform Sawyer targets is
// little endian.
static_assert(std::endian::native == std::endian::little, "little-endian hosts only");

std::string ts_name(const std::string& uid) {
  static const std::map<std::string, std::string> names = {
      {"1.2.840.10008.1.2", "Implicit VR Little Endian"},
      {"1.2.840.10008.1.2.1", "Explicit VR Little Endian"},
      {"1.2.840.10008.1.2.2", "Explicit VR Big Endian"},
      {"1.2.840.10008.1.2.1.99", "Deflated Explicit VR Little Endian"},
      {"1.2.840.10008.1.2.4.57", "JPEG Lossless"},
      {"1.2.840.10008.1.2.4.70", "JPEG Lossless SV1"},
      {"1.2.840.10008.1.2.4.50", "JPEG Baseline"},
      {"1.2.840.10008.1.2.4.51", "JPEG Extended"},
      {"1.2.840.10008.1.2.4.80", "JPEG-LS Lossless"},
      {"1.2.840.10008.1.2.4.81", "JPEG-LS Near-Lossless"},
      {"1.2.840.10008.1.2.4.90", "JPEG 2000 Lossless"},
      {"1.2.840.10008.1.2.4.91", "JPEG 2000"},
      {"1.2.840.10008.1.2.5", "RLE Lossless"},
  };
  const auto it = names.find(uid);
  return it == names.end() ? "transfer syntax " + (uid.empty() ? std::string("(none)") : uid)
                           : it->second;
}

}  // namespace

Status SliceDecoder::decode(const SliceFile& s, int width, int height, std::vector<float>& hu) {
  const size_t n = static_cast<size_t>(width) * height;
  PixelLayout layout{s.bits_allocated, s.bits_stored, s.high_bit, s.pixel_signed, s.big_endian};
  if (s.native) {
    const size_t bytes = n * static_cast<size_t>(s.bits_allocated / 8);
    raw_.resize(bytes);
    Fd fd(s.path);
    if (!fd.ok()) return Error(s.path.string(), std::string("cannot read: ") + strerror(errno));
    const int64_t got = fd.pread_all(raw_.data(), bytes, s.pixel_offset);
    if (got < 0) return Error(s.path.string(), std::string("read failed: ") + strerror(errno));
    if (static_cast<size_t>(got) != bytes)
      return Error(s.path.string(), "truncated: the pixel data ends after " + std::to_string(got) +
                                        " of " + std::to_string(bytes) + " bytes");
  } else if (Status st = decode_with_gdcm(s, width, height, layout); !st) {
    return st;
  }
  build_lut(layout, s.slope, s.intercept);
  hu.resize(n);
  const float* lut = lut_.data();
  float* out = hu.data();
  if (layout.bits_allocated == 16) {
    const auto* in = reinterpret_cast<const uint16_t*>(raw_.data());
    for (size_t k = 0; k < n; ++k) out[k] = lut[in[k]];
  } else {
    const uint8_t* in = raw_.data();
    for (size_t k = 0; k < n; ++k) out[k] = lut[in[k]];
  }
  return Status::Ok();
}

// Encapsulated files: GDCM reads the (already checked) file and one of its codecs, chosen
// here by transfer syntax, decodes into host order. Not gdcm::ImageReader / Image::GetBuffer:
// on a corrupt JPEG stream those fall back to the PVRG codec, which runs the external
// pvrg-jpeg program on temporary files (and leaks their names), and their checks of the
// decoded length are assertions.
Status SliceDecoder::decode_with_gdcm(const SliceFile& s, int width, int height,
                                      PixelLayout& layout) {
  const std::string where = s.path.string();
  const std::string what = ts_name(s.transfer_syntax);
  {
    // The file was checked at open; check again in case it changed since, because GDCM
    // aborts on malformed files rather than failing.
    Fd fd(s.path);
    if (!fd.ok()) return Error(where, std::string("cannot read: ") + strerror(errno));
    Structure st;
    if (std::string err = check_structure(fd, fd.size(), st); !err.empty())
      return Error(where, st.plain_message ? err : "corrupt DICOM: " + err);
    if (!st.pixel_encapsulated) return Error(where, "the file changed since it was opened");
  }
  const size_t expected =
      static_cast<size_t>(width) * height * static_cast<size_t>(s.bits_allocated / 8);
  try {
    gdcm::Reader reader;
    reader.SetFileName(s.path.c_str());
    if (!reader.Read()) return Error(where, "cannot read the " + what + " pixel data");
    const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
    if (!ds.FindDataElement(kPixelDataTag)) return Error(where, "no Pixel Data");
    const gdcm::DataElement& pixels = ds.GetDataElement(kPixelDataTag);
    const gdcm::SequenceOfFragments* fragments = pixels.GetSequenceOfFragments();
    if (!fragments) return Error(where, "the " + what + " pixel data is not encapsulated");
    int precision = 0;
    if (std::string err = check_codestream(s.transfer_syntax, *fragments, width, height,
                                           s.bits_allocated, precision);
        !err.empty())
      return Error(where, "corrupt " + what + " pixel data: " + err);
    // Decoded samples are the stored words; the DICOM header says how to read them (bits
    // stored, high bit, sign), only their container size comes from the decoder.
    const auto adopt_container = [&](int bits_allocated) {
      layout.bits_allocated = bits_allocated;
      layout.bits_stored = std::min(layout.bits_stored, bits_allocated);
      if (layout.high_bit >= bits_allocated) layout.high_bit = layout.bits_stored - 1;
      layout.big_endian = false;
    };

    gdcm::PixelFormat pf(1, static_cast<unsigned short>(s.bits_allocated),
                         static_cast<unsigned short>(s.bits_stored),
                         static_cast<unsigned short>(s.high_bit), s.pixel_signed ? 1 : 0);
    const unsigned int dims[3] = {static_cast<unsigned>(width), static_cast<unsigned>(height), 1};
    const auto setup = [&](gdcm::ImageCodec& codec) {
      codec.SetNumberOfDimensions(2);
      codec.SetDimensions(dims);
      codec.SetPixelFormat(pf);
      codec.SetPlanarConfiguration(0);
      codec.SetPhotometricInterpretation(gdcm::PhotometricInterpretation::MONOCHROME2);
      codec.SetNeedOverlayCleanup(false);
    };
    const std::string& ts = s.transfer_syntax;
    const bool jpeg_ls = ts == "1.2.840.10008.1.2.4.80" || ts == "1.2.840.10008.1.2.4.81";
    if (jpeg_ls && charls_available()) {
      const auto result = decode_jpeg_ls(*fragments, width, height, raw_);
      if (const std::string* err = std::get_if<std::string>(&result))
        return Error(where, "cannot decode the " + what + " pixel data: " + *err);
      adopt_container(std::get<int>(result) > 8 ? 16 : 8);
      return Status::Ok();
    }
    gdcm::DataElement out;
    bool decoded = false;
    gdcm::PixelFormat out_pf = pf;
    if (ts == "1.2.840.10008.1.2.5") {
      gdcm::RLECodec codec;
      setup(codec);
      codec.SetBufferLength(expected);
      decoded = codec.Decode(pixels, out);
      out_pf = codec.GetPixelFormat();
    } else if (jpeg_ls) {
      gdcm::JPEGLSCodec codec;
      setup(codec);
      codec.SetBufferLength(expected);
      // GDCM's 2D JPEG-LS path leaks its input copy when CharLS fails; the per-frame (3D)
      // path frees it, so a one-fragment slice goes through that one as a 1-frame volume.
      if (fragments->GetNumberOfFragments() == 1) codec.SetNumberOfDimensions(3);
      decoded = codec.Decode(pixels, out);
      out_pf = codec.GetPixelFormat();
    } else if (ts == "1.2.840.10008.1.2.4.90" || ts == "1.2.840.10008.1.2.4.91") {
      gdcm::JPEG2000Codec codec;
      setup(codec);
      codec.SetNumberOfThreadsForDecompression(1);  // the prefetch thread is parallel enough
      decoded = codec.Decode(pixels, out);
      out_pf = codec.GetPixelFormat();
    } else {
      // GDCM picks its 8-, 12- or 16-bit libjpeg from the pixel format's bits allocated; pick
      // the one that matches the stream's precision, because a mismatch is a libjpeg warning
      // and, on some streams, a GDCM assertion.
      const unsigned short bits = precision <= 8 ? 8 : precision <= 12 ? 12 : 16;
      gdcm::JPEGCodec codec;
      setup(codec);
      codec.SetPixelFormat(gdcm::PixelFormat(1, bits, bits, static_cast<unsigned short>(bits - 1),
                                             s.pixel_signed ? 1 : 0));
      decoded = codec.Decode(pixels, out);
      out_pf = codec.GetPixelFormat();
    }
    if (!decoded) return Error(where, "cannot decode the " + what + " pixel data (corrupt?)");
    const gdcm::ByteValue* bv = out.GetByteValue();
    if (out_pf.GetSamplesPerPixel() != 1 ||
        (out_pf.GetBitsAllocated() != 8 && out_pf.GetBitsAllocated() != 16))
      return Error(where, "the " + what + " pixel data decodes to an unsupported pixel format");
    adopt_container(out_pf.GetBitsAllocated());
    const size_t need =
        static_cast<size_t>(width) * height * static_cast<size_t>(layout.bits_allocated / 8);
    if (!bv || bv->GetLength() < need)
      return Error(where,
                   "the " + what + " pixel data decodes to " +
                       std::to_string(bv ? static_cast<size_t>(bv->GetLength()) : size_t{0}) +
                       " bytes, expected " + std::to_string(need) + " (" + std::to_string(width) +
                       " x " + std::to_string(height) + ")");
    raw_.resize(need);
    std::memcpy(raw_.data(), bv->GetPointer(), need);
  } catch (const std::exception& e) {
    return Error(where, "cannot decode the " + what + " pixel data: " + e.what());
  } catch (...) {
    return Error(where, "cannot decode the " + what + " pixel data");
  }
  return Status::Ok();
}

// stored word -> HU. The table is indexed by the word as it lies in memory, so the byte swap
// of big endian data, the shift for a high bit below the top, the mask of unused high bits
// and the sign extension all happen once per table, not once per pixel.
void SliceDecoder::build_lut(const PixelLayout& layout, double slope, double intercept) {
  if (has_lut_ && layout == lut_layout_ && slope == lut_slope_ && intercept == lut_intercept_)
    return;
  const int entries = layout.bits_allocated == 16 ? 65536 : 256;
  lut_.resize(static_cast<size_t>(entries));
  const int shift = layout.high_bit + 1 - layout.bits_stored;
  const uint32_t mask = layout.bits_stored >= 32 ? 0xffffffffu : (1u << layout.bits_stored) - 1u;
  const uint32_t sign = 1u << (layout.bits_stored - 1);
  for (int w = 0; w < entries; ++w) {
    uint32_t word = static_cast<uint32_t>(w);
    if (layout.big_endian && entries == 65536) word = ((word & 0xff) << 8) | (word >> 8);
    const uint32_t bits = (word >> shift) & mask;
    int64_t v = bits;
    if (layout.pixel_signed && (bits & sign)) v -= static_cast<int64_t>(mask) + 1;
    // Clamped so that an absurd rescale gives +-FLT_MAX, not an out-of-range conversion.
    const double hu = std::clamp(static_cast<double>(v) * slope + intercept,
                                 -static_cast<double>(FLT_MAX), static_cast<double>(FLT_MAX));
    lut_[static_cast<size_t>(w)] = static_cast<float>(hu);
  }
  has_lut_ = true;
  lut_layout_ = layout;
  lut_slope_ = slope;
  lut_intercept_ = intercept;
}

}  // namespace sawyer::ct::detail
