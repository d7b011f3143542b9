#pragma once
/// @file splitmix64.hpp
/// SplitMix64: a tiny deterministic pseudo-random generator (Steele, Lea, Flood,
/// "Fast splittable pseudorandom number generators", OOPSLA 2014; constants of Vigna's
/// public-domain splitmix64.c). Same seed -> same sequence on every platform. Used by SimBus
/// for loss and corruption; not for cryptography.

#include <cstdint>

namespace numen::hal {

/// 64-bit SplitMix generator; state is one integer, copyable, noexcept, no heap.
class SplitMix64 {
 public:
  /// Starts the sequence from `seed` (any value, 0 included).
  explicit constexpr SplitMix64(std::uint64_t seed = 0) noexcept : state_(seed) {}

  /// Next 64 uniformly distributed bits.
  constexpr std::uint64_t next() noexcept {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

  /// Uniform double in [0, 1) with 53 random bits.
  constexpr double uniform() noexcept {
    return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0);
  }

  /// Uniform integer in [0, n) (n > 0; returns 0 for n == 0). Multiply-shift reduction, bias
  /// < n / 2^32, irrelevant for the small n used here.
  constexpr std::uint32_t below(std::uint32_t n) noexcept {
    return static_cast<std::uint32_t>(((next() >> 32) * static_cast<std::uint64_t>(n)) >> 32);
  }

 private:
  std::uint64_t state_;
};

}  // namespace numen::hal
