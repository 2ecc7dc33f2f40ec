// Small order statistics shared by the analysis code.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace sawyer {

// Median of `v` (the upper middle element for an even count), reordering `v`; 0 when empty.
template <typename T>
double median_inplace(std::vector<T>& v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return static_cast<double>(*mid);
}

// Median of a copy of `v`.
template <typename T>
double median(std::vector<T> v) {
  return median_inplace(v);
}

}  // namespace sawyer
