// The median of a sample, as the estimators and the tracker take it: the upper middle element
// (index size / 2 of the sorted values), found by a partial sort. No ROS.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace ekf_vislam {

/// The element at index size / 2 of `values` sorted (for an even count, the upper of the two
/// middle ones); reorders `values`, which must not be empty.
template <typename T>
T upperMedian(std::vector<T>* values) {
  const auto middle = values->begin() + static_cast<std::ptrdiff_t>(values->size() / 2);
  std::nth_element(values->begin(), middle, values->end());
  return *middle;
}

}  // namespace ekf_vislam
