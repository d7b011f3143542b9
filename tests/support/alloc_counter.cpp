/// @file alloc_counter.cpp
/// Global allocation hooks for the zero-allocation tests (docs/architecture.md, Conventions: real time): replacements of the
/// allocation functions in a normal build, the sanitizer's malloc hooks under ASan/TSan.

#include "alloc_counter.hpp"

#include <cstdio>
#include <cstdlib>
#include <new>

#include <Eigen/Core>

#include "sanitizer.hpp"

namespace {
thread_local std::int64_t g_count = 0;
thread_local int g_depth = 0;
thread_local std::int64_t g_bytes = 0;  // every request on this thread, guard or not
inline void note(std::size_t n) noexcept {
  g_bytes += static_cast<std::int64_t>(n);
  if (g_depth > 0) ++g_count;
}
}  // namespace

#if NUMEN_SANITIZER_HEAP
// Under ASan/TSan the sanitizer's allocator must serve every allocation (its redzones and
// quarantine are what detect heap errors; replacing malloc here would put the tests on glibc's
// heap, unchecked, and mix the two heaps). The sanitizer's own malloc hooks count instead: they
// run for malloc, calloc, realloc, the aligned forms and every operator new, in the allocating
// thread. (Declared here: GCC does not ship <sanitizer/allocator_interface.h>.)
extern "C" int __sanitizer_install_malloc_and_free_hooks(
    void (*malloc_hook)(const volatile void*, std::size_t),
    void (*free_hook)(const volatile void*));

namespace {
void on_malloc(const volatile void*, std::size_t n) { note(n); }
void on_free(const volatile void*) {}
// Installed before main(); the sanitizer holds a few hooks: if none is left, no test may pass
// by counting nothing.
[[maybe_unused]] const bool g_hooks_installed = [] {
  if (__sanitizer_install_malloc_and_free_hooks(&on_malloc, &on_free) == 0) {
    std::fputs("alloc_counter: __sanitizer_install_malloc_and_free_hooks failed\n", stderr);
    std::abort();
  }
  return true;
}();
}  // namespace

#else  // no sanitizer heap: replace the allocation functions and forward them to glibc

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);
}

extern "C" {
void* malloc(std::size_t n) {
  note(n);
  return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) {
  note(a * b);
  return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) {
  note(n);
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
void* aligned_alloc(std::size_t al, std::size_t n) {
  note(n);
  return __libc_memalign(al, n);
}
void* memalign(std::size_t al, std::size_t n) {
  note(n);
  return __libc_memalign(al, n);
}
int posix_memalign(void** out, std::size_t al, std::size_t n) {
  note(n);
  void* p = __libc_memalign(al, n);
  if (p == nullptr) return 12;  // ENOMEM
  *out = p;
  return 0;
}
}

namespace {
void* checked(std::size_t n) {
  note(n);
  void* p = __libc_malloc(n == 0 ? 1 : n);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* checked_aligned(std::size_t n, std::align_val_t al) {
  note(n);
  void* p = __libc_memalign(static_cast<std::size_t>(al), n == 0 ? 1 : n);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t n) { return checked(n); }
void* operator new[](std::size_t n) { return checked(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  note(n);
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  note(n);
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new(std::size_t n, std::align_val_t al) { return checked_aligned(n, al); }
void* operator new[](std::size_t n, std::align_val_t al) { return checked_aligned(n, al); }
void operator delete(void* p) noexcept { __libc_free(p); }
void operator delete[](void* p) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }

#endif  // NUMEN_SANITIZER_HEAP

namespace numen::test {

std::int64_t allocation_count() noexcept { return g_count; }

std::int64_t allocated_bytes() noexcept { return g_bytes; }

AllocationGuard::AllocationGuard() noexcept
    : start_(g_count), eigen_was_allowed_(Eigen::internal::is_malloc_allowed()) {
  ++g_depth;
  Eigen::internal::set_is_malloc_allowed(false);
}

AllocationGuard::~AllocationGuard() {
  --g_depth;
  Eigen::internal::set_is_malloc_allowed(eigen_was_allowed_);
}

std::int64_t AllocationGuard::count() const noexcept { return g_count - start_; }

}  // namespace numen::test
