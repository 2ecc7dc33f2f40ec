// One TIFF or PNG slice file through OpenImageIO: what a page holds (page_info), the geometry of
// its TIFF tags (read_tags), the PNG chunk walk and the multi-page TIFF page directories that
// keep OpenImageIO from leaking or slowing down, and ImageReader, which opens files and pages.
#include "image_file.h"

#include <OpenImageIO/filesystem.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>
#include <unordered_set>

#include "text_parse.h"

namespace sawyer::ct::detail {

namespace {

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

}  // namespace

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
// Pixel types

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

TagGeometry read_tags(const OIIO::ImageSpec& spec, const fs::path& file) {
  TagGeometry t;
  const std::string name = file.filename().string();
  std::map<std::string, std::string> ij;
  const std::string desc = spec.get_string_attribute("ImageDescription");
  if (desc.starts_with("ImageJ=")) {
    std::istringstream lines(desc);
    std::string line;
    while (std::getline(lines, line)) {
      if (auto kv = split_key_value(line, "=")) ij[kv->first] = kv->second;
    }
  }
  auto ij_number = [&](const char* key) -> std::optional<double> {
    auto it = ij.find(key);
    if (it == ij.end()) return std::nullopt;
    return parse_leading_double(it->second);
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
// Multi-page TIFF

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

// ---------------------------------------------------------------------------------------------
// Reading

ImageReader::ImageReader(const char* format) : format_(format) {}
ImageReader::~ImageReader() = default;

Status ImageReader::open(const fs::path& file) {
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

bool ImageReader::open_page(const fs::path& file, const TiffPages& pages, int page,
                            std::string& detail) {
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

void ImageReader::close() {
  if (open_ && in_) in_->close();
  open_ = false;
  proxy_.reset();  // after the reader that uses it is closed
}

}  // namespace sawyer::ct::detail
