// libFuzzer target for TIFF/PNG stacks: the fuzzer's bytes become one file of an otherwise valid
// stack, which is opened through open_ct() and read to the last slice. The first byte picks the
// file:
//   0: slice 1 of a TIFF stack (slice 2 is a valid 16 x 16 16-bit TIFF, the sidecar is valid);
//   1: slice 1 of a PNG stack (likewise);
//   2: the sidecar sawyer_stack.json of a valid TIFF stack;
//   3: a multi-page TIFF (with a valid sidecar beside it).
// Seeds: tests/fuzz/corpus/fuzz_image_stack/ (a mode byte followed by a valid file).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "sawyer/ct/io/slice_sink.h"
#include "sawyer/ct/io/slice_source.h"

namespace {

namespace fs = std::filesystem;
using sawyer::ct::Format;

fs::path g_root;

void cleanup() {
  std::error_code ec;
  if (!g_root.empty()) fs::remove_all(g_root, ec);
}

void write_file(const fs::path& p, const uint8_t* data, size_t size) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

// A valid 16 x 16 x n stack in `format`, written by Sawyer's own writer.
void write_fixture(const fs::path& out, Format format, int n) {
  sawyer::ct::VolumeGeometry g;
  g.width = g.height = 16;
  g.spacing_x = g.spacing_y = 0.5;
  for (int i = 0; i < n; ++i) g.z.push_back(i);
  sawyer::ct::WriteOptions o;
  o.format = format;
  auto sink = sawyer::ct::create_ct_writer(out, g, o);
  if (!sink.ok()) std::abort();
  sawyer::ct::Slice s;
  s.width = s.height = 16;
  s.hu.assign(256, 0.0f);
  for (int i = 0; i < n; ++i) {
    for (int p = 0; p < 256; ++p) s.hu[p] = static_cast<float>(-1000 + 7 * p + 100 * i);
    if (!sink.value()->write(s).ok()) std::abort();
  }
  if (!sink.value()->finish().ok()) std::abort();
}

void setup() {
  char tmpl[] = "/tmp/fuzz_image_stack_XXXXXX";
  if (!mkdtemp(tmpl)) std::abort();
  g_root = tmpl;
  std::atexit(cleanup);
  write_fixture(g_root / "tif", Format::kTiffStack, 2);
  write_fixture(g_root / "png", Format::kPngStack, 2);
  write_fixture(g_root / "sidecar", Format::kTiffStack, 2);
  write_fixture(g_root / "multipage", Format::kMultiPageTiff, 3);
}

void open_and_read(const fs::path& p) {
  auto src = sawyer::ct::open_ct(p);
  if (!src.ok()) return;
  const sawyer::ct::VolumeGeometry& g = src.value()->geometry();
  // The readers bound slice sizes; this only keeps each run short.
  if (static_cast<long long>(g.width) * g.height * g.slice_count() > (1LL << 24)) return;
  sawyer::ct::Slice s;
  for (int i = 0; i < g.slice_count(); ++i) {
    if (!src.value()->read(i, s).ok()) return;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool ready = (setup(), true);
  (void)ready;
  if (size < 1) return 0;
  const uint8_t* body = data + 1;
  const size_t n = size - 1;
  switch (data[0] % 4) {
    case 0:
      write_file(g_root / "tif" / "slice_0001.tif", body, n);
      open_and_read(g_root / "tif");
      break;
    case 1:
      write_file(g_root / "png" / "slice_0001.png", body, n);
      open_and_read(g_root / "png");
      break;
    case 2:
      write_file(g_root / "sidecar" / "sawyer_stack.json", body, n);
      open_and_read(g_root / "sidecar");
      break;
    case 3:
      write_file(g_root / "multipage" / "stack.tif", body, n);
      open_and_read(g_root / "multipage" / "stack.tif");
      break;
  }
  return 0;
}
