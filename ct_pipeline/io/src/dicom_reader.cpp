// The DICOM reader behind open_ct(): a folder of DICOM files (or one file of it) -> one series,
// sorted along the slice normal, streamed slice by slice as HU.
//
// Every file first goes through a structural walk of our own (element headers, lengths,
// sequences, fragments; no values): the Debian GDCM is built with assertions on, and malformed
// input makes it abort() or allocate what a bogus length asks for, so GDCM only ever sees files
// whose structure is sound. The walk also locates the Pixel Data value.
// Opening scans headers only (GDCM reads up to Pixel Data and stops), groups files by Series
// Instance UID, picks the series, checks it (sizes, spacing, orientation, positions, pixel data
// length) and sorts it by Image Position (Patient) projected on the slice normal, falling back
// to Slice Location; never by file name. Reading takes one of two paths per file:
//  - native (uncompressed) pixel data: one pread at the offset found while scanning, then a
//    lookup table (stored value -> HU, per slice rescale) that also does the byte swap for big
//    endian files and the masking / sign extension of 12-bit data;
//  - encapsulated (JPEG, JPEG-LS, JPEG 2000, RLE): GDCM reads the file, the compressed stream's
//    own header is checked against the DICOM header, and the matching GDCM codec decodes it
//    (JPEG-LS: CharLS directly, see decode_jpeg_ls); the decoded size is checked again.
// Sequential reads prefetch the next slice on a worker thread, so at most three slices (the
// caller's, the prefetched one, one raw buffer per thread) are alive at any time.
#include <dlfcn.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmFileMetaInformation.h>
#include <gdcmJPEG2000Codec.h>
#include <gdcmJPEGCodec.h>
#include <gdcmJPEGLSCodec.h>
#include <gdcmPhotometricInterpretation.h>
#include <gdcmPixelFormat.h>
#include <gdcmRLECodec.h>
#include <gdcmReader.h>
#include <gdcmSequenceOfFragments.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>

#include <algorithm>
#include <bit>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "readers.h"
#include "sawyer/ct/limits.h"

namespace sawyer::ct::detail {

namespace {

// The lookup-table trick reads 16-bit words in host order; every platform Sawyer targets is
// little endian.
static_assert(std::endian::native == std::endian::little, "little-endian hosts only");

// Larger images are not CT slices; the cap keeps a corrupt header from asking for gigabytes.
constexpr int64_t kMaxPixels = 8192LL * 8192LL;
// Positions closer than this along the normal are the same slice (mm).
constexpr double kDuplicateTolerance = 1e-3;
// Positions farther out are corrupt values, and differences of them would overflow (mm).
constexpr double kMaxPosition = 1e7;

const gdcm::Tag kPixelDataTag(0x7fe0, 0x0010);

// ---------------------------------------------------------------------------------------------
// Small helpers

// An open file descriptor that closes itself.
class Fd {
 public:
  explicit Fd(const fs::path& p) : fd_(::open(p.c_str(), O_RDONLY | O_CLOEXEC)) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  bool ok() const { return fd_ >= 0; }
  // Reads up to n bytes at offset; returns the count read (short at end of file), -1 on error.
  int64_t pread_all(void* dst, size_t n, int64_t offset) const {
    size_t done = 0;
    auto* p = static_cast<char*>(dst);
    while (done < n) {
      const ssize_t r = ::pread(fd_, p + done, n - done, static_cast<off_t>(offset + done));
      if (r < 0) {
        if (errno == EINTR) continue;
        return -1;
      }
      if (r == 0) break;
      done += static_cast<size_t>(r);
    }
    return static_cast<int64_t>(done);
  }
  int64_t size() const {
    struct stat st {};
    return ::fstat(fd_, &st) == 0 ? static_cast<int64_t>(st.st_size) : -1;
  }

 private:
  int fd_;
};

std::string trim(std::string s) {
  const auto is_pad = [](char c) {
    return c == ' ' || c == '\0' || c == '\t' || c == '\r' || c == '\n';
  };
  while (!s.empty() && is_pad(s.back())) s.pop_back();
  size_t b = 0;
  while (b < s.size() && is_pad(s[b])) ++b;
  return s.substr(b);
}

std::optional<double> parse_double(std::string s) {
  s = trim(std::move(s));
  if (!s.empty() && s[0] == '+') s.erase(0, 1);
  if (s.empty()) return std::nullopt;
  double v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<long long> parse_int(std::string s) {
  s = trim(std::move(s));
  if (!s.empty() && s[0] == '+') s.erase(0, 1);
  long long v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || ptr != s.data() + s.size()) return std::nullopt;
  return v;
}

// A multi-valued Decimal String ("a\b\c") with exactly n numbers, or nothing.
std::optional<std::vector<double>> parse_ds_list(const std::string& s, size_t n) {
  std::vector<double> out;
  size_t start = 0;
  while (true) {
    const size_t end = s.find('\\', start);
    const auto v = parse_double(s.substr(start, end == std::string::npos ? end : end - start));
    if (!v) return std::nullopt;
    out.push_back(*v);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  if (out.size() != n) return std::nullopt;
  return out;
}

std::string fmt(double v, int decimals = 3) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

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

// GDCM prints warnings about odd files to stderr; Sawyer reports problems itself.
void quiet_gdcm() {
  static std::once_flag once;
  std::call_once(once, [] {
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
  });
}

// ---------------------------------------------------------------------------------------------
// Structural walk

uint32_t le32(const unsigned char* p) {
  return p[0] | (p[1] << 8) | (p[2] << 16) | (static_cast<uint32_t>(p[3]) << 24);
}
uint32_t be32(const unsigned char* p) {
  return (static_cast<uint32_t>(p[0]) << 24) | (p[1] << 16) | (p[2] << 8) | p[3];
}
bool is_vr_letter(unsigned char c) { return c >= 'A' && c <= 'Z'; }

constexpr uint32_t kUndefinedLength = 0xffffffffu;

// The transfer syntaxes Sawyer reads: the three native ones, and the encapsulated ones the
// Debian GDCM decodes. Deflate is refused: its inflated stream cannot be checked without
// inflating every file at open.
enum class Encoding { kImplicitLittle, kExplicitLittle, kExplicitBig };
struct SyntaxInfo {
  Encoding encoding;
  bool encapsulated;
};
std::optional<SyntaxInfo> syntax_info(const std::string& uid) {
  if (uid == "1.2.840.10008.1.2") return SyntaxInfo{Encoding::kImplicitLittle, false};
  if (uid == "1.2.840.10008.1.2.1") return SyntaxInfo{Encoding::kExplicitLittle, false};
  if (uid == "1.2.840.10008.1.2.2") return SyntaxInfo{Encoding::kExplicitBig, false};
  static const char* const kEncapsulated[] = {
      "1.2.840.10008.1.2.4.50", "1.2.840.10008.1.2.4.51", "1.2.840.10008.1.2.4.57",
      "1.2.840.10008.1.2.4.70", "1.2.840.10008.1.2.4.80", "1.2.840.10008.1.2.4.81",
      "1.2.840.10008.1.2.4.90", "1.2.840.10008.1.2.4.91", "1.2.840.10008.1.2.5"};
  for (const char* e : kEncapsulated)
    if (uid == e) return SyntaxInfo{Encoding::kExplicitLittle, true};
  return std::nullopt;
}

// What the walk learns about a file.
struct Structure {
  bool plain_message = false;   // the error is not corruption (unsupported syntax, truncation)
  std::string transfer_syntax;  // as in the meta header ("" for a bare data set)
  Encoding encoding = Encoding::kExplicitLittle;
  bool encapsulated_syntax = false;
  bool has_pixel_data = false;
  bool pixel_encapsulated = false;  // undefined length: fragments
  int64_t pixel_offset = 0;         // first byte of the value
  uint32_t pixel_length = 0;        // defined length (native)
  int pixel_fragments = 0;          // items after the offset table
};

// Walks a DICOM file element by element, checking what GDCM would otherwise trust: complete
// element headers, valid VRs, lengths that stay inside the file (and inside their item or
// sequence), undefined lengths only where they may occur, well-formed items and fragments, no
// trailing partial element. Values are skipped, never read. Where GDCM has compatibility hacks
// that re-interpret particular odd files, the walk refuses those files, so GDCM never reads a
// file differently from how it was checked.
class StructureWalker {
 public:
  StructureWalker(const Fd& fd, int64_t size) : fd_(fd), size_(size) {}

  // Empty string: fine; else what is wrong, for "corrupt DICOM: <what>".
  std::string walk(Structure& out) {
    out = Structure{};
    int64_t off = 0;
    unsigned char b[12];
    if (size_ >= 132 && get(128, 4, b) && std::memcmp(b, "DICM", 4) == 0) off = 132;
    if (!get(off, 8, b)) return "too short for a DICOM file";
    const unsigned group = b[0] | (b[1] << 8);
    // Two capital letters after the first tag mean explicit VR (GDCM's guess for a bare data
    // set too); letters that are not a VR Sawyer accepts are refused rather than guessed.
    const bool letters = is_vr_letter(b[4]) && is_vr_letter(b[5]);
    if (letters && !valid_vr(b + 4)) return "invalid VR in the first element";
    const bool explicit_vr = letters;
    if (group == 0x0002) {
      if (!explicit_vr) return "the file meta information is not in explicit VR";
      std::string err = walk_meta(off, out);
      if (!err.empty()) return err;
      const auto info = syntax_info(out.transfer_syntax);
      if (!info) {
        out.plain_message = true;
        if (out.transfer_syntax == "1.2.840.10008.1.2.1.99")
          return "Deflated Explicit VR Little Endian is not supported; store the series "
                 "uncompressed (e.g. gdcmconv --raw)";
        return "unsupported transfer syntax " +
               (out.transfer_syntax.empty() ? std::string("(none)") : out.transfer_syntax);
      }
      out.encoding = info->encoding;
      out.encapsulated_syntax = info->encapsulated;
    } else if (group == 0x0008) {
      // A bare data set, as GDCM guesses it: explicit VR when a VR follows the first tag.
      out.encoding = explicit_vr ? Encoding::kExplicitLittle : Encoding::kImplicitLittle;
    } else {
      return "no DICOM file meta information and no data set where one should start";
    }
    std::string err;
    const int64_t end =
        walk_items_or_elements(off, size_, out.encoding, 0, Context::kTop, &out, err);
    if (!err.empty()) return err;
    if (end != size_) return "trailing bytes after the last element";
    if (out.has_pixel_data && out.pixel_encapsulated != out.encapsulated_syntax)
      return out.pixel_encapsulated ? "encapsulated pixel data in a native transfer syntax"
                                    : "native pixel data in an encapsulated transfer syntax";
    return {};
  }

 private:
  enum class Context { kTop, kDefinedItem, kUndefinedItem };

  // Buffered pread of n <= 12 bytes at off; false when the file is shorter.
  bool get(int64_t off, size_t n, unsigned char* dst) {
    if (off < 0 || off + static_cast<int64_t>(n) > size_) return false;
    if (off < buf_off_ || off + static_cast<int64_t>(n) > buf_off_ + buf_len_) {
      buf_.resize(kWindow);
      const int64_t got = fd_.pread_all(buf_.data(), kWindow, off);
      if (got < static_cast<int64_t>(n)) return false;
      buf_off_ = off;
      buf_len_ = got;
    }
    std::memcpy(dst, buf_.data() + (off - buf_off_), n);
    return true;
  }

  static bool valid_vr(const unsigned char* v) {
    static const char* const kVrs[] = {"AE", "AS", "AT", "CS", "DA", "DS", "DT", "FD", "FL",
                                       "IS", "LO", "LT", "OB", "OD", "OF", "OL", "OV", "OW",
                                       "PN", "SH", "SL", "SQ", "SS", "ST", "SV", "TM", "UC",
                                       "UI", "UL", "UN", "UR", "US", "UT", "UV"};
    for (const char* vr : kVrs)
      if (v[0] == vr[0] && v[1] == vr[1]) return true;
    return false;
  }
  static bool long_vr(const unsigned char* v) {  // 32-bit length after 2 reserved bytes
    static const char* const kLong[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ",
                                        "SV", "UC", "UN", "UR", "UT", "UV"};
    for (const char* vr : kLong)
      if (v[0] == vr[0] && v[1] == vr[1]) return true;
    return false;
  }
  // Size of one value of a binary VR (the length must be a multiple), 1 for the rest.
  static int unit_size(const unsigned char* v) {
    const std::string vr(reinterpret_cast<const char*>(v), 2);
    if (vr == "US" || vr == "SS" || vr == "OW") return 2;
    if (vr == "UL" || vr == "SL" || vr == "FL" || vr == "AT" || vr == "OF" || vr == "OL") return 4;
    if (vr == "FD" || vr == "OD" || vr == "OV" || vr == "SV" || vr == "UV") return 8;
    return 1;
  }

  static std::string at(int64_t off) { return " at byte " + std::to_string(off); }
  static std::string tag_name(unsigned g, unsigned e) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "(%04X,%04X)", g, e);
    return buf;
  }

  std::string walk_meta(int64_t& off, Structure& out) {
    unsigned char b[12];
    while (true) {
      if (!get(off, 8, b)) return "the file ends inside the file meta information";
      const unsigned group = b[0] | (b[1] << 8), element = b[2] | (b[3] << 8);
      if (group != 0x0002) return {};
      if (!valid_vr(b + 4)) return "invalid VR in the file meta information" + at(off);
      int64_t header = 8;
      uint32_t vl = b[6] | (b[7] << 8);
      if (long_vr(b + 4)) {
        if (!get(off, 12, b)) return "the file ends inside the file meta information";
        header = 12;
        vl = le32(b + 8);
      }
      if (b[4] == 'S' && b[5] == 'Q') return "a sequence in the file meta information" + at(off);
      if (vl == kUndefinedLength || off + header + vl > size_)
        return "bad length in the file meta information" + at(off);
      if (element == 0x0010) {
        // The transfer syntax value: read it (at most 64 characters of UID).
        if (vl > 64) return "the transfer syntax UID is too long";
        std::string uid(vl, '\0');
        for (uint32_t k = 0; k < vl; ++k) {
          unsigned char c;
          if (!get(off + header + k, 1, &c)) return "the file ends inside the transfer syntax";
          uid[k] = static_cast<char>(c);
        }
        out.transfer_syntax = trim(uid);
      }
      off += header + vl;
    }
  }

  // Walks elements from `off` up to `end` (a defined item or the file) or, in an undefined
  // item, up to its delimiter. Returns the offset after what was walked; sets err on failure.
  int64_t walk_items_or_elements(int64_t off, int64_t end, Encoding enc, int depth, Context ctx,
                                 Structure* top, std::string& err) {
    if (depth > kMaxDepth) {
      err = "sequences nested deeper than " + std::to_string(kMaxDepth) + at(off);
      return off;
    }
    const bool big = enc == Encoding::kExplicitBig;
    const bool explicit_vr = enc != Encoding::kImplicitLittle;
    unsigned char b[12];
    while (off < end || ctx == Context::kUndefinedItem) {
      if (!get(off, 8, b) || off + 8 > end) {
        err = ctx == Context::kTop ? "a partial element at the end of the file" + at(off)
                                   : "the file ends inside a sequence item" + at(off);
        return off;
      }
      const unsigned group = big ? (b[0] << 8) | b[1] : b[0] | (b[1] << 8);
      const unsigned element = big ? (b[2] << 8) | b[3] : b[2] | (b[3] << 8);
      if (group == 0xfffe) {
        const uint32_t vl = big ? be32(b + 4) : le32(b + 4);
        if (ctx == Context::kUndefinedItem && element == 0xe00d && vl == 0) return off + 8;
        err = "unexpected item tag " + tag_name(group, element) + at(off);
        return off;
      }
      if (group == 0x0002 && ctx == Context::kTop) {
        err = "file meta information inside the data set" + at(off);
        return off;
      }
      // GDCM re-interprets these two elements for particular broken files (one becomes Pixel
      // Data, the other gets another length): refuse them rather than read them differently.
      if ((group == 0x00ff && element == 0x4aa5) || (group == 0x031e && element == 0x0324)) {
        err = "unsupported element " + tag_name(group, element) + at(off);
        return off;
      }
      int64_t header = 8;
      uint32_t vl;
      unsigned char vr[2] = {'U', 'N'};
      if (explicit_vr) {
        vr[0] = b[4];
        vr[1] = b[5];
        if (!valid_vr(vr)) {
          err = "invalid VR for element " + tag_name(group, element) + at(off);
          return off;
        }
        if (long_vr(vr)) {
          if (!get(off, 12, b) || off + 12 > end) {
            err = "the file ends inside element " + tag_name(group, element) + at(off);
            return off;
          }
          header = 12;
          vl = big ? be32(b + 8) : le32(b + 8);
        } else {
          vl = big ? (b[6] << 8) | b[7] : b[6] | (b[7] << 8);
        }
      } else {
        vl = le32(b + 4);
      }
      const bool is_pixel_data = group == 0x7fe0 && element == 0x0010;
      const bool is_sq = explicit_vr && vr[0] == 'S' && vr[1] == 'Q';
      const int64_t value = off + header;
      if (is_pixel_data && is_sq) {
        err = "Pixel Data with VR SQ" + at(off);
        return off;
      }
      if (vl == kUndefinedLength) {
        if (is_pixel_data) {
          const bool ob_ow = !explicit_vr || (vr[0] == 'O' && (vr[1] == 'B' || vr[1] == 'W')) ||
                             (vr[0] == 'U' && vr[1] == 'N');
          if (ctx != Context::kTop || !ob_ow) {
            err = "misplaced encapsulated Pixel Data" + at(off);
            return off;
          }
          top->has_pixel_data = true;
          top->pixel_encapsulated = true;
          top->pixel_offset = value;
          off = walk_fragments(value, end, enc, top, err);
        } else if (is_sq || !explicit_vr) {
          off = walk_sequence(value, -1, enc, depth, err);
        } else if (vr[0] == 'U' && vr[1] == 'N') {
          // CP-246: an undefined-length UN is a sequence encoded in implicit VR little endian.
          off = walk_sequence(value, -1, Encoding::kImplicitLittle, depth, err);
        } else {
          err = "undefined length for element " + tag_name(group, element) + at(off);
          return off;
        }
        if (!err.empty()) return off;
        continue;
      }
      // Odd lengths break the standard but occur; GDCM reads them as they are, except that in
      // implicit VR it turns a length of 13 into 10 (a workaround for one old writer), which
      // would make it read the file differently from this walk.
      if (vl % static_cast<uint32_t>(unit_size(vr)) != 0 || (!explicit_vr && vl == 13)) {
        err = "bad length " + std::to_string(vl) + " for element " + tag_name(group, element) +
              at(off);
        return off;
      }
      if (is_pixel_data && ctx == Context::kTop && value + vl > end) {
        top->plain_message = true;
        err = "truncated: the pixel data needs " + std::to_string(vl) + " bytes from byte " +
              std::to_string(value) + ", but the file ends at byte " + std::to_string(size_);
        return off;
      }
      if (value + vl > end) {
        err = "element " + tag_name(group, element) + " runs past the end of " +
              (ctx == Context::kTop ? std::string("the file") : std::string("its item")) + at(off);
        return off;
      }
      if (is_sq) {
        walk_sequence(value, value + vl, enc, depth, err);
        if (!err.empty()) return off;
      }
      if (is_pixel_data && ctx == Context::kTop) {
        top->has_pixel_data = true;
        top->pixel_encapsulated = false;
        top->pixel_offset = value;
        top->pixel_length = vl;
      }
      off = value + vl;
    }
    if (off != end) err = "an element runs past the end of its item" + at(off);
    return off;
  }

  // Items of a sequence: up to `end` for a defined length, else up to the delimiter.
  int64_t walk_sequence(int64_t off, int64_t end, Encoding enc, int depth, std::string& err) {
    const bool big = enc == Encoding::kExplicitBig;
    unsigned char b[8];
    while (end < 0 || off < end) {
      if (!get(off, 8, b) || (end >= 0 && off + 8 > end)) {
        err = "the file ends inside a sequence" + at(off);
        return off;
      }
      const unsigned group = big ? (b[0] << 8) | b[1] : b[0] | (b[1] << 8);
      const unsigned element = big ? (b[2] << 8) | b[3] : b[2] | (b[3] << 8);
      const uint32_t vl = big ? be32(b + 4) : le32(b + 4);
      if (group == 0xfffe && element == 0xe0dd && end < 0) {
        if (vl != 0) {
          err = "sequence delimiter with a length" + at(off);
          return off;
        }
        return off + 8;
      }
      if (group != 0xfffe || element != 0xe000) {
        err = "expected a sequence item, found " + tag_name(group, element) + at(off);
        return off;
      }
      if (vl == kUndefinedLength) {
        off = walk_items_or_elements(off + 8, size_, enc, depth + 1, Context::kUndefinedItem,
                                     nullptr, err);
      } else {
        const int64_t item_end = off + 8 + vl;
        if (item_end > size_ || (end >= 0 && item_end > end)) {
          err = "sequence item runs past its sequence" + at(off);
          return off;
        }
        off = walk_items_or_elements(off + 8, item_end, enc, depth + 1, Context::kDefinedItem,
                                     nullptr, err);
      }
      if (!err.empty()) return off;
    }
    return off;
  }

  // Encapsulated Pixel Data: the offset table item, fragment items, the sequence delimiter.
  int64_t walk_fragments(int64_t off, int64_t end, Encoding enc, Structure* top, std::string& err) {
    unsigned char b[8];
    int items = 0;
    while (true) {
      if (!get(off, 8, b) || off + 8 > end) {
        top->plain_message = true;
        err = "truncated: the file ends inside the encapsulated pixel data" + at(off);
        return off;
      }
      const unsigned group = b[0] | (b[1] << 8), element = b[2] | (b[3] << 8);
      const uint32_t vl = le32(b + 4);
      if (group == 0xfffe && element == 0xe0dd) {
        if (vl != 0 || items < 2) {
          err = items < 2 ? "encapsulated pixel data without fragments" + at(off)
                          : "sequence delimiter with a length" + at(off);
          return off;
        }
        top->pixel_fragments = items - 1;
        return off + 8;
      }
      if (group != 0xfffe || element != 0xe000 || vl == kUndefinedLength) {
        err = "bad pixel data fragment" + at(off);
        return off;
      }
      if (off + 8 + vl > end) {
        top->plain_message = true;
        err = "truncated: a pixel data fragment of " + std::to_string(vl) + " bytes at byte " +
              std::to_string(off) + " runs past the end of the file (" + std::to_string(size_) +
              " bytes)";
        return off;
      }
      if (++items > kMaxFragments) {
        err = "more than " + std::to_string(kMaxFragments) + " pixel data fragments";
        return off;
      }
      off += 8 + vl;
    }
    (void)enc;
  }

  static constexpr int kMaxDepth = 16;
  static constexpr int kMaxFragments = 1 << 16;
  static constexpr int64_t kWindow = 16 * 1024;
  const Fd& fd_;
  int64_t size_;
  std::vector<unsigned char> buf_;
  int64_t buf_off_ = 0;
  int64_t buf_len_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Header scan

// What one file's header says, before any series-level checks.
struct DicomHeader {
  fs::path path;
  bool is_image = false;  // has Rows/Columns or Pixel Data
  bool has_pixel_data = false;
  bool has_sop_class = false;
  std::string series_uid, series_description, modality, manufacturer, model;
  std::optional<long long> series_number, instance_number;
  std::string position_text, orientation_text, spacing_text, slice_location_text;
  std::string slope_text, intercept_text, photometric;
  int rows = 0, cols = 0, samples = 1, frames = 1;
  int bits_allocated = 0, bits_stored = 0, high_bit = -1;
  bool pixel_signed = false;
  std::string transfer_syntax;
  // Pixel Data element as found in the file: value offset and length (0xffffffff: undefined,
  // i.e. encapsulated). native == the value is the raw pixels at that offset.
  bool native = false;
  bool big_endian = false;
  int64_t pixel_offset = 0;
  uint32_t pixel_length = 0;
  int64_t file_size = 0;
};

std::string get_string(const gdcm::DataSet& ds, uint16_t g, uint16_t e) {
  const gdcm::Tag t(g, e);
  if (!ds.FindDataElement(t)) return {};
  const gdcm::DataElement& de = ds.GetDataElement(t);
  const gdcm::ByteValue* bv = de.GetByteValue();
  if (!bv || bv->GetLength() == 0) return {};
  return trim(std::string(bv->GetPointer(), bv->GetLength()));
}

// Unsigned short values: GDCM has already put them in host order, also for big endian files.
std::optional<int> get_us(const gdcm::DataSet& ds, uint16_t g, uint16_t e) {
  const gdcm::Tag t(g, e);
  if (!ds.FindDataElement(t)) return std::nullopt;
  const gdcm::ByteValue* bv = ds.GetDataElement(t).GetByteValue();
  if (!bv || bv->GetLength() < 2) return std::nullopt;
  const auto* p = reinterpret_cast<const unsigned char*>(bv->GetPointer());
  return static_cast<int>(p[0] | (p[1] << 8));
}

// Reads one file's header with GDCM, stopping at Pixel Data (its value is never loaded), and
// locates the Pixel Data value in the file for the native fast path.
Result<DicomHeader> scan_header(const fs::path& path) {
  const std::string where = path.string();
  DicomHeader h;
  h.path = path;
  Structure st;
  {
    Fd fd(path);
    if (!fd.ok()) return Error(where, std::string("cannot read: ") + std::strerror(errno));
    h.file_size = fd.size();
    if (h.file_size == 0) return Error(where, "empty file");
    StructureWalker walker(fd, h.file_size);
    if (std::string err = walker.walk(st); !err.empty())
      return Error(where, st.plain_message ? err : "corrupt DICOM: " + err);
  }
  gdcm::Reader reader;
  reader.SetFileName(path.c_str());
  bool ok = false;
  try {
    ok = reader.ReadUpToTag(kPixelDataTag, {kPixelDataTag});
  } catch (...) {
    ok = false;
  }
  if (!ok) return Error(where, "corrupt DICOM: GDCM cannot parse the header");
  const gdcm::File& file = reader.GetFile();
  const gdcm::DataSet& ds = file.GetDataSet();
  h.transfer_syntax = st.transfer_syntax;

  h.has_sop_class = !get_string(ds, 0x0008, 0x0016).empty() ||
                    !get_string(file.GetHeader(), 0x0002, 0x0002).empty();
  h.modality = get_string(ds, 0x0008, 0x0060);
  h.manufacturer = get_string(ds, 0x0008, 0x0070);
  h.model = get_string(ds, 0x0008, 0x1090);
  h.series_description = get_string(ds, 0x0008, 0x103e);
  h.series_uid = get_string(ds, 0x0020, 0x000e);
  h.series_number = parse_int(get_string(ds, 0x0020, 0x0011));
  h.instance_number = parse_int(get_string(ds, 0x0020, 0x0013));
  h.position_text = get_string(ds, 0x0020, 0x0032);
  h.orientation_text = get_string(ds, 0x0020, 0x0037);
  h.slice_location_text = get_string(ds, 0x0020, 0x1041);
  h.spacing_text = get_string(ds, 0x0028, 0x0030);
  h.intercept_text = get_string(ds, 0x0028, 0x1052);
  h.slope_text = get_string(ds, 0x0028, 0x1053);
  h.photometric = get_string(ds, 0x0028, 0x0004);
  h.rows = get_us(ds, 0x0028, 0x0010).value_or(0);
  h.cols = get_us(ds, 0x0028, 0x0011).value_or(0);
  h.samples = get_us(ds, 0x0028, 0x0002).value_or(1);
  h.bits_allocated = get_us(ds, 0x0028, 0x0100).value_or(0);
  h.bits_stored = get_us(ds, 0x0028, 0x0101).value_or(h.bits_allocated);
  h.high_bit = get_us(ds, 0x0028, 0x0102).value_or(h.bits_stored - 1);
  h.pixel_signed = get_us(ds, 0x0028, 0x0103).value_or(0) == 1;
  if (const auto frames = parse_int(get_string(ds, 0x0028, 0x0008))) {
    h.frames = static_cast<int>(std::clamp<long long>(*frames, 0, 1 << 30));
  }

  h.has_pixel_data = st.has_pixel_data;
  h.native = st.has_pixel_data && !st.pixel_encapsulated;
  h.big_endian = st.encoding == Encoding::kExplicitBig;
  h.pixel_offset = st.pixel_offset;
  h.pixel_length = st.pixel_length;
  h.is_image = h.has_pixel_data || (h.rows > 0 && h.cols > 0);
  return h;
}

// ---------------------------------------------------------------------------------------------
// Compressed stream headers

// GDCM's codecs size their output from the compressed stream's own header, and some of them
// leak or assert when that header is inconsistent. These checks read the frame header of the
// first fragment and require it to describe exactly the image the DICOM header promised (one
// component, the same width and height, at most 16 bits), so a corrupt stream cannot make a
// codec allocate more than one slice.

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

// Empty string when the first fragment's header matches a width x height single-component
// image; else what is wrong.
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

// Decodes one JPEG-LS frame of width x height single samples into `raw` (host order); returns
// the bits per sample, or an error text.
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

// ---------------------------------------------------------------------------------------------
// Slices and decoding

// Everything read() needs for one slice, in z order.
struct SliceFile {
  fs::path path;
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
  Status decode(const SliceFile& s, int width, int height, std::vector<float>& hu) {
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
        return Error(s.path.string(), "truncated: the pixel data ends after " +
                                          std::to_string(got) + " of " + std::to_string(bytes) +
                                          " bytes");
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

 private:
  struct PixelLayout {
    int bits_allocated, bits_stored, high_bit;
    bool pixel_signed, big_endian;
    bool operator==(const PixelLayout&) const = default;
  };

  // Encapsulated files: GDCM reads the (already checked) file and one of its codecs, chosen
  // here by transfer syntax, decodes into host order. Not gdcm::ImageReader / Image::GetBuffer:
  // on a corrupt JPEG stream those fall back to the PVRG codec, which runs the external
  // pvrg-jpeg program on temporary files (and leaks their names), and their checks of the
  // decoded length are assertions.
  Status decode_with_gdcm(const SliceFile& s, int width, int height, PixelLayout& layout) {
    const std::string where = s.path.string();
    const std::string what = ts_name(s.transfer_syntax);
    {
      // The file was checked at open; check again in case it changed since, because GDCM
      // aborts on malformed files rather than failing.
      Fd fd(s.path);
      if (!fd.ok()) return Error(where, std::string("cannot read: ") + strerror(errno));
      Structure st;
      StructureWalker walker(fd, fd.size());
      if (std::string err = walker.walk(st); !err.empty())
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
      if (jpeg_ls && charls_api().ok()) {
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
  void build_lut(const PixelLayout& layout, double slope, double intercept) {
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

  std::vector<uint8_t> raw_;
  std::vector<float> lut_;
  bool has_lut_ = false;
  PixelLayout lut_layout_{};
  double lut_slope_ = 0, lut_intercept_ = 0;
};

// ---------------------------------------------------------------------------------------------
// The source

class DicomSeriesSource final : public SliceSource {
 public:
  DicomSeriesSource(VolumeGeometry geometry, std::vector<SliceFile> slices, std::string description,
                    std::vector<std::string> notes)
      : geometry_(std::move(geometry)),
        slices_(std::move(slices)),
        description_(std::move(description)),
        notes_(std::move(notes)) {}

  ~DicomSeriesSource() override {
    if (worker_.joinable()) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
      }
      cv_.notify_all();
      worker_.join();
    }
  }

  Format format() const override { return Format::kDicom; }
  const VolumeGeometry& geometry() const override { return geometry_; }
  std::string description() const override { return description_; }
  const std::vector<std::string>& notes() const override { return notes_; }

  Status read(int i, Slice& out) override {
    const int n = static_cast<int>(slices_.size());
    if (i < 0 || i >= n)
      return Error(description_,
                   "slice " + std::to_string(i) + " is out of range 0.." + std::to_string(n - 1));
    // Take the prefetched slice if it is the one asked for. Either way wait for the worker, so
    // that only one decode runs at a time (GDCM codecs are not known to be reentrant).
    bool prefetched = false;
    Status status;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return !pending_; });
      if (result_index_ == i) {
        prefetched = true;
        status = result_status_;
      }
      result_index_ = -1;
    }
    if (prefetched) {
      if (status) out.hu.swap(prefetch_hu_);
    } else {
      status = decoder_.decode(slices_[static_cast<size_t>(i)], geometry_.width, geometry_.height,
                               out.hu);
    }
    if (!status) return status;
    out.index = i;
    out.z = geometry_.z[static_cast<size_t>(i)];
    out.width = geometry_.width;
    out.height = geometry_.height;
    if (i == last_read_ + 1 && i + 1 < n) schedule(i + 1);
    last_read_ = i;
    return Status::Ok();
  }

 private:
  void schedule(int i) {
    if (!worker_.joinable()) worker_ = std::thread([this] { work(); });
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = i;
      pending_ = true;
    }
    cv_.notify_all();
  }

  void work() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      cv_.wait(lock, [&] { return stop_ || pending_; });
      if (stop_) return;
      const int i = job_;
      lock.unlock();
      // prefetch_hu_ and prefetch_decoder_ belong to the worker while pending_ is set.
      Status st = prefetch_decoder_.decode(slices_[static_cast<size_t>(i)], geometry_.width,
                                           geometry_.height, prefetch_hu_);
      lock.lock();
      result_status_ = std::move(st);
      result_index_ = i;
      pending_ = false;
      cv_.notify_all();
    }
  }

  VolumeGeometry geometry_;
  std::vector<SliceFile> slices_;
  std::string description_;
  std::vector<std::string> notes_;
  SliceDecoder decoder_;
  int last_read_ = -1;

  // Prefetch of the next slice; guarded by mutex_.
  std::thread worker_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  bool pending_ = false;
  int job_ = -1;
  int result_index_ = -1;
  Status result_status_;
  std::vector<float> prefetch_hu_;
  SliceDecoder prefetch_decoder_;
};

// ---------------------------------------------------------------------------------------------
// Series grouping, choice and checks

struct Series {
  std::string uid;
  std::vector<const DicomHeader*> files;
  std::optional<long long> number;
  std::string description, modality, manufacturer;
};

std::string in_quotes(const std::string& s) { return "\"" + s + "\""; }

std::string series_line(int number, const Series& s) {
  std::string line = std::to_string(number) + ": " +
                     (s.uid.empty() ? std::string("(no Series Instance UID)") : s.uid);
  if (!s.description.empty()) line += " " + in_quotes(s.description);
  if (!s.modality.empty()) line += " " + s.modality;
  line += ", " + std::to_string(s.files.size()) + (s.files.size() == 1 ? " file" : " files");
  return line;
}

std::string series_list(const std::vector<Series>& all) {
  std::string list;
  for (size_t k = 0; k < all.size(); ++k)
    list += (k ? "; " : "") + series_line(static_cast<int>(k) + 1, all[k]);
  return list;
}

std::string name_list(const std::vector<fs::path>& files, size_t max_names = 5) {
  std::string s;
  for (size_t k = 0; k < files.size() && k < max_names; ++k)
    s += (k ? ", " : "") + files[k].filename().string();
  if (files.size() > max_names) s += " and " + std::to_string(files.size() - max_names) + " more";
  return s;
}

bool has_dicom_ext(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e == ".dcm" || e == ".ima" || e == ".dicom" || e == ".dic";
}

// Picks the series `wanted` names: exact UID, then a 1-based number, then a unique UID prefix.
Result<size_t> choose_series(const std::vector<Series>& all, const std::string& wanted,
                             const std::string& where) {
  for (size_t k = 0; k < all.size(); ++k)
    if (all[k].uid == wanted) return k;
  if (const auto number = parse_int(wanted); number && wanted.find('.') == std::string::npos) {
    if (*number >= 1 && *number <= static_cast<long long>(all.size()))
      return static_cast<size_t>(*number - 1);
    return Error(where, "OpenOptions::series " + wanted + ": there are only " +
                            std::to_string(all.size()) + " series: " + series_list(all));
  }
  std::vector<size_t> matches;
  for (size_t k = 0; k < all.size(); ++k)
    if (all[k].uid.starts_with(wanted)) matches.push_back(k);
  if (matches.size() == 1) return matches[0];
  if (matches.empty())
    return Error(where, "no DICOM series matches OpenOptions::series " + in_quotes(wanted) +
                            "; the folder holds: " + series_list(all));
  return Error(where, "OpenOptions::series " + in_quotes(wanted) + " matches " +
                          std::to_string(matches.size()) +
                          " series; give more of the UID or the number: " + series_list(all));
}

struct Orientation {
  Vec3 row, col, normal;
};

Result<Orientation> parse_orientation(const DicomHeader& h) {
  const auto v = parse_ds_list(h.orientation_text, 6);
  if (!v)
    return Error(h.path.string(), "Image Orientation (Patient) " + in_quotes(h.orientation_text) +
                                      " is not six numbers");
  Vec3 row{(*v)[0], (*v)[1], (*v)[2]};
  Vec3 col{(*v)[3], (*v)[4], (*v)[5]};
  // Scanners round the cosines to a few digits; anything further off is not an orientation.
  if (std::abs(row.norm() - 1) > 1e-2 || std::abs(col.norm() - 1) > 1e-2 ||
      std::abs(dot(row, col)) > 1e-2)
    return Error(h.path.string(), "Image Orientation (Patient) " + in_quotes(h.orientation_text) +
                                      " is not two orthogonal unit vectors");
  row = row.normalized();
  col = col.normalized();
  return Orientation{row, col, cross(row, col).normalized()};
}

// The checks on one file of the chosen series that do not compare it with others.
Status check_pixel_format(const DicomHeader& h) {
  const std::string where = h.path.string();
  if (h.frames > 1)
    return Error(where, "multi-frame DICOM (" + std::to_string(h.frames) +
                            " frames in one file) is not supported; export one file per slice");
  if (h.samples != 1 ||
      (!h.photometric.empty() && h.photometric != "MONOCHROME1" && h.photometric != "MONOCHROME2"))
    return Error(where, "Photometric Interpretation " +
                            (h.photometric.empty() ? std::string("(none)") : h.photometric) +
                            " with " + std::to_string(h.samples) +
                            " samples per pixel: not a grey-scale CT slice");
  if (h.rows <= 0 || h.cols <= 0)
    return Error(where, "no image size (Rows/Columns missing or zero)");
  if (static_cast<int64_t>(h.rows) * h.cols > kMaxPixels)
    return Error(where, std::to_string(h.cols) + " x " + std::to_string(h.rows) +
                            " pixels is larger than Sawyer reads (8192 x 8192)");
  if (h.bits_allocated != 8 && h.bits_allocated != 16)
    return Error(where, "Bits Allocated " + std::to_string(h.bits_allocated) +
                            " is not supported (8 or 16)");
  if (h.bits_stored < 1 || h.bits_stored > h.bits_allocated)
    return Error(where, "Bits Stored " + std::to_string(h.bits_stored) + " does not fit in " +
                            std::to_string(h.bits_allocated) + " bits allocated");
  if (!h.has_pixel_data) return Error(where, "no Pixel Data (truncated file?)");
  return Status::Ok();
}

// Native pixel data must be all there; checked at open so a truncated file is reported before
// anything is written.
Status check_pixel_length(const DicomHeader& h) {
  if (!h.native) return Status::Ok();
  const std::string where = h.path.string();
  const int64_t expected = static_cast<int64_t>(h.rows) * h.cols * (h.bits_allocated / 8);
  if (static_cast<int64_t>(h.pixel_length) < expected)
    return Error(where, "Pixel Data holds " + std::to_string(h.pixel_length) + " bytes, expected " +
                            std::to_string(expected) + " (" + std::to_string(h.cols) + " x " +
                            std::to_string(h.rows) + " x " + std::to_string(h.bits_allocated) +
                            " bits)");
  if (h.pixel_offset + expected > h.file_size)
    return Error(where, "truncated: the pixel data needs " + std::to_string(expected) +
                            " bytes from byte " + std::to_string(h.pixel_offset) +
                            ", but the file ends at byte " + std::to_string(h.file_size));
  return Status::Ok();
}

Result<std::unique_ptr<SliceSource>> build_source(const fs::path& folder, const Series& series,
                                                  std::vector<std::string> notes) {
  const std::string folder_name = folder.string();
  // Reference file: the lowest instance number (then name) - what a viewer shows first.
  std::vector<const DicomHeader*> files = series.files;
  std::sort(files.begin(), files.end(), [](const DicomHeader* a, const DicomHeader* b) {
    const long long ia = a->instance_number.value_or(0), ib = b->instance_number.value_or(0);
    return ia != ib ? ia < ib : a->path < b->path;
  });
  const DicomHeader& ref = *files.front();
  const std::string ref_name = ref.path.filename().string();

  for (const DicomHeader* h : files) {
    if (Status st = check_pixel_format(*h); !st) return st.error();
  }
  if (files.size() < 2)
    return Error(folder_name, "DICOM series " + series.uid + " has only 1 slice (" + ref_name +
                                  "); a CT volume needs at least 2 slices");

  // Size and pixel spacing: one for the whole series.
  const auto ref_spacing = parse_ds_list(ref.spacing_text, 2);
  for (const DicomHeader* h : files) {
    const std::string where = h->path.string();
    if (h->rows != ref.rows || h->cols != ref.cols)
      return Error(where, std::to_string(h->cols) + " x " + std::to_string(h->rows) +
                              " pixels, but " + ref_name + " in the same series is " +
                              std::to_string(ref.cols) + " x " + std::to_string(ref.rows) +
                              " (mixed image sizes)");
    if (h->spacing_text.empty())
      return Error(where, "no Pixel Spacing (0028,0030); cannot size the pixels in mm");
    const auto sp = parse_ds_list(h->spacing_text, 2);
    if (!sp)
      return Error(where, "Pixel Spacing " + in_quotes(h->spacing_text) + " is not two numbers");
    if (!((*sp)[0] > 0) || !((*sp)[1] > 0))
      return Error(where, "Pixel Spacing " + in_quotes(h->spacing_text) + " must be positive (mm)");
    for (double v : *sp) {
      if (Status st = check_spacing(where, "Pixel Spacing " + in_quotes(h->spacing_text) + ":", v);
          !st)
        return st.error();
    }
    if (std::abs((*sp)[0] - (*ref_spacing)[0]) > 1e-4 * (*ref_spacing)[0] ||
        std::abs((*sp)[1] - (*ref_spacing)[1]) > 1e-4 * (*ref_spacing)[1])
      return Error(where, "Pixel Spacing " + in_quotes(h->spacing_text) + " differs from " +
                              ref_name + " (" + in_quotes(ref.spacing_text) + ")");
  }

  // Orientation: one for the whole series; the normal orders the slices.
  Orientation orient{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const bool has_orientation = !ref.orientation_text.empty();
  if (has_orientation) {
    auto o = parse_orientation(ref);
    if (!o) return o.error();
    orient = o.value();
  } else {
    notes.push_back("no Image Orientation (Patient) in " + ref_name + "; assuming axial slices");
  }
  const std::optional<std::vector<double>> ref_iop =
      has_orientation ? parse_ds_list(ref.orientation_text, 6) : std::nullopt;
  for (const DicomHeader* h : files) {
    const std::string where = h->path.string();
    if (h->orientation_text.empty() != !has_orientation)
      return Error(where,
                   "Image Orientation (Patient) " +
                       (h->orientation_text.empty() ? std::string("missing")
                                                    : in_quotes(h->orientation_text)) +
                       ", but " + ref_name + " has " +
                       (has_orientation ? in_quotes(ref.orientation_text) : std::string("none")) +
                       " (inconsistent orientation within the series)");
    if (!has_orientation) continue;
    const auto v = parse_ds_list(h->orientation_text, 6);
    if (!v)
      return Error(where, "Image Orientation (Patient) " + in_quotes(h->orientation_text) +
                              " is not six numbers");
    for (size_t k = 0; k < 6; ++k) {
      if (std::abs((*v)[k] - (*ref_iop)[k]) > 1e-3)
        return Error(where, "Image Orientation (Patient) " + in_quotes(h->orientation_text) +
                                " differs from " + ref_name + " (" +
                                in_quotes(ref.orientation_text) +
                                "): inconsistent orientation within the series");
    }
  }

  // Order: Image Position (Patient) on the normal; Slice Location when a file has no position.
  struct Keyed {
    const DicomHeader* h;
    double key;
    Vec3 position;
  };
  std::vector<Keyed> keyed;
  bool use_location = false;
  for (const DicomHeader* h : files) {
    if (h->position_text.empty()) use_location = true;
  }
  for (const DicomHeader* h : files) {
    const std::string where = h->path.string();
    if (!use_location) {
      const auto p = parse_ds_list(h->position_text, 3);
      if (!p)
        return Error(where, "Image Position (Patient) " + in_quotes(h->position_text) +
                                " is not three numbers");
      const Vec3 pos{(*p)[0], (*p)[1], (*p)[2]};
      if (pos.norm() > kMaxPosition)
        return Error(where, "Image Position (Patient) " + in_quotes(h->position_text) +
                                " is more than 10 km from the origin");
      keyed.push_back({h, dot(pos, orient.normal), pos});
    } else {
      if (h->slice_location_text.empty())
        return Error(where,
                     "neither Image Position (Patient) nor Slice Location; cannot order "
                     "the slices (Sawyer never orders them by file name)");
      const auto loc = parse_double(h->slice_location_text);
      if (!loc || std::abs(*loc) > kMaxPosition)
        return Error(where, "Slice Location " + in_quotes(h->slice_location_text) +
                                " is not a usable number");
      keyed.push_back({h, *loc, *loc * orient.normal});
    }
  }
  if (use_location)
    notes.push_back(
        "some files have no Image Position (Patient); slices ordered by Slice "
        "Location");
  std::stable_sort(keyed.begin(), keyed.end(),
                   [](const Keyed& a, const Keyed& b) { return a.key < b.key; });
  for (size_t k = 1; k < keyed.size(); ++k) {
    if (keyed[k].key - keyed[k - 1].key < kDuplicateTolerance)
      return Error(folder_name, "duplicate slice position z=" + fmt(keyed[k].key - keyed[0].key) +
                                    " mm: " + keyed[k - 1].h->path.filename().string() + " and " +
                                    keyed[k].h->path.filename().string());
    // Not a duplicate, but closer than any CT slices are: a corrupt position.
    if (const double d = keyed[k].key - keyed[k - 1].key; d < kMinSpacingMm)
      return Error(folder_name, keyed[k - 1].h->path.filename().string() + " and " +
                                    keyed[k].h->path.filename().string() + " are " + fmt(d) +
                                    " mm apart; slice spacing must be " + fmt(kMinSpacingMm, 2) +
                                    "-" + fmt(kMaxSpacingMm, 0) + " mm");
  }

  // Per-file pixel data and rescale.
  std::vector<SliceFile> slices;
  slices.reserve(keyed.size());
  bool rescale_varies = false, rescale_missing = false;
  double max_shift = 0;
  for (const Keyed& k : keyed) {
    const DicomHeader& h = *k.h;
    const std::string where = h.path.string();
    if (Status st = check_pixel_length(h); !st) return st.error();
    SliceFile s;
    s.path = h.path;
    s.z = k.key - keyed.front().key;
    if (h.slope_text.empty() && h.intercept_text.empty()) rescale_missing = true;
    if (!h.slope_text.empty()) {
      const auto m = parse_double(h.slope_text);
      if (!m || *m == 0)
        return Error(
            where, "Rescale Slope " + in_quotes(h.slope_text) + " cannot map stored values to HU");
      s.slope = *m;
    }
    if (!h.intercept_text.empty()) {
      const auto b = parse_double(h.intercept_text);
      if (!b)
        return Error(where,
                     "Rescale Intercept " + in_quotes(h.intercept_text) + " is not a number");
      s.intercept = *b;
    }
    s.bits_allocated = h.bits_allocated;
    s.bits_stored = h.bits_stored;
    s.high_bit = (h.high_bit >= h.bits_stored - 1 && h.high_bit < h.bits_allocated)
                     ? h.high_bit
                     : h.bits_stored - 1;
    s.pixel_signed = h.pixel_signed;
    s.native = h.native;
    s.big_endian = h.big_endian;
    s.pixel_offset = h.pixel_offset;
    s.transfer_syntax = h.transfer_syntax;
    if (!slices.empty() &&
        (s.slope != slices.front().slope || s.intercept != slices.front().intercept))
      rescale_varies = true;
    // In-plane drift of the positions (gantry tilt): reported, not corrected.
    const Vec3 d = k.position - keyed.front().position;
    max_shift = std::max(max_shift, (d - dot(d, orient.normal) * orient.normal).norm());
    slices.push_back(std::move(s));
  }
  if (rescale_missing)
    notes.push_back(
        "some files have no Rescale Slope/Intercept; their stored values are taken "
        "as HU");
  if (rescale_varies) notes.push_back("Rescale Slope/Intercept vary per slice; applied per slice");
  if (max_shift > 0.05)
    notes.push_back("slice positions drift up to " + fmt(max_shift, 1) +
                    " mm within the slice plane (gantry tilt?); slices are stacked along the "
                    "slice normal without shear correction");
  if (ref.photometric == "MONOCHROME1")
    notes.push_back("MONOCHROME1 (inverted display); HU come from the rescale as usual");

  VolumeGeometry g;
  g.width = ref.cols;
  g.height = ref.rows;
  g.spacing_y = (*ref_spacing)[0];  // DICOM order: row spacing, then column spacing
  g.spacing_x = (*ref_spacing)[1];
  g.z.reserve(slices.size());
  for (const SliceFile& s : slices) g.z.push_back(s.z);
  g.origin = keyed.front().position;
  g.orientation = {orient.row.x, orient.row.y, orient.row.z,
                   orient.col.x, orient.col.y, orient.col.z};
  g.slice_dir = orient.normal;  // the slices were ordered along it
  g.rescale_slope = slices.front().slope;
  g.rescale_intercept = slices.front().intercept;
  g.bits_stored = ref.bits_stored;
  g.pixel_signed = ref.pixel_signed;

  std::vector<std::string> parts;
  if (!series.modality.empty()) parts.push_back(series.modality);
  std::string maker = ref.manufacturer;
  if (!ref.model.empty()) maker += (maker.empty() ? "" : " ") + ref.model;
  if (!maker.empty()) parts.push_back(in_quotes(maker));
  if (!series.description.empty()) parts.push_back(in_quotes(series.description));
  std::string description =
      "DICOM series " + (series.uid.empty() ? std::string("(no UID)") : series.uid);
  if (!parts.empty()) {
    description += " (";
    for (size_t k = 0; k < parts.size(); ++k) description += (k ? ", " : "") + parts[k];
    description += ")";
  }
  description += ", " + std::to_string(slices.size()) + " files";

  return std::unique_ptr<SliceSource>(new DicomSeriesSource(
      std::move(g), std::move(slices), std::move(description), std::move(notes)));
}

}  // namespace

bool looks_like_dicom(const fs::path& file) {
  Fd fd(file);
  if (!fd.ok()) return false;
  unsigned char b[132];
  const int64_t n = fd.pread_all(b, sizeof b, 0);
  if (n >= 132 && std::memcmp(b + 128, "DICM", 4) == 0) return true;
  if (n < 8) return false;
  // A bare data set (no preamble): little-endian group 0x0008 (or 0x0002) first, then either
  // an explicit VR (two capital letters) or a plausible implicit length.
  const unsigned group = b[0] | (b[1] << 8);
  if (group != 0x0008 && group != 0x0002) return false;
  if (is_vr_letter(b[4]) && is_vr_letter(b[5])) return true;
  return le32(b + 4) < (1u << 16);
}

Result<std::unique_ptr<SliceSource>> open_dicom(const fs::path& path, const OpenOptions& options) {
  quiet_gdcm();
  std::error_code ec;
  const bool single_file = fs::is_regular_file(path, ec);
  const fs::path folder =
      single_file ? (path.parent_path().empty() ? fs::path(".") : path.parent_path()) : path;
  const std::string folder_name = folder.string();

  // List the folder (sorted only so that messages are reproducible; order comes from headers).
  std::vector<fs::path> candidates, not_dicom, unreadable_others;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& p = it->path();
    if (p.filename().string().starts_with(".")) continue;
    std::error_code fec;
    const auto st = it->status(fec);
    if (fec || !fs::exists(st)) {
      // A broken link or a link loop: an error if it is named like a slice, else a note.
      if (has_dicom_ext(p) || p.extension().empty()) {
        return Error(p.string(),
                     "cannot read: " + (fec ? fec.message() : std::string("broken link")));
      }
      unreadable_others.push_back(p);
      continue;
    }
    if (!fs::is_regular_file(st)) continue;
    candidates.push_back(p);
  }
  if (ec) return Error(folder_name, "cannot list the folder: " + ec.message());
  std::sort(candidates.begin(), candidates.end());

  std::vector<DicomHeader> headers;
  headers.reserve(candidates.size());
  std::vector<fs::path> non_image;
  for (const fs::path& p : candidates) {
    if (!has_dicom_ext(p) && !looks_like_dicom(p)) {
      // looks_like_dicom() is false also for files we cannot open; those must not vanish
      // silently when they might be slices.
      Fd fd(p);
      if (!fd.ok() && p.extension().empty())
        return Error(p.string(), std::string("cannot read: ") + std::strerror(errno));
      not_dicom.push_back(p);
      continue;
    }
    auto h = scan_header(p);
    if (!h) return h.error();
    if (!h.value().is_image) {
      // DICOMDIR, structured reports, dose sheets: well-formed DICOM without pixels.
      if (!h.value().has_sop_class)
        return Error(p.string(), "corrupt DICOM: no SOP Class UID and no image data");
      non_image.push_back(p);
      continue;
    }
    headers.push_back(std::move(h).value());
  }

  std::vector<std::string> notes;
  if (!not_dicom.empty())
    notes.push_back("ignored " + std::to_string(not_dicom.size()) + " non-DICOM file" +
                    (not_dicom.size() == 1 ? "" : "s") + ": " + name_list(not_dicom));
  if (!unreadable_others.empty())
    notes.push_back("ignored " + std::to_string(unreadable_others.size()) + " unreadable entr" +
                    (unreadable_others.size() == 1 ? "y" : "ies") + ": " +
                    name_list(unreadable_others));
  if (!non_image.empty())
    notes.push_back("ignored " + std::to_string(non_image.size()) + " DICOM file" +
                    (non_image.size() == 1 ? "" : "s") +
                    " without image data: " + name_list(non_image));
  if (headers.empty())
    return Error(single_file ? path.string() : folder_name, "no DICOM images found");

  // Group by series.
  std::map<std::string, Series> by_uid;
  for (const DicomHeader& h : headers) {
    Series& s = by_uid[h.series_uid];
    s.uid = h.series_uid;
    s.files.push_back(&h);
    if (!s.number && h.series_number) s.number = h.series_number;
    if (s.description.empty()) s.description = h.series_description;
    if (s.modality.empty()) s.modality = h.modality;
  }
  std::vector<Series> all;
  for (auto& [uid, s] : by_uid) all.push_back(std::move(s));
  std::stable_sort(all.begin(), all.end(), [](const Series& a, const Series& b) {
    const long long na = a.number.value_or(1LL << 40), nb = b.number.value_or(1LL << 40);
    return na != nb ? na < nb : a.uid < b.uid;
  });

  size_t chosen = 0;
  if (single_file) {
    // The file names its series; --series, if given too, must agree.
    const fs::path canon = fs::weakly_canonical(path, ec);
    std::optional<size_t> owner;
    for (size_t k = 0; k < all.size() && !owner; ++k) {
      for (const DicomHeader* h : all[k].files) {
        std::error_code e2;
        if (h->path == path || fs::weakly_canonical(h->path, e2) == canon) {
          owner = k;
          break;
        }
      }
    }
    if (!owner) return Error(path.string(), "not a DICOM image (no pixel data)");
    chosen = *owner;
    if (!options.series.empty()) {
      auto pick = choose_series(all, options.series, folder_name);
      if (!pick) return pick.error();
      if (pick.value() != chosen)
        return Error(path.string(), "belongs to series " + all[chosen].uid +
                                        ", not to OpenOptions::series " + options.series);
    }
  } else if (!options.series.empty()) {
    auto pick = choose_series(all, options.series, folder_name);
    if (!pick) return pick.error();
    chosen = pick.value();
  } else if (all.size() > 1) {
    return Error(folder_name,
                 "holds " + std::to_string(all.size()) +
                     " DICOM series; choose one with OpenOptions::series (number or UID "
                     "prefix): " +
                     series_list(all));
  }
  if (all.size() > 1)
    notes.push_back("the folder holds " + std::to_string(all.size()) + " DICOM series; reading " +
                    series_line(static_cast<int>(chosen) + 1, all[chosen]));
  return build_source(folder, all[chosen], std::move(notes));
}

}  // namespace sawyer::ct::detail
