// Writing CT slice folders: the other half of slice_source.h, used by the phantom synthesiser
// and by tests that need scans in every format.
//
//   auto sink = create_ct_writer("out/phantom", geometry, {.format = Format::kDicom});
//   if (!sink) ...
//   for (...) { if (Status st = sink.value()->write(slice); !st) ... }
//   if (Status st = sink.value()->finish(); !st) ...   // only now does out/phantom appear
//
// Output is all or nothing: slices go to a temporary sibling folder that finish() renames into
// place; a sink destroyed before finish() (an error, Ctrl-C unwinding) removes its temporary
// folder and leaves any existing output untouched.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/ct/io/slice_source.h"

namespace sawyer::ct {

struct WriteOptions {
  Format format = Format::kDicom;
  // Stored value = round((HU - intercept) / slope), clamped to the stored type's range: signed
  // 16-bit for DICOM, unsigned 16-bit for image stacks (8-bit with bits_stored = 8). The default
  // intercept -1024 puts air at stored 0 in every format; the phantom asks DICOM for 0.
  double rescale_slope = 1.0;
  double rescale_intercept = -1024.0;
  int bits_stored = 16;
  // DICOM header text.
  std::string patient_name = "Sawyer^Phantom";
  std::string series_description = "Sawyer phantom";
  std::string manufacturer = "Sawyer";
  // Seeds the generated UIDs, so the same phantom gives the same files.
  unsigned long long uid_seed = 1;
  // Called by finish() with the temporary folder, after the slices and before the rename, so a
  // caller can add files (the phantom's truth/ folder) that appear atomically with the slices.
  std::function<Status(const std::filesystem::path& tmp_dir)> before_commit;
};

class SliceSink {
 public:
  virtual ~SliceSink() = default;
  // Slices arrive in order, index 0, 1, ..., with the geometry's size.
  virtual Status write(const Slice& slice) = 0;
  // Writes what remains (sidecar, volume file) and moves the folder into place.
  virtual Status finish() = 0;
};

// `out` is the folder to create (DICOM series and image stacks: one file per slice; volume
// formats: one file in the folder, named volume.vti / volume.mha / volume.nrrd).
Result<std::unique_ptr<SliceSink>> create_ct_writer(const std::filesystem::path& out,
                                                    const VolumeGeometry& geometry,
                                                    const WriteOptions& options);

}  // namespace sawyer::ct
