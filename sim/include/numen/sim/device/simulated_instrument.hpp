#pragma once
/// @file simulated_instrument.hpp
/// The device side of a simulated run: a tracked instrument (hal::DeviceEmulator) whose
/// motion is either a hand replaying a recorded or scripted Trajectory (TrajectoryMotion: the
/// axes are where the trajectory puts them, whatever the torques) or, when the scene gives the
/// device's mechanics, the closed loop (PlantMotion: the device moves under the drives' torques
/// and the hand's pull toward the trajectory). On each SYNC the emulator asks the motion for the
/// axis values at the SYNC's bus time, and its emulated encoders answer with quantised position
/// PDOs; its drives receive the torque PDOs. The controller only ever sees the bus, as on
/// hardware.

#include <cstdint>
#include <memory>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/sim/input/trajectory.hpp"
#include "numen/sim/device/plant_motion.hpp"
#include "numen/sim/device/trajectory_motion.hpp"

namespace numen::sim {

/// A simulated instrument on the device port of a bus. Construction allocates
/// and may throw std::invalid_argument (invalid config); poll() is noexcept
/// and allocation free.
class SimulatedInstrument {
 public:
  /// `trajectory` is the world pose of the tool frame (trocar instrument: the
  /// tip, z along the shaft; pose tracker: the tracked frame) and must outlive
  /// this object. Time 0 of the trajectory is bus time `start_ns`.
  SimulatedInstrument(const SimulatedInstrument&) = delete;  // the emulator points at motion_
  SimulatedInstrument& operator=(const SimulatedInstrument&) = delete;
  SimulatedInstrument(const hal::DeviceConfig& config, const Trajectory& trajectory,
                      std::int64_t start_ns = 0);
  /// Closed loop when `plant` is set: the device's mechanics and the `hand` that holds it
  /// (PlantMotion; throws std::invalid_argument as it does). Replay when `plant` is null.
  SimulatedInstrument(const hal::DeviceConfig& config, const Trajectory& trajectory,
                      const DevicePlantSettings* plant, const HandSettings& hand,
                      std::int64_t start_ns = 0);

  /// Handles every frame pending on `device_port` (DeviceEmulator::poll()): a SYNC latches
  /// the axis values of the trajectory at the SYNC's timestamp and is answered by the
  /// encoders (and, managed stack, the drives); torque / drive RPDOs update
  /// last_torques(). Then, if `now_ns` >= 0 (bus time), the managed stack's
  /// time-driven part (DeviceEmulator::tick(): boot-ups, heartbeats, the
  /// drives' watch of the controller's heartbeat, EMCYs). Returns frames handled.
  int poll(hal::Bus& device_port, std::int64_t now_ns = -1) noexcept;
  /// Makes trajectory time 0 the timestamp of the next SYNC received (a device process on a
  /// real bus, `numen device`: the controller starts whenever it starts; bus time is
  /// CLOCK_MONOTONIC). Until that SYNC, axes_at() uses the start given at construction.
  void start_at_next_sync() noexcept {
    motion_.start_at_next_sync();
    if (plant_) plant_->start_at_next_sync();
  }
  /// Bus time (ns) at which the trajectory starts.
  std::int64_t start_ns() const noexcept { return motion_.start_ns(); }

  /// Axis values of the trajectory at bus time `t_ns` (m or rad).
  hal::AxisVector axes_at(std::int64_t t_ns) const noexcept;
  /// World pose of the controlled frame the instrument would report at `t_ns`
  /// without quantisation (forward kinematics of axes_at()).
  core::Pose controlled_pose_at(std::int64_t t_ns) const noexcept;

  /// Last torques received by the drives (N·m or N per axis).
  const hal::AxisVector& last_torques() const noexcept { return emulator_.last_torques(); }
  const hal::DeviceEmulator& emulator() const noexcept { return emulator_; }
  hal::DeviceEmulator& emulator() noexcept { return emulator_; }
  const hal::Kinematics& kinematics() const noexcept { return motion_.kinematics(); }
  /// The hand's sight (hand_servo.hpp) for the replay and the closed loop's intent; null:
  /// none. `servo` must outlive this object's use of it.
  void set_servo(const HandServo* servo) noexcept {
    motion_.set_servo(servo);
    if (plant_) plant_->set_servo(servo);
  }
  /// The hand's replayed motion (TrajectoryMotion; the intent in closed loop).
  const TrajectoryMotion& motion() const noexcept { return motion_; }
  /// The closed loop's device and hand, or null in replay.
  const PlantMotion* plant() const noexcept { return plant_.get(); }

 private:
  TrajectoryMotion motion_;
  std::unique_ptr<PlantMotion> plant_;
  hal::DeviceEmulator emulator_;
};

}  // namespace numen::sim
