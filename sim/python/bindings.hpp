#pragma once
/// @file bindings.hpp
/// The parts of the Python module `numen` (docs/python.md), one function per source file,
/// called in this order by numen_module.cpp: scene_bindings.cpp (load_scene, Scene, Model,
/// InputError), data_bindings.cpp (Data, its NumPy views, step), run_bindings.cpp (run_scene,
/// the studies).

#include <pybind11/pybind11.h>

#include <filesystem>
#include <memory>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/sim/device/instrument_targets.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::python {

/// A core::Data made by core::make_data() for one Scene's model, and that Scene (kept alive
/// while the Data lives: `model` points into it). Held by the Python object `numen.Data`, never
/// moved: the NumPy views point into `data` and take the Python object as their base.
struct DataHandle {
  std::shared_ptr<const sim::Scene> scene;  ///< Owner of *model.
  const core::Model* model = nullptr;       ///< The model `data` was made for.
  core::Data data;
  /// The scene's device and binding (sim::InstrumentTargets), made by the first
  /// Data.set_targets_at() or Data.set_tool_sample().
  std::unique_ptr<sim::InstrumentTargets> instrument;
};

/// The located error of the scene's missing `part` ("trajectory" or "device": one of
/// Scene::run_missing) when the scene has none, to be thrown; nullptr when it has one.
const sim::InputError* missing_part(const sim::Scene& scene, const char* part);

/// The root of the shipped scenes and data as this module sees it: share/numen of the prefix it
/// is installed in (NUMEN_DATA_FROM_MODULE from its directory), else the executable's or the
/// source tree's (sim::shipped_data_dir_from()).
std::filesystem::path module_data_dir();

/// `t` (s) if it is finite, else ValueError naming `what` (the function and argument, e.g.
/// "Scene.target_at: t"): a NaN time would read the trajectory's first sample without a word.
double finite_time(double t, const char* what);

/// numen.InputError, load_scene, default_scene_path, Scene, Model.
void bind_scene(pybind11::module_& m);
/// numen.Data, numen.step, numen._testing.step_loop.
void bind_data(pybind11::module_& m);
/// numen.run_scene, numen.study_stability, numen.study_accuracy.
void bind_run(pybind11::module_& m);

}  // namespace numen::python
