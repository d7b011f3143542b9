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
///
/// Also FeedbackRamp: the device's soft start (`[device] soft_start`) for such a caller, who
/// renders Data::feedback_wrench itself.

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

  /// The pose the held body's centre-of-mass frame gets for the instrument sample `tool`
  /// (world): what set(tool, data) writes into Data::target — the frame Data::target (Python
  /// Data.set_target) takes — written to `pose` without setting anything. Returns false (and
  /// leaves `pose`) when data holds no body or no link of the binding drives the held body.
  bool held_body_target(const TrajectorySample& tool, const core::Data& data,
                        core::Pose& pose) const noexcept;

  /// The instrument's tool frame (the trajectory's frame: a trocar instrument's tip) in the held
  /// body's centre-of-mass frame when the instrument is at `tool`: held_body_target()⁻¹ ·
  /// tool.pose (position m and orientation, body frame). On the default and lattice scenes the
  /// tube's tip is (0, 0, 0.040) (its link_offset; the orientation is the recorded wrist, off
  /// the shaft by a sample's own angle); the identity on probe.toml (a pose tracker without
  /// offset). Returns false as held_body_target().
  bool tool_in_held_body(const TrajectorySample& tool, const core::Data& data,
                         core::Pose& pose) const noexcept;

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

/// The device's soft start for a caller that steps the scene itself and renders
/// Data::feedback_wrench (docs/scenes.md "Drive it from your own program"): `numen run`'s
/// device ramps its torques in over `[device] soft_start` (hal::ImpedanceDevice, 0.1 s by
/// default) at start-up and after each re-arm; core::step does not, so a first target 20 mm
/// from the held body gives the probe scene's full 4.2 N in the first step, and a target that
/// comes back after a dropout (held feedback, docs/safety.md "Invalid targets") jumps to the
/// new spring force in one step. apply(data) after each core::step returns the wrench to render:
///   w = (1 − r) · w_from + r · Data::feedback_wrench,  r = min(1, k · dt / soft_start_s),
/// k = 1, 2, … the steps since the ramp began (the hal device's r in its k-th write), w_from
/// the wrench rendered when it began: zero at start-up (the device's ramp), the held wrench
/// after a dropout (from the held force to the new one). A step flagged
/// core::kInvalidTarget renders the held wrench and (re)starts the ramp at the next valid
/// step. soft_start_s 0: apply() is Data::feedback_wrench. noexcept, allocation free.
class FeedbackRamp {
 public:
  /// Over `soft_start_s` (s, >= 0; Scene::device.soft_start_s, the scene's `[device]
  /// soft_start`) at steps of `dt` (s, > 0; the model's dt). Throws std::invalid_argument
  /// otherwise.
  FeedbackRamp(double soft_start_s, double dt);
  /// The ramp of `scene`: its device's soft start (0.1 s unless the scene says) at its dt.
  explicit FeedbackRamp(const Scene& scene);

  /// The wrench to render after the step that produced `data` (force N, torque N·m, world,
  /// about the held body's target point, as Data::feedback_wrench).
  core::Wrench apply(const core::Data& data) noexcept;
  /// Starts the ramp again from zero at the next apply() (a re-arm; after Data reset).
  void restart() noexcept;
  /// The factor r of the last apply() (1: the ramp is over, or soft_start_s is 0).
  double ramp() const noexcept { return ramp_; }

 private:
  double step_ = 0.0;   // dt / soft_start_s; 0: no ramp
  std::int64_t k_ = 0;  // steps since the ramp began; -1: begins at the next valid step
  double ramp_ = 1.0;
  core::Wrench from_, last_;  // rendered when the ramp began; rendered last
};

}  // namespace numen::sim
