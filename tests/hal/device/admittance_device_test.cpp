// Tests of hal/admittance_device (controller side: csp RPDOs through inverse kinematics, the
// measured wrench in the world, one period against the emulated device).
#include "numen/hal/device/admittance_device.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "alloc_counter.hpp"
#include "admittance_tracker.hpp"
#include "fixed_motion.hpp"
#include "numen/core/feedback.hpp"
#include "numen/hal/emulation/admittance_emulator.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace hal = numen::hal;
namespace core = numen::core;
using core::Quat;
using core::Vec3;

using numen::test::drain;

namespace {

hal::DeviceConfig tracker() { return numen::test::admittance_tracker(); }
hal::AxisVector zeros() { return numen::test::tracker_zeros(); }

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

/// The tracker's admittance config with the sensor 20 mm up the tool's z, turned 90° about it.
hal::AdmittanceConfig admittance_sensor_up_20mm_turned() {
  hal::AdmittanceConfig a = hal::make_admittance_config(tracker());
  a.sensor.sensor_in_tool.position = Vec3(0.0, 0.0, 0.02);
  a.sensor.sensor_in_tool.orientation = Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()));
  return a;
}

/// The tracker's axis values with the tool at (x, 0, 0), identity orientation.
hal::AxisVector admittance_tool_at_x(double x) {
  hal::AxisVector q = zeros();
  q[0] = x;
  return q;
}

TEST(AdmittanceDevice, MeasuredWrenchGoesToTheWorldAboutThePointAsked) {
  hal::SimBus bus{hal::SimBusSettings{}};
  const hal::AdmittanceConfig a = admittance_sensor_up_20mm_turned();
  const hal::AxisVector q = admittance_tool_at_x(0.1);  // tool at (0.1, 0, 0), identity orientation
  hal::AdmittanceDevice dev(tracker(), a, bus.controller(), q);
  core::Wrench s;
  s.force = Vec3(1.0, 0.0, 0.0);  // sensor x = world y
  s.torque = Vec3(0.0, 0.0, 0.01);
  const core::Wrench w = dev.world_wrench(s, Vec3(0.1, 0.0, 0.0));
  EXPECT_TRUE(w.force.isApprox(Vec3(0.0, 1.0, 0.0), 1e-12));
  // Torque about the tool origin: 0.01 z + (0, 0, 0.02) × (0, 1, 0) = (−0.02, 0, 0.01).
  EXPECT_TRUE(w.torque.isApprox(Vec3(-0.02, 0.0, 0.01), 1e-12));
}

// read() returns the measured wrench as the period's DeviceState: in the world, about the
// sensor's origin (wrench_point), the same wrench world_wrench() carries to any point; no axes
// or links (the admittance kind reads none). write(DeviceCommand) sends the pose's set-points.
TEST(AdmittanceDevice, ReadReturnsTheMeasuredWrenchInTheWorldAsTheState) {
  hal::SimBus bus{hal::SimBusSettings{}};
  const hal::AdmittanceConfig a = admittance_sensor_up_20mm_turned();
  const hal::AxisVector q = admittance_tool_at_x(0.1);  // tool at (0.1, 0, 0), identity orientation
  hal::AdmittanceEmulator emu(tracker(), a);
  numen::test::FixedMotion motion(6);
  emu.set_motion(&motion);
  emu.set_axis_values(q);
  hal::AdmittanceDevice dev(tracker(), a, bus.controller(), q);
  motion.state.handle_wrench.force = Vec3(2.0, 0.5, -1.0);
  motion.state.handle_wrench.torque = Vec3(0.01, -0.02, 0.03);
  const hal::DeviceState* s = nullptr;
  for (int i = 0; i < 3; ++i) {
    const std::int64_t t = i * 1'000'000LL;
    bus.set_time_ns(t);
    dev.begin_period(t);
    emu.poll(bus.device());
    s = &dev.read(t);
  }
  ASSERT_TRUE(s->valid);
  EXPECT_TRUE(s->ready);
  EXPECT_EQ(s->num_axes, 0);
  EXPECT_EQ(s->num_links, 0);
  EXPECT_GT(s->input_frames, 0);
  EXPECT_GT(s->wrench.force.norm(), 1.0);
  // The sensor's origin: the tool at (0.1, 0, 0), the sensor 20 mm up its z.
  EXPECT_TRUE(s->wrench_point.isApprox(Vec3(0.1, 0.0, 0.02), 1e-12));
  const Vec3 about(0.05, -0.01, 0.3);
  const core::Wrench by_state = core::carry_wrench(s->wrench, s->wrench_point, about);
  const core::Wrench by_device = dev.world_wrench(dev.force_sample().wrench, about);
  EXPECT_EQ(by_state.force, by_device.force);
  EXPECT_EQ(by_state.torque, by_device.torque);
  (void)dev.supervise(0, false);
  ASSERT_EQ(dev.lifecycle(), hal::LifecycleState::kActive);
  core::Pose p = dev.commanded_pose();
  p.position.x() += 1e-5;
  hal::DeviceCommand c;
  c.pose = &p;
  const hal::DeviceOutput& out = dev.write(c, 0);
  EXPECT_EQ(out.status, hal::IoStatus::kOk);
  EXPECT_FALSE(out.gated);
  EXPECT_FALSE(out.torque_commanded);
  EXPECT_EQ(out.controlword, hal::Controlword::kEnableOperation);
  EXPECT_NEAR(dev.setpoints()[0], 0.1 + 1e-5, 1e-12);
}

// One period as a control loop runs it: begin_period (SYNC), read (the sensor's TPDOs),
// supervise, write_pose; never allocates; the face's figures after it.
TEST(AdmittanceDevice, PeriodicCallsDoNotAllocate) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceEmulator emu(tracker(), hal::make_admittance_config(tracker()));
  numen::test::FixedMotion motion(6);
  emu.set_motion(&motion);
  hal::AdmittanceDevice dev(tracker(), hal::make_admittance_config(tracker()), bus.controller(), zeros());
  emu.set_axis_values(zeros());
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 1000; ++i) {
    const std::int64_t t = i * 1'000'000LL;
    bus.set_time_ns(t);
    dev.begin_period(t);
    motion.state.handle_wrench.force = Vec3(2.0 * std::sin(1e-3 * i), 0.0, 0.0);
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
  // The face gives its figures without naming the kind (issue 68): the force TPDOs its input
  // took (the sensor's frames) and its set-points' counters; no torque counters, no passivity
  // controller, no torque sent.
  const hal::Device& face = dev;
  EXPECT_EQ(face.input_frames(), dev.sensor().counters().frames);
  EXPECT_GT(face.input_frames(), 0u);
  EXPECT_EQ(face.conditioning().setpoints, &dev.counters());
  EXPECT_EQ(face.conditioning().torque, nullptr);
  EXPECT_EQ(face.conditioning().passivity, nullptr);
  EXPECT_TRUE(face.output().torque.empty());
}
