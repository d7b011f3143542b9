#pragma once
/// @file hand.hpp
/// The simulated user's hand on an emulated device's handle (docs/device_plant.md "The hand"),
/// one model for both kinds of device: per Cartesian degree of freedom of the controlled frame,
/// a mass attached to the handle and a spring–damper pulling it toward where the hand means to
/// be (the scene trajectory, "the intent"):
///
///   F = k (x_i − x) + c (v_i − v)              (N, at the controlled frame's origin, world)
///   T = k_r log(q_i q⁻¹) + c_r (ω_i − ω)       (N·m, world)
///
/// with the hand's mass m and rotational inertia I_r added to the handle's (an impedance
/// device's PlantMotion adds them to its axes through the kinematics; an admittance device's
/// position-controlled drives do not feel them). This is the lumped second-order arm model
/// of the haptics literature (Hogan 1985; Colgate & Brown 1994 hold the operator to such a
/// mass–spring–damper). Defaults are of the order measured on relaxed human hands: Tsuji,
/// Morasso, Goto & Ito, "Human hand impedance characteristics during maintained posture",
/// Biol. Cybern. 72(6), 1995 (inertia tenths of a kg, viscosity a few N·s/m, stiffness a few
/// hundred N/m); Hasser & Cutkosky, "System identification of the human hand grasping a haptic
/// knob", Haptics Symposium 2002 (pinch grasp: rotational stiffness below 1 N·m/rad).

#include <string>

#include "numen/core/types.hpp"

namespace numen::sim {

/// The hand (scene `[device.hand]`; docs/scenes.md). All finite and >= 0.
struct HandSettings {
  double mass = 0.3;                   ///< m, kg.
  double stiffness = 200.0;            ///< k, N/m.
  double damping = 5.0;                ///< c, N·s/m.
  double rotational_inertia = 2e-5;    ///< I_r, kg·m².
  double rotational_stiffness = 0.5;   ///< k_r, N·m/rad.
  double rotational_damping = 0.01;    ///< c_r, N·m·s/rad.
};

/// Throws std::invalid_argument "`who`: hand <key> must be finite and >= 0 (got v)" for the
/// first setting out of range (keys as in the scene file: mass, stiffness, damping,
/// rotational_inertia, rotational_stiffness, rotational_damping).
void validate(const HandSettings& hand, const std::string& who);

/// The hand's spring–damper wrench on the handle (see the file comment), world, at the
/// controlled frame's origin: `intent` and `intent_twist` where the hand means to be and how it
/// moves, `handle` and `handle_twist` where the handle is. The mass is not in it (it is
/// inertia the handle carries). noexcept, no allocation.
core::Wrench hand_wrench(const HandSettings& hand, const core::Pose& intent,
                         const core::Twist& intent_twist, const core::Pose& handle,
                         const core::Twist& handle_twist) noexcept;

}  // namespace numen::sim
