#pragma once
/// @file study_common.hpp
/// Helpers shared by the studies (`numen study accuracy`, `numen study stability`): a model
/// re-compiled with another integrator and time step, the thread CPU clock, the list of the
/// core's integrators. Study code: allocates and throws; not real-time.

#include <string>
#include <vector>

#include "numen/core/model.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim::study {

/// `model` with `integrator` and time step `dt` (s), finalized again. Throws
/// std::runtime_error("<study>: <finalize_model message>") if finalize_model() refuses it
/// (e.g. the trapezoidal rule with first-order coupling).
core::Model with_scheme(const core::Model& model, core::Integrator integrator, double dt,
                        const std::string& study);

/// The scene at `path` (load_scene()) in replay: without its `[device.plant]`, so that the
/// emulated device reads the hand's recorded pose whatever the torques. The stability study
/// measures the simulation against the hand's motion; the closed loop's device is what
/// `numen study passivity` measures (docs/studies.md).
Scene load_replayed_scene(const std::string& path);

/// Thread CPU time (s), CLOCK_THREAD_CPUTIME_ID.
double thread_cpu_seconds() noexcept;

/// Why a study case cannot run in this build (CMake options NUMEN_WITH_*, features.hpp):
/// "" when it can, else e.g. "needs joints: this build has NUMEN_WITH_ARTICULATION=OFF".
/// `joints`, `nets`: whether the case's model has joints / deformable nets.
std::string missing_parts(bool joints, bool nets);

/// The core's integrators in the order the studies report them: linearly implicit Euler,
/// symplectic Euler, linearised trapezoidal rule, linearised TR-BDF2.
const std::vector<core::Integrator>& all_integrators();

}  // namespace numen::sim::study
