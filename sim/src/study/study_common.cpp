/// @file study_common.cpp
/// Helpers shared by the studies (study_common.hpp).

#include "numen/sim/study/study_common.hpp"

#include <time.h>

#include <stdexcept>

#include "numen/core/features.hpp"

namespace numen::sim::study {

core::Model with_scheme(const core::Model& model, core::Integrator integrator, double dt,
                        const std::string& study) {
  core::Model m = model;
  m.integrator = integrator;
  m.dt = dt;
  const std::string err = core::finalize_model(m);
  if (!err.empty()) throw std::runtime_error(study + ": " + err);
  return m;
}

Scene load_replayed_scene(const std::string& path) {
  Scene scene = load_scene(path);
  scene.plant.reset();
  return scene;
}

double thread_cpu_seconds() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::string missing_parts(bool joints, bool nets) {
  if (joints && !core::kWithArticulation)
    return "needs joints: this build has NUMEN_WITH_ARTICULATION=OFF";
  if (nets && !core::kWithDeformable)
    return "needs deformable nets: this build has NUMEN_WITH_DEFORMABLE=OFF";
  return "";
}

const std::vector<core::Integrator>& all_integrators() {
  static const std::vector<core::Integrator> all = {core::Integrator::kLinearlyImplicitEuler,
                                                    core::Integrator::kSymplecticEuler,
                                                    core::Integrator::kTrapezoidal,
                                                    core::Integrator::kTrBdf2};
  return all;
}

}  // namespace numen::sim::study
