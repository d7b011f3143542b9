/// @file info_command.cpp
/// `numen info`: what a scene compiles to (sizes, stages, capacities, bytes).

#include <chrono>
#include <iostream>

#include "commands.hpp"
#include "numen/sim/run/step_timing.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/scene/scene_info.hpp"

namespace numen::app {

InfoCommand::InfoCommand(CLI::App& parent)
    : cli_(parent.add_subcommand(
          "info", "Print what a scene compiles to: sizes, the stages step() runs, capacities, bytes")) {
  cli_->add_option("scene", scene_, "Scene file (TOML); default: the shipped default scene");
  cli_->add_flag("--json", json_, "Print one JSON object instead of the report");
  add_scene_flags(cli_, nullptr, strict_);
}

int InfoCommand::execute() const {
  const std::string path = scene_.empty() ? sim::default_scene_path() : scene_;
  sim::SceneOverrides overrides;
  overrides.strict = strict_;
  const auto t0 = std::chrono::steady_clock::now();
  sim::Scene scene = sim::load_scene(path, overrides);
  const double load_wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const sim::StepTiming timing = check_loaded_scene(scene, std::cerr);
  sim::SceneInfo si = sim::describe_scene(scene);
  si.load_wall_s = load_wall_s;
  if (json_) {
    std::cout << sim::with_step_timing_json(sim::format_scene_info_json(si), timing) << std::endl;
  } else {
    std::cout << sim::format_scene_info(si);
    std::cout << sim::describe_step_timing(timing) << "\n";
  }
  return 0;
}

}  // namespace numen::app
