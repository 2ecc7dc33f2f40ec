// libFuzzer target for the DICOM reader: the fuzzer's bytes become one .dcm file in a folder
// beside one valid slice of the same series (32 x 32, signed 16-bit, z = 0), and the folder goes
// through open_ct() and read() of every slice, so the structural walk, GDCM's header parse,
// the series checks, the native fast path and GDCM's decoders all see the input.
// Seeds (tests/fuzz/corpus/fuzz_dicom/) are slices of that series at z = 1 in every transfer
// syntax Sawyer reads, so mutations reach pixel decoding.
//
//   build-fuzz/tests/fuzz/fuzz_dicom -max_total_time=180 corpus/ tests/fuzz/corpus/fuzz_dicom
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"

namespace {

namespace fs = std::filesystem;
using namespace sawyer::ct;

// The folder the inputs go to, with the valid companion slice, made once per process.
class Workspace {
 public:
  Workspace() {
    dir_ = fs::temp_directory_path() / ("sawyer_fuzz_dicom_" + std::to_string(::getpid()));
    std::error_code ec;
    fs::remove_all(dir_, ec);
    const fs::path stage = dir_.string() + "_stage";
    VolumeGeometry g;
    g.width = g.height = 32;
    g.spacing_x = g.spacing_y = 0.5;
    g.z = {0.0};
    WriteOptions o;
    o.uid_seed = 7;  // the seeds were written with the same seed: the same series
    auto sink = create_ct_writer(stage, g, o);
    Slice s;
    s.index = 0;
    s.width = s.height = 32;
    s.hu.assign(32 * 32, -500.0f);
    if (!sink || !sink.value()->write(s) || !sink.value()->finish()) {
      std::fprintf(stderr, "fuzz_dicom: cannot write the companion slice\n");
      std::abort();
    }
    fs::create_directories(dir_);
    fs::rename(stage / "slice_0001.dcm", dir_ / "companion.dcm");
    fs::remove_all(stage, ec);
  }
  ~Workspace() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Workspace workspace;
  const fs::path input = workspace.dir() / "input.dcm";
  {
    std::ofstream out(input, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  auto src = open_ct(workspace.dir());
  if (src) {
    Slice slice;
    const int n = src.value()->geometry().slice_count();
    for (int i = 0; i < n; ++i) {
      if (!src.value()->read(i, slice)) continue;
      // Touch the values so a decoder that leaves them uninitialised shows up under MSan/UBSan.
      volatile float sum = 0;
      for (float v : slice.hu) sum = sum + v;
    }
  }
  return 0;
}
