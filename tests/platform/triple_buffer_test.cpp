// Tests of platform/triple_buffer: the newest value from one thread to another, neither waiting.
#include "numen/platform/triple_buffer.hpp"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>

namespace {

using numen::platform::TripleBuffer;

TEST(TripleBuffer, TheConsumerGetsTheNewestPublishedValueOnce) {
  TripleBuffer<int> b(7);
  EXPECT_EQ(b.front(), 7);
  EXPECT_FALSE(b.acquire()) << "nothing published yet";
  b.back() = 1;
  b.publish();
  b.back() = 2;
  b.publish();  // overwrites 1, not taken
  ASSERT_TRUE(b.acquire());
  EXPECT_EQ(b.front(), 2);
  EXPECT_FALSE(b.acquire()) << "already taken";
  EXPECT_EQ(b.front(), 2) << "kept";
  b.back() = 3;
  b.publish();
  ASSERT_TRUE(b.acquire());
  EXPECT_EQ(b.front(), 3);
  // The three slots stay distinct: the producer never writes the consumer's front.
  for (int i = 4; i < 100; ++i) {
    b.back() = i;
    EXPECT_NE(&b.back(), &b.front());
    b.publish();
    if (i % 3 == 0) {
      ASSERT_TRUE(b.acquire());
      EXPECT_EQ(b.front(), i);
    }
  }
}

/// A value whose parts must agree: a torn read (the producer writing the slot the consumer
/// reads) shows as parts that differ.
struct Payload {
  std::int64_t sequence = 0;
  std::array<std::int64_t, 64> copies{};
};

// Two threads, 200 000 values: every value the consumer takes is whole and newer than the one
// before (ThreadSanitizer runs this in CI: the exchange is race-free).
TEST(TripleBuffer, TwoThreadsSeeWholeValuesInOrder) {
  TripleBuffer<Payload> b;
  constexpr std::int64_t kValues = 200'000;
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (std::int64_t s = 1; s <= kValues; ++s) {
      Payload& p = b.back();
      p.sequence = s;
      p.copies.fill(s);
      b.publish();
    }
    done.store(true);
  });
  std::int64_t last = 0, taken = 0, torn = 0, backwards = 0;
  while (true) {
    const bool finished = done.load();  // before acquire(): a value published before it is seen
    if (!b.acquire()) {
      if (finished) break;
      continue;
    }
    const Payload& p = b.front();
    for (std::int64_t c : p.copies) torn += c != p.sequence ? 1 : 0;
    backwards += p.sequence <= last ? 1 : 0;
    last = p.sequence;
    ++taken;
  }
  producer.join();
  EXPECT_EQ(torn, 0);
  EXPECT_EQ(backwards, 0);
  EXPECT_GT(taken, 0);
  EXPECT_EQ(last, kValues) << "the last value arrives";
}

}  // namespace
