// libFuzzer target for volume files: the fuzzer's bytes become one volume file, which is opened
// through open_ct() and read to the last slice. The first byte picks the kind:
//   0: volume.mha (MetaImage header and data in one file);
//   1: volume.vti (VTK XML image data);
//   2: volume.nrrd (NRRD header and data in one file);
//   3: volume.nhdr (a detached NRRD header; its data file, data.raw, holds 16 x 16 x 3 shorts).
// Seeds: tests/fuzz/corpus/fuzz_vtk_volume/ (a mode byte followed by a valid file).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "sawyer/ct/io/slice_source.h"

namespace {

namespace fs = std::filesystem;

fs::path g_root;

void cleanup() {
  std::error_code ec;
  if (!g_root.empty()) fs::remove_all(g_root, ec);
}

void setup() {
  char tmpl[] = "/tmp/fuzz_vtk_volume_XXXXXX";
  if (!mkdtemp(tmpl)) std::abort();
  g_root = tmpl;
  std::atexit(cleanup);
  std::vector<int16_t> raw(16 * 16 * 3);
  for (size_t i = 0; i < raw.size(); ++i) raw[i] = static_cast<int16_t>(-1000 + 5 * i);
  std::ofstream f(g_root / "data.raw", std::ios::binary);
  f.write(reinterpret_cast<const char*>(raw.data()), static_cast<std::streamsize>(raw.size() * 2));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool ready = (setup(), true);
  (void)ready;
  if (size < 1) return 0;
  static const char* const kNames[] = {"volume.mha", "volume.vti", "volume.nrrd", "volume.nhdr"};
  const fs::path file = g_root / kNames[data[0] % 4];
  {
    std::ofstream f(file, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  auto src = sawyer::ct::open_ct(file);
  if (src.ok()) {
    const sawyer::ct::VolumeGeometry& g = src.value()->geometry();
    // The reader bounds declared sizes by the file's size; this only keeps each run short.
    if (static_cast<long long>(g.width) * g.height * g.slice_count() <= (1LL << 24)) {
      sawyer::ct::Slice s;
      for (int i = 0; i < g.slice_count(); ++i) {
        if (!src.value()->read(i, s).ok()) break;
      }
    }
  }
  std::error_code ec;
  fs::remove(file, ec);
  return 0;
}
