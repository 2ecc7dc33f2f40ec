// The format readers and writers behind open_ct() and create_ct_writer(). Internal.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct::detail {

namespace fs = std::filesystem;

// Larger slices than this are not CT slices but corrupt headers; refuse before allocating.
inline constexpr long long kMaxSlicePixels = 1LL << 26;  // 8192 x 8192

// "what (detail)", or just "what" when a library gave no detail.
inline std::string with_detail(const std::string& what, const std::string& detail) {
  return detail.empty() ? what : what + " (" + detail + ")";
}

// dicom_reader.cpp: a folder of DICOM files (or one file of it); picks the series.
// Returns the raw z positions (possibly uneven); open_ct applies make_uniform_z.
Result<std::unique_ptr<SliceSource>> open_dicom(const fs::path& path, const OpenOptions& options);
// dicom_structure.cpp: true when the file starts like DICOM (preamble + "DICM", or a bare
// group-0008 data set).
bool looks_like_dicom(const fs::path& file);

// image_stack_reader.cpp: a folder of 2D TIFF/PNG files (natural sort of names), or one multi-page
// TIFF.
Result<std::unique_ptr<SliceSource>> open_image_stack(const fs::path& path,
                                                      const OpenOptions& options);

// volume_reader.cpp: .vti, .mha/.mhd, .nrrd/.nhdr.
Result<std::unique_ptr<SliceSource>> open_vtk_volume(const fs::path& file,
                                                     const OpenOptions& options);

// uniform_z.cpp: make_uniform_z(), with the refusal of invented slices naming `file` (the path
// open_ct was given) rather than the source's description; "" names the description.
Result<std::unique_ptr<SliceSource>> make_uniform_z(std::unique_ptr<SliceSource> source,
                                                    const OpenOptions& options,
                                                    const std::string& file);

// Writers, one per family: dicom_writer.cpp, image_stack_writer.cpp, volume_writer.cpp.
Result<std::unique_ptr<SliceSink>> create_dicom_writer(const fs::path& out,
                                                       const VolumeGeometry& geometry,
                                                       const WriteOptions& options);
Result<std::unique_ptr<SliceSink>> create_image_stack_writer(const fs::path& out,
                                                             const VolumeGeometry& geometry,
                                                             const WriteOptions& options);
Result<std::unique_ptr<SliceSink>> create_volume_writer(const fs::path& out,
                                                        const VolumeGeometry& geometry,
                                                        const WriteOptions& options);

}  // namespace sawyer::ct::detail
