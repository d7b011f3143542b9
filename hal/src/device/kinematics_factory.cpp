/// @file kinematics_factory.cpp
/// The Kinematics of a DeviceConfig.

#include "numen/hal/device/kinematics_factory.hpp"

#include "numen/hal/device/phantom_kinematics.hpp"
#include "numen/hal/device/pose_tracker_kinematics.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"

namespace numen::hal {

std::unique_ptr<Kinematics> make_kinematics(const DeviceConfig& config) {
  validate(config);
  switch (config.kind) {
    case DeviceKind::kPoseTracker:
      return std::make_unique<PoseTrackerKinematics>(config.tracker, config.tool_offset);
    case DeviceKind::kPhantom:
      return std::make_unique<PhantomKinematics>(config.phantom, config.tool_offset);
    case DeviceKind::kTrocarInstrument:
      break;
  }
  return std::make_unique<TrocarKinematics>(config.trocar, config.tool_offset);
}

}  // namespace numen::hal
