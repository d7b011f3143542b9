#pragma once
/// @file step_percentiles.hpp
/// The median and 99th percentile of a run's step times, as the peer programs report them
/// (tests/peer, tests/soft_peer). Header-only.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace numen::test {

/// Median and 99th percentile (µs) of step durations `ns` (ns), nearest rank: the
/// ⌈q·n⌉-th smallest. Reorders `ns`; both 0 for an empty sample.
inline void percentiles_us(std::vector<std::int64_t>& ns, double& median_us, double& p99_us) {
  median_us = p99_us = 0.0;
  if (ns.empty()) return;
  auto at = [&](double q) {
    const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(ns.size()))) - 1;
    const auto i = std::min(k, ns.size() - 1);
    std::nth_element(ns.begin(), ns.begin() + static_cast<std::ptrdiff_t>(i), ns.end());
    return static_cast<double>(ns[i]) * 1e-3;
  };
  median_us = at(0.5);
  p99_us = at(0.99);
}

}  // namespace numen::test
