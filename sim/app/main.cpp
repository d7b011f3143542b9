/// @file main.cpp
/// The `numen` command.
///   numen run [SCENE] [--duration S] [--trace FILE.csv] [--json] [--realtime] [--coupling MODE]
///             [--bus sim|log:FILE] [--record FILE.log]
///             [--rt-priority N] [--lock-memory] [--prefault-stack BYTES] [--cpu LIST] [--rt-strict]

#include <cstdio>
#include <iostream>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "numen/sim/input_error.hpp"
#include "numen/sim/run.hpp"
#include "numen/sim/scene.hpp"

int main(int argc, char** argv) {
  CLI::App app{"numen — real-time control core for generalized dynamic god-objects"};
  app.require_subcommand(1);

  CLI::App* run = app.add_subcommand("run", "Run a scene on the simulated bus and print a summary");
  std::string scene_path;
  double duration = -1.0;
  std::string trace_path;
  bool json = false;
  bool realtime = false;
  std::string coupling;
  run->add_option("scene", scene_path, "Scene file (TOML); default: the shipped default scene");
  run->add_option("--duration", duration, "Simulated time in seconds (default: the scene's)")
      ->check(CLI::NonNegativeNumber);
  run->add_option("--trace", trace_path, "Write a per-step CSV trace to this file");
  run->add_flag("--json", json, "Print exactly one JSON object on stdout (summary to stderr)");
  run->add_flag("--realtime", realtime, "Pace the loop to wall-clock time");
  std::string bus = "sim", record_path;
  run->add_option("--bus", bus,
                  "The controller's bus: sim (simulated instrument, default) or log:FILE "
                  "(replay a candump log's encoder frames)")
      ->check([](const std::string& v) {
        return v == "sim" || (v.rfind("log:", 0) == 0 && v.size() > 4)
                   ? std::string()
                   : std::string("expected sim or log:FILE");
      });
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
                  "Record the controller's bus traffic into this candump log (can-utils format)");
  run->add_option("--coupling", coupling, "Override the scene's coupling mode")
      ->check(CLI::IsMember({"god-object", "first-order", "direct"}));

  CLI11_PARSE(app, argc, argv);

  if (run->parsed()) {
    try {
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
      const numen::sim::RunSummary summary = numen::sim::run_scene(scene, options);
      if (json) {
        std::cerr << numen::sim::format_summary(summary);
        std::cout << numen::sim::format_summary_json(summary) << std::endl;
      } else {
        std::cout << numen::sim::format_summary(summary);
        if (!trace_path.empty()) std::cout << "  trace: " << trace_path << "\n";
      }
    } catch (const numen::sim::InputError& e) {
      std::cerr << "numen: " << e.what() << "\n";
      return 2;
    } catch (const std::exception& e) {
      std::cerr << "numen: " << e.what() << "\n";
      return 1;
    }
  }
  return 0;
}
