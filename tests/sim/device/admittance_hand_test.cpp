// Tests of sim/admittance_hand (the motion of an emulated admittance device): enabled axes
// track their csp targets with a first-order lag, disabled ones hold, and the hand's
// spring–damper is evaluated at the new state; through the emulator and a bus too.
#include "numen/sim/device/admittance_hand.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/emulation/admittance_emulator.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace hal = numen::hal;
namespace core = numen::core;
namespace sim = numen::sim;
using core::Vec3;

namespace {

hal::DeviceConfig tracker() {
  hal::DeviceConfig c = hal::make_default_pose_tracker_config(1);
  c.control_period_s = 1e-3;
  return c;
}

hal::AxisVector zeros() { return hal::AxisVector::Zero(6); }

}  // namespace

TEST(AdmittanceHand, RefusesNegativeGainsAndLag) {
  const auto message = [](const sim::HandSettings& h, double lag) {
    try {
      sim::AdmittanceHand hand(tracker(), h, lag);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message(sim::HandSettings{}, -1.0).find("drive lag must be finite and >= 0"),
            std::string::npos);
  sim::HandSettings h;
  h.stiffness = std::nan("");
  EXPECT_NE(message(h, 0.002).find("hand stiffness must be finite and >= 0"), std::string::npos);
  h = sim::HandSettings{};
  h.rotational_damping = -1.0;
  EXPECT_NE(message(h, 0.002).find("hand rotational_damping"), std::string::npos);
}

// Through the device side: RPDOs from the controller's AdmittanceDevice, SYNCs, the emulator
// asking its motion.
TEST(AdmittanceHand, DrivesFollowEnabledSetPointsWithAFirstOrderLag) {
  hal::SimBus bus{hal::SimBusSettings{}};
  sim::AdmittanceHand hand(tracker(), sim::HandSettings{}, 0.002);
  hal::AdmittanceEmulator emu(tracker(), hal::make_admittance_config(tracker()));
  emu.set_motion(&hand);
  hal::AdmittanceDevice dev(tracker(), hal::make_admittance_config(tracker()), bus.controller(),
                            zeros());
  emu.set_axis_values(zeros());
  hand.set_axis_values(zeros());
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

TEST(AdmittanceHand, TheHandsSpringAndDamperPullTheHandle) {
  sim::HandSettings st;
  st.stiffness = 200.0;
  st.damping = 4.0;
  st.rotational_stiffness = 0.5;
  sim::AdmittanceHand hand(tracker(), st, 0.002);
  core::Pose at;
  at.position = Vec3(0.010, 0.0, -0.005);  // 10 mm along x, 5 mm down from the handle
  core::Twist moving;
  moving.linear = Vec3(0.0, 0.5, 0.0);
  hand.set_hand(at, moving);
  const hal::DriveCommands held;  // every drive disabled: the handle stays at 0
  const hal::DeviceMotionState& s = hand.at_sync(0, held);
  // k (x_hand − x_dev) + c (v_hand − v_dev) = (2, 0, −1) + (0, 2, 0) N.
  EXPECT_TRUE(s.handle_wrench.force.isApprox(Vec3(2.0, 2.0, -1.0), 1e-12));
  EXPECT_NEAR(s.handle_wrench.torque.norm(), 0.0, 1e-12);
  EXPECT_EQ(s.qdot.norm(), 0.0);
  numen::test::AllocationGuard guard;
  for (int i = 1; i <= 100; ++i) (void)hand.at_sync(i * 1'000'000LL, held);
  EXPECT_EQ(guard.count(), 0);
}
