#pragma once
/// @file plant_motion.hpp
/// The motion of an emulated impedance device that moves under numen's torques
/// (hal::DeviceMotion of hal::DeviceEmulator; docs/device_plant.md): the haptic loop closed.
/// Each axis is an AxisPlant (inertia, viscous damping, Karnopp friction, the drive's torque held
/// and delayed, current loop, saturation); the hand of hand.hpp holds the handle and pulls it
/// toward the trajectory (the intent), through the device kinematics:
///
///   (m_i + (Jᵀ M_h J)_ii) q̈_i = τ_i + (Jᵀ W_h)_i − b_i q̇_i − f_f,i
///
/// with W_h = hand_wrench(intent, handle) at the controlled frame and M_h = diag(m, m, m, I_r,
/// I_r, I_r) the hand's inertia (its diagonal in axis space: the hand's coupling of two axes
/// through its mass is left out). The hand's damping on an axis's own rate is integrated with
/// the axis's (implicit); the rest of the wrench is held over each sub-step. An axis of
/// inertia 0 follows the intent exactly (as in replay: e.g. a trocar's jaw, a PHANToM's
/// undriven gimbal).
///
/// Between two SYNCs (period T) the drives hold the torque they last received: the plant steps
/// to the instant the controller's torque frames arrive (`torque_phase_s` after the SYNC, the
/// scene's compute phase), takes them, and steps to the next SYNC, in `substeps` steps per
/// control period spanned in all (sub-steps of equal length within each part; see
/// kMaxSyncGapS for a silent bus). The encoders then latch q (the emulator quantises it to
/// counts).
///
/// Also measured here, where the physics is exact (figures()): the energy that flowed into the
/// device from the hand (the one-port of Colgate & Schenkel 1997 and of the passivity observer
/// of Hannaford & Ryu 2002, evaluated on the emulator's true state), the force felt at the
/// handle, the hand–handle separation, limit cycles (LimitCycleDetector below) and divergence.
/// Construction allocates and throws std::invalid_argument; at_sync() is noexcept and
/// allocation free.

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/emulation/device_motion.hpp"
#include "numen/sim/device/axis_plant.hpp"
#include "numen/sim/device/hand.hpp"
#include "numen/sim/input/trajectory.hpp"

namespace numen::sim {

class HandServo;  // hand_servo.hpp

/// Most sub-steps per control period a plant takes.
inline constexpr int kMaxPlantSubsteps = 1000;
/// A silence of the bus longer than this (s) between two SYNCs restarts the emulated device at
/// rest where the hand means it to be (a controller that stopped and started again); shorter
/// intervals are integrated with `substeps` per control period they span.
inline constexpr double kMaxSyncGapS = 1.0;

/// An impedance device's mechanics (scene `[device.plant]`; docs/scenes.md).
struct DevicePlantSettings {
  /// One per device axis, in axis order; inertia 0: the axis follows the intent exactly.
  std::vector<AxisPlantSettings> axes;
  int substeps = 10;            ///< Sub-steps per control period, 1 .. kMaxPlantSubsteps.
  double torque_phase_s = 0.0;  ///< When the new torque reaches the drives after a SYNC, s, >= 0.
};

/// Sustained oscillation of the handle (docs/device_plant.md "Limit cycles"): the handle's
/// position relative to the intent, high-passed at kHighPassHz (first order) per Cartesian
/// component, crosses ±kBandM (hysteresis) at least kMinCrossings times in each of kBlocks
/// consecutive blocks of kBlockS. Amplitude: the block's peak |high-passed| (m); frequency:
/// crossings / (2 × kBlockS).
class LimitCycleDetector {
 public:
  static constexpr double kHighPassHz = 5.0;
  static constexpr double kBandM = 5e-5;  ///< 0.05 mm
  static constexpr double kBlockS = 0.2;
  static constexpr int kMinCrossings = 4;  ///< ≥ 2 full cycles per block: ≥ 10 Hz
  static constexpr int kBlocks = 3;

  /// Feeds the relative position `e` (m, world) at time `t_s`, sampled every `dt_s`.
  void add(const core::Vec3& e, double t_s, double dt_s) noexcept;
  bool detected() const noexcept { return detected_; }
  double amplitude_m() const noexcept { return amplitude_m_; }  ///< Largest over the detection.
  double frequency_hz() const noexcept { return frequency_hz_; }
  double time_s() const noexcept { return time_s_; }  ///< When first detected.

 private:
  bool primed_ = false;
  core::Vec3 last_e_ = core::Vec3::Zero();
  core::Vec3 y_ = core::Vec3::Zero();
  std::array<int, 3> side_{};       // -1, 0, +1: last band side
  std::array<int, 3> crossings_{};  // in the current block
  double block_start_s_ = 0.0;
  double block_peak_m_ = 0.0;
  int run_ = 0;                     // consecutive blocks that qualified
  bool detected_ = false;
  double amplitude_m_ = 0.0, frequency_hz_ = 0.0, time_s_ = 0.0;
};

/// What PlantMotion measured since the start.
struct PlantFigures {
  double port_energy_j = 0.0;         ///< ∫ W_h · V dt: energy the hand put into the device, J.
  double port_energy_min_j = 0.0;     ///< Its minimum (<= 0), J.
  double port_energy_min_time_s = 0.0;  ///< When (trajectory time), s.
  double handle_force_max_n = 0.0;    ///< Largest |force of the hand on the handle|, N.
  double handle_force_n = 0.0;        ///< The same at the last sub-step, N.
  double hand_separation_max_mm = 0.0;  ///< Largest |x_intent − x_handle|, mm.
  LimitCycleDetector limit_cycle;
  bool diverged = false;              ///< A non-finite or runaway axis (the plant then holds).
  int diverged_axis = -1;             ///< That axis (its index in the device's axes).
  double diverged_time_s = 0.0;       ///< When (trajectory time), s.
  /// Its |speed| then, m/s or rad/s (+inf where its value is not finite).
  double diverged_speed = 0.0;
  /// Its runaway speed, m/s or rad/s: 100 × its max_speed (10³ without one).
  double diverged_speed_limit = 0.0;
};

/// An impedance device with mechanics and a hand (see the file comment).
class PlantMotion final : public hal::DeviceMotion {
 public:
  /// `trajectory` (the tool frame's intent, as TrajectoryMotion takes it) must outlive this
  /// object; its time 0 is bus time `start_ns`. Throws std::invalid_argument for a bad config,
  /// a plant setting out of range (naming the axis) or a hand setting (validate()).
  PlantMotion(const hal::DeviceConfig& config, const DevicePlantSettings& plant,
              const HandSettings& hand, const Trajectory& trajectory, std::int64_t start_ns = 0);
  const hal::DeviceMotionState& at_sync(std::int64_t t_ns,
                                        const hal::DriveCommands& commands) noexcept override;
  /// Makes trajectory time 0 the time of the next SYNC (a device process on a real bus).
  void start_at_next_sync() noexcept { start_at_sync_ = true; }
  std::int64_t start_ns() const noexcept { return start_ns_; }
  /// Axis values of the intent at the last SYNC (m or rad; empty before the first).
  const hal::AxisVector& intent_axes() const noexcept { return intent_; }
  const hal::Kinematics& kinematics() const noexcept { return *kinematics_; }
  const PlantFigures& figures() const noexcept { return figures_; }
  /// The hand's sight (hand_servo.hpp): its offset() moves the intent's tool position from the
  /// next SYNC on; null: none. `servo` must outlive this object's use of it.
  void set_servo(const HandServo* servo) noexcept { servo_ = servo; }
  /// The state of the last SYNC.
  const hal::DeviceMotionState& state() const noexcept { return state_; }
  const AxisPlant& axis(int i) const noexcept { return plants_[static_cast<std::size_t>(i)]; }

 private:
  /// Steps the plant `parts` sub-steps over [t0, t1] (trajectory time, s).
  void advance(double t0, double t1, int parts) noexcept;
  /// Axis values of the intent at trajectory time `t` (s).
  hal::AxisVector intent_at(double t) const noexcept;
  /// q (and q̇) from the plant axes, the follower axes at intent_.
  void gather() noexcept;

  hal::DeviceConfig config_;
  DevicePlantSettings settings_;
  HandSettings hand_;
  const Trajectory* trajectory_;
  const HandServo* servo_ = nullptr;
  std::int64_t start_ns_;
  bool start_at_sync_ = false;
  std::unique_ptr<hal::Kinematics> kinematics_;
  std::vector<AxisPlant> plants_;   // one per axis (unused where inertia is 0)
  std::array<bool, hal::kMaxAxes> follows_{};
  hal::DeviceMotionState state_;
  hal::AxisVector intent_;          // the intent's axis values at the last SYNC
  bool had_sync_ = false;
  std::int64_t last_sync_ns_ = 0;
  PlantFigures figures_;
};

}  // namespace numen::sim
