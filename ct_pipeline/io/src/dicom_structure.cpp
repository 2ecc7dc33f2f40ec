// The structural walk every DICOM file goes through before GDCM sees it (element headers, VRs,
// lengths, sequences, items, fragments; no values), and looks_like_dicom(), the preamble check
// of format detection.
//
// The Debian GDCM is built with assertions on, and malformed input makes it abort() or allocate
// what a bogus length asks for, so GDCM only ever reads files whose structure passed here. The
// walk also locates the Pixel Data value for the native fast path (dicom_decode.cpp).
#include "dicom_structure.h"

#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "readers.h"
#include "text_parse.h"

namespace sawyer::ct::detail {

namespace {

constexpr uint32_t kUndefinedLength = 0xffffffffu;

// The transfer syntaxes Sawyer reads: the three native ones, and the encapsulated ones the
// Debian GDCM decodes. Deflate is refused: its inflated stream cannot be checked without
// inflating every file at open.
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
        out.transfer_syntax = trim(uid, kBlanksAndNul);
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

}  // namespace

std::string check_structure(const Fd& fd, int64_t size, Structure& out) {
  StructureWalker walker(fd, size);
  return walker.walk(out);
}

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

}  // namespace sawyer::ct::detail
