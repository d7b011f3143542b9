/// @file soft_constraint_mapping.cpp
/// numen springs → MuJoCo solref/solimp (see the header for the derivation).

#include "soft_constraint_mapping.hpp"

#include <mujoco/mjmodel.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace numen::peer {

SoftConstraint match_spring(double k, double c, double mass, double dt) {
  if (!(k > 0.0) || !std::isfinite(k))
    throw std::invalid_argument("match_spring: stiffness k = " + std::to_string(k));
  if (!(c >= 0.0) || !std::isfinite(c))
    throw std::invalid_argument("match_spring: damping c = " + std::to_string(c));
  if (!(mass > 0.0) || !std::isfinite(mass))
    throw std::invalid_argument("match_spring: mass = " + std::to_string(mass));
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw std::invalid_argument("match_spring: dt = " + std::to_string(dt));
  const double omega2 = k / mass;
  SoftConstraint s;
  s.impedance = std::clamp(1.0 - 1.0 / (4.0 * omega2 * dt * dt), kMinImpedance, mjMAXIMP);
  s.stiffness = (1.0 - s.impedance) * omega2;
  const double zeta = c / (2.0 * std::sqrt(k * mass));
  s.damping = 2.0 * zeta * std::sqrt(s.stiffness);
  return s;
}

double static_stiffness(const SoftConstraint& s, double mass) noexcept {
  return s.stiffness * mass / (1.0 - s.impedance);
}

}  // namespace numen::peer
