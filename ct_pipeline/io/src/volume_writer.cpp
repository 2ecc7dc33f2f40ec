// The volume file writer behind create_ct_writer(): volume.vti, volume.mha or volume.nrrd in a
// staging folder, HU as 16-bit integers or 32-bit floats on an even slice grid. MetaImage and
// NRRD slices are streamed to the file after the header (metaimage_writer.cpp,
// nrrd_writer.cpp); a .vti is held whole and written by finish() (vti_writer.cpp).
#include <vtkImageData.h>
#include <vtkType.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <new>
#include <string>
#include <vector>

#include "readers.h"
#include "staging.h"
#include "text_parse.h"
#include "volume_common.h"

namespace sawyer::ct::detail {

namespace {

class VolumeSink final : public SliceSink {
 public:
  VolumeSink(StagingDir staging, const VolumeGeometry& g, const WriteOptions& o)
      : staging_(std::move(staging)), g_(g), o_(o), float_(o.bits_stored == 32) {
    const Vec3 row{g.orientation[0], g.orientation[1], g.orientation[2]};
    const Vec3 col{g.orientation[3], g.orientation[4], g.orientation[5]};
    axis_[0] = row.normalized();
    axis_[1] = col.normalized();
    axis_[2] = cross(axis_[0], axis_[1]).normalized();
    dz_ = (g.z.back() - g.z.front()) / (g.slice_count() - 1);
  }

  Status start() {
    const std::string where = staging_.out().string();
    const size_t slice_voxels = static_cast<size_t>(g_.width) * g_.height;
    if (o_.format == Format::kVti) {
      image_ = vtkSmartPointer<vtkImageData>::New();
      image_->SetDimensions(g_.width, g_.height, g_.slice_count());
      image_->SetSpacing(g_.spacing_x, g_.spacing_y, dz_);
      image_->SetOrigin(g_.origin.x, g_.origin.y, g_.origin.z);
      image_->SetDirectionMatrix(axis_[0].x, axis_[1].x, axis_[2].x, axis_[0].y, axis_[1].y,
                                 axis_[2].y, axis_[0].z, axis_[1].z, axis_[2].z);
      image_->AllocateScalars(float_ ? VTK_FLOAT : VTK_SHORT, 1);
      if (!image_->GetScalarPointer()) return Error(where, "out of memory for the volume");
      return Status::Ok();
    }
    const fs::path file =
        staging_.path() / (o_.format == Format::kMetaImage ? "volume.mha" : "volume.nrrd");
    stream_.open(file, std::ios::binary | std::ios::trunc);
    if (!stream_) return Error(where, "cannot create " + file.filename().string());
    const std::string text = o_.format == Format::kMetaImage
                                 ? metaimage_header(g_, axis_, dz_, float_)
                                 : nrrd_header(g_, axis_, dz_, float_);
    stream_.write(text.data(), static_cast<std::streamsize>(text.size()));
    if (float_)
      fbuf_.resize(slice_voxels);
    else
      sbuf_.resize(slice_voxels);
    if (!stream_) return Error(where, "write failed (disk full?)");
    return Status::Ok();
  }

  Status write(const Slice& slice) override {
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
    const size_t n = slice.hu.size();
    float* fdst = nullptr;
    int16_t* sdst = nullptr;
    if (image_) {
      void* base = image_->GetScalarPointer(0, 0, next_);
      if (float_)
        fdst = static_cast<float*>(base);
      else
        sdst = static_cast<int16_t*>(base);
    } else {
      fdst = fbuf_.data();
      sdst = sbuf_.data();
    }
    for (size_t p = 0; p < n; ++p) {
      const float hu = slice.hu[p];
      if (!std::isfinite(hu)) {
        return Error(where, "slice " + std::to_string(next_) + ": HU value " + num(hu) +
                                " at pixel (" + std::to_string(p % g_.width) + ", " +
                                std::to_string(p / g_.width) + ")");
      }
      // Volume files hold HU directly (no rescale): signed 16-bit, or float when asked.
      if (float_)
        fdst[p] = hu;
      else
        sdst[p] = static_cast<int16_t>(stored_value(hu, 1.0, 0.0, -32768.0, 32767.0));
    }
    if (!image_) {
      // Little-endian samples, as both headers declare.
      static_assert(std::endian::native == std::endian::little, "big-endian hosts need a swap");
      const char* bytes =
          float_ ? reinterpret_cast<const char*>(fdst) : reinterpret_cast<const char*>(sdst);
      stream_.write(bytes, static_cast<std::streamsize>(n * (float_ ? 4 : 2)));
      if (!stream_) return Error(where, "write failed (disk full?)");
    }
    ++next_;
    return Status::Ok();
  }

  Status finish() override {
    const std::string where = staging_.out().string();
    if (finished_) return Error(where, "finish() called twice");
    if (next_ != g_.slice_count()) {
      return Error(where, "finish() after " + std::to_string(next_) + " of " +
                              std::to_string(g_.slice_count()) + " slices");
    }
    if (image_) {
      if (Status st = write_vti(image_, staging_.path() / "volume.vti", where); !st) return st;
      image_ = nullptr;
    } else {
      stream_.close();
      if (!stream_) return Error(where, "write failed (disk full?)");
    }
    if (o_.before_commit) {
      if (Status st = o_.before_commit(staging_.path()); !st) return st;
    }
    if (Status st = staging_.commit(); !st) return st;
    finished_ = true;
    return Status::Ok();
  }

 private:
  StagingDir staging_;
  VolumeGeometry g_;
  WriteOptions o_;
  bool float_ = false;
  Vec3 axis_[3];
  double dz_ = 1.0;
  int next_ = 0;
  bool finished_ = false;
  vtkSmartPointer<vtkImageData> image_;  // .vti: the whole volume, written by finish()
  std::ofstream stream_;                 // .mha/.nrrd: header, then slices as they come
  std::vector<float> fbuf_;
  std::vector<int16_t> sbuf_;
};

}  // namespace

Result<std::unique_ptr<SliceSink>> create_volume_writer(const fs::path& out,
                                                        const VolumeGeometry& geometry,
                                                        const WriteOptions& options) {
  const std::string where = out.string();
  if (options.format != Format::kVti && options.format != Format::kMetaImage &&
      options.format != Format::kNrrd)
    return Error(where, "not a volume format");
  if (options.bits_stored != 16 && options.bits_stored != 32) {
    return Error(where, "volume files store HU as 16-bit integers or 32-bit floats, not " +
                            std::to_string(options.bits_stored) + "-bit values");
  }
  if (geometry.width <= 0 || geometry.height <= 0 ||
      static_cast<long long>(geometry.width) * geometry.height > kMaxSlicePixels)
    return Error(where, "implausible slice size");
  if (!(geometry.spacing_x > 0) || !(geometry.spacing_y > 0))
    return Error(where, "pixel spacing must be positive");
  const int n = geometry.slice_count();
  if (n < 2) return Error(where, "a volume file needs at least 2 slices");
  // Volume formats have one slice spacing; uneven positions need a stack (its sidecar has z_mm).
  const double median = geometry.slice_spacing();
  if (!(median > 0)) return Error(where, "slice positions must increase");
  for (int k = 1; k < n; ++k) {
    const double gap = geometry.z[k] - geometry.z[k - 1];
    if (std::abs(gap - median) > 1e-3 * median) {
      return Error(where,
                   "volume formats need evenly spaced slices, but slices " + std::to_string(k - 1) +
                       " and " + std::to_string(k) + " are " + num(gap) + " mm apart (elsewhere " +
                       num(median) +
                       " mm); write a TIFF or PNG stack (it records z_mm) or resample first");
    }
  }
  const Vec3 row{geometry.orientation[0], geometry.orientation[1], geometry.orientation[2]};
  const Vec3 col{geometry.orientation[3], geometry.orientation[4], geometry.orientation[5]};
  if (std::abs(row.norm() - 1) > 1e-3 || std::abs(col.norm() - 1) > 1e-3 ||
      std::abs(dot(row, col)) > 1e-3)
    return Error(where, "orientation must hold two perpendicular unit vectors");
  try {
    Result<StagingDir> staging = StagingDir::create(out);
    if (!staging) return staging.error();
    auto sink = std::make_unique<VolumeSink>(std::move(staging).value(), geometry, options);
    if (Status st = sink->start(); !st) return st.error();
    return std::unique_ptr<SliceSink>(std::move(sink));
  } catch (const std::bad_alloc&) {
    return Error(where, "out of memory for the volume");
  }
}

}  // namespace sawyer::ct::detail
