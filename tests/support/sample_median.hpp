#pragma once
/// @file sample_median.hpp
/// The median of a sample of times, for the benchmarks' counters. Header-only.

#include <algorithm>
#include <cstddef>
#include <vector>

namespace numen::test {

/// The median of `v` (its upper middle element when the size is even; taken
/// by value, reordered); 0 for an empty sample.
inline double sample_median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace numen::test
