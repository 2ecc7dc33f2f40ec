// The TIFF and PNG stack writer behind create_ct_writer(): one 8- or 16-bit grey image per slice
// (or one multi-page TIFF) and the sawyer_stack.json sidecar with the geometry, written into a
// staging folder and moved into place by finish().
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "readers.h"
#include "sidecar.h"
#include "staging.h"
#include "text_parse.h"

namespace sawyer::ct::detail {

namespace {

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
