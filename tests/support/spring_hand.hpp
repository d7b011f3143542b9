#pragma once
// A hal::DeviceMotion for the platform tests of an admittance device (the real one,
// sim::AdmittanceHand, lives above platform): ideal csp drives — an enabled axis is at its
// target at the SYNC, a disabled one holds — and a hand on a linear and a rotational spring
// with dampers at the controlled frame, F = k (x_hand − x) + c (0 − v), T = k_r log(q_hand q⁻¹)
// − c_r ω.

#include <cstdint>
#include <memory>

#include "numen/core/rigid_body.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/hal/emulation/device_motion.hpp"

namespace numen::test {

struct SpringHand final : hal::DeviceMotion {
  SpringHand(const hal::DeviceConfig& config, double k, double c, double k_rot, double c_rot)
      : kinematics(hal::make_kinematics(config)), k(k), c(c), k_rot(k_rot), c_rot(c_rot) {
    state.q = hal::AxisVector::Zero(kinematics->num_axes());
    state.qdot = hal::AxisVector::Zero(kinematics->num_axes());
  }
  const hal::DeviceMotionState& at_sync(std::int64_t t_ns,
                                        const hal::DriveCommands& cmd) noexcept override {
    const double dt = had_sync ? static_cast<double>(t_ns - last_ns) * 1e-9 : 0.0;
    had_sync = true;
    last_ns = t_ns;
    for (int i = 0; i < state.q.size(); ++i) {
      const bool on = cmd.enabled[static_cast<std::size_t>(i)] != 0 && dt > 0.0;
      state.qdot[i] = on ? (cmd.position_target[i] - state.q[i]) / dt : 0.0;
      if (on) state.q[i] = cmd.position_target[i];
    }
    const core::Pose x = kinematics->forward(state.q);
    const core::Vec6 v = kinematics->jacobian(state.q) * state.qdot;
    state.handle_wrench.force = k * (hand.position - x.position) - c * v.head<3>();
    state.handle_wrench.torque =
        k_rot * core::quat_log(hand.orientation * x.orientation.conjugate()) - c_rot * v.tail<3>();
    return state;
  }
  std::unique_ptr<hal::Kinematics> kinematics;
  double k, c, k_rot, c_rot;
  core::Pose hand;  ///< Where the hand holds the handle (world).
  hal::DeviceMotionState state;
  std::int64_t last_ns = 0;
  bool had_sync = false;
};

}  // namespace numen::test
