/// @file soft_peer_mapping.cpp
/// numen's net constants in Bullet's terms (soft_peer_mapping.hpp).

#include "soft_peer_mapping.hpp"

#include <cmath>
#include <stdexcept>

namespace numen::soft_peer {

double link_stiffness_fraction(double k, double mu, double dt, int iterations) {
  if (!(k >= 0.0) || !(mu > 0.0) || !(dt > 0.0) || iterations < 1)
    throw std::invalid_argument("link_stiffness_fraction: k >= 0, mu > 0, dt > 0, iterations >= 1");
  const double remain = mu / (mu + k * dt * dt);
  return 1.0 - std::pow(remain, 1.0 / iterations);
}

TieStep numen_tie_step(double k_tie, double gamma_tie, double m, double dt) {
  const double d = m + gamma_tie * dt + k_tie * dt * dt;
  return {m / d, k_tie * dt * dt / d};
}

TieStep bullet_anchor_step(double hardness, double influence, int iterations) {
  const double a = 1.0 - influence * (1.0 + hardness);
  const double an = std::pow(a, iterations);
  // Σ_{j<n} a^j = (1 − a^n) / (1 − a); n when a = 1 (no influence: nothing pulled).
  const double sum = std::abs(1.0 - a) > 1e-15 ? (1.0 - an) / (1.0 - a) : static_cast<double>(iterations);
  return {an, influence * hardness * sum};
}

AnchorMapping anchor_mapping(double k_tie, double gamma_tie, double m, double dt, int iterations) {
  if (!(k_tie > 0.0) || !(gamma_tie > 0.0) || !(m > 0.0) || !(dt > 0.0) || iterations < 1)
    throw std::invalid_argument(
        "anchor_mapping: k_tie > 0, gamma_tie > 0, m > 0, dt > 0, iterations >= 1");
  AnchorMapping out;
  out.hardness = k_tie * dt / gamma_tie;
  const double retain = numen_tie_step(k_tie, gamma_tie, m, dt).retain;
  out.influence = (1.0 - std::pow(retain, 1.0 / iterations)) / (1.0 + out.hardness);
  return out;
}

}  // namespace numen::soft_peer
