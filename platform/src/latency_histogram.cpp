/// @file latency_histogram.cpp

#include "numen/platform/latency_histogram.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

namespace numen::platform {

int LatencyHistogram::bucket_of(std::int64_t ns) noexcept {
  if (ns < 64) return ns < 0 ? 0 : static_cast<int>(ns);
  const auto v = static_cast<std::uint64_t>(ns);
  const int e = std::bit_width(v) - 1;  // 2^e <= v < 2^(e+1), e >= 6
  if (e > kMaxExponent) return kBuckets - 1;
  const int sub = static_cast<int>((v >> (e - 5)) & (kSubBuckets - 1));  // top 5 bits below the leading one
  return 64 + (e - 6) * kSubBuckets + sub;
}

std::int64_t LatencyHistogram::bucket_upper(int bucket) noexcept {
  if (bucket < 64) return bucket;
  const int e = 6 + (bucket - 64) / kSubBuckets;
  const int sub = (bucket - 64) % kSubBuckets;
  const std::int64_t step = std::int64_t{1} << (e - 5);
  return (std::int64_t{1} << e) + (sub + 1) * step - 1;
}

void LatencyHistogram::record(std::int64_t ns) noexcept {
  if (ns < 0) ns = 0;
  ++counts_[static_cast<std::size_t>(bucket_of(ns))];
  ++count_;
  sum_ += ns;
  min_ = std::min(min_, ns);
  max_ = std::max(max_, ns);
}

void LatencyHistogram::reset() noexcept { *this = LatencyHistogram{}; }

std::int64_t LatencyHistogram::quantile(double q) const noexcept {
  if (count_ == 0) return 0;
  q = std::clamp(q, 0.0, 1.0);
  const auto rank = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(q * count_)));
  std::int64_t seen = 0;
  for (int b = 0; b < kBuckets; ++b) {
    seen += counts_[static_cast<std::size_t>(b)];
    if (seen >= rank) return std::min(bucket_upper(b), max_);
  }
  return max_;
}

}  // namespace numen::platform
