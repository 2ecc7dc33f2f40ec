// libFuzzer target for the sawing input files: the fuzzer's bytes become one JSON file, read as
// the first byte picks:
//   0: a pattern (sawyer-pattern/1, read_pattern_file);
//   1: grading rules (sawyer-grading/1, read_grading_file);
//   2: prices (sawyer-prices/1, read_price_file);
//   3: a pattern set (sawyer-pattern-set/1, read_pattern_set_file) and its candidates.
// Seeds: tests/fuzz/corpus/fuzz_sawing_files/ (a mode byte followed by a valid file).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/pattern.h"
#include "sawyer/sawing/pattern_set.h"
#include "sawyer/sawing/value.h"

namespace {

namespace fs = std::filesystem;

fs::path g_root;

void cleanup() {
  std::error_code ec;
  if (!g_root.empty()) fs::remove_all(g_root, ec);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool ready = [] {
    char tmpl[] = "/tmp/fuzz_sawing_files_XXXXXX";
    if (!mkdtemp(tmpl)) std::abort();
    g_root = tmpl;
    std::atexit(cleanup);
    return true;
  }();
  (void)ready;
  if (size < 1) return 0;
  const fs::path file = g_root / "input.json";
  {
    std::ofstream f(file, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  switch (data[0] % 4) {
    case 0: {
      auto p = sawyer::sawing::read_pattern_file(file);
      if (p.ok()) (void)p.value().validate();
      break;
    }
    case 1:
      (void)sawyer::sawing::read_grading_file(file);
      break;
    case 2:
      (void)sawyer::sawing::read_price_file(file);
      break;
    default: {
      auto s = sawyer::sawing::read_pattern_set_file(file);
      if (s.ok())
        for (double d : {0.0, 150.0, 1e9}) (void)s.value().candidates(d);
      break;
    }
  }
  std::error_code ec;
  fs::remove(file, ec);
  return 0;
}
