// One TIFF or PNG slice file (or one page of a multi-page TIFF) as the stack reader sees it
// (image_file.cpp): its pixel layout, the geometry its tags give, and the OpenImageIO reader
// that opens it, after the looks into the file's structure that OpenImageIO needs done first.
// Internal.
#pragma once

#include <OpenImageIO/imageio.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "png_fast.h"
#include "readers.h"
#include "sawyer/core/result.h"

namespace sawyer::ct::detail {

// OpenImageIO messages may span lines and repeat the file name; ours are one line that already
// starts with it.
std::string oiio_detail(std::string s, const fs::path& file);

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

OIIO::TypeDesc pixel_type(Pixel p);
size_t pixel_bytes(Pixel p);
std::string size_text(const PageInfo& p);    // "512 x 512"
std::string layout_text(const PageInfo& p);  // "16-bit unsigned", and the channels if not 1

// What a page holds, or why Sawyer cannot use it.
Result<PageInfo> page_info(const OIIO::ImageSpec& spec, const fs::path& file);

// ---------------------------------------------------------------------------------------------
// TIFF tags

// What the first slice's tags say about geometry; each field is empty when the tags are silent.
struct TagGeometry {
  std::optional<double> pixel_x, pixel_y;  // mm
  std::optional<double> slice_spacing;     // mm (ImageJ spacing=)
  std::optional<double> slope, intercept;  // ImageJ straight-line calibration
  int imagej_images = 0;                   // ImageJ images=
  // Where each value came from, for the notes of the values that get used.
  std::string pixel_note, slice_note, rescale_note;
};

// What `spec` (the first slice's) says in its ImageJ description and resolution tags.
TagGeometry read_tags(const OIIO::ImageSpec& spec, const fs::path& file);

// ---------------------------------------------------------------------------------------------
// Multi-page TIFF

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
TiffPages tiff_pages(const fs::path& file);

// One page of a multi-page TIFF as OpenImageIO's I/O proxy (image_file.cpp).
class PageProxy;

// ---------------------------------------------------------------------------------------------
// Reading

// One OpenImageIO reader of a fixed format, reopened for each file: creating readers by format
// name ("tiff", "png") rather than by file name keeps OpenImageIO from trying every other format
// on a damaged file, and reusing one saves the plugin lookup per slice.
class ImageReader {
 public:
  explicit ImageReader(const char* format);
  ~ImageReader();  // out of line, where PageProxy is complete

  // Opens `file` as the format's first image (a PNG after check_png_chunks).
  Status open(const fs::path& file);

  // Page `page` of a multi-page TIFF (tiff_pages() found it) as subimage 0; the message of a
  // failure is OpenImageIO's, or empty.
  bool open_page(const fs::path& file, const TiffPages& pages, int page, std::string& detail);

  void close();

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

}  // namespace sawyer::ct::detail
