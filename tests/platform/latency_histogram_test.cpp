// LatencyHistogram: bucket edges, resolution bound and quantiles against an
// exact sort of the same samples.
#include "numen/platform/latency_histogram.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"

using numen::platform::LatencyHistogram;

TEST(LatencyHistogram, EveryValueFallsInsideItsBucket) {
  for (std::int64_t v : {0LL, 1LL, 63LL, 64LL, 65LL, 127LL, 128LL, 1000LL, 4095LL, 123456789LL}) {
    const int b = LatencyHistogram::bucket_of(v);
    EXPECT_LE(v, LatencyHistogram::bucket_upper(b)) << v;
    if (b > 0) {
      EXPECT_GT(v, LatencyHistogram::bucket_upper(b - 1)) << v;
    }
  }
}

TEST(LatencyHistogram, QuantilesWithinResolutionOfExactOrderStatistics) {
  std::mt19937_64 rng(7);
  std::lognormal_distribution<double> dist(8.0, 1.0);  // ~3 µs median, long tail
  std::vector<std::int64_t> v(100000);
  LatencyHistogram h;
  for (auto& x : v) {
    x = static_cast<std::int64_t>(dist(rng));
    h.record(x);
  }
  std::sort(v.begin(), v.end());
  for (double q : {0.5, 0.9, 0.99, 0.999}) {
    const auto exact = v[static_cast<std::size_t>(std::ceil(q * v.size())) - 1];
    const auto got = h.quantile(q);
    EXPECT_GE(got, exact) << q;
    EXPECT_LE(got, exact + exact / 32 + 1) << q;  // one bucket: ≤ 1/32 relative
  }
  EXPECT_EQ(h.max(), v.back());
  EXPECT_EQ(h.min(), v.front());
  EXPECT_EQ(h.count(), 100000);
}

TEST(LatencyHistogram, RecordDoesNotAllocate) {
  LatencyHistogram h;
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 100000; ++i) h.record(i * 37);
  EXPECT_EQ(guard.count(), 0);
}
