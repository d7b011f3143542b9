// Tests of platform/control_loop with the managed CANopen stack: start-up, faults and their
// safe state, shutdown, soft start, saturation, allocations and bit-identical reruns.
#include "numen/platform/control_loop.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "control_loop_fixtures.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/managed_device.hpp"
#include "numen/hal/device/rate_estimator.hpp"
#include "numen/hal/transport/sim_bus.hpp"

using namespace numen::test::control_loop_fixtures;

// ---------------------------------------------------------------- managed CANopen stack

namespace managed {

using numen::hal::FaultCause;
using numen::hal::LifecycleState;
using numen::hal::PowerState;
using numen::hal::StartupPhase;

numen::hal::DeviceConfig managed_config() {
  numen::hal::DeviceConfig c = numen::hal::make_default_trocar_config(1);
  c.trocar.point = Vec3(0.0, 0.0, 0.2);
  c.trocar.orientation = Quat(Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitX()));
  c.control_period_s = 1e-3;
  return c;
}

/// managed_config() with a soft start of `soft_start_s` (DeviceConfig::soft_start_s).
numen::hal::DeviceConfig managed_config(double soft_start_s) {
  numen::hal::DeviceConfig c = managed_config();
  c.soft_start_s = soft_start_s;
  return c;
}

/// The loop's managed device (its CANopen master and supervisor: the test reaches past the
/// face the code above hal reads, hal::DeviceReport).
const numen::hal::ManagedDevice& managed_device(const ControlLoop& loop) {
  return dynamic_cast<const numen::hal::ManagedDevice&>(loop.device());
}
numen::hal::ManagedDevice& managed_device(ControlLoop& loop) {
  return dynamic_cast<numen::hal::ManagedDevice&>(loop.device());
}

/// The full stack: SimBus, managed DeviceEmulator (NMT, heartbeats, CiA 402 drives), the loop.
struct Rig {
  numen::hal::DeviceConfig config;
  SimBus bus{bus_settings()};
  numen::hal::DeviceEmulator emulator{config};
  numen::hal::InstrumentDevice device{config};
  numen::core::Model model = small_model();
  numen::core::Data data = numen::core::make_data(model);
  ControlLoop loop{model, data, bus.controller(), device};
  std::int64_t k = 0;
  bool controller_silent = false;

  explicit Rig(double soft_start_s = 0.0) : config(managed_config(soft_start_s)) {
    emulator.set_axis_values(kQ);
  }

  /// Period k as SceneRunner runs it: SYNC (+ NMT, heartbeat); the device answers and ticks;
  /// the controller reads, supervises, steps and writes; the device takes the RPDOs.
  const PeriodReport& period() {
    const std::int64_t t = k * kMs;
    ++k;
    bus.set_time_ns(t);
    if (!controller_silent) loop.begin_period(t);
    bus.set_time_ns(t + kLatency);
    emulator.poll(bus.device());
    emulator.tick(t + kLatency, bus.device());
    bus.set_time_ns(t + kPhase);
    if (!controller_silent) loop.end_period(t + kPhase);
    return loop.last_report();
  }
  /// Runs until the lifecycle is active and torque flows (at most `max` periods).
  void run_to_torque(int max = 100) {
    for (int i = 0; i < max && loop.first_torque_period() < 0; ++i) period();
  }
  const numen::hal::SafetySupervisor& sup() const { return *managed_device(loop).supervisor(); }
};

/// True if any drive RPDO of this period carried a non-zero target torque (emulator view).
bool any_torque(const Rig& rig) {
  for (int a = 0; a < 3; ++a) {
    if (rig.loop.impedance().sent_torques().per_mille[static_cast<std::size_t>(a)] != 0) return true;
  }
  return false;
}

TEST(ControlLoopManaged, StartUpReachesActiveInAnExactNumberOfPeriods) {
  // 1 ms periods, 100 µs latency, node heartbeats every 10 ms. Period 0: SYNC + reset
  // communication; the nodes boot (power-on) and their boot-ups are read in period 0. Period 1:
  // start remote node. Period 2 on: TPDOs. Period 10: the first heartbeats (10 ms after the
  // boot-ups) report operational → start-up complete, encoders fresh, drives disabled →
  // activate. Periods 11–13: shutdown, switch on, enable operation (one statusword round trip
  // each). Period 14: operation enabled → torque allowed.
  Rig rig;
  ASSERT_TRUE(rig.loop.managed());
  EXPECT_EQ(rig.sup().state(), LifecycleState::kInactive);  // configured at construction
  const numen::hal::CanopenMaster& m = *managed_device(rig.loop).canopen();
  for (int i = 0; i < 40; ++i) {
    const PeriodReport& r = rig.period();
    const std::int64_t k = rig.k - 1;
    SCOPED_TRACE("period " + std::to_string(k));
    EXPECT_EQ(r.startup, k == 0   ? StartupPhase::kStartNodes
                         : k < 10 ? StartupPhase::kWaitOperational
                                  : StartupPhase::kOperational);
    EXPECT_EQ(r.lifecycle, k < 10 ? LifecycleState::kInactive : LifecycleState::kActive);
    EXPECT_EQ(r.activated, k == 10);
    EXPECT_EQ(r.sample_valid, k >= 2);
    bool allowed = true;
    for (const auto& out : m.drive_outputs()) allowed = allowed && out.torque_allowed;
    EXPECT_EQ(allowed, k >= 14);
    if (k < 14) {
      EXPECT_FALSE(any_torque(rig)) << "torque before the drives are enabled";
    }
  }
  EXPECT_EQ(rig.loop.first_active_period(), 10);
  EXPECT_EQ(rig.loop.first_torque_period(), 14);
  EXPECT_EQ(m.startup().done_period, 10u);
  EXPECT_EQ(m.startup().attempts, 1u);
  EXPECT_EQ(m.counters().nmt_retries, 0u);
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(rig.emulator.drive(a)->state(), PowerState::kOperationEnabled);
    EXPECT_EQ(rig.emulator.node_state(a), numen::hal::NmtState::kOperational);
  }
  EXPECT_EQ(rig.sup().fault_log_size(), 0u);
  EXPECT_TRUE(any_torque(rig));
  // The report carries LoopStatistics' stamps, in order.
  const PeriodReport& r = rig.loop.last_report();
  EXPECT_LE(r.deadline_ns, r.woke_ns);
  EXPECT_LE(r.woke_ns, r.sync_sent_ns);
  EXPECT_LE(r.sync_sent_ns, r.input_begin_ns);
  EXPECT_LE(r.input_end_ns, r.step_begin_ns);
  EXPECT_LE(r.step_end_ns, r.output_begin_ns);
  EXPECT_LE(r.output_begin_ns, r.output_end_ns);
  EXPECT_EQ(rig.loop.statistics().summary().periods, 40);
  EXPECT_EQ(rig.loop.statistics().summary().invalid_periods, 0);
}

TEST(ControlLoopManaged, DeviceKilledZeroTorqueWithinThreePeriodsReportedWithThePeriod) {
  Rig rig;
  rig.run_to_torque();
  for (int i = 0; i < 7; ++i) rig.period();
  ASSERT_TRUE(any_torque(rig));
  rig.emulator.kill(true);  // the device stops answering anything
  const std::int64_t killed_at = rig.k;
  int zero_after = -1;
  for (int i = 0; i < 3; ++i) {
    rig.period();
    if (zero_after < 0 && !any_torque(rig)) zero_after = i;
  }
  // The third period without an encoder frame latches (encoder timeout N = 3): zero torque in
  // that very period.
  EXPECT_EQ(zero_after, 2);
  EXPECT_EQ(rig.sup().state(), LifecycleState::kSafeStop);
  const numen::hal::FaultRecord* f = rig.sup().first_fault();
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->cause, FaultCause::kEncoderTimeout);
  EXPECT_EQ(f->id, 0);      // axis 0 is the first axis found
  EXPECT_EQ(f->value, 3.0);  // periods without an accepted frame
  EXPECT_EQ(f->period, static_cast<std::uint64_t>(killed_at + 2));
  EXPECT_EQ(f->time_ns, (killed_at + 2) * kMs + kPhase);
  // The heartbeats stop too: each node is reported lost (not latching again) once its consumer
  // time (30 ms) has passed; the drives cannot confirm "disabled": kFault by the safe stop
  // timeout (100 periods).
  for (int i = 0; i < 120; ++i) rig.period();
  EXPECT_FALSE(any_torque(rig));
  EXPECT_EQ(rig.sup().state(), LifecycleState::kFault);
  EXPECT_TRUE(rig.sup().lifecycle().safe_stop_timed_out());
  int lost = 0;
  for (std::size_t i = 0; i < rig.sup().fault_log_size(); ++i) {
    const numen::hal::FaultRecord* r = rig.sup().fault_log_at(i);
    if (r->cause == FaultCause::kHeartbeatLost) {
      ++lost;
      EXPECT_FALSE(r->latched);
      EXPECT_GE(r->value, 0.030);  // s silent
      EXPECT_LT(r->value, 0.032);
    }
  }
  EXPECT_EQ(lost, 5);
  EXPECT_EQ(rig.sup().counters().latches, 1u);
}

TEST(ControlLoopManaged, DriveFaultEmcyReportedSafeStateDrivesDisabledLatchedRearmActiveAgain) {
  Rig rig;
  rig.run_to_torque();
  for (int i = 0; i < 5; ++i) rig.period();
  ASSERT_TRUE(any_torque(rig));
  ASSERT_TRUE(rig.emulator.inject_drive_fault(1, 0x2310));  // pivot_y over-current
  const std::int64_t fault_at = rig.k;
  const PeriodReport& r = rig.period();
  // EMCY and fault statusword are read in this period: latched, zero torque now.
  EXPECT_TRUE(r.entered_safe_stop);
  EXPECT_FALSE(r.torque_commanded);
  EXPECT_FALSE(any_torque(rig));
  const numen::hal::FaultRecord* f = rig.sup().first_fault();
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->cause, FaultCause::kEmcy);
  EXPECT_EQ(f->id, 2);  // node 2
  EXPECT_EQ(f->value, 0x2310);
  EXPECT_EQ(f->period, static_cast<std::uint64_t>(fault_at));
  const numen::hal::EmcyRecord* e = managed_device(rig.loop).canopen()->emcy_log().newest();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->message.node_id, 2);
  EXPECT_EQ(e->message.error_code, 0x2310);
  EXPECT_EQ(e->message.error_register, 0x03);  // generic + current
  ASSERT_EQ(rig.sup().fault_log_size(), 2u);
  EXPECT_EQ(rig.sup().newest_fault()->cause, FaultCause::kDriveFault);
  EXPECT_EQ(rig.sup().newest_fault()->id, 1);  // drive index 1
  // Disable voltage reaches the healthy drives in the next periods: kFault once all disabled.
  for (int i = 0; i < 4; ++i) rig.period();
  EXPECT_EQ(rig.sup().state(), LifecycleState::kFault);
  EXPECT_FALSE(rig.sup().lifecycle().safe_stop_timed_out());
  EXPECT_EQ(rig.emulator.drive(0)->state(), PowerState::kSwitchOnDisabled);
  EXPECT_EQ(rig.emulator.drive(1)->state(), PowerState::kFault);
  EXPECT_EQ(rig.emulator.drive(2)->state(), PowerState::kSwitchOnDisabled);
  // Latched: nothing re-enables it on its own.
  for (int i = 0; i < 50; ++i) {
    rig.period();
    ASSERT_FALSE(any_torque(rig));
    ASSERT_EQ(rig.sup().state(), LifecycleState::kFault);
  }
  // Re-arm: fault reset of drive 1, then inactive, then the automatic activation.
  EXPECT_EQ(rig.loop.rearm(), numen::platform::RearmResult::kAccepted);
  EXPECT_TRUE(rig.loop.rearm_pending());
  int periods = 0;
  while (!any_torque(rig) && periods < 50) {
    rig.period();
    ++periods;
  }
  std::printf("[   info   ] rearm to torque: %d periods\n", periods);
  EXPECT_LT(periods, 20);
  EXPECT_FALSE(rig.loop.rearm_pending());
  EXPECT_EQ(rig.sup().state(), LifecycleState::kActive);
  for (int a = 0; a < 3; ++a) EXPECT_EQ(rig.emulator.drive(a)->state(), PowerState::kOperationEnabled);
  EXPECT_EQ(rig.sup().counters().latches, 1u);
  EXPECT_EQ(rig.sup().lifecycle().counters().rearms, 1u);
  EXPECT_EQ(managed_device(rig.loop).canopen()->emcy_log().counters().resets, 1u);  // 0x0000 after the reset
  EXPECT_EQ(rig.loop.rearm(), numen::platform::RearmResult::kNotLatched);
}

TEST(ControlLoopManaged, ShutdownZeroTorqueAtOnceThenDrivesDisabledWithoutAFault) {
  // The orderly end of a run (numen run on a real bus, Ctrl-C): from the period after
  // shutdown() no torque, the drives are disabled through CiA 402 (controlword) within a few
  // periods, and this is not a fault: nothing is latched, nothing re-enables them.
  Rig rig;
  rig.run_to_torque();
  for (int i = 0; i < 5; ++i) rig.period();
  ASSERT_TRUE(any_torque(rig));
  ASSERT_FALSE(rig.loop.drives_disabled());
  rig.loop.shutdown();
  EXPECT_TRUE(rig.loop.shutting_down());
  int periods = 0;
  while (!rig.loop.drives_disabled() && periods < 50) {
    const PeriodReport& r = rig.period();
    ++periods;
    ASSERT_FALSE(r.torque_commanded) << "period " << periods;
    ASSERT_FALSE(any_torque(rig)) << "period " << periods;
  }
  std::printf("[   info   ] shutdown to drives disabled: %d periods\n", periods);
  EXPECT_TRUE(rig.loop.drives_disabled());
  EXPECT_LE(periods, 5);
  for (int a = 0; a < 3; ++a) {
    const PowerState st = rig.emulator.drive(a)->state();
    EXPECT_TRUE(st == PowerState::kSwitchOnDisabled || st == PowerState::kReadyToSwitchOn) << a;
  }
  for (int i = 0; i < 30; ++i) {
    rig.period();
    ASSERT_FALSE(any_torque(rig));
    ASSERT_TRUE(rig.loop.drives_disabled());
  }
  EXPECT_EQ(rig.sup().counters().latches, 0u);
  EXPECT_EQ(rig.loop.rearm(), numen::platform::RearmResult::kNotLatched);
}

// Torque is gated once, in ImpedanceDevice::write(): a NaN Eq. 8 wrench is mapped as it is (the map
// computes, it does not zero), reaches write()'s non-finite trip and latches the safe state
// with FaultCause::kNonFiniteTorque in that very period; no torque leaves from then on.
TEST(ControlLoopManaged, ANaNWrenchLatchesNonFiniteTorque) {
  Rig rig;
  rig.run_to_torque();
  for (int i = 0; i < 5; ++i) rig.period();
  ASSERT_TRUE(any_torque(rig));
  struct PoisonStepper final : numen::platform::Stepper {
    void step(const numen::core::Model& m, numen::core::Data& d) noexcept override {
      numen::core::step(m, d);
      d.body_feedback[0].force.x() = std::numeric_limits<double>::quiet_NaN();
    }
  } poison;
  rig.loop.set_stepper(&poison);
  const std::uint64_t trips = rig.loop.impedance().torque_counters().non_finite;
  const PeriodReport& r = rig.period();
  EXPECT_FALSE(r.torque_commanded);
  EXPECT_FALSE(any_torque(rig));
  EXPECT_EQ(rig.loop.impedance().torque_counters().non_finite, trips + 1);
  EXPECT_EQ(rig.loop.counters().non_finite_wrenches, 1u);  // the map stage's count
  EXPECT_TRUE(r.lifecycle == LifecycleState::kSafeStop || r.lifecycle == LifecycleState::kFault)
      << numen::hal::to_string(r.lifecycle);
  ASSERT_NE(rig.sup().first_fault(), nullptr);
  EXPECT_EQ(rig.sup().first_fault()->cause, FaultCause::kNonFiniteTorque);
  rig.loop.set_stepper(nullptr);
  for (int i = 0; i < 20; ++i) {
    rig.period();
    ASSERT_FALSE(any_torque(rig)) << "latched: no torque until a re-arm, period " << i;
  }
}

TEST(ControlLoopManaged, ControllerSilentEmulatedDrivesFaultOnTheirOwn) {
  // The drives watch the controller's heartbeat (10 ms, consumer time 30 ms): when the
  // controller stops, they fault by themselves (EMCY 0x8130) and apply zero torque.
  Rig rig;
  rig.run_to_torque();
  for (int i = 0; i < 3; ++i) rig.period();
  ASSERT_NE(rig.emulator.drive(0)->applied_torque_per_mille(), 0);
  const std::int64_t silent_from = rig.k;
  const std::int64_t last_heartbeat = ((silent_from - 1) / 10) * 10;  // period of the last one
  rig.controller_silent = true;
  while (rig.k < last_heartbeat + 30) {
    rig.period();
    ASSERT_EQ(rig.emulator.drive(0)->state(), PowerState::kOperationEnabled) << rig.k;
  }
  rig.period();  // period last_heartbeat + 30: 30 ms since the last heartbeat arrived
  for (int a = 0; a < 3; ++a) {
    const numen::hal::Cia402Drive* d = rig.emulator.drive(a);
    EXPECT_NE(d->state(), PowerState::kOperationEnabled);
    EXPECT_EQ(d->applied_torque_per_mille(), 0);
    EXPECT_EQ(d->error_code(), 0x8130);
  }
  EXPECT_EQ(rig.emulator.counters().controller_losses, 3u);  // nodes 1, 2, 3 carry drives
  // Their EMCYs wait on the controller's port.
  int emcys = 0;
  CanFrame frame;
  rig.bus.set_time_ns(rig.k * kMs);
  while (rig.bus.controller().read(frame) == IoStatus::kOk) {
    numen::hal::EmcyMessage msg;
    if (numen::hal::decode_emcy(frame, msg) == numen::hal::EmcyDecodeStatus::kOk) {
      EXPECT_EQ(msg.error_code, 0x8130);
      ++emcys;
    }
  }
  EXPECT_EQ(emcys, 3);
}

TEST(ControlLoopManaged, NmtStopStopsTheTpdosAndTheEncoderTimesOut) {
  Rig rig;
  rig.run_to_torque();
  for (int i = 0; i < 3; ++i) rig.period();
  ASSERT_TRUE(managed_device(rig.loop).canopen()->request_nmt(numen::hal::NmtCommand::kStopRemoteNode, 3));
  const std::int64_t p = rig.k;
  rig.period();  // period p: SYNC answered, then the stop command
  EXPECT_EQ(rig.emulator.node_state(2), numen::hal::NmtState::kStopped);
  // The drive of the stopped node faults (abort connection): never keeps the last torque.
  EXPECT_EQ(rig.emulator.drive(2)->applied_torque_per_mille(), 0);
  rig.period();
  rig.period();
  EXPECT_EQ(rig.sup().state(), LifecycleState::kActive);
  rig.period();  // period p + 3: the third without a depth TPDO
  EXPECT_EQ(rig.sup().state(), LifecycleState::kSafeStop);
  const numen::hal::FaultRecord* f = rig.sup().first_fault();
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->cause, FaultCause::kEncoderTimeout);
  EXPECT_EQ(f->id, 2);  // depth
  EXPECT_EQ(f->period, static_cast<std::uint64_t>(p + 3));
  EXPECT_FALSE(any_torque(rig));
}

// A re-arm whose nodes are not all operational reruns the start-up (reset communication,
// boot-ups, start remote node): the encoders are silent for longer than the encoder timeout
// while it runs, and none of those periods latches again. The lifecycle stays in kFault (where
// no cause latches) until the start-up is operational, the re-arm happens only once no cause is
// present (fresh encoders), the activation only then. (The HIL scenario run_device_rearm's
// bad value leaves the nodes operational: its re-arm resets faults only and restarts nothing.)
// The drives' fault reset that rearm() requests is sent again once the start-up is operational
// (ManagedDevice): sent only while it runs, the stopped node's drive (pre-operational, its RPDO
// ignored) stayed in fault, Cia402Master gave the reset up after its transition timeout, and
// torque never came back after a single re-arm.
TEST(ControlLoopManaged, RearmThatRerunsTheStartUpDoesNotLatchOnTheEncodersItSilences) {
  Rig rig;
  rig.run_to_torque();
  for (int i = 0; i < 3; ++i) rig.period();
  const numen::hal::CanopenMaster& m = *managed_device(rig.loop).canopen();
  ASSERT_TRUE(managed_device(rig.loop).canopen()->request_nmt(numen::hal::NmtCommand::kStopRemoteNode, 3));
  // kFault once the drives report disabled, or after the safe stop's timeout (the stopped
  // node's drive sends no statusword).
  for (int i = 0; i < 1000 && rig.sup().state() != LifecycleState::kFault; ++i) rig.period();
  ASSERT_EQ(rig.sup().state(), LifecycleState::kFault);
  ASSERT_NE(rig.sup().first_fault(), nullptr);
  EXPECT_EQ(rig.sup().first_fault()->cause, FaultCause::kEncoderTimeout);
  ASSERT_FALSE(m.all_nodes_operational());  // node 3 reports stopped in its heartbeats
  ASSERT_EQ(rig.sup().counters().latches, 1u);

  numen::test::AllocationGuard guard;  // the re-arm and the start-up it reruns: no allocation
  EXPECT_EQ(rig.loop.rearm(), numen::platform::RearmResult::kAccepted);
  EXPECT_TRUE(rig.loop.rearm_pending());
  std::uint32_t silent = 0;       // periods in a row with the depth encoder timed out
  std::uint32_t most_silent = 0;
  int periods = 0;
  while (!any_torque(rig) && periods < 200) {
    rig.period();
    ++periods;
    const std::uint32_t age = rig.device.last_sample().periods_since_accepted[2];
    silent = age >= 3 ? silent + 1 : 0;
    most_silent = std::max(most_silent, silent);
    ASSERT_EQ(rig.sup().counters().latches, 1u) << "latched again " << periods << " periods after the re-arm";
    ASSERT_NE(rig.sup().state(), LifecycleState::kSafeStop);
  }
  EXPECT_EQ(guard.count(), 0);
  std::printf("[   info   ] re-arm with a start-up to torque: %d periods, encoders timed out in %u in a row\n",
              periods, most_silent);
  EXPECT_EQ(m.startup().attempts, 2u) << "the re-arm reran the start-up";
  // The timeout's condition (3 periods without a fresh depth sample) was present: it latched nothing.
  EXPECT_GE(most_silent, 1u) << "the start-up silenced the encoders for longer than the timeout";
  EXPECT_TRUE(any_torque(rig));
  EXPECT_EQ(rig.sup().state(), LifecycleState::kActive);
  EXPECT_FALSE(rig.loop.rearm_pending());
  EXPECT_EQ(rig.sup().lifecycle().counters().rearms, 1u);
  for (int i = 0; i < 50; ++i) rig.period();
  EXPECT_EQ(rig.sup().state(), LifecycleState::kActive);
  EXPECT_EQ(rig.sup().counters().latches, 1u);
}

// What the period reports as feedback is what the drives get: zero while write() gates (the
// start-up, before kActive, although the core's composite Data::feedback_wrench is not), and
// once torque flows τ_sent = clamp(Jᵀ feedback) on the driven axes, 0 elsewhere, exactly the
// per mille of the RPDO the emulated drives read.
TEST(ControlLoopManaged, ReportedFeedbackIsTheWrenchWhoseTorquesWereSent) {
  Rig rig;
  int gated_with_core_feedback = 0;
  int torque_periods = 0;
  double q[5] = {kQ[0], kQ[1], kQ[2], kQ[3], kQ[4]};
  for (int i = 0; i < 120; ++i) {
    if (rig.loop.first_torque_period() >= 0) {  // move the hand: the feedback grows
      q[0] += 0.004;
      q[2] += 0.0005;
      rig.emulator.set_axis_values(q);
    }
    const PeriodReport& r = rig.period();
    const numen::hal::SentTorques& sent = rig.loop.impedance().sent_torques();
    if (!r.torque_commanded) {
      EXPECT_EQ(r.feedback.force.norm(), 0.0) << "period " << i;
      EXPECT_EQ(r.feedback.torque.norm(), 0.0) << "period " << i;
      if (rig.data.feedback_wrench.force.norm() > 0.1) ++gated_with_core_feedback;
      continue;
    }
    ++torque_periods;
    const AxisVector tau = numen::hal::torques_from_wrench(
        rig.device.kinematics().jacobian(rig.device.last_sample().q), r.feedback);
    for (int a = 0; a < 5; ++a) {
      const auto& ax = rig.config.axes[static_cast<std::size_t>(a)];
      const double want = ax.has_drive() ? std::clamp(tau[a], -ax.max_torque, ax.max_torque) : 0.0;
      EXPECT_NEAR(sent.torque[a], want, 1e-12) << "period " << i << " axis " << a;
      EXPECT_EQ(sent.per_mille[static_cast<std::size_t>(a)],
                ax.has_drive() ? numen::hal::torque_per_mille(ax, want) : 0);
    }
  }
  EXPECT_GT(gated_with_core_feedback, 0) << "the check is not vacuous: the core had feedback";
  EXPECT_GT(torque_periods, 50);
  // The drives read those RPDOs: after one more exchange each got the last per mille sent.
  const std::array<std::int16_t, numen::hal::kMaxAxes> last = rig.loop.impedance().sent_torques().per_mille;
  rig.period();  // the drives read the RPDOs, then apply them at this period's SYNC
  for (std::size_t a = 0; a < 3; ++a) EXPECT_EQ(rig.emulator.last_torque_per_mille()[a], last[a]) << a;
}

TEST(ControlLoopManaged, TorquesAreSaturatedPerAxis) {
  Rig rig;
  rig.run_to_torque();
  // Move the hand (ramp within the speed limits): the god-object lags, the feedback grows.
  double q[5] = {kQ[0], kQ[1], kQ[2], kQ[3], kQ[4]};
  double peak[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < 60; ++i) {
    q[0] += 0.004;
    q[1] -= 0.004;
    q[2] += 0.0005;
    rig.emulator.set_axis_values(q);
    rig.period();
    for (int a = 0; a < 3; ++a) {
      const double tau = rig.loop.impedance().sent_torques().torque[a];
      const double lim = rig.config.axes[static_cast<std::size_t>(a)].max_torque;
      ASSERT_LE(std::abs(tau), lim + 1e-12) << "axis " << a;
      peak[a] = std::max(peak[a], std::abs(tau));
    }
  }
  ASSERT_EQ(rig.sup().state(), LifecycleState::kActive);
  std::printf("[   info   ] peak |tau|: %.4f %.4f %.4f\n", peak[0], peak[1], peak[2]);
  // A second rig whose pivot_x limit is below that peak clamps exactly there.
  Rig low;
  low.config.axes[0].max_torque = 0.5 * peak[0];
  ASSERT_GT(peak[0], 0.0);
  numen::hal::InstrumentDevice device(low.config);
  numen::core::Data data = numen::core::make_data(low.model);
  ControlLoop loop(low.model, data, low.bus.controller(), device);
  numen::hal::DeviceEmulator emulator(low.config);
  emulator.set_axis_values(kQ);
  double q2[5] = {kQ[0], kQ[1], kQ[2], kQ[3], kQ[4]};
  double clamped_peak = 0.0;
  for (std::int64_t k = 0; k < 200; ++k) {
    if (k >= 20 && k < 80) {
      q2[0] += 0.004;
      q2[1] -= 0.004;
      q2[2] += 0.0005;
      emulator.set_axis_values(q2);
    }
    const std::int64_t t = k * kMs;
    low.bus.set_time_ns(t);
    loop.begin_period(t);
    low.bus.set_time_ns(t + kLatency);
    emulator.poll(low.bus.device());
    emulator.tick(t + kLatency, low.bus.device());
    low.bus.set_time_ns(t + kPhase);
    loop.end_period(t + kPhase);
    clamped_peak = std::max(clamped_peak, std::abs(loop.impedance().sent_torques().torque[0]));
  }
  EXPECT_DOUBLE_EQ(clamped_peak, low.config.axes[0].max_torque);
  EXPECT_GT(loop.impedance().torque_counters().axis_saturations[0], 0u);
  EXPECT_EQ(loop.impedance().torque_counters().axis_saturations[3], 0u);  // roll: no drive, τ = 0
  EXPECT_EQ(managed_device(loop).supervisor()->state(), LifecycleState::kActive);
}

/// Runs a scripted session (start-up, torque, drive fault, re-arm, kill) and returns every
/// period's per-mille commands and the body position, for the determinism test.
std::vector<std::int64_t> session(bool check_allocations) {
  Rig rig(0.05);  // a 50-period soft start: the start-up's ramp and the re-arm's are counted
  std::vector<std::int64_t> out;
  out.reserve(400 * 4);
  rig.run_to_torque();
  numen::test::AllocationGuard guard;
  double q[5] = {kQ[0], kQ[1], kQ[2], kQ[3], kQ[4]};
  for (int i = 0; i < 300; ++i) {
    q[0] = kQ[0] + 0.05 * std::sin(0.02 * i);
    rig.emulator.set_axis_values(q);
    if (i == 100) rig.emulator.inject_drive_fault(0, 0x4310);
    if (i == 150) rig.loop.rearm();
    if (i == 250) rig.emulator.kill(true);
    rig.period();
    for (int a = 0; a < 3; ++a) out.push_back(rig.loop.impedance().sent_torques().per_mille[static_cast<std::size_t>(a)]);
    std::int64_t bits = 0;
    const double x = rig.data.bodies[0].position.x();
    std::memcpy(&bits, &x, sizeof bits);
    out.push_back(bits);
  }
  if (check_allocations) {
    EXPECT_EQ(guard.count(), 0) << "allocations in 300 managed periods";
  }
  // Both ramps ran under the counter: the start-up's (begun in run_to_torque()'s last period)
  // and the one after the re-arm at period 150.
  EXPECT_EQ(rig.loop.impedance().torque_counters().soft_starts, 2u);
  EXPECT_EQ(rig.loop.impedance().torque_counters().ramped_writes, 2u * 49u);
  EXPECT_EQ(rig.sup().counters().latches, 2u);  // the drive fault, the kill
  return out;
}

TEST(ControlLoopManaged, PeriodsNeverAllocateWithTheFullStack) { session(true); }

/// Hand motion of the soft-start tests: a sine on pivot_x and depth, so that the god-object lags
/// and the feedback is never zero.
void sway(Rig& rig, int i) {
  double q[5] = {kQ[0], kQ[1], kQ[2], kQ[3], kQ[4]};
  q[0] += 0.1 * std::sin(0.05 * i);
  q[2] += 0.01 * std::sin(0.03 * i);
  rig.emulator.set_axis_values(q);
}

// The soft start at the start-up and again after a re-arm, against a twin stack without one
// that sees the same hand: the hand does not feel the torques (the emulator only records them),
// so both loops step the same god-object and the ramped stack must send exactly r times the
// twin's torques, r = min(1, k dt / T) in the k-th period since torque was enabled.
TEST(ControlLoopManaged, SoftStartRampsTheTorqueInAtStartUpAndAgainAfterARearm) {
  constexpr double kT = 0.02;   // 20 periods
  constexpr double kStep = 1e-3 / kT;
  Rig ramped(kT);
  Rig twin;
  std::int64_t since = 0;  // periods since the ramp began (0: not begun)
  AxisVector last_tau = AxisVector::Zero(5), last_twin = AxisVector::Zero(5);
  int ramps_seen = 0, ramp_periods = 0;
  for (int i = 0; i < 260; ++i) {
    if (i == 80) {  // pivot_y over-current: latched, zero torque, kFault
      ASSERT_TRUE(ramped.emulator.inject_drive_fault(1, 0x2310));
      ASSERT_TRUE(twin.emulator.inject_drive_fault(1, 0x2310));
    }
    if (i == 140) {
      ASSERT_EQ(ramped.sup().state(), LifecycleState::kFault);
      EXPECT_EQ(ramped.loop.rearm(), numen::platform::RearmResult::kAccepted);
      EXPECT_EQ(twin.loop.rearm(), numen::platform::RearmResult::kAccepted);
    }
    sway(ramped, i);
    sway(twin, i);
    const PeriodReport& r = ramped.period();
    const PeriodReport& t = twin.period();
    SCOPED_TRACE("period " + std::to_string(i));
    ASSERT_EQ(r.lifecycle, t.lifecycle);
    const numen::hal::SentTorques& sent = ramped.loop.impedance().sent_torques();
    const numen::hal::SentTorques& full = twin.loop.impedance().sent_torques();
    ASSERT_EQ(sent.gated, full.gated);
    if (r.activated) since = 0;  // torque (re-)enabled: the ramp begins at the next open gate
    if (sent.gated) {
      if (since > 0) ++since;  // a ramp runs on in time
      EXPECT_EQ(r.feedback.force.norm(), 0.0);
    } else {
      if (since == 0) ++ramps_seen;
      ++since;
      const double ramp = std::min(1.0, static_cast<double>(since) * kStep);
      EXPECT_DOUBLE_EQ(sent.ramp, ramp);
      EXPECT_DOUBLE_EQ(r.soft_start_ramp, ramp);
      if (ramp < 1.0) ++ramp_periods;
      for (int a = 0; a < 5; ++a) {
        EXPECT_EQ(sent.torque[a], sent.ramp * full.torque[a]) << "axis " << a;
        // The slope: what the ramp adds, max_torque dt / T, plus what the twin's own torque
        // changed (the god-object's motion), scaled by the previous r.
        const double lim = numen::hal::torque_limit(ramped.config.axes[static_cast<std::size_t>(a)]);
        const double prev_ramp = std::min(1.0, static_cast<double>(since - 1) * kStep);
        EXPECT_LE(std::abs(sent.torque[a] - last_tau[a]),
                  kStep * lim + prev_ramp * std::abs(full.torque[a] - last_twin[a]) + 1e-12)
            << "axis " << a;
      }
      EXPECT_NEAR(r.feedback.force.norm(), sent.ramp * t.feedback.force.norm(), 1e-12);
    }
    // The first torque period after an enable: at most max_force dt / T of feedback.
    if (since == 1) {
      EXPECT_LE(r.feedback.force.norm(), kStep * ramped.model.feedback.max_force + 1e-12);
      EXPECT_GT(t.feedback.force.norm(), 0.0) << "test bug: no feedback to ramp";
    }
    last_tau = sent.torque;
    last_twin = full.torque;
  }
  EXPECT_EQ(ramps_seen, 2) << "the start-up's ramp and the re-arm's";
  EXPECT_EQ(ramped.loop.impedance().torque_counters().soft_starts, 2u);
  EXPECT_EQ(ramp_periods, 2 * 19);
  EXPECT_EQ(twin.loop.impedance().torque_counters().soft_starts, 0u);
  EXPECT_EQ(ramped.sup().state(), LifecycleState::kActive);
}

TEST(ControlLoopManaged, RerunsAreBitIdentical) {
  const std::vector<std::int64_t> a = session(false);
  const std::vector<std::int64_t> b = session(false);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i], b[i]) << "entry " << i;
}

}  // namespace managed
