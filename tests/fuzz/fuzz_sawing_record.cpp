// libFuzzer target for sawing.json (sawyer-sawing/1) as the report and the viewer read it: the
// fuzzer's bytes are parsed from memory by sawing_record_from_json, the path read_sawing_file
// takes after reading the file. A record that is accepted must hold what its readers index
// without checking again: a value surface whose arrays match its axes, and finite board numbers
// (the report draws and sums them).
// Seeds: tests/fuzz/corpus/fuzz_sawing_record/ (a whole file of `sawyer saw` on a small grid,
// and a position the viewer saved).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "sawyer/sawing/sawing_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  sawyer::Result<sawyer::sawing::SawingRecord> r = sawyer::sawing::sawing_record_from_json(text);
  if (!r) return 0;
  const sawyer::sawing::SawingRecord& s = r.value();
  const sawyer::sawing::ValueSurface& v = s.surface;
  if (!v.empty()) {
    const size_t n = v.rotations_deg.size() * v.offsets_x_mm.size() * v.offsets_y_mm.size();
    if (v.value.size() != n || v.smoothed_value.size() != n) std::abort();
  }
  for (const sawyer::sawing::BoardRecord& b : s.boards) {
    for (double x : {b.thickness_mm, b.width_mm, b.u_mm, b.v_mm, b.z_begin_mm, b.z_end_mm,
                     b.volume_m3, b.value})
      if (!std::isfinite(x)) std::abort();  // the reader lets an infinity through
    (void)b.limit_and_offcuts();
  }
  return 0;
}
