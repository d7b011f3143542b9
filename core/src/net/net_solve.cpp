/// @file net_solve.cpp
/// Coupled linearly implicit Euler of the bodies and the deformable nets
/// (net_solve.hpp): the solve, dispatched to Eisenstat's SSOR CG without
/// joints (net_sweeps.cpp) or the arrowhead projected CG with joints
/// (net_arrowhead.cpp). The system's assembly is net_assembly.cpp.

#include "net/net_solve.hpp"

#include "net/net_terms.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/model.hpp"

namespace numen::core {

bool solve_net_system(const Model& model, Data& data) noexcept {
  data.solver_iterations = 0;
  data.solver_residual = 0.0;
#if NUMEN_WITH_ARTICULATION
  if (!model.joints.empty()) return detail::solve_net_arrowhead(model, data);
#endif
  return detail::solve_net_eisenstat(model, data);
}

}  // namespace numen::core
