#pragma once
/// @file device_binding.hpp
/// How an instrument's links and axes drive the bodies and joints of a god-object
/// (paper Eq. 6: one coupling target per body of an articulated tool; the paper's
/// imposed jaw opening), and how the bodies' feedback wrenches return to the links
/// (Eq. 8 per body, mapped to axis torques by τ = Σ_l J_lᵀ w_l).
/// Built at load time; read by the ControlLoop every period without allocation.

#include <cstdint>
#include <span>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/types.hpp"

namespace numen::platform {

/// One body driven by one link of the instrument.
struct LinkBinding {
  int link = 0;    ///< Link index of the instrument's kinematics (0: the controlled frame).
  int body = -1;   ///< Body index; -1: whichever body is held (Data::held_body).
  /// Pose of the body's COM frame in the link frame: target = link_pose · body_in_link.
  core::Pose body_in_link;
};

/// One prescribed joint driven by one axis: value = scale · q[axis] + offset,
/// rate = scale · q̇[axis] (paper §5: the jaw opening is imposed from the device).
struct AxisPrescription {
  int joint = 0;        ///< Joint index (JointModel::prescribed must be true).
  int axis = 0;         ///< Axis index of the instrument.
  double scale = 1.0;   ///< Joint units per axis unit.
  double offset = 0.0;  ///< Joint units.
};

/// The wiring between one instrument and one core::Data.
struct DeviceBinding {
  /// Bodies driven by links. Empty with no prescriptions either (is_default_rigid()): the legacy
  /// rigid binding {link 0 → the held body, identity}; empty with prescriptions: a device that
  /// drives joints only, no body.
  std::vector<LinkBinding> links;
  std::vector<AxisPrescription> prescriptions;

  /// The binding used when a scene says nothing: link 0 drives the held body.
  static DeviceBinding rigid() { return DeviceBinding{{LinkBinding{}}, {}}; }
};

/// True when `b` says nothing (no link, no prescription): the control loop then drives the held
/// body by the rigid binding (DeviceBinding::rigid()).
inline bool is_default_rigid(const DeviceBinding& b) noexcept {
  return b.links.empty() && b.prescriptions.empty();
}

/// Per body of a model of `num_bodies` bodies: 1 if a link binding of `binding` names it
/// (LinkBinding::body ≥ 0), else 0. Load time (allocates). Throws std::invalid_argument if a
/// body is bound to two links or a binding names a body out of [0, num_bodies).
std::vector<std::uint8_t> explicitly_bound_bodies(const DeviceBinding& binding, int num_bodies);

/// The body `b` drives in `d` this period, −1 for none: its own body, or, for the "held"
/// binding (body −1), the held body (Data::held_body) unless that body has a link of its
/// own (`explicit_bound`, from explicitly_bound_bodies()), which it then follows (tool
/// switching). Real-time safe.
int bound_body(const LinkBinding& b, const core::Data& d,
               std::span<const std::uint8_t> explicit_bound) noexcept;

/// The coupling target of the body bound by `b` while its link is at `link` (world frame) with
/// twist `link_twist` (ω in rad/s, the link origin's velocity in m/s, world frame): pose =
/// link · body_in_link; twist = (ω, v_link + ω × (p_body − p_link)), the rigid transfer of the
/// link's twist to the body's origin (paper Eq. 6's target per body).
void body_target_of(const LinkBinding& b, const core::Pose& link, const core::Twist& link_twist,
                    core::Pose& pose, core::Twist& twist) noexcept;

/// Sets body `body`'s coupling target in `d`: Data::target and Data::target_twist for the
/// held body, its BodyTarget (enabled) for any other. `body` must be in range.
void set_body_target(core::Data& d, int body, const core::Pose& pose, const core::Twist& twist) noexcept;

/// One link binding's share of a period (the control loop's and sim::InstrumentTargets'): the
/// body `b` drives in `d` (bound_body()) gets the target of its link, at pose `link` with twist
/// `link_twist` (world; body_target_of(), set_body_target()). Returns that body, −1 for none
/// (then nothing is set). `body_point`, if not null, receives the target's position (m, world:
/// the point its feedback is about), set even when no body is driven. Real-time safe.
int apply_link_target(const LinkBinding& b, const core::Pose& link, const core::Twist& link_twist,
                      core::Data& d, std::span<const std::uint8_t> explicit_bound,
                      core::Vec3* body_point) noexcept;

/// A prescribed joint's coordinate from its axis value `q` and rate `qdot` (m or rad, and per
/// s): Data::joint_prescribed[p.joint] = {scale · q + offset, scale · qdot}. Real-time safe.
void apply_prescription(const AxisPrescription& p, double q, double qdot, core::Data& d) noexcept;

}  // namespace numen::platform
