// Tests of numen/hal/device/safety_supervisor.hpp in a closed loop over SimBus (InstrumentDevice +
// DeviceEmulator encoders, an emulated CiA 402 drive with its Cia402Master, heartbeats and
// EMCY): drive fault → zero torque → disabled → latched → rearm → enabled again. The
// supervisor alone: safety_supervisor_test.cpp.
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

// ---------------------------------------------------------------------------------------------
// Closed loop over SimBus
// ---------------------------------------------------------------------------------------------

// Controller: InstrumentDevice (encoders), one Cia402Master, HeartbeatMonitor, EmcyLog and the
// supervisor. Device: DeviceEmulator (encoders answering SYNC), an emulated Cia402Drive on node
// kDriveNode with its RPDO / TPDO (drive_rpdo_mapping / drive_tpdo_mapping), a heartbeat
// producer, and an EMCY when the drive faults. 1 ms periods, 100 µs bus latency.
constexpr std::uint8_t kDriveNode = 0x30;
constexpr std::uint32_t kDriveRpdo = 0x200 + kDriveNode;
constexpr std::uint32_t kDriveTpdo = 0x180 + kDriveNode;

// This rig drives its own drive and heartbeat: the emulator's encoders answer every SYNC.
DeviceConfig minimal(DeviceConfig c) {
  c.canopen.managed = false;
  return c;
}

struct ClosedLoopRig {
  ClosedLoopRig()
      : bus(bus_settings()),
        device(minimal(make_default_trocar_config(1))),
        emulator(minimal(make_default_trocar_config(1))),
        producer(kDriveNode, 10 * kMs),
        sup(settings()) {
    monitor.add(kDriveNode, 25 * kMs);
    producer.start(0);
    const double q[5] = {0.0, 0.0, 0.05, 0.0, 0.0};
    emulator.set_axis_values(q);
  }
  static SimBusSettings bus_settings() {
    SimBusSettings s;
    s.latency_ns = 100'000;
    return s;
  }
  static SafetySettings settings() {
    SafetySettings s;
    s.num_axes = 5;
    s.safe_stop_timeout_periods = 50;
    return s;
  }

  SimBus bus;
  InstrumentDevice device;
  DeviceEmulator emulator;
  Cia402Drive drive;
  Cia402Master master;
  HeartbeatProducer producer;
  HeartbeatMonitor<4> monitor;
  EmcyLog<8> emcy;
  SafetySupervisor sup;
  PdoMapping rpdo = drive_rpdo_mapping();
  PdoMapping tpdo = drive_tpdo_mapping();
  std::uint16_t statusword = 0;
  std::int64_t t = 0;
  std::array<double, 5> tau{};
  Cia402MasterOutput out;
  bool emcy_pending = false;

  // Device side at time t: answer SYNC (encoders and the drive's TPDO), heartbeat, EMCY,
  // apply a received drive RPDO.
  void device_side() {
    CanFrame f;
    while (bus.device().read(f) == IoStatus::kOk) {
      if (f.id == kDriveRpdo) {
        std::array<std::int64_t, 2> v{};
        if (rpdo.unpack(f, v) == PdoStatus::kOk) {
          drive.step(static_cast<std::uint16_t>(v[0]), static_cast<std::int16_t>(v[1]));
        }
        continue;
      }
      emulator.on_frame(f, bus.device());
      if (is_sync(f)) {
        CanFrame tx;
        tx.id = kDriveTpdo;
        const std::array<std::int64_t, 2> v = {drive.statusword(),
                                               drive.applied_torque_per_mille()};
        tpdo.pack(v, tx);
        tx.timestamp_ns = t;
        bus.device().write(tx);
      }
    }
    if (producer.poll(t, NmtState::kOperational, f)) bus.device().write(f);
    if (emcy_pending) {
      EmcyMessage m;
      m.node_id = kDriveNode;
      m.error_code = 0x2310;  // continuous over-current
      m.error_register = ErrorRegisterBit::kGeneric | ErrorRegisterBit::kCurrent;
      encode_emcy(m, t, f);
      bus.device().write(f);
      emcy_pending = false;
    }
  }

  // One 1 ms period.
  void period(double torque_request) {
    t += kMs;
    bus.set_time_ns(t);
    // Controller: the RPDO of the previous period has arrived at the drive by now.
    device_side();
    bus.controller().write(make_sync(t));
    bus.set_time_ns(t + 200'000);  // the answers arrive
    device_side();
    bus.set_time_ns(t + 400'000);
    CanFrame f;
    while (bus.controller().read(f) == IoStatus::kOk) {
      if (f.id == kDriveTpdo) {
        std::array<std::int64_t, 2> v{};
        if (tpdo.unpack(f, v) == PdoStatus::kOk) statusword = static_cast<std::uint16_t>(v[0]);
      } else if (f.id > kHeartbeatBaseCobId) {
        monitor.on_frame(f);
      } else if (f.id > kEmcyBaseCobId && f.id < 0x100) {
        emcy.on_frame(f);
      } else {
        device.on_frame(f);
      }
    }
    const DeviceSample s = device.sample(t);
    monitor.poll(t);
    out = master.update(statusword);
    SafetyInputs in;
    in.periods_since_accepted = std::span<const std::uint32_t>(s.periods_since_accepted.data(), 5);
    in.axis_faults = std::span<const FaultMask>(s.axis_faults.data(), 5);
    in.heartbeats = monitor.consumers();
    in.emcy_faults = emcy.counters().faults;
    in.emcy_last_fault = newest_emcy_fault(emcy);
    in.drives = std::span<const Cia402MasterOutput>(&out, 1);
    in.bus_state = bus.controller().state();
    sup.update(t, in);
    master.request(sup.drive_target());
    // What hal::ImpedanceDevice::write() does: the lifecycle's gate, the clamp to 0.5 N·m.
    tau.fill(sup.torque_allowed() ? std::clamp(torque_request, -0.5, 0.5) : 0.0);
    // Drive 0 carries axis 0's torque; rated torque 1 N·m → per mille.
    const auto per_mille = static_cast<std::int16_t>(std::lround(tau[0] * 1000.0));
    CanFrame rx;
    const std::array<std::int64_t, 2> v = {out.controlword,
                                            out.torque_allowed ? per_mille : std::int16_t{0}};
    rpdo.pack(v, rx);
    rx.id = kDriveRpdo;
    rx.timestamp_ns = t;
    bus.controller().write(rx);
  }
};

TEST(SafetySupervisor, ClosedLoopDriveFaultZeroTorqueDisabledLatchedRearmEnabled) {
  ClosedLoopRig l;
  ASSERT_EQ(l.sup.configure(), LR::kOk);
  for (int i = 0; i < 30; ++i) l.period(0.2);
  ASSERT_EQ(l.sup.state(), LS::kInactive);
  ASSERT_EQ(l.sup.activate(), LR::kOk) << to_string(l.sup.blocking().cause);
  int up = 0;
  while (l.drive.applied_torque_per_mille() == 0 && up < 20) {
    l.period(0.8);  // clamped to 0.5 N·m
    ++up;
  }
  ASSERT_EQ(l.drive.state(), PS::kOperationEnabled);
  l.period(0.8);
  EXPECT_EQ(l.drive.applied_torque_per_mille(), 500);

  // The drive faults (over-current) and sends an EMCY.
  l.drive.inject_fault(0x2310);
  l.emcy_pending = true;
  l.period(0.8);
  // The EMCY and the statusword of the fault are read in this period: latched (EMCY comes
  // first in the evaluation order, the drive fault is recorded in the same period), zero
  // torque sent now.
  EXPECT_EQ(l.sup.state(), LS::kSafeStop);
  ASSERT_NE(l.sup.first_fault(), nullptr);
  EXPECT_EQ(l.sup.first_fault()->cause, FC::kEmcy);
  EXPECT_EQ(l.sup.first_fault()->id, kDriveNode);
  EXPECT_EQ(l.sup.first_fault()->value, 0x2310);
  EXPECT_EQ(l.sup.first_fault()->time_ns, l.t);
  ASSERT_EQ(l.sup.fault_log_size(), 2u);
  EXPECT_EQ(l.sup.newest_fault()->cause, FC::kDriveFault);
  EXPECT_EQ(l.sup.newest_fault()->period, l.sup.first_fault()->period);
  EXPECT_FALSE(l.sup.newest_fault()->latched);
  EXPECT_EQ(l.tau[0], 0.0);
  EXPECT_FALSE(l.out.torque_allowed);
  for (int i = 0; i < 10 && l.sup.state() != LS::kFault; ++i) l.period(0.8);
  EXPECT_EQ(l.sup.state(), LS::kFault);
  EXPECT_FALSE(l.sup.lifecycle().safe_stop_timed_out());
  EXPECT_EQ(l.drive.applied_torque_per_mille(), 0);

  // Latched: stays so while the drive is in fault.
  for (int i = 0; i < 20; ++i) l.period(0.8);
  EXPECT_EQ(l.sup.state(), LS::kFault);
  EXPECT_EQ(l.sup.rearm(), LR::kCausePresent);
  EXPECT_EQ(l.sup.blocking().cause, FC::kDriveFault);
  EXPECT_EQ(l.drive.state(), PS::kFault);

  // The operator resets the drive fault (the drive stays disabled: target kDisabled).
  l.master.request_fault_reset();
  for (int i = 0; i < 6; ++i) l.period(0.8);
  EXPECT_EQ(l.drive.state(), PS::kSwitchOnDisabled);
  EXPECT_EQ(l.sup.state(), LS::kFault);
  EXPECT_EQ(l.drive.applied_torque_per_mille(), 0);
  ASSERT_EQ(l.sup.rearm(), LR::kOk) << to_string(l.sup.blocking().cause);
  EXPECT_EQ(l.sup.state(), LS::kInactive);
  for (int i = 0; i < 10; ++i) l.period(0.8);
  EXPECT_EQ(l.drive.state(), PS::kSwitchOnDisabled);  // not re-enabled without activate()
  ASSERT_EQ(l.sup.activate(), LR::kOk);
  for (int i = 0; i < 10; ++i) l.period(0.3);
  EXPECT_EQ(l.drive.state(), PS::kOperationEnabled);
  EXPECT_EQ(l.drive.applied_torque_per_mille(), 300);
  EXPECT_EQ(l.sup.counters().latches, 1u);
  EXPECT_EQ(l.device.counters().frames_unknown_id, 0u);
}

TEST(SafetySupervisor, ClosedLoopSilentEncodersTimeOutAtExactlyThreePeriods) {
  ClosedLoopRig l;
  ASSERT_EQ(l.sup.configure(), LR::kOk);
  for (int i = 0; i < 15; ++i) l.period(0.0);  // the first heartbeat comes at 10 ms
  ASSERT_EQ(l.sup.activate(), LR::kOk) << to_string(l.sup.blocking().cause);
  for (int i = 0; i < 10; ++i) l.period(0.1);
  ASSERT_TRUE(l.sup.torque_allowed());
  l.emulator.set_responding(false);
  l.period(0.1);
  l.period(0.1);
  EXPECT_EQ(l.sup.state(), LS::kActive);
  const std::uint64_t k = l.sup.period() + 1;
  l.period(0.1);
  EXPECT_EQ(l.sup.state(), LS::kSafeStop);
  ASSERT_NO_FATAL_FAILURE(
      expect_record(l.sup.first_fault(), FC::kEncoderTimeout, 0, k, l.t, "closed loop timeout"));
  EXPECT_EQ(l.tau[0], 0.0);
}

TEST(SafetySupervisor, ClosedLoopPeriodDoesNotAllocate) {
  ClosedLoopRig l;
  l.sup.configure();
  for (int i = 0; i < 15; ++i) l.period(0.0);
  ASSERT_EQ(l.sup.activate(), LR::kOk);
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 30; ++i) l.period(0.4);
  l.drive.inject_fault(0x2310);
  l.emcy_pending = true;
  for (int i = 0; i < 30; ++i) l.period(0.4);
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(l.sup.state(), LS::kFault);
}

}  // namespace
