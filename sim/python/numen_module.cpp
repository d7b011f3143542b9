/// @file numen_module.cpp
/// The Python module `numen` (docs/python.md): numen's scenes, core step and runs from Python.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "numen/core/features.hpp"

PYBIND11_MODULE(numen, m) {
  m.doc() =
      "numen: real-time control core for generalized dynamic god-objects, from Python.\n\n"
      "load_scene(path) -> Scene; scene.make_data() -> Data; data.set_target(...); "
      "data.step(scene); read-only NumPy views of Data (no copy); run_scene(scene) -> dict; "
      "study_stability() / study_accuracy() -> list of dicts. SI units, world frame, "
      "quaternions as (x, y, z, w). docs/python.md.";
  // The optional parts of this build (docs/architecture.md "Build options"): a scene that needs
  // a part left out fails to load with an InputError naming the option.
  pybind11::dict features;
  features["articulation"] = numen::core::kWithArticulation;
  features["deformable"] = numen::core::kWithDeformable;
  m.attr("features") = features;
  numen::python::bind_scene(m);
  numen::python::bind_data(m);
  numen::python::bind_run(m);
}
