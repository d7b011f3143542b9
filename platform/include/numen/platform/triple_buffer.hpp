#pragma once
/// @file triple_buffer.hpp
/// TripleBuffer<T>: the newest value from one producer thread to one consumer thread, neither
/// ever waiting for the other — the exchange of the multirate god-object's two loops
/// (docs/multirate.md, "Two threads"). Three slots: the producer fills its back slot and
/// publishes it by swapping it with the middle one; the consumer, when the middle one is newer
/// than what it holds, swaps its front slot with it. One std::atomic<unsigned> holds the middle
/// slot's index and a "fresh" bit; publish() and acquire() are one atomic exchange each
/// (lock-free and wait-free where std::atomic<unsigned> is, as on every target here). A value
/// the consumer did not take before the next publish() is overwritten: what passes is the
/// newest, not every value (the caller sends running totals where nothing may be lost).
/// Memory order: publish() releases the back slot's writes, acquire() acquires them.
/// The slots are constructed at construction (allocation there only, by T's constructor);
/// back(), publish(), acquire() and front() never allocate, lock or block.
/// One producer thread and one consumer thread; each end's calls from one thread at a time.

#include <array>
#include <atomic>

namespace numen::platform {

template <typename T>
class TripleBuffer {
 public:
  /// All three slots copies of `initial` (the consumer's front() reads it before the first
  /// publish()).
  explicit TripleBuffer(const T& initial = T{}) : slots_{initial, initial, initial} {}
  TripleBuffer(const TripleBuffer&) = delete;
  TripleBuffer& operator=(const TripleBuffer&) = delete;

  /// Producer: the slot to fill next (its contents are an older value, not necessarily the
  /// last one published).
  T& back() noexcept { return slots_[back_]; }
  /// Producer: makes back() the newest value; back() is then another slot.
  void publish() noexcept {
    back_ = middle_.exchange(back_ | kFresh, std::memory_order_acq_rel) & kIndex;
  }

  /// Consumer: takes the newest published value into front() if there is one it has not
  /// taken; returns whether it did.
  bool acquire() noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFresh) == 0) return false;
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    return true;
  }
  /// Consumer: the value last taken (the initial value before the first acquire()).
  T& front() noexcept { return slots_[front_]; }
  const T& front() const noexcept { return slots_[front_]; }

 private:
  static constexpr unsigned kIndex = 3u;
  static constexpr unsigned kFresh = 4u;
  std::array<T, 3> slots_;
  unsigned back_ = 0;                  // producer's
  std::atomic<unsigned> middle_{1u};   // shared: index | fresh bit
  unsigned front_ = 2;                 // consumer's
};

}  // namespace numen::platform
