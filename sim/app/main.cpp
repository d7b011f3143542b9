/// @file main.cpp
/// The `numen` command.
///   numen run [SCENE] [--duration S] [--trace FILE.csv] [--json] [--realtime] [--coupling MODE]
///             [--bus sim|log:FILE|can:IFACE|serial:PATH[@BAUD]] [--record FILE.log] [--phase S]
///             [--rt-priority N] [--lock-memory] [--prefault-stack BYTES] [--cpu LIST] [--rt-strict]
///   numen device [SCENE] --bus can:IFACE|serial:PATH[@BAUD] [--duration S] [--ready]
///   numen info [SCENE] [--json]
///   numen study accuracy [--out DIR] [--quick] [--case NAME]...
///   numen study stability [--out DIR] [--quick] [--family NAME]...
/// SIGINT / SIGTERM: while the input loads, the process ends at once (status 128 + signal;
/// nothing is open on a bus yet); once a run or device has started, it ends cleanly (run: zero
/// torque, drives disabled; both: summary). Exit statuses: docs/inputs.md.

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "numen/sim/bus_spec.hpp"
#include "numen/sim/cli_values.hpp"
#include "numen/sim/device_process.hpp"
#include "numen/sim/input_error.hpp"
#include "numen/sim/progress_bar.hpp"
#include "numen/sim/run.hpp"
#include "numen/sim/run_verdict.hpp"
#include "numen/sim/scene.hpp"
#include "numen/sim/scene_info.hpp"
#include "numen/sim/study_accuracy.hpp"
#include "numen/sim/study_stability.hpp"

namespace {
std::atomic<bool> g_stop{false};  // lock-free: safe to store from a signal handler
static_assert(std::atomic<bool>::is_always_lock_free, "signal handlers store to std::atomic<bool>");
std::atomic<int> g_stop_signal{0};  // the signal that set g_stop
std::atomic<bool> g_rearm{false};  // SIGUSR1: the operator's re-arm (RunOptions::rearm)
/// True while the command loads its input (scene, trajectory, logs): nothing is open on a bus
/// and nothing was commanded, so a stop signal ends the process at once (loading a large file
/// must not make SIGINT / SIGTERM wait). Cleared just before the bus is opened.
std::atomic<bool> g_loading{true};
static_assert(std::atomic<int>::is_always_lock_free, "signal handlers store to std::atomic<int>");
extern "C" void on_signal(int sig) {
  if (g_loading.load(std::memory_order_relaxed)) {
    // Async-signal-safe: write(2) and _exit(2) only.
    static const char msg[] = "numen: stopped by a signal while loading (nothing was commanded)\n";
    [[maybe_unused]] const ssize_t n = ::write(STDERR_FILENO, msg, sizeof msg - 1);
    ::_exit(128 + sig);
  }
  g_stop_signal.store(sig, std::memory_order_relaxed);
  g_stop.store(true, std::memory_order_relaxed);
}
extern "C" void on_rearm_signal(int) { g_rearm.store(true, std::memory_order_relaxed); }
void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  struct sigaction rearm {};
  rearm.sa_handler = on_rearm_signal;
  sigemptyset(&rearm.sa_mask);
  sigaction(SIGUSR1, &rearm, nullptr);
}
/// Runs a subcommand's body, which returns its exit status (docs/inputs.md, "Exit statuses");
/// an exception ends it with 2 for bad input (InputError: scene, trajectory, option values) or
/// 1 for any other error (I/O, out of memory, internal), printed as "numen: what".
template <typename Body>
int run_guarded(Body&& body) {
  try {
    return body();
  } catch (const numen::sim::InputError& e) {
    std::cerr << "numen: " << e.what() << "\n";
    return numen::sim::code(numen::sim::ExitStatus::kInputRejected);
  } catch (const std::bad_alloc&) {
    std::cerr << "numen: out of memory (the scene, its trajectory or a log is too large for "
                 "this machine)\n";
    return numen::sim::code(numen::sim::ExitStatus::kError);
  } catch (const std::exception& e) {
    std::cerr << "numen: " << e.what() << "\n";
    return numen::sim::code(numen::sim::ExitStatus::kError);
  }
}

/// CLI11 check of a time in seconds (numen::sim::check_seconds): finite, in [lo, hi] or (lo, hi].
CLI::Validator seconds_check(double lo, double hi, bool lo_exclusive) {
  return CLI::Validator(
      [=](const std::string& v) { return numen::sim::check_seconds(v, lo, hi, lo_exclusive); },
      "SECONDS");
}

std::string check_bus(const std::string& v, bool real_only) {
  try {
    const numen::sim::BusSpec spec = numen::sim::parse_bus_spec(v);
    if (real_only && !spec.real()) return "expected can:IFACE or serial:PATH[@BAUD]";
    return numen::sim::missing_backend(spec);  // a backend this build left out
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"numen — real-time control core for generalized dynamic god-objects"};
  app.require_subcommand(1);

  CLI::App* run = app.add_subcommand("run", "Run a scene on the simulated bus and print a summary");
  run->footer(
      "Signals: SIGINT / SIGTERM end the run cleanly (zero torque, drives disabled); SIGUSR1 "
      "re-arms after a latched safe state (docs/safety.md).");
  std::string scene_path;
  double duration = -1.0;
  std::string trace_path;
  bool json = false;
  bool realtime = false;
  std::string coupling;
  run->add_option("scene", scene_path, "Scene file (TOML); default: the shipped default scene");
  run->add_option("--duration", duration, "Simulated time in seconds (default: the scene's)")
      ->check(seconds_check(0.0, numen::sim::kMaxRunDuration, true));
  run->add_option("--trace", trace_path, "Write a per-step CSV trace to this file");
  run->add_flag("--json", json, "Print exactly one JSON object on stdout (summary to stderr)");
  run->add_flag("--realtime", realtime, "Pace the loop to wall-clock time");
  std::string bus = "sim", record_path;
  run->add_option("--bus", bus,
                  "The controller's bus: sim (simulated instrument, default), log:FILE "
                  "(replay a candump log's encoder frames), can:IFACE (SocketCAN) or "
                  "serial:PATH[@BAUD] (serial line); a real bus is paced to CLOCK_MONOTONIC")
      ->check([](const std::string& v) { return check_bus(v, false); });
  double phase = -1.0;
  run->add_option("--phase", phase,
                  "Real bus: seconds after the SYNC to read the device's answers (default: the "
                  "scene's [bus] compute_phase)")
      ->check(seconds_check(0.0, 1.0, false));
  numen::platform::RealtimeSettings rt;
  run->add_option("--rt-priority", rt.fifo_priority,
                  "SCHED_FIFO priority 1-99 of the loop thread (0: leave the scheduler alone)")
      ->check(CLI::Range(0, 99));
  run->add_flag("--lock-memory", rt.lock_memory, "mlockall(MCL_CURRENT|MCL_FUTURE) before the loop");
  run->add_option("--prefault-stack", rt.prefault_stack_bytes,
                  "Bytes of the loop thread's stack to touch before the loop (e.g. 262144)");
  run->add_option("--cpu", rt.cpu_affinity, "CPUs the loop thread may run on, e.g. --cpu 1 or --cpu 2,3")
      ->delimiter(',');
  run->add_flag("--rt-strict", rt.strict, "Fail instead of reporting when a real-time step fails");
  run->add_option("--record", record_path,
                  "Record the controller's bus traffic into this candump log (can-utils format); "
                  "a paced run drops (and counts) what its writer cannot keep up with, an offline "
                  "run waits for it");
  std::uint32_t overrun_limit = 3;
  run->add_option("--overrun-limit", overrun_limit,
                  "Paced run: consecutive overruns that latch the safe state (default 3); 0 counts "
                  "and reports overruns without latching (a host that cannot hold the period)");
  run->add_option("--coupling", coupling, "Override the scene's coupling mode")
      ->check(CLI::IsMember({"god-object", "first-order", "direct"}));

  CLI::App* dev = app.add_subcommand("device", "Run a scene's simulated instrument on a real bus");
  std::string dev_scene, dev_bus;
  double dev_duration = -1.0;
  bool dev_ready = false;
  dev->add_option("scene", dev_scene, "Scene file (TOML); default: the shipped default scene");
  dev->add_option("--bus", dev_bus, "can:IFACE or serial:PATH[@BAUD]")
      ->required()
      ->check([](const std::string& v) { return check_bus(v, true); });
  dev->add_option("--duration", dev_duration, "Seconds to run (default: until SIGINT/SIGTERM)")
      ->check(seconds_check(0.0, numen::sim::kMaxRunDuration, true));
  dev->add_flag("--ready", dev_ready, "Print READY on stdout once the bus is open");

  CLI::App* info = app.add_subcommand(
      "info", "Print what a scene compiles to: sizes, the stages step() runs, capacities, bytes");
  std::string info_scene;
  bool info_json = false;
  info->add_option("scene", info_scene, "Scene file (TOML); default: the shipped default scene");
  info->add_flag("--json", info_json, "Print one JSON object instead of the report");

  CLI::App* study = app.add_subcommand("study", "Measure the integrators (docs/results.md)");
  study->require_subcommand(1);
  CLI::App* accuracy = study->add_subcommand(
      "accuracy",
      "Work-precision data per integrator: error against CPU time per simulated second");
  std::string accuracy_out = "accuracy";
  bool accuracy_quick = false;
  std::vector<std::string> accuracy_cases;
  accuracy->add_option("--out", accuracy_out,
                       "Directory of accuracy.csv, accuracy_orders.csv, accuracy_references.csv "
                       "(plots: docs/figures/plot_accuracy.py DIR)");
  accuracy->add_flag("--quick", accuracy_quick,
                     "Coarser grid (1e-2 … 1e-4 s), horizons × 0.3, references at 2e-5 s: seconds");
  accuracy->add_option("--case", accuracy_cases, "Run only these cases (repeatable)")
      ->check(CLI::IsMember(numen::sim::accuracy_case_names()));

  CLI::App* stability = study->add_subcommand(
      "stability", "Stiff and extreme cases: a verdict per run (stable, or diverged at step N)");
  std::string stability_out = "stability";
  bool stability_quick = false;
  std::vector<std::string> stability_families;
  stability->add_option("--out", stability_out,
                        "Directory of stability_<family>.csv and stability_boundary.csv "
                        "(maps: docs/figures/plot_stability.py DIR)");
  stability->add_flag("--quick", stability_quick, "Coarse grids, short runs: seconds");
  stability->add_option("--family", stability_families, "Run only these families (repeatable)")
      ->check(CLI::IsMember(numen::sim::stability_family_names()));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every refused value or option is input rejected.
    const int status = app.exit(e);
    return status == 0 ? 0 : numen::sim::code(numen::sim::ExitStatus::kInputRejected);
  }

  if (stability->parsed()) {
    return run_guarded([&] {
      numen::sim::StabilityOptions options;
      options.quick = stability_quick;
      options.families = stability_families;
      numen::sim::ProgressBar bar;
      options.progress = [&bar](double done, double total, const std::string& label) {
        bar.update(done, total, label);
      };
      const numen::sim::StabilityResult result = numen::sim::run_stability_study(options);
      bar.finish();
      numen::sim::write_stability_csv(result, stability_out);
      std::cout << numen::sim::format_stability_tables(result);
      std::printf("%zu runs in %.1f s; wrote %s/stability_*.csv\n", result.rows.size(),
                  result.wall_s, stability_out.c_str());
      return 0;
    });
  }

  if (accuracy->parsed()) {
    return run_guarded([&] {
      numen::sim::AccuracyOptions options;
      options.quick = accuracy_quick;
      options.cases = accuracy_cases;
      numen::sim::ProgressBar bar;
      options.progress = [&bar](double done, double total, const std::string& label) {
        bar.update(done, total, label);
      };
      const numen::sim::AccuracyResult result = numen::sim::run_accuracy_study(options);
      bar.finish();
      numen::sim::write_accuracy_csv(result, accuracy_out);
      std::cout << numen::sim::format_accuracy_table(result);
      std::cout << "wrote " << accuracy_out << "/accuracy.csv, accuracy_orders.csv, "
                << "accuracy_references.csv\n";
      return 0;
    });
  }
  install_signal_handlers();  // the studies keep the default: a signal ends them at once

  if (info->parsed()) {
    return run_guarded([&] {
      const std::string path = info_scene.empty() ? numen::sim::default_scene_path() : info_scene;
      const numen::sim::SceneInfo si = numen::sim::describe_scene(numen::sim::load_scene(path));
      if (info_json)
        std::cout << numen::sim::format_scene_info_json(si) << std::endl;
      else
        std::cout << numen::sim::format_scene_info(si);
      return 0;
    });
  }

  if (dev->parsed()) {
    return run_guarded([&] {
      const std::string path = dev_scene.empty() ? numen::sim::default_scene_path() : dev_scene;
      const numen::sim::Scene scene = numen::sim::load_scene(path);
      numen::sim::DeviceOptions options;
      options.bus = dev_bus;
      options.duration_s = dev_duration;
      options.stop = &g_stop;
      options.announce_ready = dev_ready;
      g_loading.store(false, std::memory_order_relaxed);
      std::cout << numen::sim::format_device_summary(numen::sim::run_device(scene, options));
      return 0;
    });
  }

  if (run->parsed()) {
    return run_guarded([&] {
      numen::sim::SceneOverrides overrides;
      if (!coupling.empty()) overrides.coupling = numen::sim::parse_coupling_mode(coupling);
      const std::string path = scene_path.empty() ? numen::sim::default_scene_path() : scene_path;
      const numen::sim::Scene scene = numen::sim::load_scene(path, overrides);
      numen::sim::RunOptions options;
      options.duration_s = duration;
      options.realtime = realtime;
      options.trace_path = trace_path;
      options.bus.spec = bus;
      options.bus.record_path = record_path;
      options.rt = rt;
      options.stop = &g_stop;
      options.compute_phase_s = phase;
      options.overrun_limit = overrun_limit;
      options.rearm = &g_rearm;
      g_loading.store(false, std::memory_order_relaxed);  // from here a signal ends the run cleanly
      const numen::sim::RunSummary summary = numen::sim::run_scene(scene, options);
      if (json) {
        std::cerr << numen::sim::format_summary(summary);
        std::cout << numen::sim::format_summary_json(summary) << std::endl;
      } else {
        std::cout << numen::sim::format_summary(summary);
        if (!trace_path.empty()) std::cout << "  trace: " << trace_path << "\n";
      }
      // A run stopped by a signal and otherwise clean exits 128 + the signal (shell convention).
      if (summary.exit_status == 0 && summary.stopped)
        return 128 + g_stop_signal.load(std::memory_order_relaxed);
      return summary.exit_status;
    });
  }
  return 0;
}
