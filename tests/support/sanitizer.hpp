#pragma once
/// @file sanitizer.hpp
/// What sanitizers this test build runs under (CMake NUMEN_SANITIZE, docs/architecture.md
/// "Build options"), and NUMEN_SKIP_UNDER_SANITIZER for the few tests that cannot run there.
/// Header-only, for test files and tests/support.

#include <gtest/gtest.h>

#include <string_view>

// A sanitizer that brings its own heap and shadow memory (ASan, TSan, MSan): it intercepts
// malloc and operator new, and ignores mlock/mlockall.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define NUMEN_SANITIZER_HEAP 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define NUMEN_SANITIZER_HEAP 1
#endif
#endif
#ifndef NUMEN_SANITIZER_HEAP
#define NUMEN_SANITIZER_HEAP 0
#endif

#if defined(__SANITIZE_ADDRESS__)
#define NUMEN_SANITIZER_ADDRESS 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define NUMEN_SANITIZER_ADDRESS 1
#endif
#endif
#ifndef NUMEN_SANITIZER_ADDRESS
#define NUMEN_SANITIZER_ADDRESS 0
#endif

#ifndef NUMEN_SANITIZERS
#define NUMEN_SANITIZERS ""  // tests/CMakeLists.txt defines it: the NUMEN_SANITIZE list
#endif

namespace numen::test {

/// The -fsanitize= list of this build (e.g. "address,undefined"); empty in a normal build.
constexpr std::string_view kSanitizers = NUMEN_SANITIZERS;

/// True if this build runs under `name` ("address", "undefined", "thread"), or under any
/// sanitizer when `name` is empty.
constexpr bool under_sanitizer(std::string_view name = {}) {
  if (name.empty()) return !kSanitizers.empty();
  std::string_view rest = kSanitizers;
  while (!rest.empty()) {
    const auto comma = rest.find(',');
    if (rest.substr(0, comma) == name) return true;
    if (comma == std::string_view::npos) break;
    rest.remove_prefix(comma + 1);
  }
  return false;
}

}  // namespace numen::test

/// Skips the current test in a sanitizer build (any NUMEN_SANITIZE) with `reason`, which ctest
/// and the gtest output show; in a normal build it does nothing. For tests that a sanitizer
/// makes too slow or cannot run at all; name the reason (what the sanitizer changes).
#define NUMEN_SKIP_UNDER_SANITIZER(reason)                                              \
  do {                                                                                  \
    if constexpr (::numen::test::under_sanitizer())                                     \
      GTEST_SKIP() << "skipped under -fsanitize=" << ::numen::test::kSanitizers << ": " \
                   << (reason);                                                         \
  } while (false)

/// Skips the current test under a sanitizer with its own heap and shadow memory (ASan, TSan,
/// MSan: NUMEN_SANITIZER_HEAP) with `reason`; does nothing in other builds, UBSan alone included.
#define NUMEN_SKIP_UNDER_SANITIZER_HEAP(reason)                                         \
  do {                                                                                  \
    if constexpr (NUMEN_SANITIZER_HEAP)                                                 \
      GTEST_SKIP() << "skipped under -fsanitize=" << ::numen::test::kSanitizers << ": " \
                   << (reason);                                                         \
  } while (false)
