/// @file hand.cpp
/// The simulated user's hand: a spring–damper toward the intent (hand.hpp).

#include "numen/sim/device/hand.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "numen/core/rigid_body.hpp"

namespace numen::sim {

void validate(const HandSettings& h, const std::string& who) {
  const std::pair<const char*, double> values[] = {
      {"mass", h.mass},
      {"stiffness", h.stiffness},
      {"damping", h.damping},
      {"rotational_inertia", h.rotational_inertia},
      {"rotational_stiffness", h.rotational_stiffness},
      {"rotational_damping", h.rotational_damping}};
  for (const auto& [key, v] : values) {
    if (std::isfinite(v) && v >= 0.0) continue;
    std::ostringstream m;
    m << who << ": hand " << key << " must be finite and >= 0 (got " << v << ")";
    throw std::invalid_argument(m.str());
  }
}

core::Wrench hand_wrench(const HandSettings& h, const core::Pose& intent,
                         const core::Twist& intent_twist, const core::Pose& handle,
                         const core::Twist& handle_twist) noexcept {
  core::Wrench w;
  w.force = h.stiffness * (intent.position - handle.position) +
            h.damping * (intent_twist.linear - handle_twist.linear);
  w.torque = h.rotational_stiffness *
                 core::quat_log(intent.orientation * handle.orientation.conjugate()) +
             h.rotational_damping * (intent_twist.angular - handle_twist.angular);
  return w;
}

}  // namespace numen::sim
