#pragma once
/// @file instrument_targets.hpp
/// InstrumentTargets: an instrument sample (the world pose of its tool frame and its jaw, as
/// Scene::trajectory gives it, or the axis values) turned into the targets of a core::Data —
/// the held body's Data::target (its centre-of-mass frame), every other linked body's
/// Data::body_targets entry and every prescribed joint's Data::joint_prescribed — through the
/// scene's device kinematics (trocar, tool offset) and binding (the bodies' `link` and
/// `link_offset`, the joints' `prescribed`): what `numen run`'s control loop does each period
/// from the decoded encoders (platform::ControlLoop), for a caller that steps the scene itself
/// (docs/scenes.md "Drive it from your own program"; the Python module's Data.set_targets_at).
///
/// The tool frame is not the held body's frame: on the default scene the trajectory's sample is
/// the instrument's tip, 40 mm ahead of the tube's centre of mass along the shaft, and its
/// orientation keeps the recorded wrist, 16.5° off the shaft through the trocar at t = 0.
/// Construction allocates; the rest is noexcept and allocation free.

#include <cstdint>
#include <memory>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/platform/device_binding.hpp"
#include "numen/sim/input/trajectory.hpp"

namespace numen::sim {

struct Scene;

/// Targets of a scene's bodies and prescribed joints from instrument samples (see the file
/// comment). The Data given to the setters must be one of the scene's model
/// (core::make_data(scene.model)).
class InstrumentTargets {
 public:
  /// The device (Scene::device, its kinematics), binding (Scene::binding; the rigid binding
  /// link 0 → held body when it binds nothing) and model size of `scene`, copied: the object
  /// does not refer to the scene. A scene without [device] (Scene::has_device false) has the
  /// identity pose tracker: the sample is the held body's target. Throws
  /// std::invalid_argument for a binding that does not fit the model (a scene load has checked
  /// it).
  explicit InstrumentTargets(const Scene& scene);

  /// Axis values (m or rad; the device's order, DeviceConfig::axes) that put the instrument's
  /// tool frame at `tool` (sim::instrument_axes(): the trocar instrument's inverse kinematics
  /// of the tip through the trocar, jaw from the sample, the recorded wrist dropped).
  hal::AxisVector axes(const TrajectorySample& tool) const noexcept;

  /// Sets the targets of an instrument at axis values `q` moving at rates `qdot` (m/s, rad/s;
  /// both num_axes() long): each bound body's target is its link's pose · link_offset, with the
  /// link's twist J_l q̇ carried to the body's centre of mass; each prescribed joint's
  /// coordinate is scale · q + offset, its rate scale · q̇.
  void set(const hal::AxisVector& q, const hal::AxisVector& qdot, core::Data& data) const noexcept;

  /// set() at the axes of `tool`, at rest (q̇ = 0: the coupling's damping then pulls the bodies
  /// towards rest; give the next sample for the rates).
  void set(const TrajectorySample& tool, core::Data& data) const noexcept;

  /// set() at the axes of `tool`, the rates the forward difference of the axes towards `later`,
  /// `interval` s after it (angles wrapped; interval > 0, else at rest).
  void set(const TrajectorySample& tool, const TrajectorySample& later, double interval,
           core::Data& data) const noexcept;

  /// set() from `trajectory` at time t (s): the sample at t and, for the rates, the one a
  /// period later (Trajectory::period(); at rest past its end) — the difference that
  /// Trajectory::twist_at() takes for the tool frame.
  void set_at(const Trajectory& trajectory, double t, core::Data& data) const noexcept;

  /// Number of axes of the device.
  int num_axes() const noexcept { return kinematics_->num_axes(); }
  /// The device's kinematics (controlled frame = tool frame · tool_offset).
  const hal::Kinematics& kinematics() const noexcept { return *kinematics_; }

 private:
  hal::DeviceConfig config_;
  std::unique_ptr<hal::Kinematics> kinematics_;
  platform::DeviceBinding binding_;
  std::vector<std::uint8_t> explicit_bound_;
};

}  // namespace numen::sim
