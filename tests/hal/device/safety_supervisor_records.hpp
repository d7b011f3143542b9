#pragma once
/// @file safety_supervisor_records.hpp
/// Shared by the SafetySupervisor tests (safety_supervisor_test.cpp,
/// safety_supervisor_closed_loop_test.cpp): short names of the supervisor's enums, the period
/// unit, and the check of a fault record (cause, id, period, time).

#include <cstdint>
#include <string>

#include <gtest/gtest.h>

#include "numen/hal/device/safety_supervisor.hpp"
#include "test_constants.hpp"

namespace numen::test::safety_records {

using LS = hal::LifecycleState;
using LR = hal::LifecycleResult;
using FC = hal::FaultCause;
using PS = hal::PowerState;
using numen::test::kMs;

using hal::FaultRecord;

inline void expect_record(const FaultRecord* r, FC cause, std::uint8_t id, std::uint64_t period,
                          std::int64_t time_ns, const std::string& what) {
  ASSERT_NE(r, nullptr) << what;
  EXPECT_EQ(r->cause, cause) << what << ": got " << to_string(r->cause);
  EXPECT_EQ(r->id, id) << what;
  EXPECT_EQ(r->period, period) << what;
  EXPECT_EQ(r->time_ns, time_ns) << what;
}

}  // namespace numen::test::safety_records
