// libFuzzer target for the stack sidecar (sawyer_stack.json): the fuzzer's bytes are the
// sidecar's text, parsed by parse_stack_sidecar() in memory. Beyond "no crash, no leak, no
// exception", a sidecar that parses must hold what the reader relies on: spacings within the
// limits, z positions finite, strictly increasing, no closer than the smallest spacing and
// within the longest z extent, file names inside the stack's folder; anything else aborts.
// Seeds: tests/fuzz/corpus/fuzz_sidecar/ (valid and nearly valid sidecars).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "sawyer/ct/io/limits.h"
#include "sidecar.h"

namespace {

using sawyer::ct::kMaxSpacingMm;
using sawyer::ct::kMaxZExtentMm;
using sawyer::ct::kMinSpacingMm;

void check_spacing(const std::optional<double>& v) {
  if (v && !(*v >= kMinSpacingMm && *v <= kMaxSpacingMm)) std::abort();
}

void check(const sawyer::ct::detail::StackSidecar& sc) {
  check_spacing(sc.pixel_spacing_x);
  check_spacing(sc.pixel_spacing_y);
  check_spacing(sc.slice_spacing);
  for (size_t i = 0; i < sc.z_mm.size(); ++i) {
    if (!std::isfinite(sc.z_mm[i])) std::abort();
    if (i > 0 && !(sc.z_mm[i] - sc.z_mm[i - 1] >= kMinSpacingMm)) std::abort();
  }
  if (!sc.z_mm.empty() && sc.z_mm.back() - sc.z_mm.front() > kMaxZExtentMm) std::abort();
  if (!sc.z_mm.empty() && !sc.files.empty() && sc.z_mm.size() != sc.files.size()) std::abort();
  if (sc.rescale_slope && !(std::isfinite(*sc.rescale_slope) && *sc.rescale_slope != 0))
    std::abort();
  if (sc.rescale_intercept && !std::isfinite(*sc.rescale_intercept)) std::abort();
  for (const std::string& f : sc.files) {
    if (f.empty() || f.front() == '/' || f.find("..") != std::string::npos) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto sc = sawyer::ct::detail::parse_stack_sidecar(text, "fuzz/sawyer_stack.json");
  if (sc.ok()) check(sc.value());
  return 0;
}
