// libFuzzer target for log.json (sawyer-log/1): the fuzzer's bytes are parsed from memory by
// log_from_json, the path every command's loader takes after reading the file (read_log_json).
// A model that is accepted must be valid, must write and read back to the same text, and must
// answer the queries the sawing and rendering code make of it without a fault.
// Seeds: tests/fuzz/corpus/fuzz_log_json/ (small logs cut from the bundled samples).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "sawyer/model/log_json.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  sawyer::Result<sawyer::LogModel> log = sawyer::log_from_json(text);
  if (!log) return 0;
  const sawyer::LogModel& m = log.value();
  if (!sawyer::validate(m)) std::abort();  // the reader accepted what the checks refuse
  const std::string written = sawyer::log_to_json(m);
  sawyer::Result<sawyer::LogModel> again = sawyer::log_from_json(written);
  if (!again || sawyer::log_to_json(again.value()) != written) std::abort();  // no round trip
  // The model's queries over its own extent.
  const sawyer::Stem& s = m.stem;
  for (double t : {0.0, 0.37, 1.0}) {
    const double z = s.z_begin() + t * (s.z_end() - s.z_begin());
    const sawyer::Vec2 p = s.pith_at(z);
    (void)s.radius_at(1.0, z);
    (void)m.material_at({p.x + 10.0, p.y, z});
  }
  for (const sawyer::Knot& k : m.knots) {
    double z0 = 0, z1 = 0;
    k.z_range(&z0, &z1);
    (void)k.axis_point(0.5 * k.r_end, s);
  }
  return 0;
}
