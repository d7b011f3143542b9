// Tests of hal/admittance_emulator (the device side of an admittance device): csp RPDOs set
// the drives' commands the motion is told at each SYNC, the axes are where the motion puts
// them, and the force sensor reports the motion's hand wrench in its own frame.
#include "numen/hal/emulation/admittance_emulator.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "admittance_tracker.hpp"
#include "fixed_motion.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/device/force_sensor.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace hal = numen::hal;
namespace core = numen::core;
using core::Quat;
using core::Vec3;

using numen::test::drain;

namespace {

hal::DeviceConfig emulator_tracker() { return numen::test::admittance_tracker(); }
hal::AxisVector emulator_zeros() { return numen::test::tracker_zeros(); }

}  // namespace

TEST(AdmittanceEmulator, EnabledSetPointsReachTheMotionAndItsAxesAreReported) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceEmulator emu(emulator_tracker(), hal::make_admittance_config(emulator_tracker()));
  numen::test::FixedMotion motion(6);
  emu.set_motion(&motion);
  hal::AdmittanceDevice dev(emulator_tracker(), hal::make_admittance_config(emulator_tracker()),
                            bus.controller(), emulator_zeros());
  emu.set_axis_values(emulator_zeros());
  core::Pose p;
  p.position = Vec3(0.004, 0.0, 0.0);
  dev.set_pose(p);
  // Disabled (shutdown): the target is not taken.
  dev.write_setpoints(hal::Controlword::kShutdown, 0);
  bus.controller().write(hal::make_sync(0));
  emu.poll(bus.device());
  EXPECT_FALSE(emu.enabled(0));
  EXPECT_EQ(motion.last.enabled[0], 0);
  EXPECT_EQ(motion.last.position_target[0], 0.0);
  EXPECT_EQ(motion.last_t_ns, 0);
  // Enabled: the motion is told the target at the next SYNC; the axes are the motion's.
  dev.write_setpoints(hal::Controlword::kEnableOperation, 1'000'000);
  motion.state.q[0] = 0.0025;
  motion.state.qdot[0] = 2.5;
  bus.set_time_ns(1'000'000);
  bus.controller().write(hal::make_sync(1'000'000));
  emu.poll(bus.device());
  EXPECT_TRUE(emu.enabled(0));
  EXPECT_EQ(motion.last.enabled[0], 1);
  EXPECT_NEAR(motion.last.position_target[0], 0.004, 1e-6);  // 1 µm counts
  EXPECT_EQ(motion.last_t_ns, 1'000'000);
  EXPECT_EQ(emu.q()[0], 0.0025);
  EXPECT_EQ(emu.qdot()[0], 2.5);
  EXPECT_EQ(motion.syncs, 2);
  EXPECT_EQ(emu.counters().rpdos, 12u);
}

TEST(AdmittanceEmulator, SensorReportsTheMotionsHandWrenchInItsFrame) {
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceConfig a = hal::make_admittance_config(emulator_tracker());
  a.sensor.sensor_in_tool.orientation = Quat(Eigen::AngleAxisd(M_PI, Vec3::UnitX()));  // flipped
  hal::AdmittanceEmulator emu(emulator_tracker(), a);
  numen::test::FixedMotion motion(6);
  motion.state.handle_wrench.force = Vec3(2.0, 0.0, -1.0);  // world
  emu.set_motion(&motion);
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
  // Without a motion the device holds still and measures nothing.
  emu.set_sensor_silent(false);
  emu.set_motion(nullptr);
  bus.set_time_ns(2'000'000);
  bus.controller().write(hal::make_sync(2'000'000));
  emu.poll(bus.device());
  EXPECT_EQ(emu.hand_wrench().force.norm(), 0.0);
}
