#pragma once
/// @file latency_histogram.hpp
/// Preallocated log-linear histogram of durations (ns), in the manner of
/// HdrHistogram: values below 64 ns are exact, above that each power of two
/// is split into 32 buckets (relative resolution ≤ 3.2 %). record() is O(1),
/// noexcept, allocation-free; percentiles are read after (or during) a run.

#include <array>
#include <cstdint>

namespace numen::platform {

/// Histogram of non-negative durations in nanoseconds, up to ~2^40 ns (18 min);
/// larger values land in the last bucket. Negative values count as 0.
class LatencyHistogram {
 public:
  static constexpr int kSubBuckets = 32;
  static constexpr int kMaxExponent = 40;
  static constexpr int kBuckets = 64 + (kMaxExponent - 6 + 1) * kSubBuckets;

  /// Adds one sample.
  void record(std::int64_t ns) noexcept;
  /// Clears all counts.
  void reset() noexcept;
  /// Samples recorded.
  std::int64_t count() const noexcept { return count_; }
  /// Smallest sample (ns), 0 when empty.
  std::int64_t min() const noexcept { return count_ ? min_ : 0; }
  /// Largest sample (ns), 0 when empty.
  std::int64_t max() const noexcept { return max_; }
  /// Mean of the samples (ns), 0 when empty.
  double mean() const noexcept { return count_ ? static_cast<double>(sum_) / count_ : 0.0; }
  /// Value (ns) at quantile q in [0, 1] (upper edge of its bucket, clamped to
  /// the observed max); 0 when empty.
  std::int64_t quantile(double q) const noexcept;

  /// Bucket of a value, and the inclusive upper edge of a bucket (for tests/export).
  static int bucket_of(std::int64_t ns) noexcept;
  static std::int64_t bucket_upper(int bucket) noexcept;
  std::int64_t bucket_count(int bucket) const noexcept { return counts_[static_cast<std::size_t>(bucket)]; }

 private:
  std::array<std::int64_t, kBuckets> counts_{};
  std::int64_t count_ = 0;
  std::int64_t sum_ = 0;
  std::int64_t min_ = INT64_MAX;
  std::int64_t max_ = 0;
};

}  // namespace numen::platform
