// The JSON of a sawn position, shared by `sawyer saw` (sawing.json) and the viewer's saved
// position (both the `sawyer-sawing/1` format, docs/sawing.md).
#pragma once

#include <nlohmann/json.hpp>

#include "sawyer/sawing/grading.h"
#include "sawyer/sawing/sawing.h"
#include "sawyer/sawing/value.h"

namespace sawyer::sawing {

// {"rotation_deg", "offset_x_mm", "offset_y_mm"}.
nlohmann::ordered_json position_json(const LogPosition& p);

// One entry per board of `sawn` (graded and priced in `value`): size, placement, z range, volume,
// grade, the rule that limited it, price and value; with `details` also its wane per side and
// every knot on its sides.
nlohmann::ordered_json boards_json(const SawResult& sawn, const LogValue& value,
                                   const GradingRules& rules, bool details);

}  // namespace sawyer::sawing
