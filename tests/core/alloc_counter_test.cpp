// Self-test of the allocation counter used by every zero-allocation test:
// it must see operator new, malloc and Eigen's dynamic allocations.
#include <cstdlib>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "alloc_counter.hpp"

namespace {
template <class T>
void escape(T* p) {
  asm volatile("" : : "g"(p) : "memory");
}
}  // namespace

TEST(AllocationCounter, CountsOperatorNewAndMalloc) {
  numen::test::AllocationGuard guard;
  auto* v = new std::vector<int>(100);  // two allocations
  escape(v);
  delete v;
  void* p = std::malloc(16);
  escape(p);
  std::free(p);
  EXPECT_EQ(guard.count(), 3);
}

TEST(AllocationCounter, NothingCountedOutsideAGuard) {
  const auto before = numen::test::allocation_count();
  std::vector<int> v(100);
  escape(&v);
  EXPECT_EQ(numen::test::allocation_count(), before);
}

TEST(AllocationCounter, GuardForbidsEigenHeapAllocation) {
  numen::test::AllocationGuard guard;
  EXPECT_FALSE(Eigen::internal::is_malloc_allowed());
}
