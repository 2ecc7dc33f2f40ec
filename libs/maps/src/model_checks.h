// Checks the writers add to validate() (sawyer/model/log_json.h), which leaves the pith, the
// heartwood and the bark's finiteness to the caller.
#pragma once

#include <cmath>
#include <string>

#include "sawyer/core/result.h"
#include "sawyer/model/log_model.h"

namespace sawyer::maps_detail {

// The first non-finite pith, heartwood or bark value, named by its key path.
inline Status check_finite(const Stem& s) {
  for (size_t i = 0; i < s.pith.size(); ++i)
    if (!std::isfinite(s.pith[i].x) || !std::isfinite(s.pith[i].y))
      return Error("stem.pith[" + std::to_string(i) + "]", "not a finite position");
  for (size_t i = 0; i < s.heartwood.size(); ++i)
    for (size_t k = 0; k < s.heartwood[i].size(); ++k)
      if (!std::isfinite(s.heartwood[i][k]))
        return Error("stem.heartwood[" + std::to_string(i) + "][" + std::to_string(k) + "]",
                     "not a finite number");
  for (size_t i = 0; i < s.bark_mm.size(); ++i)
    if (!std::isfinite(s.bark_mm[i]))
      return Error("stem.bark_mm[" + std::to_string(i) + "]", "not a finite number");
  return Status::Ok();
}

}  // namespace sawyer::maps_detail
