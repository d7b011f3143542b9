#pragma once
/// @file kinematics_factory.hpp
/// make_kinematics: the Kinematics a DeviceConfig describes (load time only).

#include <memory>

#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/kinematics.hpp"

namespace numen::hal {

/// Builds TrocarKinematics, PoseTrackerKinematics or PhantomKinematics from the config's kind,
/// geometry and tool offset. Allocates; throws std::invalid_argument if validate(config) does.
std::unique_ptr<Kinematics> make_kinematics(const DeviceConfig& config);

}  // namespace numen::hal
