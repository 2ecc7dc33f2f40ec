// The TIFF and PNG stack reader behind open_ct(): a folder of 2D images (one per slice, in
// natural name order or as sawyer_stack.json lists them) or one multi-page TIFF, each image
// through OpenImageIO (image_file.cpp). docs/ct_input.md is the user's side of it.
//
// Reading never holds more than a few slices: open() checks every file's header (size, pixel
// type, channels) so a bad stack fails before a long run; read() decodes one image into buffers
// reused from slice to slice, while (ascending reads) worker threads decode the next few slices.
// Geometry comes from, in this order, the command-line options, the sidecar, and TIFF tags
// (ImageJ description, resolution tags); HU follow resolve_rescale().
#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <exception>
#include <future>
#include <map>
#include <mutex>
#include <system_error>
#include <thread>

#include "image_file.h"
#include "png_fast.h"
#include "readers.h"
#include "sawyer/ct/io/limits.h"
#include "sidecar.h"
#include "text_parse.h"

namespace sawyer::ct::detail {

namespace {

constexpr const char* k8BitMessage =
    "8-bit slices carry no HU scale: give rescale_slope/rescale_intercept in sawyer_stack.json "
    "or OpenOptions::rescale_slope/OpenOptions::rescale_intercept";

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
// Reading

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

}  // namespace sawyer::ct::detail
