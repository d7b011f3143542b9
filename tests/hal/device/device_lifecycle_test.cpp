// Tests of numen/hal/device/device_lifecycle.hpp: every transition from every state (allowed or
// refused with its reason), the safe stop (zero torque at once, kFault on drives disabled or
// exactly at the timeout), rearm only without a cause present, no allocation per period.
#include "numen/hal/device/device_lifecycle.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "alloc_counter.hpp"

namespace {

using namespace numen::hal;
using LS = LifecycleState;
using LR = LifecycleResult;

constexpr LifecycleInputs kQuiet{};                     // no fault, no cause, drives enabled
constexpr LifecycleInputs kFaultIn{true, true, false};  // fault detected, cause present
constexpr LifecycleInputs kDisabled{false, false, true};

// A lifecycle brought into `target` through the normal path.
DeviceLifecycle in_state(LS target, LifecycleSettings s = {}) {
  DeviceLifecycle l(s);
  if (target == LS::kUnconfigured) return l;
  EXPECT_EQ(l.configure(), LR::kOk);
  if (target == LS::kInactive) return l;
  if (target == LS::kActive) {
    EXPECT_EQ(l.activate(), LR::kOk);
    return l;
  }
  EXPECT_EQ(l.activate(), LR::kOk);
  l.update(0, kFaultIn);
  if (target == LS::kSafeStop) return l;
  l.update(1, kDisabled);  // drives disabled, the cause gone
  EXPECT_EQ(l.state(), LS::kFault);
  return l;
}

constexpr LS kAll[] = {LS::kUnconfigured, LS::kInactive, LS::kActive, LS::kSafeStop, LS::kFault};

TEST(DeviceLifecycle, StartsUnconfiguredWithoutTorque) {
  DeviceLifecycle l;
  EXPECT_EQ(l.state(), LS::kUnconfigured);
  EXPECT_FALSE(l.torque_allowed());
  EXPECT_EQ(l.drive_target(), Cia402Target::kDisabled);
}

TEST(DeviceLifecycle, TransitionTableFromEveryState) {
  // Expected result of each request from each state (rows: kAll order).
  struct Row {
    LR configure, activate, deactivate, cleanup, rearm;
  };
  const Row rows[] = {
      {LR::kOk, LR::kNotInactive, LR::kNotActive, LR::kNotInactive, LR::kNotFaulted},
      {LR::kNotUnconfigured, LR::kOk, LR::kNotActive, LR::kOk, LR::kNotFaulted},
      {LR::kNotUnconfigured, LR::kNotInactive, LR::kOk, LR::kNotInactive, LR::kNotFaulted},
      {LR::kFaultLatched, LR::kFaultLatched, LR::kFaultLatched, LR::kFaultLatched,
       LR::kSafeStopInProgress},
      {LR::kFaultLatched, LR::kFaultLatched, LR::kFaultLatched, LR::kFaultLatched, LR::kOk},
  };
  const LS after_ok[5][5] = {
      // configure, activate, deactivate, cleanup, rearm
      {LS::kInactive, LS::kUnconfigured, LS::kUnconfigured, LS::kUnconfigured, LS::kUnconfigured},
      {LS::kInactive, LS::kActive, LS::kInactive, LS::kUnconfigured, LS::kInactive},
      {LS::kActive, LS::kActive, LS::kInactive, LS::kActive, LS::kActive},
      {LS::kSafeStop, LS::kSafeStop, LS::kSafeStop, LS::kSafeStop, LS::kSafeStop},
      {LS::kFault, LS::kFault, LS::kFault, LS::kFault, LS::kInactive},
  };
  for (int s = 0; s < 5; ++s) {
    const Row& r = rows[s];
    const LR expected[5] = {r.configure, r.activate, r.deactivate, r.cleanup, r.rearm};
    for (int t = 0; t < 5; ++t) {
      DeviceLifecycle l = in_state(kAll[s]);
      ASSERT_EQ(l.state(), kAll[s]);
      const std::uint64_t refused = l.counters().refused;
      LR got = LR::kOk;
      switch (t) {
        case 0:
          got = l.configure();
          break;
        case 1:
          got = l.activate();
          break;
        case 2:
          got = l.deactivate();
          break;
        case 3:
          got = l.cleanup();
          break;
        case 4:
          got = l.rearm();
          break;
      }
      EXPECT_EQ(got, expected[t]) << to_string(kAll[s]) << " request " << t;
      EXPECT_EQ(l.state(), after_ok[s][t]) << to_string(kAll[s]) << " request " << t;
      EXPECT_EQ(l.counters().refused, refused + (got == LR::kOk ? 0u : 1u));
      EXPECT_NE(std::string(to_string(got)), "unknown");
    }
  }
}

TEST(DeviceLifecycle, TorqueAndDriveTargetPerState) {
  for (LS s : kAll) {
    const DeviceLifecycle l = in_state(s);
    EXPECT_EQ(l.torque_allowed(), s == LS::kActive) << to_string(s);
    EXPECT_EQ(l.drive_target(), s == LS::kActive ? Cia402Target::kEnabled : Cia402Target::kDisabled)
        << to_string(s);
    EXPECT_EQ(l.latched(), s == LS::kSafeStop || s == LS::kFault) << to_string(s);
  }
}

TEST(DeviceLifecycle, FaultForbidsTorqueInTheSamePeriod) {
  DeviceLifecycle l = in_state(LS::kActive);
  l.update(10, kQuiet);
  ASSERT_TRUE(l.torque_allowed());
  const LifecycleUpdate u = l.update(20, kFaultIn);
  EXPECT_TRUE(u.entered_safe_stop);
  EXPECT_EQ(u.state, LS::kSafeStop);
  EXPECT_FALSE(l.torque_allowed());  // the caller sends zero in this very period
  EXPECT_EQ(l.drive_target(), Cia402Target::kDisabled);
  EXPECT_EQ(l.safe_stop_since_ns(), 20);
  EXPECT_EQ(l.safe_stop_periods(), 0u);
  EXPECT_EQ(l.counters().safe_stops, 1u);
}

TEST(DeviceLifecycle, FaultInInactiveLatchesToo) {
  DeviceLifecycle l = in_state(LS::kInactive);
  EXPECT_TRUE(l.update(0, kFaultIn).entered_safe_stop);
  EXPECT_EQ(l.state(), LS::kSafeStop);
}

TEST(DeviceLifecycle, UnconfiguredIgnoresFaults) {
  DeviceLifecycle l;
  EXPECT_FALSE(l.update(0, kFaultIn).entered_safe_stop);
  EXPECT_EQ(l.state(), LS::kUnconfigured);
}

TEST(DeviceLifecycle, SafeStopEndsWhenTheDrivesReportDisabled) {
  DeviceLifecycle l = in_state(LS::kActive);
  l.update(0, kFaultIn);
  // Even drives already disabled in the trip period are only looked at from the next update.
  for (int k = 1; k <= 4; ++k) {
    const LifecycleUpdate u = l.update(k, LifecycleInputs{false, true, false});
    ASSERT_EQ(u.state, LS::kSafeStop) << k;
    EXPECT_EQ(l.safe_stop_periods(), static_cast<std::uint32_t>(k));
  }
  const LifecycleUpdate u = l.update(5, LifecycleInputs{false, true, true});
  EXPECT_TRUE(u.entered_fault);
  EXPECT_FALSE(u.timed_out);
  EXPECT_EQ(l.state(), LS::kFault);
  EXPECT_EQ(l.fault_since_ns(), 5);
  EXPECT_FALSE(l.safe_stop_timed_out());
  EXPECT_FALSE(l.torque_allowed());
}

TEST(DeviceLifecycle, SafeStopTimesOutAtExactlyTheTimeout) {
  LifecycleSettings s;
  s.safe_stop_timeout_periods = 4;
  DeviceLifecycle l = in_state(LS::kActive, s);
  l.update(0, kFaultIn);
  for (int k = 1; k < 4; ++k) {
    ASSERT_EQ(l.update(k, LifecycleInputs{false, true, false}).state, LS::kSafeStop) << k;
  }
  const LifecycleUpdate u = l.update(4, LifecycleInputs{false, true, false});
  EXPECT_TRUE(u.entered_fault);
  EXPECT_TRUE(u.timed_out);
  EXPECT_TRUE(l.safe_stop_timed_out());
  EXPECT_EQ(l.counters().safe_stop_timeouts, 1u);
}

TEST(DeviceLifecycle, RearmRefusedWhileACauseIsPresentThenNeedsActivateAgain) {
  DeviceLifecycle l = in_state(LS::kFault);
  l.update(10, LifecycleInputs{false, true, true});
  EXPECT_EQ(l.rearm(), LR::kCausePresent);
  EXPECT_EQ(l.state(), LS::kFault);
  // The cause is gone: a later fault-free verdict is needed (faults are not re-armed blindly).
  l.update(11, kDisabled);
  EXPECT_EQ(l.rearm(), LR::kOk);
  EXPECT_EQ(l.state(), LS::kInactive);
  EXPECT_FALSE(l.torque_allowed());
  l.update(12, kDisabled);
  EXPECT_FALSE(l.torque_allowed());  // not re-activated by itself
  EXPECT_EQ(l.activate(), LR::kOk);
  EXPECT_TRUE(l.torque_allowed());
  EXPECT_EQ(l.counters().rearms, 1u);
}

TEST(DeviceLifecycle, ActivateRefusedWhileACauseIsPresent) {
  DeviceLifecycle l = in_state(LS::kInactive);
  l.update(0, LifecycleInputs{false, true, true});
  EXPECT_EQ(l.activate(), LR::kCausePresent);
  EXPECT_EQ(l.state(), LS::kInactive);
  l.update(1, kDisabled);
  EXPECT_EQ(l.activate(), LR::kOk);
}

TEST(DeviceLifecycle, TripLatchesBetweenUpdates) {
  DeviceLifecycle l = in_state(LS::kActive);
  l.update(7, kQuiet);
  EXPECT_TRUE(l.trip().entered_safe_stop);
  EXPECT_EQ(l.state(), LS::kSafeStop);
  EXPECT_EQ(l.safe_stop_since_ns(), 7);
  EXPECT_FALSE(l.trip().entered_safe_stop);  // already latched
  DeviceLifecycle u;
  EXPECT_FALSE(u.trip().entered_safe_stop);
  EXPECT_EQ(u.state(), LS::kUnconfigured);
}

TEST(DeviceLifecycle, SettingsAreValidated) {
  LifecycleSettings s;
  s.safe_stop_timeout_periods = 0;
  try {
    DeviceLifecycle l(s);
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("safe_stop_timeout_periods"), std::string::npos);
  }
}

TEST(DeviceLifecycle, PerPeriodCallsDoNotAllocate) {
  DeviceLifecycle l;
  numen::test::AllocationGuard guard;
  l.configure();
  l.activate();
  for (int k = 0; k < 100; ++k) l.update(k, k == 50 ? kFaultIn : kQuiet);
  l.update(101, kDisabled);
  l.rearm();
  l.trip();
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(l.state(), LS::kSafeStop);
}

}  // namespace
