/// @file device_command.cpp
/// `numen device`: a scene's simulated instrument on a real bus, until the duration or a signal.

#include <iostream>

#include "commands.hpp"
#include "numen/sim/device/device_process.hpp"
#include "numen/sim/input/cli_values.hpp"
#include "numen/sim/scene/scene.hpp"
#include "signals.hpp"

namespace numen::app {

DeviceCommand::DeviceCommand(CLI::App& parent)
    : cli_(parent.add_subcommand("device", "Run a scene's simulated instrument on a real bus")) {
  cli_->add_option("scene", scene_, "Scene file (TOML); default: the shipped default scene");
  cli_->add_option("--bus", bus_, "can:IFACE or serial:PATH[@BAUD]")
      ->required()
      ->check([](const std::string& v) { return check_bus(v, true); });
  cli_->add_option("--duration", duration_, "Seconds to run (default: until SIGINT/SIGTERM)")
      ->check(seconds_check(0.0, sim::kMaxRunDuration, true));
  cli_->add_flag("--ready", ready_,
                 "Print READY on stdout once the device answers (bus open, nodes booted)");
  add_scene_flags(cli_, &replay_, strict_);
}

int DeviceCommand::execute() const {
  const std::string path = scene_.empty() ? sim::default_scene_path() : scene_;
  sim::SceneOverrides overrides;
  overrides.replay = replay_;
  overrides.strict = strict_;
  const sim::Scene scene = sim::load_scene(path, overrides);
  sim::DeviceOptions options;
  options.bus = bus_;
  options.duration_s = duration_;
  options.stop = &stop_flag();
  if (ready_) options.on_ready = [] { std::cout << "READY" << std::endl; };
  loading_done();
  std::cout << sim::format_device_summary(sim::run_device(scene, options));
  return 0;
}

}  // namespace numen::app
