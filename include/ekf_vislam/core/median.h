// The median of a sample, found by a partial sort: as the estimators and the tracker take it (the
// upper middle element, index size / 2 of the sorted values), and the usual one (the mean of the
// two middle elements of an even count) for reported figures. No ROS.
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

/// The median of `values`: the middle element, or for an even count the mean of the two middle
/// ones; reorders `values`, which must not be empty.
inline double median(std::vector<double>* values) {
  const double upper = upperMedian(values);
  if (values->size() % 2 != 0) return upper;
  const auto middle = values->begin() + static_cast<std::ptrdiff_t>(values->size() / 2);
  return 0.5 * (upper + *std::max_element(values->begin(), middle));
}

}  // namespace ekf_vislam
