// End-to-end tests of numen/hal/emulation/device_emulator.hpp with InstrumentDevice on a SimBus with
// latency: SYNC -> encoder TPDOs -> checked target; wrench -> torque RPDOs -> drives. Faults
// (corruption, out of range, silence, jumps) are rejected and counted; the exchange is
// allocation free and deterministic.
#include "numen/hal/emulation/device_emulator.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <memory>
#include <numbers>
#include <span>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/sdo.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/minimal_device.hpp"
#include "numen/hal/device/phantom_kinematics.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"

namespace device_emulator_test {  // named: the unity build shares a TU with other test files

using namespace numen::hal;
using numen::core::Vec3;
using numen::core::Wrench;
using TK = TrocarKinematics;
constexpr std::int64_t kPeriodNs = 1'000'000;  // 1 kHz
constexpr double kPeriodS = 1e-3;

DeviceConfig trocar_config() {
  DeviceConfig c = make_default_trocar_config(1);
  c.canopen.managed = false;  // the minimal protocol (the managed stack: canopen_master_test)
  c.control_period_s = kPeriodS;
  c.trocar.point = Vec3(0.0, 0.0, 0.25);
  c.trocar.orientation = numen::core::Quat(Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitX()));
  return c;
}

// A smooth instrument motion inside the default limits, axis values at time t (s).
void trajectory(double t, double* q) {
  q[TK::kPivotX] = 0.3 * std::sin(2.0 * t);
  q[TK::kPivotY] = 0.2 * std::cos(1.5 * t);
  q[TK::kDepth] = 0.12 + 0.04 * std::sin(3.0 * t);
  q[TK::kRoll] = wrap_angle(1.5 * t);  // keeps turning: exercises the wrap
  q[TK::kJaw] = 0.5 + 0.4 * std::sin(5.0 * t);
}

// Controller and device on one SimBus. One period k at t = k·P:
//   controller: read TPDOs -> sample(t) -> command(w) -> SYNC;
//   device, at t + P/2: read SYNC and RPDOs -> answer with TPDOs (delivered before t + P).
struct EmulatorRig {
  explicit EmulatorRig(const SimBusSettings& s, const DeviceConfig& c = trocar_config())
      : bus(s), device(c), emulator(c), sender(device, bus.controller()) {}

  // The controller's sending half: τ = Σ J_lᵀ w_l (torques_for), then MinimalDevice::write().
  IoStatus command_links(std::span<const Wrench> w, std::int64_t t) {
    AxisVector tau;
    device.torques_for(w, tau);
    return sender.write(std::span<const double>(tau.data(), static_cast<std::size_t>(tau.size())),
                        t);
  }

  DeviceSample period(std::int64_t k, const Wrench& w) {
    const std::int64_t t = k * kPeriodNs;
    bus.set_time_ns(t);
    const DeviceSample s = (sender.read(t), sender.sample());  // frames -> on_frame, sample(t)
    command_links(std::span<const Wrench>(&w, 1), t);
    bus.controller().write(make_sync(t));
    bus.set_time_ns(t + kPeriodNs / 2);
    emulator.poll(bus.device());
    return s;
  }

  SimBus bus;
  InstrumentDevice device;
  DeviceEmulator emulator;
  MinimalDevice sender;
};

SimBusSettings latency_only() {
  SimBusSettings s;
  s.latency_ns = 200'000;  // 0.2 ms
  return s;
}

TEST(DeviceEmulator, AnswersEachSyncWithOneTpdoPerAxisStampedWithTheSync) {
  SimBus bus(SimBusSettings{});
  DeviceEmulator emu(trocar_config());
  const double q[5] = {0.1, 0.2, 0.1, -0.5, 0.3};
  emu.set_axis_values(q);
  bus.set_time_ns(1234);
  bus.controller().write(make_sync(1234, 1));
  CanFrame sync;
  ASSERT_EQ(bus.device().read(sync), IoStatus::kOk);
  emu.on_frame(sync, bus.device());
  EXPECT_EQ(emu.counters().tpdos_sent, 5u);
  CanFrame f;
  for (int i = 0; i < 5; ++i) {
    ASSERT_EQ(bus.controller().read(f), IoStatus::kOk);
    const AxisConfig& a = emu.config().axes[static_cast<std::size_t>(i)];
    std::int32_t counts = 0;
    ASSERT_EQ(decode_position_pdo(f, a.encoder_cob_id, counts), DecodeStatus::kOk);
    EXPECT_EQ(counts, value_to_counts(a, q[i]));
    EXPECT_EQ(f.timestamp_ns, 1234);
  }
  EXPECT_EQ(bus.controller().read(f), IoStatus::kWouldBlock);
}

TEST(DeviceEmulator, ControllerSamplesThePoseTheEmulatorWasGiven) {
  EmulatorRig rig(latency_only());
  double q[5];
  trajectory(0.0, q);
  rig.emulator.set_axis_values(q);
  DeviceSample s;
  for (int k = 0; k < 3; ++k) s = rig.period(k, Wrench{});
  ASSERT_TRUE(s.valid);
  for (int i = 0; i < 5; ++i) {
    const double quant =
        0.5 / rig.device.config().axes[static_cast<std::size_t>(i)].counts_per_unit;
    EXPECT_NEAR(s.q[i], q[i], quant + 1e-15) << i;
  }
  AxisVector qv(5);
  for (int i = 0; i < 5; ++i) qv[i] = q[i];
  const numen::core::Pose truth = rig.device.kinematics().forward(qv);
  EXPECT_LT((s.pose.position - truth.position).norm(), 1e-4);  // 0.25 m × 1/5215 rad
  EXPECT_LT(s.pose.orientation.angularDistance(truth.orientation), 1e-3);
  // Sample age: TPDO delivered at t − P/2 + latency, well inside 3 periods.
  EXPECT_EQ(rig.device.counters().rejected_stale, 0u);
}

TEST(DeviceEmulator, FollowsAMovingInstrumentWithOnePeriodOfDelay) {
  EmulatorRig rig(latency_only());
  double q[5];
  trajectory(0.0, q);
  rig.emulator.set_axis_values(q);
  // sent[k]: the values the emulator answers the SYNC of period k with.
  std::vector<std::array<double, 5>> sent{{q[0], q[1], q[2], q[3], q[4]}};
  for (int k = 0; k < 2000; ++k) {
    const DeviceSample s = rig.period(k, Wrench{});
    // The answers to period k − 1's SYNC are sampled in period k.
    if (k >= 1) {
      ASSERT_TRUE(s.valid) << k;
      const auto& expected = sent[static_cast<std::size_t>(k - 1)];
      for (int i = 0; i < 5; ++i) {
        const AxisConfig& a = rig.device.config().axes[static_cast<std::size_t>(i)];
        ASSERT_NEAR(axis_difference(s.q[i], expected[static_cast<std::size_t>(i)], a.wraps), 0.0,
                    0.5 / a.counts_per_unit + 1e-12)
            << "period " << k << " axis " << i;
      }
    }
    trajectory((k + 1) * kPeriodS, q);
    // set_axis_values happens after period k's emulator poll, so it is answered at k + 1.
    rig.emulator.set_axis_values(q);
    sent.push_back({q[0], q[1], q[2], q[3], q[4]});
  }
  EXPECT_EQ(rig.device.counters().values_rejected, 0u);
  EXPECT_EQ(rig.device.counters().samples_valid, 1999u);
}

TEST(DeviceEmulator, TorquesRoundTripThroughRpdos) {
  EmulatorRig rig(latency_only());
  double q[5];
  trajectory(0.3, q);
  rig.emulator.set_axis_values(q);
  for (int k = 0; k < 3; ++k) rig.period(k, Wrench{});
  Wrench w;
  w.force = Vec3(0.8, -0.4, 1.2);
  w.torque = Vec3(0.02, -0.01, 0.03);
  rig.period(3, w);  // command sent at t, read by the emulator at t + P/2
  const AxisVector& sent = rig.sender.sent_torques().torque;
  const AxisVector& got = rig.emulator.last_torques();
  EXPECT_GT(sent.norm(), 0.0);
  for (int i = 0; i < 5; ++i) {
    const AxisConfig& a = rig.device.config().axes[static_cast<std::size_t>(i)];
    EXPECT_EQ(rig.emulator.last_torque_per_mille()[static_cast<std::size_t>(i)],
              rig.sender.sent_torques().per_mille[static_cast<std::size_t>(i)]);
    EXPECT_NEAR(got[i], sent[i], 0.5e-3 * a.rated_torque + 1e-12) << i;
  }
  EXPECT_EQ(rig.emulator.counters().rpdos, 3u * 4u);
}

TEST(DeviceEmulator, OutOfRangeValueIsRejectedAndTheTargetHeld) {
  EmulatorRig rig(latency_only());
  double q[5];
  trajectory(0.0, q);
  rig.emulator.set_axis_values(q);
  DeviceSample good;
  for (int k = 0; k < 3; ++k) good = rig.period(k, Wrench{});
  ASSERT_TRUE(good.valid);
  double bad[5];
  std::copy(q, q + 5, bad);
  bad[TK::kDepth] = 0.40;  // beyond max 0.35 m
  rig.emulator.set_axis_values(bad);
  DeviceSample s = rig.period(3, Wrench{});  // answers with bad values arrive now
  s = rig.period(4, Wrench{});
  EXPECT_FALSE(s.valid);
  EXPECT_TRUE(s.axis_faults[TK::kDepth] & SampleFault::kOutOfRange);
  EXPECT_EQ(s.q[TK::kDepth], good.q[TK::kDepth]);
  EXPECT_EQ(s.pose.position, good.pose.position);
  EXPECT_GE(rig.device.counters().rejected_out_of_range, 1u);
  rig.emulator.set_axis_values(q);
  rig.period(5, Wrench{});
  EXPECT_TRUE(rig.period(6, Wrench{}).valid);
}

TEST(DeviceEmulator, SilentDeviceBecomesStaleAndTheTargetStays) {
  EmulatorRig rig(latency_only());
  double q[5];
  trajectory(0.2, q);
  rig.emulator.set_axis_values(q);
  DeviceSample good;
  for (int k = 0; k < 4; ++k) good = rig.period(k, Wrench{});
  ASSERT_TRUE(good.valid);
  rig.emulator.set_responding(false);
  int first_stale = -1;
  for (int k = 4; k < 20; ++k) {
    const DeviceSample s = rig.period(k, Wrench{});
    EXPECT_EQ(s.pose.position, good.pose.position) << k;
    if (!s.valid && first_stale < 0) {
      first_stale = k;
      EXPECT_EQ(s.faults, SampleFault::kStale);
      EXPECT_EQ(s.twist.linear.norm(), 0.0);
    }
  }
  // Last TPDO delivered at 3.7 ms; older than 3 ms from 6.7 ms on: period 7 is the first stale.
  EXPECT_EQ(first_stale, 7);
  EXPECT_EQ(rig.device.counters().rejected_stale, 5u * 13u);
  EXPECT_EQ(rig.emulator.counters().syncs_ignored, 16u);
  rig.emulator.set_responding(true);
  rig.period(20, Wrench{});
  EXPECT_TRUE(rig.period(21, Wrench{}).valid);
}

TEST(DeviceEmulator, JumpIsRejectedAndCounted) {
  EmulatorRig rig(latency_only());
  double q[5];
  trajectory(0.0, q);
  rig.emulator.set_axis_values(q);
  DeviceSample good;
  for (int k = 0; k < 3; ++k) good = rig.period(k, Wrench{});
  double jumped[5];
  std::copy(q, q + 5, jumped);
  jumped[TK::kPivotY] += 0.05;  // 50 periods of travel at 10 rad/s... in one
  rig.emulator.set_axis_values(jumped);
  rig.period(3, Wrench{});
  const DeviceSample s = rig.period(4, Wrench{});
  EXPECT_TRUE(s.axis_faults[TK::kPivotY] & SampleFault::kJump);
  EXPECT_EQ(s.q[TK::kPivotY], good.q[TK::kPivotY]);
  EXPECT_EQ(s.pose.position, good.pose.position);
  EXPECT_EQ(rig.device.counters().rejected_jump, 1u);
}

// Runs `periods` periods on a faulty bus; checks every period that rejected axes hold their
// value and accepted ones are plausible. Returns the device counters.
DeviceCounters run_faulty(const SimBusSettings& settings, int periods, EmulatorRig& rig) {
  double q[5];
  trajectory(0.0, q);
  rig.emulator.set_axis_values(q);
  std::array<int, 5> rejected_run{};
  DeviceSample prev;
  std::vector<std::array<double, 5>> sent{{q[0], q[1], q[2], q[3], q[4]}};
  for (int k = 0; k < periods; ++k) {
    const DeviceSample s = rig.period(k, Wrench{});
    EXPECT_TRUE(s.pose.position.allFinite());
    if (k > 0 && prev.ready) {
      for (int i = 0; i < 5; ++i) {
        const auto ui = static_cast<std::size_t>(i);
        const AxisConfig& a = rig.device.config().axes[ui];
        constexpr FaultMask kRejection = SampleFault::kMalformed | SampleFault::kJump |
                                         SampleFault::kOutOfRange | SampleFault::kNonFinite;
        if (s.axis_faults[ui] & kRejection) {
          EXPECT_EQ(s.q[i], prev.q[i]) << "held value, period " << k << " axis " << i;
          ++rejected_run[ui];
        } else if (s.axis_faults[ui] == SampleFault::kNone) {
          // Accepted: within the jump allowance of the truth it was sent with.
          const double truth = sent[static_cast<std::size_t>(k - 1)][ui];
          const double bound = a.max_speed * kPeriodS * (rejected_run[ui] + 2) +
                               rig.device.config().jump_tolerance_counts / a.counts_per_unit + 1e-9;
          EXPECT_LE(std::abs(axis_difference(s.q[i], truth, a.wraps)), bound)
              << "period " << k << " axis " << i;
          rejected_run[ui] = 0;
        }
      }
    }
    prev = s;
    trajectory((k + 1) * kPeriodS, q);
    rig.emulator.set_axis_values(q);
    sent.push_back({q[0], q[1], q[2], q[3], q[4]});
  }
  (void)settings;
  return rig.device.counters();
}

TEST(DeviceEmulator, CorruptedFramesAreRejectedAndCounted) {
  SimBusSettings s = latency_only();
  s.corruption_probability = 0.05;
  s.seed = 11;
  EmulatorRig rig(s);
  const DeviceCounters n = run_faulty(s, 4000, rig);
  const auto& link = rig.bus.link_counters(SimBus::Direction::kDeviceToController);
  EXPECT_GT(link.corrupted(), 500u);
  EXPECT_GT(n.frames_wrong_length, 0u);
  EXPECT_EQ(n.frames_wrong_length, n.rejected_malformed);
  EXPECT_GT(n.rejected_jump + n.rejected_out_of_range, 0u);
  // Every corrupted length is caught; a bit flip is caught unless it lands in the few low
  // bits a real motion could explain.
  EXPECT_GT(n.values_rejected, link.corrupted() / 2);
  // SYNC and RPDO corruption on the way down is seen by the emulator.
  EXPECT_GT(rig.emulator.counters().frames_malformed, 0u);
}

TEST(DeviceEmulator, LostFramesLeaveTheTargetHeldAndFresh) {
  SimBusSettings s = latency_only();
  s.drop_probability = 0.1;
  s.seed = 5;
  EmulatorRig rig(s);
  const DeviceCounters n = run_faulty(s, 3000, rig);
  EXPECT_GT(rig.bus.link_counters(SimBus::Direction::kDeviceToController).dropped, 0u);
  // A lost frame is no rejection; only runs of >= 3 lost answers make an axis stale.
  EXPECT_EQ(n.rejected_jump + n.rejected_out_of_range + n.rejected_malformed, 0u);
  EXPECT_GT(n.samples_valid, 2900u);
}

// A trace of the whole exchange: every sample's bits and faults.
struct Trace {
  std::vector<double> values;
  std::vector<FaultMask> faults;
  DeviceCounters counters;
};

Trace run_trace(std::uint64_t seed) {
  SimBusSettings s = latency_only();
  s.drop_probability = 0.05;
  s.corruption_probability = 0.05;
  s.seed = seed;
  EmulatorRig rig(s);
  Trace tr;
  double q[5];
  trajectory(0.0, q);
  rig.emulator.set_axis_values(q);
  Wrench w;
  for (int k = 0; k < 2000; ++k) {
    w.force = Vec3(std::sin(0.01 * k), 0.5, -0.2);
    const DeviceSample smp = rig.period(k, w);
    for (int i = 0; i < 5; ++i) tr.values.push_back(smp.q[i]);
    tr.values.push_back(smp.pose.position.x());
    tr.values.push_back(smp.twist.angular.z());
    tr.values.push_back(rig.emulator.last_torques()[0]);
    tr.faults.push_back(smp.faults);
    trajectory((k + 1) * kPeriodS, q);
    rig.emulator.set_axis_values(q);
  }
  tr.counters = rig.device.counters();
  return tr;
}

TEST(DeviceEmulator, IdenticalSeedsGiveIdenticalRuns) {
  const Trace a = run_trace(99);
  const Trace b = run_trace(99);
  ASSERT_EQ(a.values.size(), b.values.size());
  EXPECT_EQ(std::memcmp(a.values.data(), b.values.data(), a.values.size() * sizeof(double)), 0);
  EXPECT_EQ(a.faults, b.faults);
  EXPECT_EQ(std::memcmp(&a.counters, &b.counters, sizeof(DeviceCounters)), 0);
  const Trace c = run_trace(100);
  EXPECT_NE(a.faults, c.faults);
}

TEST(DeviceEmulator, TenThousandPeriodsWithoutAllocation) {
  SimBusSettings s = latency_only();
  s.drop_probability = 0.02;
  s.corruption_probability = 0.02;
  EmulatorRig rig(s);
  double q[5];
  trajectory(0.0, q);
  rig.emulator.set_axis_values(q);
  for (int k = 0; k < 5; ++k) rig.period(k, Wrench{});
  int valid = 0;
  std::int64_t allocations = 0;
  {
    numen::test::AllocationGuard guard;
    Wrench w;
    for (int k = 5; k < 10005; ++k) {
      w.force = Vec3(0.5 * std::sin(0.003 * k), 0.2, -0.3);
      w.torque = Vec3(0.0, 0.01, 0.0);
      const DeviceSample smp = rig.period(k, w);
      valid += smp.valid ? 1 : 0;
      trajectory((k + 1) * kPeriodS, q);
      rig.emulator.set_axis_values(q);
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_GT(valid, 9000);
  EXPECT_EQ(rig.device.counters().samples, 10005u);
}

TEST(DeviceEmulator, PoseTrackerEndToEnd) {
  DeviceConfig c = make_default_pose_tracker_config(40);
  c.canopen.managed = false;
  c.control_period_s = kPeriodS;
  EmulatorRig rig(latency_only(), c);
  const double q[6] = {0.1, -0.2, 0.3, 2.0, -0.4, -3.0};
  rig.emulator.set_axis_values(q);
  DeviceSample s;
  for (int k = 0; k < 3; ++k) s = rig.period(k, Wrench{});
  ASSERT_TRUE(s.valid);
  AxisVector qv(6);
  for (int i = 0; i < 6; ++i) qv[i] = q[i];
  const numen::core::Pose truth = PoseTrackerKinematics().forward(qv);
  EXPECT_LT((s.pose.position - truth.position).norm(), 1e-6);
  EXPECT_LT(s.pose.orientation.angularDistance(truth.orientation), 3e-6);
  EXPECT_EQ(rig.emulator.counters().rpdos, 0u);  // no drives: nothing commanded
}

TEST(DeviceEmulator, PhantomEndToEnd) {
  // A phantom arm: six encoders answer each SYNC, three drives receive the link torques.
  DeviceConfig c = make_default_phantom_config(50);
  c.canopen.managed = false;
  c.control_period_s = kPeriodS;
  EmulatorRig rig(latency_only(), c);
  const double q[6] = {0.3, -0.2, 0.1, -1.0, 0.6, 2.5};
  rig.emulator.set_axis_values(q);
  DeviceSample s;
  for (int k = 0; k < 3; ++k) s = rig.period(k, Wrench{});
  ASSERT_TRUE(s.valid);
  EXPECT_EQ(rig.emulator.counters().tpdos_sent, 18u);  // 3 SYNCs × 6 axes
  AxisVector qv(6);
  for (int i = 0; i < 6; ++i) qv[i] = q[i];
  const PhantomKinematics truth_k(c.phantom, c.tool_offset);
  const numen::core::Pose truth = truth_k.forward(qv);
  EXPECT_LT((s.pose.position - truth.position).norm(), 1e-5);
  EXPECT_LT(s.pose.orientation.angularDistance(truth.orientation), 1e-3);
  ASSERT_EQ(s.num_links, 5);
  const numen::core::Pose elbow = truth_k.link_pose(PhantomKinematics::kLinkForearm, qv);
  EXPECT_LT((s.link_poses[PhantomKinematics::kLinkForearm].position - elbow.position).norm(),
            1e-5);
  // Link wrenches -> RPDOs on the three drives only -> the emulated drives.
  std::array<Wrench, PhantomKinematics::kNumLinks> w{};
  w[PhantomKinematics::kLinkStylus].force = Vec3(0.0, 0.0, -2.0);  // push the gimbal down
  w[PhantomKinematics::kLinkForearm].torque = Vec3(0.0, 0.05, 0.0);
  const std::uint64_t rpdos = rig.emulator.counters().rpdos;
  rig.bus.set_time_ns(3 * kPeriodNs);
  rig.sender.read(3 * kPeriodNs);
  ASSERT_EQ(rig.command_links(w, 3 * kPeriodNs), IoStatus::kOk);
  rig.bus.set_time_ns(3 * kPeriodNs + kPeriodNs / 2);
  rig.emulator.poll(rig.bus.device());
  EXPECT_EQ(rig.emulator.counters().rpdos - rpdos, 3u);
  for (int i = 0; i < 6; ++i) {
    const AxisConfig& a = c.axes[static_cast<std::size_t>(i)];
    EXPECT_NEAR(rig.emulator.last_torques()[i], rig.sender.sent_torques().torque[i],
                0.5e-3 * a.rated_torque + 1e-12)
        << i;
    if (i >= 3) {
      EXPECT_EQ(rig.emulator.last_torques()[i], 0.0);
    }
  }
  EXPECT_GT(std::abs(rig.emulator.last_torques()[PhantomKinematics::kShoulder]), 0.1);
}

}  // namespace device_emulator_test

// ---------------------------------------------------------------- managed stack

namespace device_emulator_test {  // named: the unity build shares a TU with other test files
using namespace numen::hal;

TEST(DeviceEmulatorManaged, BootsAnswersNmtAndSendsPdosOnlyWhenOperational) {
  DeviceConfig c = make_default_trocar_config(1);
  SimBusSettings s;
  s.latency_ns = 0;
  SimBus bus(s);
  numen::hal::DeviceEmulator emu(c);
  CanFrame f;
  emu.tick(0, bus.device());  // power-on: 5 boot-ups
  int boot_ups = 0;
  while (bus.controller().read(f) == IoStatus::kOk)
    boot_ups += (f.id > 0x700 && f.data[0] == 0) ? 1 : 0;
  EXPECT_EQ(boot_ups, 5);
  bus.controller().write(numen::hal::make_sync(1, 1));
  emu.poll(bus.device());
  EXPECT_EQ(bus.pending(SimBus::Direction::kDeviceToController), 0u) << "no PDO in pre-operational";
  numen::hal::encode_nmt(numen::hal::NmtCommand::kStartRemoteNode, 0, 2, f);
  bus.controller().write(f);
  bus.controller().write(numen::hal::make_sync(3, 2));
  emu.poll(bus.device());
  EXPECT_EQ(bus.pending(SimBus::Direction::kDeviceToController), 8u);  // 5 encoders + 3 drives
  while (bus.controller().read(f) == IoStatus::kOk) {
  }
  // Stop node 4 (roll): its encoder falls silent, its heartbeat says stopped.
  numen::hal::encode_nmt(numen::hal::NmtCommand::kStopRemoteNode, 4, 4, f);
  bus.controller().write(f);
  bus.controller().write(numen::hal::make_sync(5, 3));
  emu.poll(bus.device());
  EXPECT_EQ(bus.pending(SimBus::Direction::kDeviceToController), 7u);
  EXPECT_EQ(emu.node_state(3), numen::hal::NmtState::kStopped);
  // An injected drive fault: EMCY at the next tick, drive in fault reaction, torque 0.
  while (bus.controller().read(f) == IoStatus::kOk) {
  }
  ASSERT_TRUE(emu.inject_drive_fault(2, 0x4310));
  EXPECT_FALSE(emu.inject_drive_fault(3, 0x4310));  // roll has no drive
  emu.tick(6, bus.device());
  ASSERT_EQ(bus.controller().read(f), IoStatus::kOk);
  numen::hal::EmcyMessage m;
  ASSERT_EQ(numen::hal::decode_emcy(f, m), numen::hal::EmcyDecodeStatus::kOk);
  EXPECT_EQ(m.node_id, 3);
  EXPECT_EQ(m.error_code, 0x4310);
  EXPECT_EQ(m.error_register, 0x09);  // generic + temperature
  EXPECT_EQ(emu.drive(2)->state(), numen::hal::PowerState::kFaultReactionActive);
  // Killed: nothing read is answered, nothing is sent.
  emu.kill(true);
  bus.controller().write(numen::hal::make_sync(7, 4));
  emu.poll(bus.device());
  emu.tick(100 * 1'000'000, bus.device());
  EXPECT_EQ(bus.pending(SimBus::Direction::kDeviceToController), 0u);
  EXPECT_EQ(emu.counters().frames_while_killed, 1u);
}

}  // namespace device_emulator_test

// ---------------------------------------------------------------- SDO (managed stack)

namespace device_emulator_test {  // named: the unity build shares a TU with other test files
using namespace numen::hal;

/// Runs `client`'s transfer against the emulator over `bus` (no latency), up to 20 exchanges
/// of 1 ms; the client's timeout decides for a silent node.
SdoStatus sdo_exchange(SdoClient& client, DeviceEmulator& emu, SimBus& bus, std::int64_t& t) {
  CanFrame f;
  for (int i = 0; i < 20 && client.status() == SdoStatus::kPending; ++i, t += 1'000'000) {
    bus.set_time_ns(t);
    while (client.take_request(f, t)) bus.controller().write(f);
    emu.poll(bus.device());
    while (bus.controller().read(f) == IoStatus::kOk) client.on_frame(f);
    client.poll(t);
  }
  return client.status();
}

TEST(DeviceEmulatorManaged, EveryNodeAnswersSdoWithItsIdentity) {
  const DeviceConfig c = make_default_trocar_config(1);
  SimBusSettings s;
  s.latency_ns = 0;
  SimBus bus(s);
  DeviceEmulator emu(c);
  std::int64_t t = 0;
  // Before the boot-up (initialisation) a node takes no SDO: the client times out.
  SdoClient early(1, 5'000'000);
  std::array<std::uint8_t, 64> buf{};
  ASSERT_TRUE(early.start_upload({0x1000, 0}, buf, t));
  EXPECT_EQ(sdo_exchange(early, emu, bus, t), SdoStatus::kAborted);
  EXPECT_EQ(early.abort_code(), SdoAbort::kTimeout);
  EXPECT_EQ(emu.counters().sdo_not_allowed, 1u);
  emu.tick(t, bus.device());  // boot-ups: every node pre-operational
  CanFrame f;
  while (bus.controller().read(f) == IoStatus::kOk) {
  }
  for (const CanopenAxisConfig& x : c.canopen.axes) {
    SCOPED_TRACE(int(x.node_id));
    SdoClient client(x.node_id);
    const bool drive = emu.object_dictionary(x.node_id) != nullptr &&
                       c.axes[static_cast<std::size_t>(&x - c.canopen.axes.data())].has_drive();
    std::uint32_t v = 0;
    ASSERT_TRUE(client.start_upload({0x1000, 0}, buf, t));
    ASSERT_EQ(sdo_exchange(client, emu, bus, t), SdoStatus::kDone);
    std::memcpy(&v, buf.data(), 4);
    EXPECT_EQ(v & 0xFFFF, drive ? 402u : 406u);  // CiA profile number
    ASSERT_TRUE(client.start_upload({0x1018, 4}, buf, t));
    ASSERT_EQ(sdo_exchange(client, emu, bus, t), SdoStatus::kDone);
    std::memcpy(&v, buf.data(), 4);
    EXPECT_EQ(v, x.node_id);  // serial number
    ASSERT_TRUE(client.start_upload({0x1008, 0}, buf, t));  // segmented
    ASSERT_EQ(sdo_exchange(client, emu, bus, t), SdoStatus::kDone);
    const std::string name(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(client.transferred()));
    EXPECT_NE(name.find(drive ? "drive" : "encoder"), std::string::npos) << name;
    // Refusals by name: a read-only write, an object the node does not have.
    ASSERT_TRUE(client.start_download({0x1000, 0}, std::span<const std::uint8_t>(buf.data(), 4), t));
    EXPECT_EQ(sdo_exchange(client, emu, bus, t), SdoStatus::kAborted);
    EXPECT_EQ(client.abort_code(), SdoAbort::kReadOnly);
    ASSERT_TRUE(client.start_upload({0x2000, 0}, buf, t));
    EXPECT_EQ(sdo_exchange(client, emu, bus, t), SdoStatus::kAborted);
    EXPECT_EQ(client.abort_code(), SdoAbort::kNoObject);
  }
  EXPECT_EQ(emu.object_dictionary(99), nullptr);
  // A stopped node does not answer.
  encode_nmt(NmtCommand::kStopRemoteNode, 2, t, f);
  bus.controller().write(f);
  emu.poll(bus.device());
  SdoClient stopped(2, 5'000'000);
  ASSERT_TRUE(stopped.start_upload({0x1000, 0}, buf, t));
  EXPECT_EQ(sdo_exchange(stopped, emu, bus, t), SdoStatus::kAborted);
  EXPECT_EQ(stopped.abort_code(), SdoAbort::kTimeout);
}

/// Writes `value` (`bytes` long) to `a` of node `node`; returns 0 or the abort code.
std::uint32_t sdo_write(DeviceEmulator& emu, SimBus& bus, std::int64_t& t, std::uint8_t node,
                        SdoAddress a, std::uint32_t value, std::size_t bytes) {
  SdoClient client(node, 5'000'000);
  std::array<std::uint8_t, 4> b{};
  for (std::size_t i = 0; i < 4; ++i) b[i] = static_cast<std::uint8_t>(value >> (8 * i));
  EXPECT_TRUE(client.start_download(a, std::span<const std::uint8_t>(b.data(), bytes), t));
  return sdo_exchange(client, emu, bus, t) == SdoStatus::kDone ? 0 : client.abort_code();
}

std::uint32_t od_value(const DeviceEmulator& emu, std::uint8_t node, SdoAddress a) {
  std::uint32_t v = 0;
  EXPECT_TRUE(emu.object_dictionary(node)->read_unsigned(a, v));
  return v;
}

/// The default trainer's emulator on a SimBus without latency, its nodes booted (pre-operational,
/// boot-ups read away).
struct BootedTrainer {
  SimBus bus{SimBusSettings{0}};
  DeviceEmulator emu{make_default_trocar_config(1)};
  std::int64_t t = 0;
  BootedTrainer() {
    emu.tick(t, bus.device());
    CanFrame f;
    while (bus.controller().read(f) == IoStatus::kOk) {
    }
  }
};

TEST(DeviceEmulatorManaged, PdoParametersFollowTheCia301SequenceAndTakeEffect) {
  BootedTrainer rig;
  DeviceEmulator& emu = rig.emu;
  SimBus& bus = rig.bus;
  std::int64_t& t = rig.t;
  CanFrame f;
  // Node 1's drive TPDO2 (0x1801 / 0x1A01), as the configuration gives it.
  EXPECT_EQ(od_value(emu, 1, {0x1801, 1}), 0x281u);
  EXPECT_EQ(od_value(emu, 1, {0x1A01, 0}), 2u);
  EXPECT_EQ(od_value(emu, 1, {0x1A01, 2}), 0x60770010u);
  EXPECT_EQ(od_value(emu, 1, {0x1A01, 3}), 0u);
  // Refused while the PDO exists: the mapping (count and entries), another COB-ID.
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 0}, 0, 1), SdoAbort::kUnsupportedAccess);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 1}, 0x60410010, 4), SdoAbort::kUnsupportedAccess);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1801, 1}, 0x291, 4), SdoAbort::kInvalidValue);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1801, 1}, 0x701, 4), SdoAbort::kInvalidValue);  // reserved
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1801, 1}, 0x20000281, 4), SdoAbort::kInvalidValue);  // 29-bit
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1801, 2}, 0xFE, 1), SdoAbort::kInvalidValue);  // event-driven
  // The sequence: disable, count 0, entries, count, re-enable on another COB-ID.
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1801, 1}, 0x80000281u, 4), 0u);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 1}, 0x60410010, 4), SdoAbort::kUnsupportedAccess);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 0}, 0, 1), 0u);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 3}, 0x60720010, 4), SdoAbort::kNotMappable);  // not a PDO object
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 3}, 0x60400010, 4), SdoAbort::kNotMappable);  // an RPDO object
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 3}, 0x60410020, 4), SdoAbort::kNotMappable);  // wrong length
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 3}, 0x60610008, 4), 0u);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 4}, 0x60640020, 4), 0u);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 5}, 0x60040020, 4), 0u);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 0}, 9, 1), SdoAbort::kValueTooHigh);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 0}, 5, 1), SdoAbort::kPdoLength);  // 15 bytes
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1A01, 0}, 3, 1), 0u);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1801, 1}, 0x291, 4), 0u);
  // Operational and synchronised: the drive TPDO goes out on 0x291 with its 5 bytes.
  encode_nmt(NmtCommand::kStartRemoteNode, 0, t, f);
  bus.controller().write(f);
  bus.controller().write(make_sync(t));
  emu.poll(bus.device());
  int on_new = 0;
  int on_old = 0;
  while (bus.controller().read(f) == IoStatus::kOk) {
    on_new += f.id == 0x291 && f.len == 5;
    on_old += f.id == 0x281;
  }
  EXPECT_EQ(on_new, 1);
  EXPECT_EQ(on_old, 0);
  // Reset communication: the configuration's PDO again.
  encode_nmt(NmtCommand::kResetCommunication, 1, t, f);
  bus.controller().write(f);
  emu.poll(bus.device());
  EXPECT_EQ(od_value(emu, 1, {0x1801, 1}), 0x281u);
  EXPECT_EQ(od_value(emu, 1, {0x1A01, 0}), 2u);
}

TEST(DeviceEmulatorManaged, HeartbeatSyncAndDriveObjectsRules) {
  BootedTrainer rig;
  DeviceEmulator& emu = rig.emu;
  SimBus& bus = rig.bus;
  std::int64_t& t = rig.t;
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1005, 0}, 0x40000080u, 4), SdoAbort::kInvalidValue);  // producer
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1005, 0}, 0x80, 4), 0u);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1016, 1}, 0x01000000u, 4), SdoAbort::kInvalidValue);
  EXPECT_EQ(sdo_write(emu, bus, t, 4, {0x1016, 1}, 0x007F0032u, 4), SdoAbort::kNoObject);  // no drive
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x6072, 0}, 0, 2), SdoAbort::kValueTooLow);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x6072, 0}, 40000, 2), SdoAbort::kValueTooHigh);
  EXPECT_EQ(sdo_write(emu, bus, t, 4, {0x6072, 0}, 1000, 2), SdoAbort::kNoObject);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x6072, 0}, 1200, 2), 0u);
  EXPECT_EQ(emu.drive(0)->settings().max_torque_per_mille, 1200);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x6060, 0}, 8, 1), 0u);  // csp: applies no torque
  EXPECT_EQ(emu.drive(0)->modes_of_operation_display(), 8);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1017, 0}, 25, 2), 0u);
  EXPECT_EQ(sdo_write(emu, bus, t, 1, {0x1016, 1}, 0x007F0064u, 4), 0u);
  // Reset node: every object back to the configuration's values, and applied.
  CanFrame f;
  encode_nmt(NmtCommand::kResetNode, 1, t, f);
  bus.controller().write(f);
  emu.poll(bus.device());
  EXPECT_EQ(od_value(emu, 1, {0x6072, 0}), 2000u);
  EXPECT_EQ(emu.drive(0)->settings().max_torque_per_mille, 2000);
  EXPECT_EQ(emu.drive(0)->modes_of_operation_display(), 10);
  EXPECT_EQ(od_value(emu, 1, {0x1017, 0}), 10u);
  EXPECT_EQ(od_value(emu, 1, {0x1016, 1}), 0x007F001Eu);
}

}  // namespace device_emulator_test
