// Tests of numen/hal/device/safety_supervisor.hpp: every latching cause with its record (what, which,
// when: the exact period), zero torque in the detection period, the encoder timeout at exactly
// N periods, overruns only when consecutive, reject-only conditions, rearm refused while a
// cause persists, the torque permission, a NaN torque reported, the fault log ring, no allocation per
// period. The closed loop over SimBus: safety_supervisor_closed_loop_test.cpp.
#include "numen/hal/device/safety_supervisor.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/canopen/pdo_mapping.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "safety_supervisor_records.hpp"

namespace {

using namespace numen::hal;
using namespace numen::test::safety_records;
constexpr std::uint8_t kNode = 5;  // the watched node (heartbeat, EMCY)

SafetySettings two_axes() {
  SafetySettings s;
  s.num_axes = 2;
  s.safe_stop_timeout_periods = 10;
  return s;
}

// A supervisor with two axes, two drives and one heartbeat node, fed synthetic inputs once per
// 1 ms period. By default everything is healthy: every axis accepted a frame this period, the
// node sends a heartbeat every period, the drives follow the supervisor's drive target one
// period later (operation enabled / switch on disabled).
struct SupervisorRig {
  explicit SupervisorRig(SafetySettings s = two_axes()) : sup(s) {
    hb.add(kNode, 3 * kMs);
    for (Cia402MasterOutput& d : drives) d.state = PS::kSwitchOnDisabled;
  }

  SafetySupervisor sup;
  std::array<std::uint32_t, 2> age{};
  std::array<FaultMask, 2> mask{};
  HeartbeatMonitor<4> hb;
  EmcyLog<8> emcy;
  std::array<Cia402MasterOutput, 2> drives{};
  bool overrun = false;
  BusState bus = BusState::kOk;
  bool io_error = false;
  bool heartbeats_on = true;
  bool drives_follow = true;
  std::size_t axis_entries = 2;
  std::int64_t t = 0;
  std::uint64_t periods = 0;  // update() calls made = index of the next period

  // One period; returns the lifecycle update.
  LifecycleUpdate step() {
    t += kMs;
    if (heartbeats_on) {
      CanFrame f;
      encode_heartbeat(kNode, NmtState::kOperational, t, f);
      hb.on_frame(f);
    }
    hb.poll(t);
    SafetyInputs in;
    in.periods_since_accepted = std::span<const std::uint32_t>(age.data(), axis_entries);
    in.axis_faults = std::span<const FaultMask>(mask.data(), axis_entries);
    in.heartbeats = hb.consumers();
    in.emcy_faults = emcy.counters().faults;
    in.emcy_last_fault = newest_emcy_fault(emcy);
    in.drives = drives;
    in.overrun = overrun;
    in.bus_state = bus;
    in.io_error = io_error;
    const LifecycleUpdate u = sup.update(t, in);
    ++periods;
    if (drives_follow) {
      for (Cia402MasterOutput& d : drives) {
        d.state = sup.drive_target() == Cia402Target::kEnabled ? PS::kOperationEnabled
                                                               : PS::kSwitchOnDisabled;
      }
    }
    return u;
  }

  void run(int n) {
    for (int i = 0; i < n; ++i) step();
  }

  // configure → one healthy period → activate → one period in kActive.
  void bring_up() {
    ASSERT_EQ(sup.configure(), LR::kOk);
    step();
    ASSERT_EQ(sup.activate(), LR::kOk) << to_string(sup.blocking().cause);
    step();
    ASSERT_EQ(sup.state(), LS::kActive);
    ASSERT_TRUE(sup.torque_allowed());
  }

  // The torques this period would send (requested {1, -0.25}): hal::ImpedanceDevice::write() gates them
  // on torque_allowed().
  std::array<double, 2> torques() const {
    if (!sup.torque_allowed()) return {0.0, 0.0};
    return {1.0, -0.25};
  }
};

// One injection: `inject` changes the rig before the period in which the cause must be
// detected (called before every step from then on, so the condition persists).
struct Case {
  const char* name;
  std::function<void(SupervisorRig&)> inject;
  FC cause;
  std::uint8_t id;
  double value;  // NaN: not checked
};

const double kAny = std::numeric_limits<double>::quiet_NaN();

std::vector<Case> latching_cases() {
  return {
      {"encoder jump",
       [](SupervisorRig& r) {
         r.mask[1] = SampleFault::kJump;
         r.age[1] = 1;
       },
       FC::kEncoderJump, 1, SampleFault::kJump},
      {"out of range",
       [](SupervisorRig& r) {
         r.mask[0] = SampleFault::kOutOfRange;
         r.age[0] = 1;
       },
       FC::kOutOfRange, 0, SampleFault::kOutOfRange},
      {"non-finite",
       [](SupervisorRig& r) {
         r.mask[1] = SampleFault::kNonFinite;
         r.age[1] = 1;
       },
       FC::kNonFinite, 1, SampleFault::kNonFinite},
      {"drive fault",
       [](SupervisorRig& r) {
         r.drives[1].fault = true;
         r.drives[1].state = PS::kFault;
       },
       FC::kDriveFault, 1, static_cast<double>(PS::kFault)},
      {"drive stuck", [](SupervisorRig& r) { r.drives[0].stuck = true; }, FC::kDriveStuck, 0, kAny},
      {"bus off", [](SupervisorRig& r) { r.bus = BusState::kBusOff; }, FC::kBusOff, 0,
       static_cast<double>(BusState::kBusOff)},
      {"I/O error", [](SupervisorRig& r) { r.io_error = true; }, FC::kIoError, 0, 0.0},
      {"bad input", [](SupervisorRig& r) { r.axis_entries = 1; }, FC::kBadInput, 0, 0.0},
      {"node reset",
       [](SupervisorRig& r) {
         if (!r.heartbeats_on) return;  // one reset
         CanFrame f;
         encode_heartbeat(kNode, NmtState::kBootUp, r.t + kMs / 2, f);
         r.hb.on_frame(f);
         r.heartbeats_on = false;
       },
       FC::kNodeReset, kNode, kAny},
      {"EMCY",
       [](SupervisorRig& r) {
         if (r.emcy.counters().received > 0) return;
         EmcyMessage m;
         m.node_id = kNode;
         m.error_code = 0x4310;
         m.error_register = ErrorRegisterBit::kGeneric | ErrorRegisterBit::kTemperature;
         r.emcy.record(m, r.t);
       },
       FC::kEmcy, kNode, 0x4310},
  };
}

TEST(SafetySupervisor, EveryCauseLatchesInItsDetectionPeriodWithZeroTorqueAtOnce) {
  for (const Case& c : latching_cases()) {
    SupervisorRig r;
    r.bring_up();
    r.run(5);
    ASSERT_EQ(r.torques()[0], 1.0);
    const std::uint64_t k = r.periods;  // the detection period
    c.inject(r);
    const LifecycleUpdate u = r.step();
    EXPECT_TRUE(u.entered_safe_stop) << c.name;
    EXPECT_EQ(r.sup.state(), LS::kSafeStop) << c.name;
    EXPECT_TRUE(r.sup.commanded_torque_zero()) << c.name;
    EXPECT_EQ(r.sup.drive_target(), Cia402Target::kDisabled) << c.name;
    const std::array<double, 2> tau = r.torques();  // the same period's command
    EXPECT_EQ(tau[0], 0.0) << c.name;
    EXPECT_EQ(tau[1], 0.0) << c.name;
    ASSERT_NO_FATAL_FAILURE(expect_record(r.sup.first_fault(), c.cause, c.id, k, r.t, c.name));
    EXPECT_TRUE(r.sup.first_fault()->latched) << c.name;
    if (!std::isnan(c.value)) {
      EXPECT_EQ(r.sup.first_fault()->value, c.value) << c.name;
    }
    EXPECT_EQ(r.sup.counters().latches, 1u) << c.name;
    // It stays latched: zero torque every later period, whatever happens.
    for (int i = 0; i < 30; ++i) {
      c.inject(r);
      r.step();
      ASSERT_TRUE(r.sup.commanded_torque_zero()) << c.name;
      ASSERT_EQ(r.torques()[0], 0.0) << c.name;
    }
    EXPECT_EQ(r.sup.state(), LS::kFault) << c.name;
    EXPECT_EQ(r.sup.first_fault()->period, k) << c.name;
    // A persisting cause is one event: recorded once, not once per period.
    int same = 0;
    for (std::size_t i = 0; i < r.sup.fault_log_size(); ++i) {
      same += r.sup.fault_log_at(i)->cause == c.cause ? 1 : 0;
    }
    EXPECT_EQ(same, 1) << c.name;
  }
}

TEST(SafetySupervisor, HeartbeatLossLatchesInThePeriodTheConsumerDetectsIt) {
  SupervisorRig r;  // consumer timeout 3 ms, one heartbeat per 1 ms period
  r.bring_up();
  r.run(3);
  const std::int64_t last = r.t;
  r.heartbeats_on = false;
  // Lost at last + 3 ms: the periods at last + 1 ms and + 2 ms are fine.
  r.step();
  r.step();
  EXPECT_EQ(r.sup.state(), LS::kActive);
  const std::uint64_t k = r.periods;
  r.step();
  EXPECT_EQ(r.t, last + 3 * kMs);
  EXPECT_EQ(r.sup.state(), LS::kSafeStop);
  ASSERT_NO_FATAL_FAILURE(
      expect_record(r.sup.first_fault(), FC::kHeartbeatLost, kNode, k, r.t, "heartbeat"));
  EXPECT_DOUBLE_EQ(r.sup.first_fault()->value, 3e-3);  // silent for 3 ms
}

TEST(SafetySupervisor, HeartbeatLossThatRecoveredBeforeTheUpdateStillLatches) {
  SupervisorRig r;
  r.bring_up();
  r.heartbeats_on = false;
  // Between two updates the node is lost (poll at +4 ms) and heard again: the consumer is
  // alive at the update, but its loss counter grew: faults are events.
  CanFrame f;
  r.hb.poll(r.t + 4 * kMs);
  encode_heartbeat(kNode, NmtState::kOperational, r.t + 4 * kMs, f);
  r.hb.on_frame(f);
  r.t += 4 * kMs;
  r.heartbeats_on = true;
  ASSERT_EQ(r.hb.consumers()[0].status(), HeartbeatStatus::kAlive);
  r.step();
  EXPECT_EQ(r.sup.state(), LS::kSafeStop);
  ASSERT_NE(r.sup.first_fault(), nullptr);
  EXPECT_EQ(r.sup.first_fault()->cause, FC::kHeartbeatLost);
}

TEST(SafetySupervisor, EncoderTimeoutFiresAtExactlyNPeriodsWithoutAFreshFrame) {
  for (std::uint32_t n : {1u, 3u, 5u}) {
    SafetySettings s = two_axes();
    s.encoder_timeout_periods = n;
    SupervisorRig r(s);
    r.bring_up();
    // Axis 1 accepted a frame in the last period; from now on none. The held value is not
    // stale for the first two periods (no fault bit), then stale.
    for (std::uint32_t p = 1; p < n; ++p) {
      r.age[1] = p;
      r.mask[1] = p <= 2 ? SampleFault::kNone : SampleFault::kStale;
      r.step();
      ASSERT_EQ(r.sup.state(), LS::kActive) << "N=" << n << " period without frame " << p;
      ASSERT_EQ(r.torques()[1], -0.25);
    }
    const std::uint64_t k = r.periods;
    r.age[1] = n;
    r.mask[1] = SampleFault::kStale;
    r.step();
    EXPECT_EQ(r.sup.state(), LS::kSafeStop) << "N=" << n;
    ASSERT_NO_FATAL_FAILURE(
        expect_record(r.sup.first_fault(), FC::kEncoderTimeout, 1, k, r.t, "timeout"));
    EXPECT_EQ(r.sup.first_fault()->value, static_cast<double>(n));
  }
}

TEST(SafetySupervisor, IsolatedStaleFramesOnlyRejectTheSample) {
  SupervisorRig r;  // N = 3
  r.bring_up();
  for (int i = 0; i < 50; ++i) {
    // Two periods without a frame (stale, malformed), then a fresh one: never N in a row.
    const int phase = i % 3;
    r.age[0] = static_cast<std::uint32_t>(phase == 2 ? 0 : phase + 1);
    r.mask[0] = phase == 0 ? SampleFault::kMalformed
                           : (phase == 1 ? SampleFault::kStale : SampleFault::kNone);
    r.step();
    ASSERT_EQ(r.sup.state(), LS::kActive) << i;
  }
  EXPECT_EQ(r.sup.fault_log_size(), 0u);
  EXPECT_EQ(r.sup.counters().rejected_samples, 34u);  // phases 0 and 1 of 50 periods
}

TEST(SafetySupervisor, OverrunsLatchOnlyWhenConsecutive) {
  SupervisorRig r;  // overrun_limit = 3
  r.bring_up();
  const bool pattern[] = {true, true, false, true, false, true, true, false, true, true};
  for (bool o : pattern) {
    r.overrun = o;
    r.step();
    ASSERT_EQ(r.sup.state(), LS::kActive);
  }
  EXPECT_EQ(r.sup.counters().overruns, 7u);
  EXPECT_EQ(r.sup.consecutive_overruns(), 2u);
  const std::uint64_t k = r.periods;
  r.overrun = true;
  r.step();  // third in a row
  EXPECT_EQ(r.sup.state(), LS::kSafeStop);
  ASSERT_NO_FATAL_FAILURE(expect_record(r.sup.first_fault(), FC::kOverruns, 0, k, r.t, "overruns"));
  EXPECT_EQ(r.sup.first_fault()->value, 3.0);
}

TEST(SafetySupervisor, NothingHoldsTheLastCommand) {
  SupervisorRig r;
  // Unconfigured and inactive: zeros, whatever was asked.
  EXPECT_EQ(r.torques()[0], 0.0);
  ASSERT_EQ(r.sup.configure(), LR::kOk);
  r.step();
  EXPECT_EQ(r.torques()[0], 0.0);
  ASSERT_EQ(r.sup.activate(), LR::kOk);
  r.step();
  EXPECT_EQ(r.torques()[0], 1.0);
  // A fault: the command of the period before is not repeated, every entry is 0.
  r.mask[0] = SampleFault::kOutOfRange;
  r.step();
  EXPECT_FALSE(r.sup.torque_allowed());
  EXPECT_TRUE(r.sup.commanded_torque_zero());
  r.mask[0] = SampleFault::kNone;
  r.run(3);
  ASSERT_EQ(r.sup.state(), LS::kFault);
  ASSERT_EQ(r.sup.rearm(), LR::kOk);
  r.step();
  EXPECT_EQ(r.sup.state(), LS::kInactive);
  EXPECT_EQ(r.torques()[0], 0.0);
  // Deactivate is no fault but also zero.
  ASSERT_EQ(r.sup.activate(), LR::kOk);
  r.step();
  EXPECT_EQ(r.torques()[0], 1.0);
  ASSERT_EQ(r.sup.deactivate(), LR::kOk);
  EXPECT_EQ(r.torques()[0], 0.0);
}

TEST(SafetySupervisor, RearmRefusedWhileTheCausePersistsAcceptedAfterThenActivateAgain) {
  SupervisorRig r;
  r.bring_up();
  r.mask[1] = SampleFault::kOutOfRange;
  r.age[1] = 1;
  r.run(4);
  ASSERT_EQ(r.sup.state(), LS::kFault);
  EXPECT_EQ(r.sup.rearm(), LR::kCausePresent);
  EXPECT_EQ(r.sup.blocking().cause, FC::kOutOfRange);
  EXPECT_EQ(r.sup.blocking().id, 1);
  EXPECT_EQ(r.sup.state(), LS::kFault);
  // In range again, but no fresh frame for 3 periods: still blocked, now by the timeout.
  r.mask[1] = SampleFault::kStale;
  r.age[1] = 5;
  r.step();
  EXPECT_EQ(r.sup.rearm(), LR::kCausePresent);
  EXPECT_EQ(r.sup.blocking().cause, FC::kEncoderTimeout);
  // Fresh again.
  r.mask[1] = SampleFault::kNone;
  r.age[1] = 0;
  r.step();
  EXPECT_EQ(r.sup.blocking().cause, FC::kNone);
  ASSERT_NE(r.sup.first_fault(), nullptr);
  EXPECT_EQ(r.sup.rearm(), LR::kOk);
  EXPECT_EQ(r.sup.first_fault(), nullptr);
  EXPECT_EQ(r.sup.state(), LS::kInactive);
  r.run(5);
  EXPECT_FALSE(r.sup.torque_allowed());  // not re-activated by itself
  EXPECT_EQ(r.sup.drive_target(), Cia402Target::kDisabled);
  EXPECT_EQ(r.sup.activate(), LR::kOk);
  r.step();
  EXPECT_TRUE(r.sup.torque_allowed());
  EXPECT_EQ(r.torques()[0], 1.0);
}

TEST(SafetySupervisor, ActivationWaitsForEncodersHeartbeatsAndDisabledDrives) {
  SupervisorRig r;
  r.heartbeats_on = false;
  r.mask = {SampleFault::kNoData, SampleFault::kNoData};
  r.age = {7, 7};
  ASSERT_EQ(r.sup.configure(), LR::kOk);
  r.run(10);  // no encoder data in kInactive: not a fault (the timeout is not armed yet)
  EXPECT_EQ(r.sup.state(), LS::kInactive);
  EXPECT_EQ(r.sup.activate(), LR::kCausePresent);
  EXPECT_EQ(r.sup.blocking().cause, FC::kHeartbeatLost);  // never heard
  r.heartbeats_on = true;
  r.step();
  EXPECT_EQ(r.sup.activate(), LR::kCausePresent);
  EXPECT_EQ(r.sup.blocking().cause, FC::kEncoderTimeout);
  r.mask = {};
  r.age = {};
  r.drives[0].state = PS::kSwitchedOn;
  r.drives_follow = false;
  r.step();
  EXPECT_EQ(r.sup.activate(), LR::kCausePresent);
  EXPECT_EQ(r.sup.blocking().cause, FC::kDriveEnergized);
  r.drives_follow = true;
  r.run(2);
  EXPECT_EQ(r.sup.activate(), LR::kOk);
  EXPECT_EQ(r.sup.fault_log_size(), 0u);
}

TEST(SafetySupervisor, SafeStopEndsInFaultWhenDrivesDisableOrRecordsTheTimeout) {
  {
    SupervisorRig r;
    r.bring_up();
    r.io_error = true;
    r.step();  // trip; the drives follow kDisabled in the rig
    r.io_error = false;
    EXPECT_EQ(r.sup.state(), LS::kSafeStop);
    r.step();
    EXPECT_EQ(r.sup.state(), LS::kFault);
    EXPECT_FALSE(r.sup.lifecycle().safe_stop_timed_out());
  }
  {
    SupervisorRig r;  // safe_stop_timeout_periods = 10
    r.bring_up();
    r.drives_follow = false;  // drive 0 stays in operation enabled (not disabling)
    r.bus = BusState::kBusOff;
    r.step();
    r.bus = BusState::kOk;
    const std::uint64_t trip = r.periods - 1;
    for (int i = 1; i < 10; ++i) {
      r.step();
      ASSERT_EQ(r.sup.state(), LS::kSafeStop) << i;
    }
    r.step();
    EXPECT_EQ(r.sup.state(), LS::kFault);
    EXPECT_TRUE(r.sup.lifecycle().safe_stop_timed_out());
    ASSERT_NO_FATAL_FAILURE(
        expect_record(r.sup.newest_fault(), FC::kSafeStopTimeout, 0, trip + 10, r.t, "timeout"));
    EXPECT_EQ(r.sup.newest_fault()->value, 10.0);
    EXPECT_FALSE(r.sup.newest_fault()->latched);
    ASSERT_NE(r.sup.first_fault(), nullptr);
    EXPECT_EQ(r.sup.first_fault()->cause, FC::kBusOff);
    EXPECT_EQ(r.sup.rearm(), LR::kCausePresent);  // the drive is still not disabled
    EXPECT_EQ(r.sup.blocking().cause, FC::kDriveEnergized);
  }
}

TEST(SafetySupervisor, CausesAreRecordedOncePerEpisodeAndLaterFaultsDoNotReplaceTheFirst) {
  SupervisorRig r;
  r.bring_up();
  r.mask[0] = SampleFault::kOutOfRange;
  r.step();
  ASSERT_NE(r.sup.first_fault(), nullptr);
  const FaultRecord first = *r.sup.first_fault();
  for (int i = 0; i < 20; ++i) r.step();  // persists: one record
  EXPECT_EQ(r.sup.fault_log_size(), 1u);
  r.mask[1] = SampleFault::kJump;  // a second cause while latched
  r.step();
  EXPECT_EQ(r.sup.fault_log_size(), 2u);
  ASSERT_NE(r.sup.newest_fault(), nullptr);
  EXPECT_EQ(r.sup.newest_fault()->cause, FC::kEncoderJump);
  EXPECT_FALSE(r.sup.newest_fault()->latched);
  ASSERT_NE(r.sup.first_fault(), nullptr);
  EXPECT_EQ(r.sup.first_fault()->cause, first.cause);
  EXPECT_EQ(r.sup.first_fault()->period, first.period);
  r.mask[0] = SampleFault::kNone;  // clears, then comes back: a new record
  r.step();
  r.mask[0] = SampleFault::kOutOfRange;
  r.step();
  EXPECT_EQ(r.sup.fault_log_size(), 3u);
  EXPECT_EQ(r.sup.counters().latches, 1u);
}

TEST(SafetySupervisor, SeveralCausesInOnePeriodAreAllRecordedTheFirstInOrderLatches) {
  SupervisorRig r;
  r.bring_up();
  r.mask[1] = SampleFault::kJump;
  r.overrun = true;
  r.io_error = true;
  r.step();
  ASSERT_EQ(r.sup.fault_log_size(), 2u);
  EXPECT_EQ(r.sup.fault_log_at(0)->cause, FC::kIoError);
  EXPECT_TRUE(r.sup.fault_log_at(0)->latched);
  EXPECT_EQ(r.sup.fault_log_at(1)->cause, FC::kEncoderJump);
  EXPECT_FALSE(r.sup.fault_log_at(1)->latched);
  EXPECT_EQ(r.sup.first_fault()->cause, FC::kIoError);
}

TEST(SafetySupervisor, FaultLogIsARingOfFixedCapacity) {
  SupervisorRig r;
  r.bring_up();
  // Toggle an I/O error: one record per rising edge.
  for (std::size_t i = 0; i < kFaultLogCapacity + 10; ++i) {
    r.io_error = true;
    r.step();
    r.io_error = false;
    r.step();
  }
  EXPECT_EQ(r.sup.fault_log_size(), kFaultLogCapacity);
  EXPECT_EQ(r.sup.counters().records, kFaultLogCapacity + 10);
  EXPECT_EQ(r.sup.counters().records_overwritten, 10u);
  // Oldest held is the 11th; its period: bring_up took 2, each record 2 periods apart.
  ASSERT_EQ(r.sup.fault_log_size(), kFaultLogCapacity);
  EXPECT_EQ(r.sup.fault_log_at(0)->period, 2u + 2 * 10);
  EXPECT_EQ(r.sup.fault_log_at(kFaultLogCapacity), nullptr);
  ASSERT_NE(r.sup.first_fault(), nullptr);
  EXPECT_EQ(r.sup.first_fault()->period, 2u);  // kept apart from the ring
}

// The clamp and the gate of the axis torques are hal::ImpedanceDevice::write()'s (device_test.cpp); a
// non-finite torque it finds is reported here and latches.
TEST(SafetySupervisor, NonFiniteTorqueLatches) {
  for (double bad :
       {std::numeric_limits<double>::quiet_NaN(), -std::numeric_limits<double>::infinity()}) {
    SupervisorRig r;
    r.bring_up();
    const std::uint64_t k = r.periods - 1;  // the period of the last update
    (void)bad;  // what write() found; the supervisor is told the axis
    r.sup.trip_non_finite_torque(1);
    EXPECT_EQ(r.sup.state(), LS::kSafeStop);
    EXPECT_FALSE(r.sup.torque_allowed());
    ASSERT_NO_FATAL_FAILURE(
        expect_record(r.sup.first_fault(), FC::kNonFiniteTorque, 1, k, r.t, "NaN torque"));
    EXPECT_EQ(r.sup.counters().non_finite_torques, 1u);
    EXPECT_EQ(r.sup.counters().latches, 1u);
    r.step();
    r.step();
    EXPECT_EQ(r.sup.state(), LS::kFault);
    EXPECT_EQ(r.sup.rearm(), LR::kOk);  // an event: nothing persists
  }
}

TEST(SafetySupervisor, UnconfiguredAbsorbsEventsWithoutActing) {
  SupervisorRig r;
  EmcyMessage m;
  m.node_id = kNode;
  m.error_code = 0x5000;
  r.emcy.record(m, 0);
  r.io_error = true;
  r.run(3);
  EXPECT_EQ(r.sup.fault_log_size(), 0u);
  r.io_error = false;
  ASSERT_EQ(r.sup.configure(), LR::kOk);
  r.step();
  EXPECT_EQ(r.sup.state(), LS::kInactive);  // the old EMCY is not acted on after configure
  EXPECT_EQ(r.sup.fault_log_size(), 0u);
}

TEST(SafetySupervisor, SettingsAreValidated) {
  auto message = [](SafetySettings s) -> std::string {
    try {
      SafetySupervisor sup(s);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  SafetySettings s = two_axes();
  s.encoder_timeout_periods = 0;
  EXPECT_NE(message(s).find("encoder_timeout_periods"), std::string::npos);
  s = two_axes();
  s.overrun_limit = 0;
  EXPECT_NE(message(s).find("overrun_limit"), std::string::npos);
  s = two_axes();
  s.safe_stop_timeout_periods = 0;
  EXPECT_NE(message(s).find("safe_stop_timeout_periods"), std::string::npos);
  s = two_axes();
  s.num_axes = 0;
  EXPECT_NE(message(s).find("num_axes"), std::string::npos);
  s.num_axes = 9;
  EXPECT_NE(message(s).find("num_axes"), std::string::npos);
  EXPECT_EQ(message(two_axes()), "");
}

TEST(SafetySupervisor, CauseNamesAreDistinct) {
  std::vector<std::string> names;
  for (int c = 0; c <= static_cast<int>(FC::kForceTimeout); ++c) {
    const std::string n = to_string(static_cast<FC>(c));
    EXPECT_NE(n, "unknown");
    for (const std::string& o : names) EXPECT_NE(n, o);
    names.push_back(n);
  }
}

TEST(SafetySupervisor, PerPeriodCallsDoNotAllocate) {
  SupervisorRig r;
  r.bring_up();
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 200; ++i) {
    r.overrun = i % 2 == 0;
    r.mask[1] = i > 150 ? SampleFault::kJump : SampleFault::kNone;
    r.io_error = i % 7 == 0 && i > 100;
    r.step();
  }
  r.mask[1] = SampleFault::kNone;
  r.io_error = false;
  r.step();
  r.sup.rearm();
  r.sup.activate();
  r.step();
  r.sup.trip_non_finite_torque(1);
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(r.sup.counters().records, 3u);
}

}  // namespace
