#pragma once
/// @file integrator.hpp
/// Time integration of the rigid bodies (paper Eq. 1, §5): linearly implicit
/// Euler with the stiffness and damping Jacobians of coupling springs and
/// contacts, and symplectic Euler as the explicit baseline.

#include <vector>

#include <Eigen/Core>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Scratch of the integrator, sized once by resize().
struct SolverScratch {
  /// Sizes every buffer for `model`. Allocates: make_data() only.
  void resize(const Model& model);
};

}  // namespace numen::core
