// Self-test of the allocation counter used by every zero-allocation test:
// it must see operator new, malloc and Eigen's dynamic allocations.
#include <cstddef>
#include <cstdlib>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "sanitizer.hpp"

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

#if NUMEN_SANITIZER_ADDRESS
// Under ASan the tests run on ASan's heap although alloc_counter.cpp counts every allocation:
// a planted heap-buffer-overflow must be reported (and abort). Compiled only with
// NUMEN_SANITIZE=address,...; with the allocation functions replaced (the counter before the
// sanitizer hooks) the write lands in glibc's chunk unreported and this test fails.
TEST(AllocationCounterDeathTest, AddressSanitizerSeesAHeapBufferOverflow) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(
      {
        numen::test::AllocationGuard guard;  // counting on, as in every zero-allocation test
        // The pointer read back through a volatile: UBSan's object-size check cannot see
        // where it points, so the report must come from ASan's heap.
        char* volatile p = new char[16];
        const volatile std::size_t end = 16;
        p[end] = 1;  // one past the end
        delete[] p;
      },
      "heap-buffer-overflow");
}
#endif
