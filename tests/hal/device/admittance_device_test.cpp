// Tests of hal/admittance_device (controller side: csp RPDOs through inverse kinematics, the
// measured wrench in the world) and hal/admittance_emulator (device side: drives that follow
// the set-points, a force sensor measuring the simulated hand).
#include "numen/hal/device/admittance_device.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "alloc_counter.hpp"
#include "numen/hal/emulation/admittance_emulator.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace hal = numen::hal;
namespace core = numen::core;
using core::Quat;
using core::Vec3;

namespace {

hal::DeviceConfig tracker() {
  hal::DeviceConfig c = hal::make_default_pose_tracker_config(1);
  c.control_period_s = 1e-3;
  return c;
}

hal::AxisVector zeros() { return hal::AxisVector::Zero(6); }

/// Reads every frame pending on `port` into `out` (at most 16); returns the count.
int drain(hal::Bus& port, std::array<hal::CanFrame, 16>& out) {
  int n = 0;
  hal::CanFrame f;
  while (n < 16 && port.read(f) == hal::IoStatus::kOk) out[static_cast<std::size_t>(n++)] = f;
  return n;
}

}  // namespace

TEST(AdmittanceDevice, DefaultRpdosAreRpdo1OfTheAxisNodes) {
  const hal::AdmittanceConfig a = hal::make_admittance_config(tracker());
  ASSERT_EQ(a.rpdo_cob_ids.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) EXPECT_EQ(a.rpdo_cob_ids[i], 0x201u + i);
  EXPECT_NO_THROW(hal::validate(tracker(), a));
  const hal::PdoMapping m = hal::csp_drive_rpdo_mapping();
  EXPECT_EQ(m.length(), 6);
  EXPECT_EQ(m.mapping_parameter()[0], 0x60400010u);
  EXPECT_EQ(m.mapping_parameter()[1], 0x607A0020u);
}

TEST(AdmittanceDevice, ValidateRejectsClashingCobIds) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceConfig a = hal::make_admittance_config(tracker());
  a.rpdo_cob_ids[2] = 0x181;  // axis x's encoder
  EXPECT_THROW(hal::validate(tracker(), a), std::invalid_argument);
  a = hal::make_admittance_config(tracker());
  a.rpdo_cob_ids[3] = a.rpdo_cob_ids[0];
  EXPECT_THROW(hal::validate(tracker(), a), std::invalid_argument);
  a = hal::make_admittance_config(tracker());
  a.rpdo_cob_ids[0] = 0x1A0;  // the sensor's force TPDO
  EXPECT_THROW(hal::validate(tracker(), a), std::invalid_argument);
  a = hal::make_admittance_config(tracker());
  a.rpdo_cob_ids.pop_back();
  EXPECT_THROW(hal::validate(tracker(), a), std::invalid_argument);
  EXPECT_THROW(hal::AdmittanceDevice(tracker(), hal::make_admittance_config(tracker()),
                                     bus.controller(), hal::AxisVector::Zero(5)),
               std::invalid_argument);
}

TEST(AdmittanceDevice, WorkedCspFrameOfProtocolSection18) {
  // x = 12.345 mm at 1 µm/count → 12345 = 0x3039; controlword enable operation 0x000F.
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceDevice dev(tracker(), hal::make_admittance_config(tracker()), bus.controller(), zeros());
  hal::AxisVector q = zeros();
  q[0] = 0.012345;  // a set-point (set_pose would rate limit a 12 mm step to 5 mm)
  dev.reset_setpoints(q);
  ASSERT_EQ(dev.write_setpoints(hal::Controlword::kEnableOperation, 5),
            hal::IoStatus::kOk);
  std::array<hal::CanFrame, 16> got;
  ASSERT_EQ(drain(bus.device(), got), 6);
  const hal::CanFrame& f = got[0];
  EXPECT_EQ(f.id, 0x201u);
  ASSERT_EQ(f.len, 6);
  const std::uint8_t want[6] = {0x0F, 0x00, 0x39, 0x30, 0x00, 0x00};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(f.data[static_cast<std::size_t>(i)], want[i]) << i;
  EXPECT_EQ(got[1].id, 0x202u);
  EXPECT_EQ(dev.counts()[0], 12345);
  EXPECT_EQ(dev.counters().rpdos_written, 6u);
}

TEST(AdmittanceDevice, SetPointsAreClampedToTheRangeAndRateLimited) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceDevice dev(tracker(), hal::make_admittance_config(tracker()), bus.controller(), zeros());
  core::Pose p;
  p.position = Vec3(0.1, 0.0, 0.0);  // 100 mm away; max speed 5 m/s → 5 mm per 1 ms period
  dev.set_pose(p);
  EXPECT_NEAR(dev.setpoints()[0], 0.005, 1e-15);
  EXPECT_EQ(dev.counters().rate_limited, 1u);
  for (int i = 0; i < 30; ++i) dev.set_pose(p);
  EXPECT_NEAR(dev.setpoints()[0], 0.1, 1e-12);  // reached after 20 periods and stays
  p.position = Vec3(1.5, 0.0, 0.0);             // beyond max = 1 m: clamped (and rate limited)
  hal::AxisVector q = zeros();
  q[0] = 0.999;
  dev.reset_setpoints(q);
  dev.set_pose(p);
  EXPECT_DOUBLE_EQ(dev.setpoints()[0], 1.0);
  EXPECT_GE(dev.counters().clamped_to_range, 1u);
}

TEST(AdmittanceDevice, MeasuredWrenchGoesToTheWorldAboutThePointAsked) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceConfig a = hal::make_admittance_config(tracker());
  a.sensor.sensor_in_tool.position = Vec3(0.0, 0.0, 0.02);
  a.sensor.sensor_in_tool.orientation = Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()));
  hal::AxisVector q = zeros();
  q[0] = 0.1;  // tool at (0.1, 0, 0), identity orientation
  hal::AdmittanceDevice dev(tracker(), a, bus.controller(), q);
  core::Wrench s;
  s.force = Vec3(1.0, 0.0, 0.0);  // sensor x = world y
  s.torque = Vec3(0.0, 0.0, 0.01);
  const core::Wrench w = dev.world_wrench(s, Vec3(0.1, 0.0, 0.0));
  EXPECT_TRUE(w.force.isApprox(Vec3(0.0, 1.0, 0.0), 1e-12));
  // Torque about the tool origin: 0.01 z + (0, 0, 0.02) × (0, 1, 0) = (−0.02, 0, 0.01).
  EXPECT_TRUE(w.torque.isApprox(Vec3(-0.02, 0.0, 0.01), 1e-12));
}

TEST(AdmittanceEmulator, DrivesFollowEnabledSetPointsWithAFirstOrderLag) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceEmulatorSettings st;
  st.lag_s = 0.002;
  hal::AdmittanceEmulator emu(tracker(), hal::make_admittance_config(tracker()), st);
  hal::AdmittanceDevice dev(tracker(), hal::make_admittance_config(tracker()), bus.controller(), zeros());
  emu.set_axis_values(zeros());
  core::Pose p;
  p.position = Vec3(0.004, 0.0, 0.0);
  dev.set_pose(p);
  // Disabled (shutdown): the target is ignored, the axis holds.
  bus.controller().write(hal::make_sync(0));
  dev.write_setpoints(hal::Controlword::kShutdown, 0);
  emu.poll(bus.device());
  bus.set_time_ns(1'000'000);
  bus.controller().write(hal::make_sync(1'000'000));
  emu.poll(bus.device());
  EXPECT_EQ(emu.q()[0], 0.0);
  EXPECT_FALSE(emu.enabled(0));
  // Enabled: one SYNC interval (1 ms) later q = 4 mm · (1 − e^{−1/2}).
  dev.write_setpoints(hal::Controlword::kEnableOperation, 1'000'000);
  bus.set_time_ns(2'000'000);
  bus.controller().write(hal::make_sync(2'000'000));
  emu.poll(bus.device());
  EXPECT_TRUE(emu.enabled(0));
  EXPECT_NEAR(emu.q()[0], 0.004 * (1.0 - std::exp(-0.5)), 1e-6);  // 1 µm counts
  EXPECT_NEAR(emu.qdot()[0], emu.q()[0] / 1e-3, 1e-9);
  EXPECT_EQ(emu.counters().rpdos, 12u);
}

TEST(AdmittanceEmulator, SensorReportsTheHandSpringInItsFrame) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceEmulatorSettings st;
  st.k_hand = 200.0;
  st.c_hand = 0.0;
  hal::AdmittanceConfig a = hal::make_admittance_config(tracker());
  a.sensor.sensor_in_tool.orientation = Quat(Eigen::AngleAxisd(M_PI, Vec3::UnitX()));  // flipped
  hal::AdmittanceEmulator emu(tracker(), a, st);
  emu.set_axis_values(zeros());
  core::Pose hand;
  hand.position = Vec3(0.010, 0.0, -0.005);  // 10 mm along x, 5 mm down from the handle
  emu.set_hand(hand, core::Twist{});
  bus.controller().write(hal::make_sync(0));
  emu.poll(bus.device());
  hal::ForceSensor sensor(a.sensor);
  std::array<hal::CanFrame, 16> got;
  const int n = drain(bus.controller(), got);
  ASSERT_EQ(n, 2);
  for (int i = 0; i < n; ++i) EXPECT_TRUE(sensor.on_frame(got[static_cast<std::size_t>(i)]));
  const hal::ForceSample r = sensor.sample(0);
  ASSERT_TRUE(r.valid);
  // World (2, 0, −1) N; the sensor frame is turned by π about x: (2, 0, 1) N.
  EXPECT_NEAR(r.wrench.force.x(), 2.0, 0.01);
  EXPECT_NEAR(r.wrench.force.y(), 0.0, 0.01);
  EXPECT_NEAR(r.wrench.force.z(), 1.0, 0.01);
  EXPECT_TRUE(emu.hand_wrench().force.isApprox(Vec3(2.0, 0.0, -1.0), 1e-12));
  // Silenced sensor: no TPDOs.
  emu.set_sensor_silent(true);
  bus.set_time_ns(1'000'000);
  bus.controller().write(hal::make_sync(1'000'000));
  emu.poll(bus.device());
  EXPECT_EQ(drain(bus.controller(), got), 0);
}

// One period as a control loop runs it: begin_period (SYNC), read (the sensor's TPDOs),
// supervise, write_pose; never allocates.
TEST(AdmittanceDevice, PeriodicCallsDoNotAllocate) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceEmulator emu(tracker(), hal::make_admittance_config(tracker()), {});
  hal::AdmittanceDevice dev(tracker(), hal::make_admittance_config(tracker()), bus.controller(), zeros());
  emu.set_axis_values(zeros());
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 1000; ++i) {
    const std::int64_t t = i * 1'000'000LL;
    bus.set_time_ns(t);
    dev.begin_period(t);
    core::Pose hand;
    hand.position = Vec3(0.01 * std::sin(1e-3 * i), 0.0, 0.0);
    emu.set_hand(hand, core::Twist{});
    emu.poll(bus.device());
    (void)dev.read(t);
    (void)dev.supervise(t, false);
    const hal::ForceSample& s = dev.force_sample();
    core::Pose p = dev.commanded_pose();
    p.position += 1e-4 * dev.world_wrench(s.wrench, p.position).force;
    dev.write_pose(&p, t);
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(dev.sensor().counters().accepted, 990u);
  EXPECT_EQ(dev.lifecycle(), hal::LifecycleState::kActive);
  EXPECT_EQ(dev.controlword(), hal::Controlword::kEnableOperation);
}
