// Tests of platform/control_loop with several devices: two emulated instruments on one SimBus
// (one BusShare port each on both sides) through one loop. Each device's feedback goes only to
// its own motors (its τ is the one a loop of that device alone computes); one device's fault
// latches its safe state and, in the same period, the other's (FaultCause::kPeerFault;
// docs/safety.md "Several devices"); managed devices on one bus share one NMT master (one
// broadcast start-up when they start together; re-arming one never resets the other's nodes;
// a minimal device's nodes on the bus get no NMT message at all);
// no allocation in the period; bad wirings are refused.
#include "numen/platform/control_loop.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>
#include <vector>

#include "alloc_counter.hpp"
#include "control_loop_fixtures.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/hal/device/bus_filters.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/impedance_device.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/transport/bus_share.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace control_loop_devices_test {  // named: the unity build shares a TU with other test files

namespace core = numen::core;
namespace hal = numen::hal;
namespace platform = numen::platform;
namespace fx = numen::test::control_loop_fixtures;

/// Two free bodies (no spheres: they never touch), the first the held one; the fixtures'
/// gains.
core::Model two_body_model() {
  core::Model m = fx::small_model();
  core::BodyModel right = m.bodies[0];
  right.name = "right";
  m.bodies[0].name = "left";
  m.bodies.push_back(right);
  m.initial_held_body = 0;
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// The trocar instrument on nodes first_node .. +4, its trocar point `x` m along x.
hal::DeviceConfig instrument_config(std::uint8_t first_node, bool managed, double x) {
  hal::DeviceConfig c = hal::make_default_trocar_config(first_node);
  c.canopen.managed = managed;
  c.trocar.point = core::Vec3(x, 0.0, 0.2);
  c.trocar.orientation = core::Quat(Eigen::AngleAxisd(std::numbers::pi, core::Vec3::UnitX()));
  c.control_period_s = 1e-3;
  return c;
}

/// Link 0 of a device drives `body`.
platform::DeviceBinding drive_body(int body) {
  return platform::DeviceBinding{{platform::LinkBinding{0, body, {}}}, {}};
}

/// Instrument i0 on bus b0 driving body 0 and i1 on bus b1 driving body 1 (b0 may be b1).
std::vector<platform::LoopDevice> pair_on(hal::Bus& b0, hal::InstrumentDevice& i0, hal::Bus& b1,
                                          hal::InstrumentDevice& i1) {
  std::vector<platform::LoopDevice> d(2);
  d[0].bus = &b0;
  d[0].instrument = &i0;
  d[0].binding = drive_body(0);
  d[1].bus = &b1;
  d[1].instrument = &i1;
  d[1].binding = drive_body(1);
  return d;
}

/// The controller's side of a bus that keeps the NMT messages written through it (fixed
/// storage: no allocation), as (command specifier, node id).
class NmtTap final : public hal::Bus {
 public:
  explicit NmtTap(hal::Bus& bus) : bus_(&bus) {}
  hal::IoStatus read(hal::CanFrame& frame) noexcept override { return bus_->read(frame); }
  hal::IoStatus write(const hal::CanFrame& frame) noexcept override {
    hal::NmtMessage m;
    if (hal::decode_nmt(frame, m) == hal::NmtDecodeStatus::kOk && count_ < sent_.size())
      sent_[count_++] = {static_cast<int>(m.command), static_cast<int>(m.node_id)};
    return bus_->write(frame);
  }
  hal::BusState state() const noexcept override { return bus_->state(); }
  hal::BusCounters counters() const noexcept override { return bus_->counters(); }
  /// The NMT messages written since the last clear().
  std::vector<std::pair<int, int>> sent() const {
    return std::vector<std::pair<int, int>>(sent_.begin(), sent_.begin() + static_cast<long>(count_));
  }
  void clear() noexcept { count_ = 0; }

 private:
  hal::Bus* bus_;
  std::array<std::pair<int, int>, 256> sent_{};
  std::size_t count_ = 0;
};

/// Device i of `n` instruments on one SimBus, each with its emulator on its own BusShare port
/// of the device side; `loop_bodies` says which body each device of the loop drives.
struct Rig {
  /// `startup_timeout_ms`: both instruments' CanopenConfig::startup_timeout_ms.
  Rig(bool managed, std::vector<int> devices_in_loop, std::uint32_t startup_timeout_ms = 1000)
      : Rig(std::array<bool, 2>{managed, managed}, std::move(devices_in_loop),
            startup_timeout_ms) {}
  /// `managed[i]`: instrument i's protocol (the managed stack, or the minimal protocol).
  Rig(std::array<bool, 2> managed, std::vector<int> devices_in_loop,
      std::uint32_t startup_timeout_ms = 1000)
      : configs{with_startup_timeout(instrument_config(1, managed[0], 0.0), startup_timeout_ms),
                with_startup_timeout(instrument_config(11, managed[1], 0.1), startup_timeout_ms)},
        share(bus.device()),
        emulators{hal::DeviceEmulator{configs[0]}, hal::DeviceEmulator{configs[1]}},
        instruments{hal::InstrumentDevice{configs[0]}, hal::InstrumentDevice{configs[1]}},
        ports{&share.add_port(hal::device_filters(configs[0])),
              &share.add_port(hal::device_filters(configs[1]))},
        in_loop(std::move(devices_in_loop)),
        model(two_body_model()),
        data(core::make_data(model)),
        loop(model, data, loop_devices(), platform::ControlLoopSettings{}) {
    move(0);
  }

  static hal::DeviceConfig with_startup_timeout(hal::DeviceConfig c, std::uint32_t ms) {
    c.canopen.startup_timeout_ms = ms;
    return c;
  }

  std::vector<platform::LoopDevice> loop_devices() {
    std::vector<platform::LoopDevice> out;
    for (int i : in_loop) {
      platform::LoopDevice d;
      d.bus = &tap;
      d.instrument = &instruments[static_cast<std::size_t>(i)];
      d.binding = drive_body(i);
      out.push_back(d);
    }
    return out;
  }

  /// The axes at period k: instrument 0 still, instrument 1's insertion depth oscillating
  /// (plus offset1: a break in its recording).
  void move(std::int64_t k) {
    emulators[0].set_axis_values(fx::kQ);
    double q[5] = {fx::kQ[0], fx::kQ[1], fx::kQ[2], fx::kQ[3], fx::kQ[4]};
    for (std::size_t a = 0; a < 5; ++a) q[a] += offset1[a];
    q[3] += 0.02 * std::sin(0.05 * static_cast<double>(k));
    emulators[1].set_axis_values(q);
  }

  /// Period k as SceneRunner runs it; the emulators then take the torque RPDOs.
  const platform::PeriodReport& period() {
    const std::int64_t t = k * fx::kMs;
    move(k);
    ++k;
    bus.set_time_ns(t);
    loop.begin_period(t);
    bus.set_time_ns(t + fx::kLatency);
    for (std::size_t i = 0; i < 2; ++i) {
      emulators[i].poll(*ports[i]);
      emulators[i].tick(t + fx::kLatency, *ports[i]);
    }
    bus.set_time_ns(t + fx::kPhase);
    const platform::PeriodReport& r = loop.end_period(t + fx::kPhase);
    bus.set_time_ns(t + fx::kPhase + fx::kLatency);
    for (std::size_t i = 0; i < 2; ++i) emulators[i].poll(*ports[i]);
    return r;
  }

  std::array<hal::DeviceConfig, 2> configs;
  hal::SimBus bus{fx::bus_settings()};
  hal::BusShare share;
  std::array<hal::DeviceEmulator, 2> emulators;
  std::array<hal::InstrumentDevice, 2> instruments;
  std::array<hal::Bus*, 2> ports;
  std::vector<int> in_loop;
  std::array<double, 5> offset1{};  // added to instrument 1's axes (move())
  NmtTap tap{bus.controller()};  // the loop's side of the bus
  core::Model model;
  core::Data data;
  platform::ControlLoop loop;
  std::int64_t k = 0;
};

/// The torques device `i` of `rig`'s loop computed this period (its map stage's τ).
std::vector<double> tau_of(const Rig& rig, std::size_t i) {
  const hal::AxisVector& tau = rig.loop.period_data(i).tau;
  return std::vector<double>(tau.data(), tau.data() + tau.size());
}

TEST(ControlLoopDevices, EachDevicesFeedbackGoesOnlyToItsOwnMotors) {
  // The pair through one loop against each instrument alone (the other body then undriven):
  // the bodies never touch, so each device's τ must be what its own loop computes, period by
  // period — a device that got the other's feedback would carry the moving instrument's
  // wrench while its own body rests.
  Rig both(false, {0, 1});
  Rig left(false, {0});
  Rig right(false, {1});
  ASSERT_EQ(both.loop.num_devices(), 2u);
  double apart = 0.0, right_max = 0.0;
  for (int p = 0; p < 300; ++p) {
    both.period();
    left.period();
    right.period();
    const std::vector<double> t0 = tau_of(both, 0), t1 = tau_of(both, 1);
    const std::vector<double> a = tau_of(left, 0), b = tau_of(right, 0);
    ASSERT_EQ(t0.size(), a.size());
    ASSERT_EQ(t1.size(), b.size());
    for (std::size_t j = 0; j < a.size(); ++j) {
      EXPECT_NEAR(t0[j], a[j], 1e-9) << "period " << p << " axis " << j;
      EXPECT_NEAR(t1[j], b[j], 1e-9) << "period " << p << " axis " << j;
      apart = std::max(apart, std::abs(t0[j] - t1[j]));
      right_max = std::max(right_max, std::abs(t1[j]));
    }
    // Each device's torque frames carry its own τ: the drives of each instrument received them.
    const hal::SentTorques& s0 = both.loop.impedance(0).sent_torques();
    const hal::SentTorques& s1 = both.loop.impedance(1).sent_torques();
    EXPECT_EQ(s0.per_mille, left.loop.impedance(0).sent_torques().per_mille) << "period " << p;
    EXPECT_EQ(s1.per_mille, right.loop.impedance(0).sent_torques().per_mille) << "period " << p;
  }
  // Not blind: the two devices' torques differ (a device fed the other's feedback would
  // carry it), and the moving one's are not small.
  EXPECT_GT(apart, 0.1);
  EXPECT_GT(right_max, 0.1);
  EXPECT_TRUE(both.loop.period_data(1).report.torque_commanded);
  EXPECT_EQ(both.loop.period_data(1).bound_body[0], 1);
  EXPECT_EQ(both.loop.period_data(0).bound_body[0], 0);
  // Each instrument's encoders reached its own device only: no frame of an unknown id.
  EXPECT_EQ(both.instruments[0].counters().frames_unknown_id, 0u);
  EXPECT_EQ(both.instruments[1].counters().frames_unknown_id, 0u);
}

TEST(ControlLoopDevices, OneDevicesFaultLatchesItsSafeStateAndThePeersInTheSamePeriod) {
  Rig rig(true, {0, 1});
  for (int i = 0; i < 100 && (rig.loop.first_torque_period(0) < 0 || rig.loop.first_torque_period(1) < 0); ++i)
    rig.period();
  ASSERT_GE(rig.loop.first_torque_period(0), 0);
  ASSERT_GE(rig.loop.first_torque_period(1), 0);
  for (int i = 0; i < 20; ++i) rig.period();  // both run with torque
  ASSERT_EQ(rig.loop.device(0).lifecycle(), hal::LifecycleState::kActive);
  ASSERT_EQ(rig.loop.device(1).lifecycle(), hal::LifecycleState::kActive);

  // Instrument 1's depth encoder falls silent: after encoder_timeout_periods its device
  // latches kEncoderTimeout, and device 0 latches kPeerFault in that very period.
  rig.emulators[1].set_encoder_silent(3, true);
  numen::test::AllocationGuard guard;
  int latched_at = -1;
  for (int i = 0; i < 20 && latched_at < 0; ++i) {
    rig.period();
    if (rig.loop.period_data(1).report.entered_safe_stop) latched_at = i;
  }
  ASSERT_GE(latched_at, 0);
  const platform::PeriodReport& r0 = rig.loop.period_data(0).report;
  const platform::PeriodReport& r1 = rig.loop.period_data(1).report;
  EXPECT_EQ(r1.fault_cause, hal::FaultCause::kEncoderTimeout);
  EXPECT_EQ(r0.fault_cause, hal::FaultCause::kPeerFault);
  ASSERT_NE(rig.loop.device(0).first_fault(), nullptr);
  EXPECT_EQ(rig.loop.device(0).first_fault()->id, 1);  // the peer's index in the loop
  EXPECT_EQ(r0.lifecycle, hal::LifecycleState::kSafeStop);
  EXPECT_EQ(r1.lifecycle, hal::LifecycleState::kSafeStop);
  EXPECT_FALSE(r0.torque_commanded);  // zero torque on both from the same period
  EXPECT_FALSE(r1.torque_commanded);
  for (int i = 0; i < 50; ++i) {
    rig.period();
    EXPECT_FALSE(rig.loop.period_data(0).report.torque_commanded);
    EXPECT_FALSE(rig.loop.period_data(1).report.torque_commanded);
  }
  EXPECT_EQ(rig.loop.device(0).lifecycle(), hal::LifecycleState::kFault);
  EXPECT_EQ(rig.loop.device(1).lifecycle(), hal::LifecycleState::kFault);
  EXPECT_EQ(guard.count(), 0);

  // Re-armed while instrument 1 is still silent: device 0 may re-arm but is latched again by
  // its still-faulted peer; once the encoder answers again both re-arm and torque returns.
  rig.emulators[1].set_encoder_silent(3, false);
  ASSERT_EQ(rig.loop.rearm(), platform::RearmResult::kAccepted);
  for (int i = 0; i < 200 && !(rig.loop.period_data(0).report.torque_commanded &&
                               rig.loop.period_data(1).report.torque_commanded); ++i)
    rig.period();
  EXPECT_TRUE(rig.loop.period_data(0).report.torque_commanded);
  EXPECT_TRUE(rig.loop.period_data(1).report.torque_commanded);
}

// The policy for the other hand at a recording break (docs/safety.md "Recording breaks"):
// instrument 1's roll steps by 1.7 rad (~100°) in one period and goes on from there, as
// Suturing_D001's left tip at rows 857→858. Its device refuses the sample and latches
// kEncoderJump; device 0 latches kPeerFault in the same period. Neither re-arms by itself: both
// stay latched (zero torque) while instrument 1's samples are accepted again (the jump check
// accepts the new value once max_speed · Δt covers it, 1.7 rad / 30 rad/s ≈ 57 ms) and for as
// long as nobody re-arms; one re-arm (the operator's: ControlLoop::rearm(), `numen run`'s
// SIGUSR1) brings both back.
TEST(ControlLoopDevices, ARecordingBreakOnOneHandLatchesBothHandsUntilTheOperatorReArms) {
  Rig rig(true, {0, 1});
  for (int i = 0;
       i < 100 && (rig.loop.first_torque_period(0) < 0 || rig.loop.first_torque_period(1) < 0); ++i)
    rig.period();
  for (int i = 0; i < 20; ++i) rig.period();
  ASSERT_TRUE(rig.loop.period_data(0).report.torque_commanded);
  ASSERT_TRUE(rig.loop.period_data(1).report.torque_commanded);

  rig.offset1[3] = 1.7;  // the break: instrument 1's roll, +1.7 rad in one period, for good
  int latched_at = -1;
  for (int i = 0; i < 5 && latched_at < 0; ++i) {
    rig.period();
    if (rig.loop.period_data(1).report.entered_safe_stop) latched_at = i;
  }
  ASSERT_GE(latched_at, 0);
  EXPECT_EQ(rig.loop.period_data(1).report.fault_cause, hal::FaultCause::kEncoderJump);
  EXPECT_EQ(rig.loop.period_data(0).report.fault_cause, hal::FaultCause::kPeerFault);
  EXPECT_FALSE(rig.loop.period_data(0).report.torque_commanded);  // both, in the same period
  EXPECT_FALSE(rig.loop.period_data(1).report.torque_commanded);
  // No re-arm of its own: 2 s later both are still latched, though instrument 1's samples
  // have long been accepted again.
  int valid_after = 0;
  for (int i = 0; i < 2000; ++i) {
    rig.period();
    EXPECT_FALSE(rig.loop.period_data(0).report.torque_commanded) << "period " << i;
    EXPECT_FALSE(rig.loop.period_data(1).report.torque_commanded) << "period " << i;
    valid_after += rig.loop.period_data(1).report.sample_valid ? 1 : 0;
  }
  EXPECT_GT(valid_after, 1900);
  EXPECT_EQ(rig.loop.device(0).lifecycle(), hal::LifecycleState::kFault);
  EXPECT_EQ(rig.loop.device(1).lifecycle(), hal::LifecycleState::kFault);
  // The operator's re-arm: both come back, active with nothing latched (each through its soft
  // start; the hands at rest by now, their bodies on their targets: little torque to send).
  ASSERT_EQ(rig.loop.rearm(), platform::RearmResult::kAccepted);
  const auto state = [&](std::size_t i) {
    const platform::PeriodReport& r = rig.loop.period_data(i).report;
    return std::string(hal::to_string(r.lifecycle)) + " (" + hal::to_string(r.fault_cause) + ")";
  };
  const auto back = [&](std::size_t i) {
    const platform::PeriodReport& r = rig.loop.period_data(i).report;
    return r.lifecycle == hal::LifecycleState::kActive && r.fault_cause == hal::FaultCause::kNone;
  };
  int both_back = -1;
  for (int i = 0; i < 200 && both_back < 0; ++i) {
    rig.period();
    if (back(0) && back(1)) both_back = i;
  }
  EXPECT_GE(both_back, 0) << "device 0 " << state(0) << ", device 1 " << state(1);
  for (int i = 0; i < 100; ++i) {  // and stay so
    rig.period();
    EXPECT_TRUE(back(0) && back(1)) << "device 0 " << state(0) << ", device 1 " << state(1);
  }
}

TEST(ControlLoopDevices, EachDeviceSendsOneSyncPerBus) {
  Rig rig(false, {0, 1});
  rig.bus.set_time_ns(0);
  rig.loop.begin_period(0);
  EXPECT_EQ(rig.bus.pending(hal::SimBus::Direction::kControllerToDevice), 1u);  // one SYNC
}

TEST(ControlLoopDevices, ManagedDevicesStartingTogetherShareOneBroadcastStartUp) {
  // One NMT master per bus: both devices ask for the reset communication (then the start) of
  // all their nodes in the same period, so one broadcast each goes out, not one per device.
  Rig rig(true, {0, 1});
  rig.bus.set_time_ns(0);
  rig.loop.begin_period(0);
  EXPECT_EQ(rig.bus.pending(hal::SimBus::Direction::kControllerToDevice), 2u);  // SYNC, 000#8200
  rig.loop.end_period(fx::kPhase);
  for (int i = 0; i < 100 && (rig.loop.first_torque_period(0) < 0 || rig.loop.first_torque_period(1) < 0); ++i)
    rig.period();
  ASSERT_GE(rig.loop.first_torque_period(0), 0);
  ASSERT_GE(rig.loop.first_torque_period(1), 0);
  // The whole start-up: one reset communication and one start to all nodes (one master per
  // device would have sent each twice).
  EXPECT_EQ(rig.tap.sent(), (std::vector<std::pair<int, int>>{{0x82, 0}, {0x01, 0}}));
  EXPECT_EQ(rig.loop.device(0).report().heartbeat_losses, 0u);
  EXPECT_EQ(rig.loop.device(1).report().heartbeat_losses, 0u);
}

TEST(ControlLoopDevices, ReArmingOneManagedDeviceNeverResetsTheOthersNodes) {
  // Instrument 1 is off when the loop starts: its start-up fails (30 ms), device 0 starts
  // alone and drives. Instrument 1 is switched on and re-armed: its start-up reruns (reset
  // communication, boot-up, start) through the bus's one NMT master, addressed to its nodes
  // 11-15, so device 0's nodes never leave operational and device 0 never misses a period:
  // its encoders in every period, torque in every period, no latch. A broadcast reset (one
  // master per device) would reset nodes 1-5: device 0 would latch a node reset.
  Rig rig(true, {0, 1}, 30);
  rig.emulators[1].kill(true);
  for (int i = 0; i < 200 && !(rig.loop.first_torque_period(0) >= 0 &&
                               rig.loop.period_data(1).report.startup == hal::StartupPhase::kFailed);
       ++i)
    rig.period();
  ASSERT_GE(rig.loop.first_torque_period(0), 0);
  ASSERT_EQ(rig.loop.period_data(1).report.startup, hal::StartupPhase::kFailed);
  ASSERT_EQ(rig.loop.device(1).lifecycle(), hal::LifecycleState::kInactive);  // no latch
  for (int i = 0; i < 20; ++i) rig.period();
  ASSERT_TRUE(rig.loop.period_data(0).report.torque_commanded);
  const std::uint64_t nmt0 = rig.emulators[0].counters().nmt_commands;
  const std::uint64_t attempts1 = rig.loop.device(1).report().startup.attempts;

  rig.emulators[1].kill(false);  // switched on: its nodes boot (power-on) and wait
  rig.tap.clear();
  numen::test::AllocationGuard guard;
  ASSERT_EQ(rig.loop.rearm(), platform::RearmResult::kAccepted);  // device 1's (0: not latched)
  int periods = 0;
  for (; periods < 300 && !rig.loop.period_data(1).report.torque_commanded; ++periods) {
    rig.period();
    const platform::PeriodReport& r0 = rig.loop.period_data(0).report;
    ASSERT_TRUE(r0.sample_valid) << "device 0 without its encoders in period " << periods;
    ASSERT_TRUE(r0.torque_commanded) << "device 0 without torque in period " << periods;
    ASSERT_EQ(r0.lifecycle, hal::LifecycleState::kActive) << "period " << periods;
    for (int a = 0; a < 5; ++a)
      ASSERT_EQ(rig.emulators[0].node_state(a), hal::NmtState::kOperational)
          << "node " << (1 + a) << " in period " << periods;
  }
  EXPECT_EQ(guard.count(), 0);
  // Device 1 ran its start-up again and drives; device 0 was never addressed.
  EXPECT_TRUE(rig.loop.period_data(1).report.torque_commanded);
  EXPECT_EQ(rig.loop.device(1).report().startup.phase, hal::StartupPhase::kOperational);
  EXPECT_EQ(rig.loop.device(1).report().startup.attempts, attempts1 + 1);
  EXPECT_EQ(rig.emulators[0].counters().nmt_commands, nmt0);
  // Reset communication, then start, to each node of device 1, and nothing else.
  EXPECT_EQ(rig.tap.sent(), (std::vector<std::pair<int, int>>{{0x82, 11}, {0x82, 12}, {0x82, 13},
                                                              {0x82, 14}, {0x82, 15}, {0x01, 11},
                                                              {0x01, 12}, {0x01, 13}, {0x01, 14},
                                                              {0x01, 15}}));
  EXPECT_EQ(rig.loop.device(0).report().latches, 0u);
  EXPECT_EQ(rig.loop.device(0).first_fault(), nullptr);
  EXPECT_LT(periods, 100);  // reset, boot-ups, start, the first operational heartbeats
}

TEST(ControlLoopDevices, AMinimalDevicesNodesGetNoNmtFromItsManagedPeer) {
  // A minimal device (self-starting encoders on nodes 1-5, no NMT of its own) and a managed
  // one (nodes 11-15) on one bus. The managed device's start-up asks for the reset
  // communication and the start of all its nodes; the bus's NMT master knows the minimal
  // device is there, so neither goes out as a broadcast (node id 0 would reset the minimal
  // device's encoders and restart their PDOs mid-run): both are addressed to nodes 11-15, and
  // no NMT message names node 0 or nodes 1-5. The minimal device drives from its first
  // sample and keeps its encoders and torque through its peer's whole start-up; no allocation.
  Rig rig(std::array<bool, 2>{false, true}, {0, 1});
  numen::test::AllocationGuard guard;
  int minimal_torque = 0;
  int periods = 0;
  for (; periods < 200 && rig.loop.first_torque_period(1) < 0; ++periods) {
    rig.period();
    const platform::PeriodReport& r0 = rig.loop.period_data(0).report;
    if (rig.loop.first_torque_period(0) < 0) continue;
    ASSERT_TRUE(r0.sample_valid) << "minimal device without its encoders in period " << periods;
    ASSERT_TRUE(r0.torque_commanded) << "minimal device without torque in period " << periods;
    ++minimal_torque;
  }
  EXPECT_EQ(guard.count(), 0);
  ASSERT_GE(rig.loop.first_torque_period(1), 0);  // the managed device started and drives
  EXPECT_EQ(rig.loop.device(1).report().startup.phase, hal::StartupPhase::kOperational);
  EXPECT_LE(rig.loop.first_torque_period(0), 2);  // the minimal device drove from the start
  EXPECT_GT(minimal_torque, 10);
  EXPECT_EQ(rig.tap.sent(), (std::vector<std::pair<int, int>>{{0x82, 11}, {0x82, 12}, {0x82, 13},
                                                              {0x82, 14}, {0x82, 15}, {0x01, 11},
                                                              {0x01, 12}, {0x01, 13}, {0x01, 14},
                                                              {0x01, 15}}));
  for (int a = 0; a < 5; ++a)
    EXPECT_EQ(rig.emulators[1].node_state(a), hal::NmtState::kOperational) << "node " << 11 + a;
}

TEST(ControlLoopDevices, RefusesManagedDevicesOneBusCannotHold) {
  // One NMT master per bus: two devices on one node, or two controller node ids, are refused.
  hal::DeviceConfig c0 = instrument_config(1, true, 0.0);
  hal::DeviceConfig c1 = instrument_config(3, true, 0.1);  // nodes 3-7: 3, 4, 5 are c0's too
  hal::InstrumentDevice i0{c0}, i1{c1};
  hal::SimBus bus{fx::bus_settings()};
  const core::Model model = two_body_model();
  core::Data data = core::make_data(model);
  std::vector<platform::LoopDevice> d = pair_on(bus.controller(), i0, bus.controller(), i1);
  EXPECT_THROW(platform::ControlLoop(model, data, d), std::invalid_argument);
  hal::DeviceConfig c2 = instrument_config(11, true, 0.1);
  c2.canopen.controller_node_id = 100;
  hal::InstrumentDevice i2{c2};
  d[1].instrument = &i2;
  EXPECT_THROW(platform::ControlLoop(model, data, d), std::invalid_argument);
  // On two buses, each device is its bus's only one: both wirings run.
  hal::SimBus other{fx::bus_settings()};
  d[1].bus = &other.controller();
  EXPECT_NO_THROW(platform::ControlLoop(model, data, d));
  d[1].instrument = &i1;
  EXPECT_NO_THROW(platform::ControlLoop(model, data, d));
}

TEST(ControlLoopDevices, DevicesOnTwoBusesEachGetTheirOwnSyncAndFrames) {
  // One instrument per bus: no sharing, each device its bus's SYNC producer; both drive.
  const hal::DeviceConfig c0 = instrument_config(1, false, 0.0);
  const hal::DeviceConfig c1 = instrument_config(11, false, 0.1);
  hal::InstrumentDevice i0{c0}, i1{c1};
  hal::DeviceEmulator e0{c0}, e1{c1};
  hal::SimBus bus0{fx::bus_settings()}, bus1{fx::bus_settings()};
  const core::Model model = two_body_model();
  core::Data data = core::make_data(model);
  platform::ControlLoop loop(model, data, pair_on(bus0.controller(), i0, bus1.controller(), i1));
  e0.set_axis_values(fx::kQ);
  e1.set_axis_values(fx::kQ);
  for (std::int64_t k = 0; k < 20; ++k) {
    const std::int64_t t = k * fx::kMs;
    bus0.set_time_ns(t);
    bus1.set_time_ns(t);
    loop.begin_period(t);
    EXPECT_EQ(bus0.pending(hal::SimBus::Direction::kControllerToDevice), 1u);  // its SYNC
    EXPECT_EQ(bus1.pending(hal::SimBus::Direction::kControllerToDevice), 1u);
    bus0.set_time_ns(t + fx::kLatency);
    bus1.set_time_ns(t + fx::kLatency);
    e0.poll(bus0.device());
    e1.poll(bus1.device());
    bus0.set_time_ns(t + fx::kPhase);
    bus1.set_time_ns(t + fx::kPhase);
    loop.end_period(t + fx::kPhase);
    bus0.set_time_ns(t + fx::kPhase + fx::kLatency);
    bus1.set_time_ns(t + fx::kPhase + fx::kLatency);
    e0.poll(bus0.device());
    e1.poll(bus1.device());
  }
  EXPECT_TRUE(loop.last_report(0).torque_commanded);
  EXPECT_TRUE(loop.last_report(1).torque_commanded);
  EXPECT_GT(i0.counters().frames_decoded, 0u);
  EXPECT_GT(i1.counters().frames_decoded, 0u);
  EXPECT_EQ(i0.counters().frames_unknown_id, 0u);
  EXPECT_EQ(i1.counters().frames_unknown_id, 0u);
}

TEST(ControlLoopDevices, RefusesWiringsThatCannotRun) {
  const hal::DeviceConfig c0 = instrument_config(1, false, 0.0);
  const hal::DeviceConfig c1 = instrument_config(11, false, 0.1);
  hal::InstrumentDevice i0{c0}, i1{c1};
  hal::SimBus bus{fx::bus_settings()};
  const core::Model model = two_body_model();
  core::Data data = core::make_data(model);
  auto make = [&](platform::DeviceBinding b0, platform::DeviceBinding b1) {
    std::vector<platform::LoopDevice> d(2);
    d[0].bus = &bus.controller();
    d[0].instrument = &i0;
    d[0].binding = std::move(b0);
    d[1].bus = &bus.controller();
    d[1].instrument = &i1;
    d[1].binding = std::move(b1);
    return platform::ControlLoop(model, data, d);
  };
  // Two devices on one body, or both on the held body (the default rigid binding).
  EXPECT_THROW(make(drive_body(1), drive_body(1)), std::invalid_argument);
  EXPECT_THROW(make(platform::DeviceBinding::rigid(), platform::DeviceBinding::rigid()),
               std::invalid_argument);
  EXPECT_NO_THROW(make(drive_body(0), drive_body(1)));
  // A device whose binding is empty gets the rigid one: the refusal says so (issue 66: it
  // said "both drive the held body (link binding body -1)" of a device the scene bound to
  // nothing).
  try {
    (void)make(platform::DeviceBinding::rigid(), platform::DeviceBinding{});
    ADD_FAILURE() << "two devices on the held body accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("device 1's binding is empty, which is the rigid "
                                         "binding, link 0 -> the held body"),
              std::string::npos)
        << e.what();
  }
  // No device, more than kMaxLoopDevices, a missing bus.
  EXPECT_THROW(platform::ControlLoop(model, data, std::span<const platform::LoopDevice>{}),
               std::invalid_argument);
  std::vector<platform::LoopDevice> many(platform::kMaxLoopDevices + 1);
  for (platform::LoopDevice& d : many) {
    d.bus = &bus.controller();
    d.instrument = &i0;
  }
  EXPECT_THROW(platform::ControlLoop(model, data, many), std::invalid_argument);
  std::vector<platform::LoopDevice> no_bus(1);
  no_bus[0].instrument = &i0;
  EXPECT_THROW(platform::ControlLoop(model, data, no_bus), std::invalid_argument);
}

}  // namespace control_loop_devices_test
