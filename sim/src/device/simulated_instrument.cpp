/// @file simulated_instrument.cpp

#include "numen/sim/device/simulated_instrument.hpp"

namespace numen::sim {

SimulatedInstrument::SimulatedInstrument(const hal::DeviceConfig& config,
                                         const Trajectory& trajectory, std::int64_t start_ns)
    : motion_(config, trajectory, start_ns), emulator_(config) {
  emulator_.set_motion(&motion_);
}

SimulatedInstrument::SimulatedInstrument(const hal::DeviceConfig& config,
                                         const Trajectory& trajectory,
                                         const DevicePlantSettings* plant,
                                         const HandSettings& hand, std::int64_t start_ns)
    : motion_(config, trajectory, start_ns), emulator_(config) {
  if (plant) plant_ = std::make_unique<PlantMotion>(config, *plant, hand, trajectory, start_ns);
  emulator_.set_motion(plant_ ? static_cast<hal::DeviceMotion*>(plant_.get()) : &motion_);
}

hal::AxisVector SimulatedInstrument::axes_at(std::int64_t t_ns) const noexcept {
  return motion_.axes_at(t_ns);
}

core::Pose SimulatedInstrument::controlled_pose_at(std::int64_t t_ns) const noexcept {
  return motion_.kinematics().forward(axes_at(t_ns));
}

int SimulatedInstrument::poll(hal::Bus& device_port, std::int64_t now_ns) noexcept {
  const int handled = emulator_.poll(device_port, 1 << 30);
  if (now_ns >= 0) emulator_.tick(now_ns, device_port);
  return handled;
}

}  // namespace numen::sim
