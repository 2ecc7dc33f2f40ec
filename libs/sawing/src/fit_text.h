// Text the sawing library's errors share: one number printf-style, and the phrase every "does not
// fit" error ends with (a single pattern's, check_pattern_fits, and a pattern set's,
// check_setup_fits), so both say the same of the log.
#pragma once

#include <string>

namespace sawyer::sawing {

std::string fmt(const char* format, double v);
// "the log's usable diameter is 182.4 mm (inscribed in the top end, under bark)"
std::string usable_diameter_text(double usable_diameter_mm);

}  // namespace sawyer::sawing
