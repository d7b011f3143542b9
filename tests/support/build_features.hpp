#pragma once
/// @file build_features.hpp
/// Skips a test that needs an optional part this build left out (CMake options
/// NUMEN_WITH_*, numen/core/features.hpp, numen/hal/features.hpp). Used where a
/// test of something else needs such a part (the shipped default scene has
/// joints); the tests *of* a left-out part are not compiled at all
/// (tests/CMakeLists.txt). ctest reports a skipped test as skipped, not passed.

#include <gtest/gtest.h>

#include "numen/core/features.hpp"
#if __has_include("numen/hal/features.hpp")  // not in the core suite, which links numen::core only
#include "numen/hal/features.hpp"
#endif

/// First statement of a test that needs joints (e.g. loads the default scene).
#define NUMEN_REQUIRE_ARTICULATION()                                  \
  do {                                                                \
    if (!::numen::core::kWithArticulation)                            \
      GTEST_SKIP() << "this build has NUMEN_WITH_ARTICULATION=OFF";   \
  } while (0)

/// First statement of a test that needs deformable nets.
#define NUMEN_REQUIRE_DEFORMABLE()                                    \
  do {                                                                \
    if (!::numen::core::kWithDeformable)                              \
      GTEST_SKIP() << "this build has NUMEN_WITH_DEFORMABLE=OFF";     \
  } while (0)

/// First statement of a test that needs the serial backend (SerialBus); hal and above.
#define NUMEN_REQUIRE_SERIAL()                                        \
  do {                                                                \
    if (!::numen::hal::kWithSerial)                                   \
      GTEST_SKIP() << "this build has NUMEN_WITH_SERIAL=OFF";         \
  } while (0)

/// First statement of a test that needs libevdev (hal and above): the evdev pointer, and the
/// event code names of a `[trajectory.pointer]` (the shipped mouse scene).
#define NUMEN_REQUIRE_EVDEV()                                         \
  do {                                                                \
    if (!::numen::hal::kWithEvdev)                                    \
      GTEST_SKIP() << "this build has NUMEN_WITH_EVDEV=OFF";          \
  } while (0)
