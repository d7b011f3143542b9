#pragma once
/// @file device_binding.hpp
/// How an instrument's links and axes drive the bodies and joints of a god-object
/// (paper Eq. 6: one coupling target per body of an articulated tool; the paper's
/// imposed jaw opening), and how the bodies' feedback wrenches return to the links
/// (Eq. 8 per body, mapped to axis torques by τ = Σ_l J_lᵀ w_l).
/// Built at load time; read by the ControlLoop every period without allocation.

#include <vector>

#include "numen/core/types.hpp"

namespace numen::platform {

/// One body driven by one link of the instrument.
struct LinkBinding {
  int link = 0;    ///< Link index of the instrument's kinematics (0: the controlled frame).
  int body = -1;   ///< Body index; -1: whichever body is attached (Data::attached_body).
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
  /// Bodies driven by links. Empty: the legacy rigid binding {link 0 → the
  /// attached body, identity}.
  std::vector<LinkBinding> links;
  std::vector<AxisPrescription> prescriptions;

  /// The binding used when a scene says nothing: link 0 drives the attached body.
  static DeviceBinding rigid() { return DeviceBinding{{LinkBinding{}}, {}}; }
};

}  // namespace numen::platform
