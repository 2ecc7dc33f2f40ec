// Shared by the sawing benches (value_bench, decision): the 2ex pattern a log takes.
#pragma once

#include <optional>
#include <string>

#include "sawyer/sawing/pattern.h"

namespace sawyer::bench {

// The widest of three 2ex patterns whose usable diameter `usable_mm` takes: 50×150 with 25×100
// sides, else 50×100 centre boards, else 38×75 with 19×75 sides; none when even that does not
// fit. `label` is the short name the tables print.
struct TwoEx {
  sawing::Pattern pattern;
  const char* label = "";
};

inline std::optional<TwoEx> widest_two_ex(double usable_mm, const std::string& log_id) {
  sawing::CantOptions narrow, small;
  narrow.centre_width_mm = 100;
  small.centre_thickness_mm = 38;
  small.centre_width_mm = 75;
  small.side_thickness_mm = 19;
  small.side_width_mm = 75;
  for (const TwoEx& t : {TwoEx{sawing::two_ex_pattern({}), "2ex 50x150"},
                         TwoEx{sawing::two_ex_pattern(narrow), "2ex 50x100"},
                         TwoEx{sawing::two_ex_pattern(small), "2ex 38x75"}})
    if (check_pattern_fits(t.pattern, usable_mm, log_id)) return t;
  return std::nullopt;
}

}  // namespace sawyer::bench
