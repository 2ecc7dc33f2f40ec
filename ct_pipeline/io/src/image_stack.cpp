// TIFF and PNG slice stacks through OpenImageIO: a folder of 2D images (one per slice, in natural
// name order or as sawyer_stack.json lists them) or one multi-page TIFF, and the writer that
// produces such stacks for the phantom and the tests. docs/ct_input.md is the user's side of it.
//
// Reading never holds more than a few slices: open() checks every file's header (size, pixel
// type, channels) so a bad stack fails before a long run; read() decodes one image into buffers
// reused from slice to slice, while (ascending reads) worker threads decode the next few slices.
// Geometry comes from, in this order, the command-line options, the sidecar, and TIFF tags
// (ImageJ description, resolution tags); HU follow resolve_rescale().
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <fstream>
#include <future>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <system_error>
#include <thread>
#include <unordered_set>

#include "png_fast.h"
#include "readers.h"
#include "sawyer/ct/limits.h"
#include "sidecar.h"

namespace sawyer::ct::detail {

namespace {

// Larger slices than this are not CT slices but corrupt headers; refuse before allocating.
constexpr long long kMaxSlicePixels = 1LL << 26;  // 8192 x 8192

constexpr const char* k8BitMessage =
    "8-bit slices carry no HU scale: give rescale_slope/rescale_intercept in sawyer_stack.json "
    "or OpenOptions::rescale_slope/OpenOptions::rescale_intercept";

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

// OpenImageIO messages may span lines and repeat the file name; ours are one line that already
// starts with it.
std::string oiio_detail(std::string s, const fs::path& file) {
  // (Built with append: GCC 12 warns falsely on "\"" + string + "\"".)
  std::string quoted(1, '"');
  quoted.append(file.string()).push_back('"');
  for (const std::string& p : {quoted, file.string()}) {
    for (size_t at = s.find(p); !p.empty() && at != std::string::npos; at = s.find(p))
      s.erase(at, p.size());
  }
  std::replace(s.begin(), s.end(), '\n', ' ');
  // "Could not open file: : No such file" once the name is gone -> "Could not open file: No such".
  for (size_t at = s.find(": :"); at != std::string::npos; at = s.find(": :")) s.erase(at, 2);
  const size_t b = s.find_first_not_of(" :");
  s = b == std::string::npos ? std::string() : s.substr(b);
  while (!s.empty() && (s.back() == ' ' || s.back() == '.')) s.pop_back();
  if (s.size() > 200) s = s.substr(0, 197) + "...";
  return s;
}

// ---------------------------------------------------------------------------------------------
// File order

// Natural order: runs of digits compare as numbers (slice_2 < slice_10), other characters
// case-insensitively; ties (slice_01 vs slice_1) fall back to plain byte order so the order is
// total.
bool natural_less(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  auto digit = [](char c) { return c >= '0' && c <= '9'; };
  while (i < a.size() && j < b.size()) {
    if (digit(a[i]) && digit(b[j])) {
      size_t ie = i, je = j;
      while (ie < a.size() && digit(a[ie])) ++ie;
      while (je < b.size() && digit(b[je])) ++je;
      size_t ia = i, jb = j;
      while (ia + 1 < ie && a[ia] == '0') ++ia;
      while (jb + 1 < je && b[jb] == '0') ++jb;
      if (ie - ia != je - jb) return ie - ia < je - jb;
      if (const int c = a.compare(ia, ie - ia, b, jb, je - jb); c != 0) return c < 0;
      i = ie;
      j = je;
    } else {
      const int ca = std::tolower(static_cast<unsigned char>(a[i]));
      const int cb = std::tolower(static_cast<unsigned char>(b[j]));
      if (ca != cb) return ca < cb;
      ++i;
      ++j;
    }
  }
  if ((i == a.size()) != (j == b.size())) return i == a.size();
  return a < b;
}

bool is_tiff_ext(const std::string& e) { return e == ".tif" || e == ".tiff"; }
bool is_png_ext(const std::string& e) { return e == ".png"; }

// ---------------------------------------------------------------------------------------------
// Pixel types

enum class Pixel { kU8, kI8, kU16, kI16, kFloat };

struct PageInfo {
  int width = 0;
  int height = 0;
  int channels = 0;
  Pixel pixel = Pixel::kU16;
  int bits = 16;  // per sample as stored in the file

  bool same_layout(const PageInfo& o) const {
    return width == o.width && height == o.height && channels == o.channels && pixel == o.pixel;
  }
};

const char* pixel_name(Pixel p) {
  switch (p) {
    case Pixel::kU8:
      return "8-bit unsigned";
    case Pixel::kI8:
      return "8-bit signed";
    case Pixel::kU16:
      return "16-bit unsigned";
    case Pixel::kI16:
      return "16-bit signed";
    case Pixel::kFloat:
      return "floating-point";
  }
  return "?";
}

OIIO::TypeDesc pixel_type(Pixel p) {
  switch (p) {
    case Pixel::kU8:
      return OIIO::TypeDesc::UINT8;
    case Pixel::kI8:
      return OIIO::TypeDesc::INT8;
    case Pixel::kU16:
      return OIIO::TypeDesc::UINT16;
    case Pixel::kI16:
      return OIIO::TypeDesc::INT16;
    case Pixel::kFloat:
      return OIIO::TypeDesc::FLOAT;
  }
  return OIIO::TypeDesc::UNKNOWN;
}

size_t pixel_bytes(Pixel p) {
  switch (p) {
    case Pixel::kU8:
    case Pixel::kI8:
      return 1;
    case Pixel::kU16:
    case Pixel::kI16:
      return 2;
    case Pixel::kFloat:
      return 4;
  }
  return 0;
}

std::string size_text(const PageInfo& p) {
  return std::to_string(p.width) + " x " + std::to_string(p.height);
}

std::string layout_text(const PageInfo& p) {
  std::string s = pixel_name(p.pixel);
  if (p.channels != 1) s += ", " + std::to_string(p.channels) + " channels";
  return s;
}

// What a page holds, or why Sawyer cannot use it.
Result<PageInfo> page_info(const OIIO::ImageSpec& spec, const fs::path& file) {
  PageInfo p;
  p.width = spec.width;
  p.height = spec.height;
  p.channels = spec.nchannels;
  if (spec.width <= 0 || spec.height <= 0 ||
      static_cast<long long>(spec.width) * spec.height > kMaxSlicePixels) {
    return Error(file.string(), "implausible image size " + std::to_string(spec.width) + " x " +
                                    std::to_string(spec.height));
  }
  if (spec.depth > 1) return Error(file.string(), "is a 3D image, expected 2D slices");
  if (spec.nchannels < 1 || spec.nchannels > 4)
    return Error(file.string(),
                 "has " + std::to_string(spec.nchannels) + " channels; CT slices have one (grey)");
  // One type for all channels: per-channel formats only occur in exotic files.
  if (!spec.channelformats.empty()) {
    for (const OIIO::TypeDesc& t : spec.channelformats)
      if (t != spec.format) return Error(file.string(), "has channels of different pixel types");
  }
  p.bits = spec.get_int_attribute("oiio:BitsPerSample", static_cast<int>(spec.format.size() * 8));
  const OIIO::TypeDesc::BASETYPE base = static_cast<OIIO::TypeDesc::BASETYPE>(spec.format.basetype);
  switch (base) {
    case OIIO::TypeDesc::UINT8:
      p.pixel = Pixel::kU8;
      break;
    case OIIO::TypeDesc::INT8:
      p.pixel = Pixel::kI8;
      break;
    case OIIO::TypeDesc::UINT16:
      p.pixel = Pixel::kU16;
      break;
    case OIIO::TypeDesc::INT16:
      p.pixel = Pixel::kI16;
      break;
    case OIIO::TypeDesc::HALF:
    case OIIO::TypeDesc::FLOAT:
    case OIIO::TypeDesc::DOUBLE:
      p.pixel = Pixel::kFloat;
      break;
    default:
      return Error(file.string(), std::string("pixel type ") + spec.format.c_str() +
                                      " is not supported (Sawyer reads 8- and 16-bit integer and "
                                      "floating-point slices)");
  }
  // OpenImageIO widens packed depths (1, 4, 12 bits ...) to the full 8/16-bit range, which would
  // scale the stored values; stored values are what the rescale applies to, so refuse them.
  const bool integer = p.pixel != Pixel::kFloat;
  if (integer && p.bits != static_cast<int>(pixel_bytes(p.pixel) * 8)) {
    return Error(file.string(), std::to_string(p.bits) +
                                    "-bit packed samples are not supported; save the slices "
                                    "as 8- or 16-bit images");
  }
  return p;
}

// ---------------------------------------------------------------------------------------------
// TIFF tags

// Millimetres per unit of an ImageJ "unit=" value; 0 when unknown.
double unit_to_mm(std::string u) {
  u = lower(u);
  if (u == "mm" || u == "millimeter" || u == "millimetre") return 1.0;
  if (u == "cm" || u == "centimeter" || u == "centimetre") return 10.0;
  if (u == "m" || u == "meter" || u == "metre") return 1000.0;
  if (u == "um" || u == "micron" || u == "microns" || u == "\\u00b5m" || u == "\xc2\xb5m")
    return 1e-3;
  if (u == "nm") return 1e-6;
  if (u == "in" || u == "inch" || u == "inches") return 25.4;
  return 0.0;
}

// What the first slice's tags say about geometry; each field is empty when the tags are silent.
struct TagGeometry {
  std::optional<double> pixel_x, pixel_y;  // mm
  std::optional<double> slice_spacing;     // mm (ImageJ spacing=)
  std::optional<double> slope, intercept;  // ImageJ straight-line calibration
  int imagej_images = 0;                   // ImageJ images=
  // Where each value came from, for the notes of the values that get used.
  std::string pixel_note, slice_note, rescale_note;
};

TagGeometry read_tags(const OIIO::ImageSpec& spec, const fs::path& file) {
  TagGeometry t;
  const std::string name = file.filename().string();
  std::map<std::string, std::string> ij;
  const std::string desc = spec.get_string_attribute("ImageDescription");
  if (desc.starts_with("ImageJ=")) {
    std::istringstream lines(desc);
    std::string line;
    while (std::getline(lines, line)) {
      if (const size_t eq = line.find('='); eq != std::string::npos)
        ij[line.substr(0, eq)] = line.substr(eq + 1);
    }
  }
  auto ij_number = [&](const char* key) -> std::optional<double> {
    auto it = ij.find(key);
    if (it == ij.end()) return std::nullopt;
    char* end = nullptr;
    const double v = std::strtod(it->second.c_str(), &end);
    if (end == it->second.c_str() || !std::isfinite(v)) return std::nullopt;
    return v;
  };
  const double ij_unit = ij.count("unit") ? unit_to_mm(ij["unit"]) : 0.0;
  if (auto n = ij_number("images")) t.imagej_images = static_cast<int>(std::clamp(*n, 0.0, 1e9));
  if (auto s = ij_number("spacing"); s && *s > 0 && ij_unit > 0) {
    t.slice_spacing = *s * ij_unit;
    t.slice_note =
        "slice spacing " + num(*t.slice_spacing) + " mm from the ImageJ description of " + name;
  }
  // ImageJ's straight-line calibration (cf=0): value = c0 + c1 * stored. ImageJ uses it for
  // signed 16-bit data (c0 = -32768) and for calibrated CT.
  if (auto cf = ij_number("cf"); cf && *cf == 0) {
    auto c0 = ij_number("c0"), c1 = ij_number("c1");
    if (c0 && c1 && *c1 != 0) {
      t.intercept = *c0;
      t.slope = *c1;
      t.rescale_note = "rescale slope " + num(*c1) + ", intercept " + num(*c0) +
                       " from the ImageJ calibration of " + name;
    }
  }

  const float xres = spec.get_float_attribute("XResolution", 0.0f);
  const float yres = spec.get_float_attribute("YResolution", xres);
  const std::string res_unit = lower(spec.get_string_attribute("ResolutionUnit"));
  double mm_per_unit = 0.0;
  std::string unit_shown;
  if (res_unit == "cm") {
    mm_per_unit = 10.0;
    unit_shown = "per cm";
  } else if (res_unit == "mm") {
    mm_per_unit = 1.0;
    unit_shown = "per mm";
  } else if (res_unit == "in" || res_unit == "inch") {
    mm_per_unit = 25.4;
    unit_shown = "per inch";
  } else if (ij_unit > 0) {  // ImageJ writes ResolutionUnit none and puts the unit in the text
    mm_per_unit = ij_unit;
    unit_shown = "per " + ij["unit"] + " (ImageJ)";
  }
  if (xres > 0 && yres > 0 && std::isfinite(xres) && std::isfinite(yres) && mm_per_unit > 0) {
    if ((res_unit == "in" || res_unit == "inch") && xres == 72.0f && yres == 72.0f) {
      // 72 per inch is what image programs write when they know nothing; it is not a scan.
      t.pixel_note = "ignored the resolution tags of " + name + " (72 per inch, a program default)";
    } else {
      t.pixel_x = mm_per_unit / xres;
      t.pixel_y = mm_per_unit / yres;
      t.pixel_note = "pixel spacing " + num(*t.pixel_x) + " x " + num(*t.pixel_y) +
                     " mm from the resolution tags of " + name + " (" + num(xres) + " " +
                     unit_shown + ")";
    }
  }
  return t;
}

// ---------------------------------------------------------------------------------------------
// Reading

// Walks a PNG's chunks (length, type) to IEND without reading their data. OpenImageIO 2.4's PNG
// reader leaks a string each time libpng's read callback hits the end of a truncated file (the
// error longjmps over it), so truncated files are refused here before OpenImageIO sees them.
Status check_png_chunks(const fs::path& file) {
  // pread of 8-byte chunk heads: a stream would refill its buffer after every seek.
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Error(file.string(), "cannot open for reading");
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    return Error(file.string(), "cannot read the file size");
  }
  const uint64_t size = static_cast<uint64_t>(st.st_size);
  auto read_at = [&](uint64_t pos, unsigned char* buf, size_t n) {
    return ::pread(fd, buf, n, static_cast<off_t>(pos)) == static_cast<ssize_t>(n);
  };
  Status result = Error(file.string(), "corrupt PNG (too many chunks)");
  unsigned char sig[8];
  static const unsigned char kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (!read_at(0, sig, 8) || std::memcmp(sig, kSig, 8) != 0) {
    result = Error(file.string(), "cannot read as PNG (no PNG signature)");
  } else {
    uint64_t pos = 8;
    for (int chunk = 0; chunk < 1000000; ++chunk) {
      unsigned char head[8];
      if (!read_at(pos, head, 8)) {
        result = Error(file.string(), "truncated PNG (ends without IEND)");
        break;
      }
      const uint64_t length = (uint64_t{head[0]} << 24) | (uint64_t{head[1]} << 16) |
                              (uint64_t{head[2]} << 8) | head[3];
      if (length > 0x7fffffffu) {
        result = Error(file.string(), "corrupt PNG (chunk length)");
        break;
      }
      if (chunk == 0 && (std::memcmp(head + 4, "IHDR", 4) != 0 || length != 13)) {
        result = Error(file.string(), "corrupt PNG (IHDR is not the first chunk)");
        break;
      }
      pos += 12 + length;  // length, type, data, CRC
      if (pos > size) {
        result = Error(file.string(), "truncated PNG (a chunk runs past the end)");
        break;
      }
      if (std::memcmp(head + 4, "IEND", 4) == 0) {
        result = Status::Ok();
        break;
      }
    }
  }
  ::close(fd);
  return result;
}

// Where the pages of a multi-page TIFF start. OpenImageIO reaches page i with libtiff's
// TIFFSetDirectory, which in libtiff 4.5 walks the chain of image directories (IFDs) from the
// first one on every call: reading n pages costs O(n^2) small reads (800 pages: 337 slices/s).
// So the chain is walked once here, and each page is opened through PageProxy as if it were the
// file's first page, which costs the same for page 800 as for page 1.
struct TiffPages {
  bool big_endian = false;
  bool big_tiff = false;
  std::vector<uint64_t> ifd;  // offset of each page's directory, in page order
};

// The IFD chain as far as libtiff would follow it: to a zero or unreadable next-offset or the
// first loop. Empty when the file is not a TIFF (OpenImageIO then says why).
TiffPages tiff_pages(const fs::path& file) {
  TiffPages t;
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return t;
  auto read_at = [&](uint64_t pos, unsigned char* buf, size_t n) {
    return ::pread(fd, buf, n, static_cast<off_t>(pos)) == static_cast<ssize_t>(n);
  };
  auto value = [&](const unsigned char* b, int n) {
    uint64_t v = 0;
    for (int k = 0; k < n; ++k) v |= uint64_t{b[t.big_endian ? n - 1 - k : k]} << (8 * k);
    return v;
  };
  unsigned char head[16];
  if (read_at(0, head, 8) && (std::memcmp(head, "II", 2) == 0 || std::memcmp(head, "MM", 2) == 0)) {
    t.big_endian = head[0] == 'M';
    const uint64_t magic = value(head + 2, 2);
    t.big_tiff = magic == 43;
    uint64_t next = 0;
    if (magic == 42) {
      next = value(head + 4, 4);
    } else if (t.big_tiff && read_at(0, head, 16)) {
      next = value(head + 8, 8);
    }
    const int count_bytes = t.big_tiff ? 8 : 2, entry_bytes = t.big_tiff ? 20 : 12,
              offset_bytes = t.big_tiff ? 8 : 4;
    std::unordered_set<uint64_t> seen;
    while (next != 0 && seen.insert(next).second && t.ifd.size() < 1000000) {
      unsigned char b[8];
      if (!read_at(next, b, count_bytes)) break;
      const uint64_t entries = value(b, count_bytes);
      t.ifd.push_back(next);
      if (entries > (uint64_t{1} << 32) ||
          !read_at(next + count_bytes + entries * entry_bytes, b, offset_bytes))
        break;
      next = value(b, offset_bytes);
    }
  }
  ::close(fd);
  return t;
}

// A multi-page TIFF seen through OpenImageIO's I/O proxy with one page's directory offset in the
// header's first-IFD field, so that OpenImageIO opens that page as page 1 (subimage 0).
class PageProxy final : public OIIO::Filesystem::IOProxy {
 public:
  PageProxy(const fs::path& file, const TiffPages& pages, int page) : IOProxy(file.string(), Read) {
    fd_ = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    struct stat st {};
    if (fd_ < 0 || ::fstat(fd_, &st) != 0) {
      m_mode = Closed;
      return;
    }
    size_ = static_cast<size_t>(st.st_size);
    const int n = pages.big_tiff ? 8 : 4;
    patch_at_ = pages.big_tiff ? 8 : 4;
    patch_size_ = n;
    const uint64_t v = pages.ifd[page];
    for (int k = 0; k < n; ++k)
      patch_[pages.big_endian ? n - 1 - k : k] = static_cast<unsigned char>(v >> (8 * k));
  }
  ~PageProxy() override {
    if (fd_ >= 0) ::close(fd_);
  }
  const char* proxytype() const override { return "sawyer-tiff-page"; }
  size_t size() const override { return size_; }
  size_t read(void* buf, size_t n) override {
    const size_t got = pread(buf, n, m_pos);
    m_pos += static_cast<int64_t>(got);
    return got;
  }
  size_t pread(void* buf, size_t n, int64_t offset) override {
    if (fd_ < 0 || offset < 0) return 0;
    const ssize_t got = ::pread(fd_, buf, n, static_cast<off_t>(offset));
    if (got <= 0) return 0;
    auto* b = static_cast<unsigned char*>(buf);
    for (int k = 0; k < patch_size_; ++k) {
      const int64_t at = patch_at_ + k;
      if (at >= offset && at < offset + got) b[at - offset] = patch_[k];
    }
    return static_cast<size_t>(got);
  }

 private:
  int fd_ = -1;
  size_t size_ = 0;
  int patch_at_ = 4, patch_size_ = 4;
  unsigned char patch_[8] = {};
};

// One OpenImageIO reader of a fixed format, reopened for each file: creating readers by format
// name ("tiff", "png") rather than by file name keeps OpenImageIO from trying every other format
// on a damaged file, and reusing one saves the plugin lookup per slice.
class ImageReader {
 public:
  explicit ImageReader(const char* format) : format_(format) {}

  Status open(const fs::path& file) {
    close();
    if (!in_) {
      in_ = OIIO::ImageInput::create(format_);
      if (!in_)
        return Error(
            file.string(),
            with_detail(std::string("no ") + format_ + " reader in OpenImageIO", OIIO::geterror()));
    }
    if (format_ == std::string("png")) {
      if (Status st = check_png_chunks(file); !st) return st;
    }
    OIIO::ImageSpec spec;
    if (!in_->open(file.string(), spec)) {
      const std::string detail = oiio_detail(in_->geterror(), file);
      in_.reset();  // a failed open can leave the reader in any state; start afresh next time
      return Error(file.string(), with_detail(std::string("cannot read as ") +
                                                  (format_ == std::string("png") ? "PNG" : "TIFF"),
                                              detail));
    }
    file_ = file;
    open_ = true;
    return Status::Ok();
  }

  // Page `page` of a multi-page TIFF (tiff_pages() found it) as subimage 0; the message of a
  // failure is OpenImageIO's, or empty.
  bool open_page(const fs::path& file, const TiffPages& pages, int page, std::string& detail) {
    close();
    if (!in_) in_ = OIIO::ImageInput::create(format_);
    if (!in_) {
      detail = oiio_detail(OIIO::geterror(), file);
      return false;
    }
    proxy_ = std::make_unique<PageProxy>(file, pages, page);
    if (!proxy_->opened()) {
      proxy_.reset();
      detail = "cannot open for reading";
      return false;
    }
    OIIO::ImageSpec config;
    OIIO::Filesystem::IOProxy* io = proxy_.get();
    config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &io);
    OIIO::ImageSpec spec;
    if (!in_->open(file.string(), spec, config)) {
      detail = oiio_detail(in_->geterror(), file);
      in_.reset();
      proxy_.reset();
      return false;
    }
    file_ = file;
    open_ = true;
    return true;
  }

  void close() {
    if (open_ && in_) in_->close();
    open_ = false;
    proxy_.reset();  // after the reader that uses it is closed
  }

  bool is_open(const fs::path& file) const { return open_ && file_ == file; }
  OIIO::ImageInput& input() { return *in_; }
  PngGreyDecoder& png_grey() { return png_grey_; }

 private:
  const char* format_;
  PngGreyDecoder png_grey_;           // this thread's buffers for the grey PNG fast path
  std::unique_ptr<PageProxy> proxy_;  // the multi-page TIFF's page that in_ has open; outlives it
  std::unique_ptr<OIIO::ImageInput> in_;
  fs::path file_;
  bool open_ = false;
};

// Stored -> HU with one multiply-add; channels beyond the first must equal it (grey stored as
// RGB) and are otherwise refused, since guessing a grey conversion would change CT values.
template <typename T>
Status convert_to_hu(const T* src, int width, int height, int channels, double slope,
                     double intercept, bool check_finite, const fs::path& file, int slice,
                     float* dst) {
  const size_t n = static_cast<size_t>(width) * height;
  const float s = static_cast<float>(slope), b = static_cast<float>(intercept);
  const int colour = std::min(channels, 3);  // a fourth channel is alpha and is ignored
  if (channels == 1) {
    for (size_t p = 0; p < n; ++p) dst[p] = static_cast<float>(src[p]) * s + b;
  } else {
    for (size_t p = 0; p < n; ++p) {
      const T* px = src + p * channels;
      for (int c = 1; c < colour; ++c) {
        if (!(px[c] == px[0])) {
          return Error(file.string(), "slice " + std::to_string(slice) + ": colour image (" +
                                          std::to_string(channels) +
                                          " channels) with differing "
                                          "channels at pixel (" +
                                          std::to_string(p % width) + ", " +
                                          std::to_string(p / width) + "); CT slices must be grey");
        }
      }
      dst[p] = static_cast<float>(px[0]) * s + b;
    }
  }
  if (check_finite) {
    for (size_t p = 0; p < n; ++p) {
      if (!std::isfinite(dst[p])) {
        const double v = static_cast<double>(src[p * channels]);
        return Error(file.string(), "slice " + std::to_string(slice) + ": value " +
                                        (std::isnan(v) ? std::string("NaN") : num(v)) +
                                        " at pixel (" + std::to_string(p % width) + ", " +
                                        std::to_string(p / width) + ")");
      }
    }
  }
  return Status::Ok();
}

// Slices (files, or pages of a multi-page TIFF) are decoded ahead on worker threads while the
// caller works on the current one: PNG and compressed TIFF decoding is the cost of reading a
// stack (PNG: ~4.5 ms of CPU per 512 x 512 16-bit slice through libpng + zlib, roughly half that
// for grey PNGs through png_fast.cpp's libdeflate path), so the rate grows with the cores
// decoding. One worker per core, at least 2 and at most 8; that many
// slices wait decoded at most (raw samples, ~0.5 MB each for 512 x 512 16-bit), and only while
// slices are read in ascending order.
int read_ahead() {
  static const int n = static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 2u, 8u));
  return n;
}

class ImageStackSource final : public SliceSource {
 public:
  Format format_ = Format::kTiffStack;
  VolumeGeometry geometry_;
  std::string description_;
  std::vector<std::string> notes_;
  std::vector<fs::path> files_;  // one per slice; a multi-page TIFF has one file
  bool multipage_ = false;
  bool png_ = false;
  TiffPages pages_;  // a multi-page TIFF's pages, each opened on its own (see PageProxy)
  PageInfo layout_;  // every slice has this size and pixel type
  double slope_ = 1.0, intercept_ = 0.0;
  std::unique_ptr<ImageReader> reader_;  // the caller's thread; the multi-page file stays open
  std::vector<unsigned char> raw_;

  ~ImageStackSource() override { drop_pending(); }

  Format format() const override { return format_; }
  const VolumeGeometry& geometry() const override { return geometry_; }
  std::string description() const override { return description_; }
  const std::vector<std::string>& notes() const override { return notes_; }

  Status read(int i, Slice& out) override {
    if (i < 0 || i >= geometry_.slice_count())
      return Error(files_.front().string(), "slice " + std::to_string(i) + " out of range");
    const fs::path& file = multipage_ ? files_.front() : files_[i];
    try {
      Status st = take_or_decode(i);
      schedule_after(i);
      last_read_ = i;
      if (!st) return st;
      return to_hu(i, file, out);
    } catch (const std::exception& e) {
      reader_->close();
      return Error(file.string(), "slice " + std::to_string(i) + ": " + e.what());
    } catch (...) {
      reader_->close();
      return Error(file.string(), "slice " + std::to_string(i) + ": cannot read the image");
    }
  }

 private:
  struct Decoded {
    Status status;
    std::vector<unsigned char> raw;
  };

  const fs::path& file_of(int i) const { return multipage_ ? files_.front() : files_[i]; }

  // Reads slice i's samples into `raw` with `reader` (one reader per thread).
  Status decode(int i, ImageReader& reader, std::vector<unsigned char>& raw) const {
    const fs::path& file = file_of(i);
    Status st = decode_with(i, file, reader, raw);
    reader.close();
    return st;
  }

  Status decode_with(int i, const fs::path& file, ImageReader& reader,
                     std::vector<unsigned char>& raw) const {
    if (multipage_) {
      std::string detail;
      if (!reader.open_page(file, pages_, i, detail))
        return Error(file.string(),
                     with_detail("cannot read page " + std::to_string(i + 1), detail));
    } else if (png_ && layout_.channels == 1 &&
               (layout_.pixel == Pixel::kU8 || layout_.pixel == Pixel::kU16)) {
      // Grey 8/16-bit PNG, the usual CT export: decoded in png_fast.cpp at about half the CPU of
      // libpng + zlib. A file it does not take (other PNG kinds, one that changed since the stack
      // was opened, damaged chunks) goes on to OpenImageIO below, which has the messages for it.
      std::string detail;
      switch (reader.png_grey().decode(file, layout_.width, layout_.height,
                                       static_cast<int>(pixel_bytes(layout_.pixel) * 8), raw,
                                       detail)) {
        case PngGreyDecoder::Outcome::kDecoded:
          return Status::Ok();
        case PngGreyDecoder::Outcome::kCorrupt:
          return Error(file.string(), with_detail("corrupt or truncated image data", detail));
        case PngGreyDecoder::Outcome::kNotHandled:
          break;
      }
    }
    if (!multipage_ && !reader.is_open(file)) {
      if (Status st = reader.open(file); !st) return st;
    }
    OIIO::ImageInput& in = reader.input();
    const int subimage = 0;  // a multi-page TIFF's page is opened as subimage 0
    // The header was checked when the stack was opened; check again in case the file changed.
    Result<PageInfo> page = page_info(in.spec(), file);
    if (!page) return page.error();
    if (!page.value().same_layout(layout_)) {
      return Error(file.string(), "changed since the stack was opened (now " +
                                      size_text(page.value()) + ", " + layout_text(page.value()) +
                                      ")");
    }
    const size_t n = static_cast<size_t>(layout_.width) * layout_.height;
    raw.resize(n * layout_.channels * pixel_bytes(layout_.pixel));
    // OpenImageIO 2.4 can return true from a short read of uncompressed strips and only leave a
    // message behind, so the error state counts too.
    in.geterror();  // clear anything left from the header
    const bool read_ok =
        in.read_image(subimage, 0, 0, layout_.channels, pixel_type(layout_.pixel), raw.data());
    if (!read_ok || in.has_error()) {
      return Error(
          file.string(),
          with_detail(multipage_ ? "page " + std::to_string(i + 1) + " is corrupt or truncated"
                                 : std::string("corrupt or truncated image data"),
                      oiio_detail(in.geterror(), file)));
    }
    return Status::Ok();
  }

  // Slice i's samples into raw_: from the read-ahead if it is there, else decoded here.
  Status take_or_decode(int i) {
    auto it = pending_.find(i);
    if (it == pending_.end()) return decode(i, *reader_, raw_);
    Decoded d = it->second.get();
    pending_.erase(it);
    raw_.swap(d.raw);
    give_back_buffer(std::move(d.raw));
    return d.status;
  }

  // Keeps the next read_ahead() slices decoding while reading goes up in order; anything else
  // (a jump, reading backwards) drops the read-ahead.
  void schedule_after(int i) {
    const bool ascending = i == last_read_ + 1;
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (!ascending || it->first <= i || it->first > i + read_ahead()) {
        it->second.wait();
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
    if (!ascending) return;
    for (int j = i + 1; j <= i + read_ahead() && j < geometry_.slice_count(); ++j) {
      if (pending_.count(j)) continue;
      pending_[j] = std::async(std::launch::async, [this, j]() {
        Decoded d;
        d.raw = take_buffer();
        std::unique_ptr<ImageReader> reader = take_reader();
        try {
          d.status = decode(j, *reader, d.raw);
        } catch (const std::exception& e) {
          reader->close();
          d.status = Error(file_of(j).string(), "slice " + std::to_string(j) + ": " + e.what());
        } catch (...) {
          reader->close();
          d.status =
              Error(file_of(j).string(), "slice " + std::to_string(j) + ": cannot read the image");
        }
        give_back_reader(std::move(reader));
        return d;
      });
    }
  }

  void drop_pending() {
    for (auto& [j, f] : pending_) f.wait();
    pending_.clear();
  }

  std::unique_ptr<ImageReader> take_reader() {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    if (readers_.empty()) return std::make_unique<ImageReader>(png_ ? "png" : "tiff");
    std::unique_ptr<ImageReader> r = std::move(readers_.back());
    readers_.pop_back();
    return r;
  }
  void give_back_reader(std::unique_ptr<ImageReader> r) {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    readers_.push_back(std::move(r));
  }
  std::vector<unsigned char> take_buffer() {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    if (buffers_.empty()) return {};
    std::vector<unsigned char> b = std::move(buffers_.back());
    buffers_.pop_back();
    return b;
  }
  void give_back_buffer(std::vector<unsigned char> b) {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    buffers_.push_back(std::move(b));
  }

  Status to_hu(int i, const fs::path& file, Slice& out) const {
    const size_t n = static_cast<size_t>(layout_.width) * layout_.height;
    out.index = i;
    out.z = geometry_.z[i];
    out.width = layout_.width;
    out.height = layout_.height;
    out.hu.resize(n);
    const int w = layout_.width, h = layout_.height, c = layout_.channels;
    const unsigned char* raw = raw_.data();
    switch (layout_.pixel) {
      case Pixel::kU8:
        return convert_to_hu(reinterpret_cast<const uint8_t*>(raw), w, h, c, slope_, intercept_,
                             false, file, i, out.hu.data());
      case Pixel::kI8:
        return convert_to_hu(reinterpret_cast<const int8_t*>(raw), w, h, c, slope_, intercept_,
                             false, file, i, out.hu.data());
      case Pixel::kU16:
        return convert_to_hu(reinterpret_cast<const uint16_t*>(raw), w, h, c, slope_, intercept_,
                             false, file, i, out.hu.data());
      case Pixel::kI16:
        return convert_to_hu(reinterpret_cast<const int16_t*>(raw), w, h, c, slope_, intercept_,
                             false, file, i, out.hu.data());
      case Pixel::kFloat:
        return convert_to_hu(reinterpret_cast<const float*>(raw), w, h, c, slope_, intercept_, true,
                             file, i, out.hu.data());
    }
    return Status::Ok();
  }

  int last_read_ = -1;
  std::map<int, std::future<Decoded>> pending_;
  std::mutex pool_mutex_;  // guards readers_ and buffers_, shared with the read-ahead tasks
  std::vector<std::unique_ptr<ImageReader>> readers_;
  std::vector<std::vector<unsigned char>> buffers_;
};

// The stack's files and where its sidecar may be.
struct StackLayout {
  fs::path where;  // what errors name: the folder or the multi-page TIFF
  std::vector<fs::path> files;
  bool multipage = false;
  bool png = false;
  std::optional<fs::path> sidecar;  // the sidecar that was found
  std::optional<StackSidecar> sc;
  std::vector<std::string> notes;
  std::optional<Error> mixed;  // TIFF and PNG files together: an error unless "files" picks
  size_t image_files = 0;      // TIFF and PNG files in the folder
};

std::optional<fs::path> existing_file(const fs::path& p) {
  std::error_code ec;
  if (fs::is_regular_file(p, ec)) return p;
  return std::nullopt;
}

Status find_files(const fs::path& path, StackLayout& s) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    // One multi-page TIFF: its own <name>.json first, then the folder's sawyer_stack.json.
    const std::string e = lower(path.extension().string());
    if (!is_tiff_ext(e)) return Error(path.string(), "not a TIFF file");
    s.where = path;
    s.files = {path};
    s.multipage = true;
    fs::path own = path;
    own.replace_extension(".json");
    s.sidecar = existing_file(own);
    if (!s.sidecar) s.sidecar = existing_file(path.parent_path() / kStackSidecarName);
    return Status::Ok();
  }
  if (!fs::is_directory(path, ec)) return Error(path.string(), "no such file or folder");
  s.where = path;
  s.sidecar = existing_file(path / kStackSidecarName);
  std::vector<std::string> tiffs, pngs;
  for (fs::directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.starts_with(".")) continue;
    std::error_code fec;
    if (!it->is_regular_file(fec)) continue;
    const std::string e = lower(it->path().extension().string());
    if (is_tiff_ext(e)) tiffs.push_back(name);
    if (is_png_ext(e)) pngs.push_back(name);
  }
  if (ec) return Error(path.string(), "cannot list the folder: " + ec.message());
  if (!tiffs.empty() && !pngs.empty()) {
    s.mixed = Error(path.string(), "mixes TIFF (" + std::to_string(tiffs.size()) + ") and PNG (" +
                                       std::to_string(pngs.size()) +
                                       ") files; a stack is one kind of image");
  }
  if (tiffs.empty() && pngs.empty()) return Error(path.string(), "no TIFF or PNG slices found");
  s.png = !pngs.empty();
  s.image_files = tiffs.size() + pngs.size();
  std::vector<std::string>& names = s.png ? pngs : tiffs;
  if (names.size() == 1 && !s.png) {
    // One TIFF in a folder: a multi-page TIFF (a one-page one fails the slice count below).
    s.multipage = true;
    fs::path own = path / names[0];
    own.replace_extension(".json");
    if (auto p = existing_file(own)) s.sidecar = p;
  }
  std::sort(names.begin(), names.end(), natural_less);
  for (const std::string& n : names) s.files.push_back(path / n);
  return Status::Ok();
}

// Applies the sidecar's "files" list to a folder stack.
Status apply_file_list(StackLayout& s) {
  if (!s.sc || s.sc->files.empty()) return Status::Ok();
  const std::string where = s.sidecar->string();
  if (s.multipage && s.files.size() == 1 && s.files[0] == s.where) {
    s.notes.push_back(where + ": \"files\" ignored for a multi-page TIFF");
    return Status::Ok();
  }
  const fs::path dir = s.where;
  std::vector<fs::path> listed;
  for (const std::string& name : s.sc->files) {
    const fs::path p = dir / name;
    if (!existing_file(p))
      return Error(where, "\"files\" names " + name + ", which is not a file in " + dir.string());
    const std::string e = lower(p.extension().string());
    if (!is_tiff_ext(e) && !is_png_ext(e))
      return Error(where, "\"files\" names " + name + ", which is not a TIFF or PNG file");
    if (!listed.empty() && is_png_ext(e) != is_png_ext(lower(listed.front().extension().string())))
      return Error(where, "\"files\" mixes TIFF and PNG files; a stack is one kind of image");
    listed.push_back(p);
  }
  if (listed.size() < s.image_files) {
    s.notes.push_back(std::to_string(s.image_files - listed.size()) + " image files in " +
                      dir.string() + " are not in the \"files\" list of " +
                      std::string(kStackSidecarName) + " and were ignored");
  }
  s.png = is_png_ext(lower(listed.front().extension().string()));
  s.files = std::move(listed);
  s.mixed.reset();
  s.multipage = false;
  return Status::Ok();
}

Status check_option(const std::optional<double>& v, const std::string& where, const char* flag) {
  if (v && !(*v > 0 && std::isfinite(*v)))
    return Error(where, std::string(flag) + " must be a positive number of mm, got " + num(*v));
  if (v) return check_spacing(where, flag, *v);
  return Status::Ok();
}

// Stored value -> HU (docs/ct_input.md, "HU"): an explicit rescale wins, each of slope and
// intercept taken from the options, else the sidecar, else the ImageJ calibration (a missing one
// is 1 or 0); without any, float and signed 16-bit data are HU, unsigned 16-bit is taken as
// HU + 1024 with a note, and 8-bit data is refused.
Status resolve_rescale(const OpenOptions& options, const StackLayout& s, const TagGeometry& tags,
                       const PageInfo& layout, const fs::path& first, ImageStackSource& src) {
  if (options.rescale_slope &&
      !(std::isfinite(*options.rescale_slope) && *options.rescale_slope != 0))
    return Error(s.where.string(), "OpenOptions::rescale_slope must be a non-zero number, got " +
                                       num(*options.rescale_slope));
  if (options.rescale_intercept && !std::isfinite(*options.rescale_intercept))
    return Error(s.where.string(), "OpenOptions::rescale_intercept must be a number, got " +
                                       num(*options.rescale_intercept));
  const StackSidecar none;
  const StackSidecar& sc = s.sc ? *s.sc : none;
  const std::optional<double> slope = options.rescale_slope ? options.rescale_slope
                                      : sc.rescale_slope    ? sc.rescale_slope
                                                            : tags.slope;
  const std::optional<double> intercept = options.rescale_intercept ? options.rescale_intercept
                                          : sc.rescale_intercept    ? sc.rescale_intercept
                                                                    : tags.intercept;
  const bool from_tags = (tags.slope && !options.rescale_slope && !sc.rescale_slope) ||
                         (tags.intercept && !options.rescale_intercept && !sc.rescale_intercept);
  if (from_tags) src.notes_.push_back(tags.rescale_note);
  if (slope || intercept) {
    src.slope_ = slope.value_or(1.0);
    src.intercept_ = intercept.value_or(0.0);
    return Status::Ok();
  }
  switch (layout.pixel) {
    case Pixel::kU8:
    case Pixel::kI8:
      return Error(first.string(), k8BitMessage);
    case Pixel::kU16:
      src.slope_ = 1.0;
      src.intercept_ = -1024.0;
      src.notes_.push_back(
          "unsigned 16-bit slices without a rescale: assumed HU = value - 1024 "
          "(give rescale_slope/rescale_intercept if that is wrong)");
      return Status::Ok();
    case Pixel::kI16:
    case Pixel::kFloat:
      src.slope_ = 1.0;
      src.intercept_ = 0.0;
      return Status::Ok();
  }
  return Status::Ok();
}

Result<std::unique_ptr<SliceSource>> open_stack(const fs::path& path, const OpenOptions& options) {
  StackLayout s;
  if (Status st = find_files(path, s); !st) return st.error();
  const std::string where = s.where.string();
  if (s.sidecar) {
    Result<StackSidecar> sc = read_stack_sidecar(*s.sidecar);
    if (!sc) return sc.error();
    s.sc = std::move(sc).value();
    for (const std::string& k : s.sc->unknown_keys)
      s.notes.push_back(s.sidecar->string() + ": unknown key \"" + k + "\" ignored");
    if (Status st = apply_file_list(s); !st) return st.error();
  }
  if (s.mixed) return *s.mixed;
  if (Status st = check_option(options.pixel_spacing, where, "OpenOptions::pixel_spacing"); !st)
    return st.error();
  if (Status st = check_option(options.slice_spacing, where, "OpenOptions::slice_spacing"); !st)
    return st.error();

  auto src = std::make_unique<ImageStackSource>();
  src->multipage_ = s.multipage;
  src->files_ = s.files;
  src->format_ = s.multipage ? Format::kMultiPageTiff
                 : s.png     ? Format::kPngStack
                             : Format::kTiffStack;
  src->png_ = s.png;
  src->reader_ = std::make_unique<ImageReader>(s.png ? "png" : "tiff");
  src->notes_ = s.notes;
  ImageReader& reader = *src->reader_;

  // Headers: every file (or page) must have the first one's size and pixel type.
  const fs::path& first = s.files.front();
  if (Status st = reader.open(first); !st) return st.error();
  Result<PageInfo> first_page = page_info(reader.input().spec(), first);
  if (!first_page) return first_page.error();
  const PageInfo layout = first_page.value();
  TagGeometry tags;
  if (!s.png) tags = read_tags(reader.input().spec(), first);
  int count = 0;
  if (s.multipage) {
    // As many pages as OpenImageIO could reach by seeking (the IFD chain up to its first
    // unreadable directory), but each opened directly.
    src->pages_ = tiff_pages(first);
    ImageReader page_reader("tiff");
    const int pages = static_cast<int>(src->pages_.ifd.size());
    std::string detail;
    for (count = 1; count < pages && page_reader.open_page(first, src->pages_, count, detail);
         ++count) {
      Result<PageInfo> page = page_info(page_reader.input().spec(), first);
      if (!page) return page.error().with_context("page " + std::to_string(count + 1));
      if (page.value().width != layout.width || page.value().height != layout.height) {
        return Error(where, "mixed page sizes: page " + std::to_string(count + 1) + " is " +
                                size_text(page.value()) + " but page 1 is " + size_text(layout));
      }
      if (!page.value().same_layout(layout)) {
        return Error(where, "mixed pixel types: page " + std::to_string(count + 1) + " is " +
                                layout_text(page.value()) + " but page 1 is " +
                                layout_text(layout));
      }
    }
    if (count == 1 && tags.imagej_images > 1) {
      return Error(where, "ImageJ stack of " + std::to_string(tags.imagej_images) +
                              " images stored after a single TIFF page (ImageJ's layout for "
                              "large stacks) is not supported; save it as an image sequence");
    }
  } else {
    reader.close();
    // The headers are read on two threads (this one and one more), each taking every other
    // file: opening 800 files is a tenth of the time to read a TIFF stack. The first bad file in
    // name order is the one reported, as when they were read one by one.
    struct Header {
      Status status;
      PageInfo page;
    };
    const size_t n = s.files.size();
    std::vector<Header> headers(n);
    std::atomic<size_t> first_bad{n};
    auto read_headers = [&](size_t from) {
      ImageReader r(s.png ? "png" : "tiff");
      for (size_t k = from; k < n && k < first_bad.load(); k += 2) {
        Header& h = headers[k];
        h.status = r.open(s.files[k]);
        if (h.status) {
          Result<PageInfo> page = page_info(r.input().spec(), s.files[k]);
          r.close();
          if (page)
            h.page = page.value();
          else
            h.status = page.error();
        }
        if (!h.status) {
          for (size_t b = first_bad.load(); k < b && !first_bad.compare_exchange_weak(b, k);) {
          }
        }
      }
    };
    std::future<void> other_half = std::async(std::launch::async, read_headers, size_t{2});
    read_headers(1);
    other_half.get();
    for (size_t k = 1; k < n; ++k) {
      if (!headers[k].status) return headers[k].status.error();
      const Result<PageInfo> page = headers[k].page;
      const std::string other = s.files[k].filename().string();
      const std::string base = first.filename().string();
      if (page.value().width != layout.width || page.value().height != layout.height) {
        return Error(where, "mixed image sizes: " + other + " is " + size_text(page.value()) +
                                " but " + base + " is " + size_text(layout));
      }
      if (!page.value().same_layout(layout)) {
        return Error(where, "mixed pixel types: " + other + " is " + layout_text(page.value()) +
                                " but " + base + " is " + layout_text(layout));
      }
    }
    count = static_cast<int>(s.files.size());
  }
  reader.close();
  if (count < 2) {
    return Error(where, "needs at least 2 slices, found 1 (" + first.filename().string() + ")");
  }
  src->layout_ = layout;

  // Geometry: options, then sidecar, then tags.
  VolumeGeometry& g = src->geometry_;
  g.width = layout.width;
  g.height = layout.height;
  const StackSidecar empty_sidecar;
  const StackSidecar& sc = s.sc ? *s.sc : empty_sidecar;
  const std::string sidecar_name = s.sidecar ? s.sidecar->filename().string() : kStackSidecarName;
  if (options.pixel_spacing) {
    g.spacing_x = g.spacing_y = *options.pixel_spacing;
    if (sc.pixel_spacing_x)
      src->notes_.push_back("OpenOptions::pixel_spacing " + num(*options.pixel_spacing) +
                            " mm overrides " + sidecar_name);
  } else if (sc.pixel_spacing_x) {
    g.spacing_x = *sc.pixel_spacing_x;
    g.spacing_y = *sc.pixel_spacing_y;
  } else if (tags.pixel_x) {
    g.spacing_x = *tags.pixel_x;
    g.spacing_y = *tags.pixel_y;
    src->notes_.push_back(tags.pixel_note);
  } else {
    if (!tags.pixel_note.empty()) src->notes_.push_back(tags.pixel_note);
    return Error(where, "no pixel spacing: put \"pixel_spacing_mm\" in " + sidecar_name +
                            " beside the slices or give OpenOptions::pixel_spacing (mm)");
  }
  if (options.slice_spacing) {
    for (int i = 0; i < count; ++i) g.z.push_back(i * *options.slice_spacing);
    if (sc.slice_spacing || !sc.z_mm.empty())
      src->notes_.push_back("OpenOptions::slice_spacing " + num(*options.slice_spacing) +
                            " mm overrides " + sidecar_name);
  } else if (!sc.z_mm.empty()) {
    if (static_cast<int>(sc.z_mm.size()) != count) {
      return Error(s.sidecar->string(), "\"z_mm\" has " + std::to_string(sc.z_mm.size()) +
                                            " positions for " + std::to_string(count) + " slices");
    }
    for (double z : sc.z_mm) g.z.push_back(z - sc.z_mm.front());
  } else if (sc.slice_spacing) {
    for (int i = 0; i < count; ++i) g.z.push_back(i * *sc.slice_spacing);
  } else if (tags.slice_spacing) {
    for (int i = 0; i < count; ++i) g.z.push_back(i * *tags.slice_spacing);
    src->notes_.push_back(tags.slice_note);
  } else {
    return Error(where, "no slice spacing: put \"slice_spacing_mm\" (or \"z_mm\") in " +
                            sidecar_name +
                            " beside the slices or give OpenOptions::slice_spacing (mm)");
  }
  if (sc.origin) g.origin = *sc.origin;
  if (sc.orientation) {
    g.orientation = *sc.orientation;
    // As in DICOM, the slices follow the normal row × column.
    const auto& o = g.orientation;
    g.slice_dir = cross(Vec3{o[0], o[1], o[2]}, Vec3{o[3], o[4], o[5]}).normalized();
  }

  if (Status st = resolve_rescale(options, s, tags, layout, first, *src); !st) return st.error();
  g.rescale_slope = src->slope_;
  g.rescale_intercept = src->intercept_;
  g.bits_stored =
      layout.pixel == Pixel::kFloat ? 32 : static_cast<int>(pixel_bytes(layout.pixel) * 8);
  g.pixel_signed =
      layout.pixel == Pixel::kI8 || layout.pixel == Pixel::kI16 || layout.pixel == Pixel::kFloat;

  std::string desc = format_name(src->format_);
  if (s.multipage) {
    desc += " " + first.filename().string() + ", " + std::to_string(count) + " pages";
  } else {
    desc += ", " + std::to_string(count) + " files (" + s.files.front().filename().string() +
            " ... " + s.files.back().filename().string() + ")";
  }
  desc += ", " + size_text(layout) + ", " + layout_text(layout);
  src->description_ = desc;
  // The sidecar checked its own keys; this holds the whole geometry (image size, field of view,
  // ImageJ spacing) to the limits.
  if (Status st = check_geometry_limits(where, g); !st) return st.error();
  return std::unique_ptr<SliceSource>(std::move(src));
}

// ---------------------------------------------------------------------------------------------
// Writing

class ImageStackSink final : public SliceSink {
 public:
  ImageStackSink(StagingDir staging, const VolumeGeometry& g, const WriteOptions& o)
      : staging_(std::move(staging)), g_(g), o_(o) {
    digits_ = std::max<int>(4, static_cast<int>(std::to_string(g.slice_count()).size()));
  }

  ~ImageStackSink() override {
    // An abandoned multi-page file must be closed before the staging folder is removed.
    if (out_) {
      try {
        out_->close();
      } catch (...) {
      }
    }
  }

  Status write(const Slice& slice) override {
    try {
      return write_slice(slice);
    } catch (const std::exception& e) {
      return Error(staging_.out().string(), "slice " + std::to_string(next_) + ": " + e.what());
    }
  }

  Status finish() override {
    const std::string where = staging_.out().string();
    if (finished_) return Error(where, "finish() called twice");
    if (next_ != g_.slice_count()) {
      return Error(where, "finish() after " + std::to_string(next_) + " of " +
                              std::to_string(g_.slice_count()) + " slices");
    }
    if (out_) {
      const bool ok = out_->close();
      const std::string err = ok ? std::string() : out_->geterror();
      out_.reset();
      if (!ok) return Error(where, with_detail("cannot finish stack.tif", err));
    }
    const std::string text = format_stack_sidecar(
        g_, o_.rescale_slope, o_.rescale_intercept,
        o_.format == Format::kMultiPageTiff ? std::vector<std::string>{} : files_);
    {
      std::ofstream f(staging_.path() / kStackSidecarName, std::ios::binary | std::ios::trunc);
      f << text;
      f.close();
      if (!f) return Error(where, std::string("cannot write ") + kStackSidecarName);
    }
    if (o_.before_commit) {
      if (Status st = o_.before_commit(staging_.path()); !st) return st;
    }
    if (Status st = staging_.commit(); !st) return st;
    finished_ = true;
    return Status::Ok();
  }

 private:
  Status write_slice(const Slice& slice) {
    const std::string where = staging_.out().string();
    if (finished_) return Error(where, "write() after finish()");
    if (next_ >= g_.slice_count())
      return Error(where, "more slices than the geometry's " + std::to_string(g_.slice_count()));
    if (slice.width != g_.width || slice.height != g_.height ||
        slice.hu.size() != static_cast<size_t>(g_.width) * g_.height) {
      return Error(where, "slice " + std::to_string(next_) + " is " + std::to_string(slice.width) +
                              " x " + std::to_string(slice.height) + ", expected " +
                              std::to_string(g_.width) + " x " + std::to_string(g_.height));
    }
    const bool eight = o_.bits_stored == 8;
    const double hi = eight ? 255.0 : 65535.0;
    const size_t n = slice.hu.size();
    if (eight)
      buf8_.resize(n);
    else
      buf16_.resize(n);
    for (size_t p = 0; p < n; ++p) {
      const float hu = slice.hu[p];
      if (!std::isfinite(hu)) {
        return Error(where, "slice " + std::to_string(next_) + ": HU value " + num(hu) +
                                " at pixel (" + std::to_string(p % g_.width) + ", " +
                                std::to_string(p / g_.width) + ")");
      }
      const double v = stored_value(hu, o_.rescale_slope, o_.rescale_intercept, 0.0, hi);
      if (eight)
        buf8_[p] = static_cast<uint8_t>(v);
      else
        buf16_[p] = static_cast<uint16_t>(v);
    }
    OIIO::ImageSpec spec(g_.width, g_.height, 1,
                         eight ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::UINT16);
    const void* data = eight ? static_cast<const void*>(buf8_.data()) : buf16_.data();
    const bool png = o_.format == Format::kPngStack;
    if (png) {
      // Level 1: a few percent larger than the default, several times faster to write.
      spec.attribute("png:compressionLevel", 1);
    } else {
      spec.attribute("compression", "none");  // uncompressed reads fastest
      // Resolution tags in pixels per cm, so other programs see the spacing too.
      spec.attribute("XResolution", static_cast<float>(10.0 / g_.spacing_x));
      spec.attribute("YResolution", static_cast<float>(10.0 / g_.spacing_y));
      spec.attribute("ResolutionUnit", "cm");
      // OpenImageIO writes YResolution as XResolution x PixelAspectRatio.
      spec.attribute("PixelAspectRatio", static_cast<float>(g_.spacing_x / g_.spacing_y));
    }

    if (o_.format == Format::kMultiPageTiff) {
      const fs::path file = staging_.path() / "stack.tif";
      if (!out_) {
        out_ = OIIO::ImageOutput::create("tiff");
        if (!out_) return Error(where, with_detail("no TIFF writer", OIIO::geterror()));
        if (!out_->open(file.string(), spec, OIIO::ImageOutput::Create))
          return Error(where, with_detail("cannot create stack.tif", out_->geterror()));
      } else if (!out_->open(file.string(), spec, OIIO::ImageOutput::AppendSubimage)) {
        return Error(where,
                     with_detail("cannot add page " + std::to_string(next_ + 1) + " to stack.tif",
                                 out_->geterror()));
      }
      if (!out_->write_image(spec.format, data))
        return Error(
            where, with_detail("cannot write page " + std::to_string(next_ + 1), out_->geterror()));
    } else {
      std::string name = std::to_string(next_ + 1);
      name = "slice_" + std::string(digits_ - std::min<int>(digits_, name.size()), '0') + name +
             (png ? ".png" : ".tif");
      const fs::path file = staging_.path() / name;
      std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(png ? "png" : "tiff");
      if (!out) return Error(where, with_detail("no image writer", OIIO::geterror()));
      if (!out->open(file.string(), spec) || !out->write_image(spec.format, data)) {
        const std::string err = out->geterror();
        out->close();
        return Error(where, with_detail("cannot write " + name, err));
      }
      if (!out->close()) return Error(where, with_detail("cannot write " + name, out->geterror()));
      files_.push_back(name);
    }
    ++next_;
    return Status::Ok();
  }

  StagingDir staging_;
  VolumeGeometry g_;
  WriteOptions o_;
  int digits_ = 4;
  int next_ = 0;
  bool finished_ = false;
  std::vector<std::string> files_;
  std::unique_ptr<OIIO::ImageOutput> out_;  // the multi-page TIFF, open between pages
  std::vector<uint16_t> buf16_;
  std::vector<uint8_t> buf8_;
};

}  // namespace

Result<std::unique_ptr<SliceSource>> open_image_stack(const fs::path& path,
                                                      const OpenOptions& options) {
  try {
    return open_stack(path, options);
  } catch (const std::exception& e) {
    return Error(path.string(), with_detail("cannot read the image stack", e.what()));
  } catch (...) {
    return Error(path.string(), "cannot read the image stack");
  }
}

Result<std::unique_ptr<SliceSink>> create_image_stack_writer(const fs::path& out,
                                                             const VolumeGeometry& geometry,
                                                             const WriteOptions& options) {
  const std::string where = out.string();
  if (options.format != Format::kTiffStack && options.format != Format::kPngStack &&
      options.format != Format::kMultiPageTiff)
    return Error(where, "not an image stack format");
  if (options.bits_stored != 8 && options.bits_stored != 16)
    return Error(where,
                 "image stacks store 8 or 16 bits, not " + std::to_string(options.bits_stored));
  if (!std::isfinite(options.rescale_slope) || options.rescale_slope == 0 ||
      !std::isfinite(options.rescale_intercept))
    return Error(where, "rescale slope must be non-zero and both rescale values finite");
  if (geometry.width <= 0 || geometry.height <= 0 ||
      static_cast<long long>(geometry.width) * geometry.height > kMaxSlicePixels)
    return Error(where, "implausible slice size");
  if (!(geometry.spacing_x > 0) || !(geometry.spacing_y > 0))
    return Error(where, "pixel spacing must be positive");
  for (size_t i = 1; i < geometry.z.size(); ++i) {
    if (!(geometry.z[i] > geometry.z[i - 1]))
      return Error(where,
                   "slice positions must increase strictly (slice " + std::to_string(i) + ")");
  }
  Result<StagingDir> staging = StagingDir::create(out);
  if (!staging) return staging.error();
  return std::unique_ptr<SliceSink>(
      std::make_unique<ImageStackSink>(std::move(staging).value(), geometry, options));
}

}  // namespace sawyer::ct::detail
