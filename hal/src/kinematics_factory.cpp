/// @file kinematics_factory.cpp
/// The Kinematics of a DeviceConfig.

#include "numen/hal/kinematics_factory.hpp"

#include "numen/hal/pose_tracker_kinematics.hpp"
#include "numen/hal/trocar_kinematics.hpp"

namespace numen::hal {

std::unique_ptr<Kinematics> make_kinematics(const DeviceConfig& config) {
  validate(config);
  if (config.kind == DeviceKind::kPoseTracker) {
    return std::make_unique<PoseTrackerKinematics>(config.tracker, config.tool_offset);
  }
  return std::make_unique<TrocarKinematics>(config.trocar, config.tool_offset);
}

}  // namespace numen::hal
