/// @file run_bindings.cpp
/// numen.run_scene (a run through the bus, its summary as a dict) and the studies
/// (numen.study_stability, numen.study_accuracy: their rows as lists of dicts).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_accuracy.hpp"
#include "numen/sim/study/study_common.hpp"
#include "numen/sim/study/study_fields.hpp"
#include "numen/sim/study/study_stability.hpp"

namespace py = pybind11;

namespace numen::python {
namespace {

/// Longest grid run study_stability(grid_steps=...) takes (steps): 500 times the full study's
/// 2000. A grid run is not interrupted inside (Ctrl-C is seen between runs, interruptible()):
/// at a few µs a step, one such run takes seconds.
constexpr int kMaxGridSteps = 1'000'000;

/// How often a long call looks at Python's signals (interruptible()).
constexpr std::chrono::milliseconds kSignalPoll{50};

/// Thrown by a study's progress callback once the call was interrupted: ends the study between
/// two runs (caught by interruptible(), never seen by Python).
struct Interrupted {};

/// Runs `work` (C++ only: it must not touch Python) on a thread of its own while this thread
/// waits for it without the GIL (other Python threads go on) and, every kSignalPoll, takes the
/// GIL and runs Python's signal handlers (PyErr_CheckSignals). When a handler raises (Ctrl-C:
/// KeyboardInterrupt), `stop` is set, `work` is waited for (it must end soon after: a run's
/// RunOptions::stop, a study's progress callback throwing Interrupted) and that exception is
/// raised; its result is dropped. CPython runs handlers on its main thread only: a call from
/// another Python thread runs to its end. `work`'s own exception is rethrown here.
template <typename Work>
auto interruptible(std::atomic<bool>& stop, Work work) -> decltype(work()) {
  std::optional<decltype(work())> result;
  std::exception_ptr error;
  std::mutex mutex;
  std::condition_variable finished;
  bool done = false;
  std::thread worker([&] {
    try {
      result.emplace(work());
    } catch (const Interrupted&) {
    } catch (...) {
      error = std::current_exception();
    }
    const std::lock_guard<std::mutex> lock(mutex);
    done = true;
    finished.notify_one();
  });
  bool interrupted = false;
  for (bool over = false; !over;) {
    {
      py::gil_scoped_release unlocked;
      std::unique_lock<std::mutex> lock(mutex);
      over = finished.wait_for(lock, kSignalPoll, [&done] { return done; });
    }
    if (!over && !interrupted && PyErr_CheckSignals() != 0) {
      interrupted = true;  // the handler's exception is pending until the worker has ended
      stop.store(true);
    }
  }
  worker.join();
  if (interrupted) throw py::error_already_set();
  if (error) std::rethrow_exception(error);
  return std::move(*result);
}

/// `study` (sim::run_stability_study, sim::run_accuracy_study) run with `options` by
/// interruptible(): its progress callback (options.progress, replaced; the caller's options are
/// for this call only, the callback refers to a local) throws Interrupted once Ctrl-C was seen,
/// which ends the study between two runs.
template <typename Options, typename Study>
auto interruptible_study(Options& options, Study study) {
  std::atomic<bool> stop{false};
  options.progress = [&stop](double, double, const std::string&) {
    if (stop.load()) throw Interrupted{};
  };
  return interruptible(stop, [&options, study] { return study(options); });
}

/// Integrators by their scene-file names ("implicit-euler", ...); empty: all (the studies'
/// default). ValueError for an unknown name.
std::vector<core::Integrator> integrators_named(const std::vector<std::string>& names) {
  std::vector<core::Integrator> out;
  for (const std::string& name : names) {
    bool found = false;
    for (const core::Integrator i : sim::study::all_integrators())
      if (name == sim::to_string(i)) {
        out.push_back(i);
        found = true;
      }
    if (!found) throw py::value_error("unknown integrator '" + name + "'");
  }
  return out;
}

/// `name` if it is one of `known`, else ValueError listing them (the CLI's check).
void check_member(const std::string& what, const std::string& name,
                  const std::vector<std::string>& known) {
  for (const std::string& k : known)
    if (k == name) return;
  std::string list;
  for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
  throw py::value_error("unknown " + what + " '" + name + "' (one of: " + list + ")");
}

/// A study row as a dict, keyed by its field list (study_fields.hpp).
py::dict row_dict(const sim::StabilityRow& r) {
  py::dict d;
  sim::stability_row_fields(r, [&d](const char* key, const auto& v) { d[key] = v; });
  return d;
}

py::dict row_dict(const sim::AccuracyRow& r) {
  py::dict d;
  sim::accuracy_row_fields(r, [&d](const char* key, const auto& v) { d[key] = v; });
  return d;
}

template <typename Row>
py::list rows_list(const std::vector<Row>& rows) {
  py::list out;
  for (const Row& r : rows) out.append(row_dict(r));
  return out;
}

}  // namespace

void bind_run(py::module_& m) {
  m.def(
      "run_scene",
      [](const sim::Scene& scene, std::optional<double> duration, const std::string& bus,
         const std::string& trace, const std::string& record, const std::string& record_view) {
        sim::RunOptions options;
        if (duration) {
          // `numen run --duration`'s range (sim::check_seconds): NaN or a negative value would
          // otherwise select the scene's duration.
          if (!std::isfinite(*duration) || *duration <= 0.0 || *duration > sim::kMaxRunDuration)
            throw py::value_error("run_scene: duration must be a finite number of seconds in (0, " +
                                  sim::format_input_number(sim::kMaxRunDuration) +
                                  "] (or None: the scene's), got " +
                                  sim::format_input_number(*duration));
          options.duration_s = *duration;
        }
        options.bus.spec = bus;
        options.bus.record_path = record;
        options.trace_path = trace;
        options.record_view_path = record_view;
        std::atomic<bool> stop{false};
        options.stop = &stop;  // Ctrl-C: the run ends cleanly, then KeyboardInterrupt
        const std::string json = interruptible(
            stop, [&] { return sim::format_summary_json(sim::run_scene(scene, options)); });
        return py::module_::import("json").attr("loads")(json);
      },
      py::arg("scene"), py::arg("duration") = py::none(), py::arg("bus") = "sim",
      py::arg("trace") = "", py::arg("record") = "", py::arg("record_view") = "",
      "Runs `scene` like `numen run`: the controller (platform::ControlLoop) over `bus` "
      "('sim': the simulated bus and instrument; 'log:FILE', 'can:IFACE', 'serial:PATH' as "
      "`numen run --bus`), for `duration` s of simulated time (None: the scene's; else in "
      "(0, 1e7] as `numen run --duration`), offline (unpaced). Ctrl-C (SIGINT) ends the run "
      "cleanly within 50 ms and raises KeyboardInterrupt (from the main thread). trace / "
      "record / record_view: paths of the CSV trace, the candump recording "
      "of the controller port and the view recording ('' : none). Returns the summary as the "
      "dict of `numen run --json` (every figure, dotted names as nested dicts; exit_status 0: "
      "clean, exit_reasons). Raises InputError, ValueError (duration, bus spec), RuntimeError "
      "(files).");

  m.def(
      "study_stability",
      [](bool quick, const std::vector<std::string>& families,
         const std::vector<std::string>& integrators, int grid_steps) {
        sim::StabilityOptions options;
        options.quick = quick;
        options.scene_dir = (module_data_dir() / "scenes").string();  // the module's prefix's
        for (const std::string& f : families)
          check_member("family", f, sim::stability_family_names());
        options.families = families;
        options.integrators = integrators_named(integrators);
        if (grid_steps > kMaxGridSteps)
          throw py::value_error("study_stability: grid_steps must be at most " +
                                std::to_string(kMaxGridSteps) +
                                " steps per grid run (<= 0: the study's, 300 quick or 2000), got " +
                                std::to_string(grid_steps));
        options.grid_steps = grid_steps;
        return rows_list(interruptible_study(options, sim::run_stability_study).rows);
      },
      py::arg("quick") = true, py::arg("families") = std::vector<std::string>{},
      py::arg("integrators") = std::vector<std::string>{}, py::arg("grid_steps") = -1,
      "The stability study (`numen study stability`, docs/results.md): stiff and extreme runs, "
      "a verdict each, on the shipped scenes beside default_scene_path(). quick: coarse grids, short runs (seconds); families: subset of "
      "'coupling', 'contact', 'articulation', 'extreme', 'boundary', 'scenes' (empty: all); "
      "integrators: scene-file names (empty: all); grid_steps: steps per grid run (<= 0: the "
      "study's; at most 1000000, else ValueError). Ctrl-C (SIGINT) ends the study after the "
      "run in progress and raises KeyboardInterrupt (from the main thread). Returns one dict "
      "per run: family, case, integrator, dt_s, mass_kg, stiffness "
      "(N/m), parameter_name, parameter, omega_dt, steps, stable, diverged_step, reason, "
      "energy_ref_j, energy_ratio_max, penetration_max_m, penetration_bound_m, drift_max_m, "
      "nonfinite_steps, note (the columns of stability_<family>.csv).");

  m.def(
      "study_accuracy",
      [](bool quick, const std::vector<std::string>& cases,
         const std::vector<std::string>& integrators) {
        sim::AccuracyOptions options;
        options.quick = quick;
        options.scene_dir = (module_data_dir() / "scenes").string();  // the module's prefix's
        for (const std::string& c : cases) check_member("case", c, sim::accuracy_case_names());
        options.cases = cases;
        options.integrators = integrators_named(integrators);
        return rows_list(interruptible_study(options, sim::run_accuracy_study).rows);
      },
      py::arg("quick") = true, py::arg("cases") = std::vector<std::string>{},
      py::arg("integrators") = std::vector<std::string>{},
      "The accuracy study (`numen study accuracy`, docs/results.md): error against a reference "
      "over a grid of time steps, on the shipped scenes beside default_scene_path(). quick: coarse grid (1e-2 ... 1e-4 s), short horizons; cases: "
      "subset of 'free-body', 'wall', 'articulated', 'deformable' (empty: all); integrators: "
      "scene-file names (empty: all). Ctrl-C ends it after the run in progress "
      "(KeyboardInterrupt). Returns one dict per run: case, integrator, dt_s, steps, "
      "horizon_s, position_error_max_mm, position_error_rms_mm, orientation_error_max_mrad, "
      "orientation_error_rms_mrad, cpu_s_per_sim_s, diverged, nonfinite_steps, reference.");
}

}  // namespace numen::python
