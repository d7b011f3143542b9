#pragma once
/// @file net_states.hpp
/// Helpers of the tests of deformable nets: an `int` node index as the `std::size_t` the
/// arrays take, and a deterministic perturbation of every node's state. Header-only; needs
/// numen::core only.

#include <cmath>
#include <cstddef>

#include "numen/core/data.hpp"

namespace numen::test {

/// `i` as an array index.
inline std::size_t at(int i) { return static_cast<std::size_t>(i); }

/// Moves node i by dx · u(i) (m) and changes its velocity by dv · v(i) (m/s), with u, v
/// fixed, non-degenerate directions of the node's index (a smooth, repeatable perturbation).
inline void perturb_nodes(core::Data& d, double dx, double dv) {
  for (std::size_t i = 0; i < d.nodes.size(); ++i) {
    const double s = static_cast<double>(i) + 1.0;
    d.nodes[i].position += dx * core::Vec3(std::sin(1.3 * s), std::cos(2.1 * s), std::sin(0.7 * s + 1.0));
    d.nodes[i].velocity += dv * core::Vec3(std::cos(1.7 * s), std::sin(2.9 * s), std::cos(0.3 * s));
  }
}

}  // namespace numen::test
