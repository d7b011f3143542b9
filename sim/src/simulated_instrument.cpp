/// @file simulated_instrument.cpp

#include "numen/sim/simulated_instrument.hpp"

#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"

namespace numen::sim {

SimulatedInstrument::SimulatedInstrument(const hal::DeviceConfig& config,
                                         const Trajectory& trajectory, std::int64_t start_ns)
    : config_(config),
      trajectory_(&trajectory),
      start_ns_(start_ns),
      kinematics_(hal::make_kinematics(config)),
      emulator_(config) {}

hal::AxisVector instrument_axes(const hal::DeviceConfig& config, const hal::Kinematics& kinematics,
                                const TrajectorySample& s) noexcept {
  if (config.kind == hal::DeviceKind::kTrocarInstrument)
    return static_cast<const hal::TrocarKinematics&>(kinematics).inverse_tool(s.pose, s.jaw);
  core::Pose controlled;  // tracked frame · tool_offset
  controlled.position = s.pose.position + s.pose.orientation * config.tool_offset.position;
  controlled.orientation = s.pose.orientation * config.tool_offset.orientation;
  return kinematics.inverse(controlled, hal::AxisVector());
}

hal::AxisVector SimulatedInstrument::axes_at(std::int64_t t_ns) const noexcept {
  return instrument_axes(config_, *kinematics_,
                         trajectory_->at(static_cast<double>(t_ns - start_ns_) * 1e-9));
}

core::Pose SimulatedInstrument::controlled_pose_at(std::int64_t t_ns) const noexcept {
  return kinematics_->forward(axes_at(t_ns));
}

int SimulatedInstrument::poll(hal::Bus& device_port, std::int64_t now_ns) noexcept {
  int handled = 0;
  hal::CanFrame frame;
  while (device_port.read(frame) == hal::IoStatus::kOk) {
    ++handled;
    if (emulator_.killed()) {
      emulator_.on_frame(frame, device_port);  // counted and discarded
      continue;
    }
    if (hal::is_sync(frame)) {
      if (start_at_sync_) {
        start_ns_ = frame.timestamp_ns;
        start_at_sync_ = false;
      }
      const hal::AxisVector q = axes_at(frame.timestamp_ns);
      emulator_.set_axis_values(q.data());
    }
    emulator_.on_frame(frame, device_port);
  }
  if (now_ns >= 0) emulator_.tick(now_ns, device_port);
  return handled;
}

}  // namespace numen::sim
