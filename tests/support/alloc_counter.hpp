#pragma once
/// @file alloc_counter.hpp
/// Counts heap allocations (global operator new in all its forms, malloc,
/// calloc, realloc, aligned_alloc, posix_memalign) made by the current thread
/// while an AllocationGuard is alive, and switches Eigen's runtime malloc check
/// off in the same scope (EIGEN_RUNTIME_NO_MALLOC: Eigen asserts on a heap
/// allocation). Linked into every test executable.

#include <cstdint>

namespace numen::test {

/// Allocations counted on this thread since the last reset.
std::int64_t allocation_count() noexcept;

/// Bytes requested from the heap by this thread since it started (every form
/// above; realloc counts its new size, frees are not subtracted), counted with
/// or without a guard. Take differences: allocated_bytes() after − before is
/// what the code in between asked for.
std::int64_t allocated_bytes() noexcept;

/// Scope in which allocations are counted (and Eigen allocations forbidden).
class AllocationGuard {
 public:
  AllocationGuard() noexcept;
  ~AllocationGuard();
  AllocationGuard(const AllocationGuard&) = delete;
  AllocationGuard& operator=(const AllocationGuard&) = delete;
  /// Allocations made in this scope so far.
  std::int64_t count() const noexcept;

 private:
  std::int64_t start_;
  bool eigen_was_allowed_;
};

}  // namespace numen::test
