#pragma once
/// @file trajectory_motion.hpp
/// The motion of an emulated impedance instrument driven by a recorded or scripted hand
/// (hal::DeviceMotion of hal::DeviceEmulator): at each SYNC the axes are where the
/// trajectory puts the tool at the SYNC's bus time, through the instrument's inverse
/// kinematics (instrument_axes()), whatever torques the drives hold — the hand is taken to be
/// rigid and the device massless. Construction allocates; the rest is noexcept and
/// allocation free.

#include <cstdint>
#include <memory>

#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/emulation/device_motion.hpp"
#include "numen/sim/input/trajectory.hpp"

namespace numen::sim {

class HandServo;  // hand_servo.hpp

/// Axis values (m or rad) that put an instrument of `config` (with its `kinematics`, built
/// from the same config) at the tool-frame pose of `sample`: trocar instrument — inverse
/// kinematics of the tip through the trocar, jaw from the sample; pose tracker — inverse
/// kinematics of the tracked frame · tool_offset. noexcept, no allocation.
hal::AxisVector instrument_axes(const hal::DeviceConfig& config, const hal::Kinematics& kinematics,
                                const TrajectorySample& sample) noexcept;

/// A hand replaying a trajectory on an impedance instrument (see the file comment).
class TrajectoryMotion final : public hal::DeviceMotion {
 public:
  /// `trajectory` is the world pose of the tool frame (trocar instrument: the tip, z along the
  /// shaft; pose tracker: the tracked frame) and must outlive this object. Time 0 of the
  /// trajectory is bus time `start_ns`. Throws std::invalid_argument for a bad `config`.
  TrajectoryMotion(const hal::DeviceConfig& config, const Trajectory& trajectory,
                   std::int64_t start_ns = 0);
  const hal::DeviceMotionState& at_sync(std::int64_t t_ns,
                                        const hal::DriveCommands& commands) noexcept override;
  /// Makes trajectory time 0 the time of the next SYNC (a device process on a real bus).
  void start_at_next_sync() noexcept { start_at_sync_ = true; }
  /// Bus time (ns) at which the trajectory starts.
  std::int64_t start_ns() const noexcept { return start_ns_; }
  /// Axis values of the trajectory at bus time `t_ns` (m or rad), the tool frame moved by the
  /// servo's offset where one is set.
  hal::AxisVector axes_at(std::int64_t t_ns) const noexcept;
  const hal::Kinematics& kinematics() const noexcept { return *kinematics_; }
  /// The hand's sight (hand_servo.hpp): its offset() moves the trajectory's tool position from
  /// the next SYNC on; null: none. `servo` must outlive this object's use of it.
  void set_servo(const HandServo* servo) noexcept { servo_ = servo; }

 private:
  hal::DeviceConfig config_;
  const Trajectory* trajectory_;
  const HandServo* servo_ = nullptr;
  std::int64_t start_ns_;
  bool start_at_sync_ = false;
  std::unique_ptr<hal::Kinematics> kinematics_;
  hal::DeviceMotionState state_;
};

}  // namespace numen::sim
