// What the volume readers and writers share (volume_common.cpp): the header a MetaImage, NRRD
// or .vti file declares and its checks, the VTK plumbing, and the source that reads slices
// through VTK (volume_reader.cpp); each format's reader and writer is in a file of its own.
// Internal.
#pragma once

#include <vtkAlgorithm.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkImageReader2.h>
#include <vtkSmartPointer.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "readers.h"
#include "sawyer/core/result.h"
#include "sawyer/core/vec.h"
#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct::detail {

constexpr long long kMaxSlices = 1LL << 20;
// deflate cannot expand data by more than about 1032:1, so a compressed volume that claims more
// than this many bytes per byte on disk is corrupt (and would make VTK allocate for nothing).
constexpr double kMaxCompressionRatio = 1100.0;

inline Vec3 normalized(Vec3 v) { return v.normalized(); }

// Bytes as "1.5 MB" for notes.
std::string mb(double bytes);

// ---------------------------------------------------------------------------------------------
// What a header declares, format-independent.

enum class Scalar { kU8, kI8, kU16, kI16, kF32, kF64 };

size_t scalar_bytes(Scalar s);
int vtk_type(Scalar s);
std::optional<Scalar> scalar_of_vtk(int t);
const char* scalar_name(Scalar s);

struct VolumeHeader {
  int dims[3] = {0, 0, 0};
  double spacing[3] = {0, 0, 0};
  Vec3 origin;
  Vec3 axis[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // unit direction of each index axis
  Scalar scalar = Scalar::kI16;
  bool big_endian = false;
  bool compressed = false;
  fs::path data_file;        // where the samples are
  uint64_t data_offset = 0;  // byte offset of the first sample in data_file (raw data)
  std::optional<double> slope, intercept;  // MetaImage ElementToIntensityFunction*

  uint64_t voxels() const {
    return static_cast<uint64_t>(dims[0]) * static_cast<uint64_t>(dims[1]) *
           static_cast<uint64_t>(dims[2]);
  }
  uint64_t data_bytes() const { return voxels() * scalar_bytes(scalar); }
};

// Sizes: 3 positive ones within the limits; `key` names them in errors.
Status check_dims(const VolumeHeader& h, const std::string& where, const char* key);
// Spacings: 3 positive ones within ct::check_spacing's limits; `key` names them in errors.
Status check_spacing(const VolumeHeader& h, const std::string& where, const char* key);

// The size of `p`, or an error that `where` leads.
Result<uint64_t> file_size(const fs::path& p, const std::string& where);

// Raw data must be all there; compressed data must be able to hold what it claims.
Status check_data_size(const VolumeHeader& h, const std::string& where);

// Reads the start of a file (headers are small; a 4 MB cap keeps garbage from being slurped).
Result<std::string> read_head(const fs::path& file, size_t max_bytes);

// ---------------------------------------------------------------------------------------------
// VTK plumbing

// Collects VTK's error messages (which would otherwise go to stderr) so they can become one
// Error line; warnings are dropped.
class VtkErrors : public vtkCommand {
 public:
  static VtkErrors* New() { return new VtkErrors; }
  void Execute(vtkObject*, unsigned long event, void* data) override;
  void clear() {
    count_ = 0;
    first_.clear();
  }
  bool any() const { return count_ > 0; }
  const std::string& first() const { return first_; }

  void watch(vtkObject* o) {
    if (!o) return;
    o->AddObserver(vtkCommand::ErrorEvent, this);
    o->AddObserver(vtkCommand::WarningEvent, this);
  }

 private:
  int count_ = 0;
  std::string first_;
};

// A volume file read slice by slice (or whole, when `whole_`) through the VTK reader that its
// format's open_*() set up (volume_reader.cpp).
class VtkVolumeSource final : public SliceSource {
 public:
  Format format_ = Format::kVti;
  fs::path file_;
  VolumeGeometry geometry_;
  std::string description_;
  std::vector<std::string> notes_;
  vtkSmartPointer<vtkAlgorithm> reader_;
  vtkSmartPointer<VtkErrors> errors_;
  int extent_[6] = {0, 0, 0, 0, 0, 0};  // whole extent
  bool whole_ = false;                  // the reader cannot stream: read everything once
  bool whole_loaded_ = false;
  std::optional<Scalar> scalar_;  // known from the header, or from the first slice read
  double slope_ = 1.0, intercept_ = 0.0;

  Format format() const override { return format_; }
  const VolumeGeometry& geometry() const override { return geometry_; }
  std::string description() const override { return description_; }
  const std::vector<std::string>& notes() const override { return notes_; }

  Status read(int i, Slice& out) override;

  // Runs the reader for slice `i` (or everything) and returns its output's scalars.
  Result<vtkDataArray*> update(int i, vtkImageData** image);

 private:
  template <typename T>
  Status convert(const T* base, vtkImageData* img, int k, int i, Slice& out);
  Status read_slice(int i, Slice& out);
};

// A reader of raw samples at a known offset (a header checked by the format's parser):
// vtkImageReader2 seeks to the requested slice, so only that slice is read.
vtkSmartPointer<vtkImageReader2> raw_reader(const VolumeHeader& h);

// ---------------------------------------------------------------------------------------------
// The formats. Each reads and checks its header into `h` and sets up src.reader_ (and, where
// the reader cannot stream, src.whole_ with a note).

// metaimage_reader.cpp: .mha/.mhd.
Status open_metaimage(const fs::path& file, VtkVolumeSource& src, VolumeHeader& h);
// nrrd_reader.cpp: .nrrd/.nhdr.
Status open_nrrd(const fs::path& file, VtkVolumeSource& src, VolumeHeader& h);
// vti_reader.cpp: .vti; bounds the declared size by the size on disk before VTK allocates.
Status open_vti(const fs::path& file, VtkVolumeSource& src, VolumeHeader& h);

// The writers' format parts (volume_writer.cpp streams the slices): the header text of
// volume.mha (metaimage_writer.cpp) and volume.nrrd (nrrd_writer.cpp) for a volume of `g`'s
// size with index axes `axis`, slice spacing `dz` and 16-bit integer or (float_samples) float
// samples; and volume.vti from `image` (vti_writer.cpp), `where` leading its errors.
std::string metaimage_header(const VolumeGeometry& g, const Vec3 (&axis)[3], double dz,
                             bool float_samples);
std::string nrrd_header(const VolumeGeometry& g, const Vec3 (&axis)[3], double dz,
                        bool float_samples);
Status write_vti(vtkImageData* image, const fs::path& file, const std::string& where);

}  // namespace sawyer::ct::detail
