/// @file cli_support.cpp
/// What the subcommands share: the guard that turns exceptions and a stdout that could not be
/// written into exit statuses, and the CLI11 checks of times and bus specs.

#include <iostream>
#include <new>
#include <stdexcept>

#include "commands.hpp"
#include "numen/sim/input/bus_spec.hpp"
#include "numen/sim/input/cli_values.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/run/step_timing.hpp"
#include "numen/sim/scene/scene.hpp"
#include "standard_streams.hpp"

namespace numen::app {

int run_guarded(const std::function<int()>& body) {
  try {
    return with_stdout_checked(body());
  } catch (const sim::InputError& e) {
    std::cerr << "numen: " << e.what() << "\n";
    return sim::code(sim::ExitStatus::kInputRejected);
  } catch (const std::bad_alloc&) {
    std::cerr << "numen: out of memory (the scene, its trajectory or a log is too large for "
                 "this machine)\n";
    return sim::code(sim::ExitStatus::kError);
  } catch (const std::exception& e) {
    std::cerr << "numen: " << e.what() << "\n";
    return sim::code(sim::ExitStatus::kError);
  }
}

void add_scene_flags(CLI::App* command, bool* replay, bool& strict) {
  if (replay != nullptr)
    command->add_flag("--replay", *replay,
                      "Run the device in replay: the encoders read the trajectory whatever the "
                      "torques (the scene's [device.plant] is checked, then not used)");
  command->add_flag("--strict", strict,
                    "The passivity lint's findings are errors (exit 2), not warnings");
}

CLI::Validator seconds_check(double lo, double hi, bool lo_exclusive) {
  return CLI::Validator(
      [=](const std::string& v) { return sim::check_seconds(v, lo, hi, lo_exclusive); },
      "SECONDS");
}

CLI::Validator number_check(double lo, double hi, bool lo_exclusive) {
  return CLI::Validator(
      [=](const std::string& v) {
        std::string e = sim::check_seconds(v, lo, hi, lo_exclusive);
        // check_seconds words its message for seconds; the checks are the same.
        if (const auto at = e.find(" of seconds"); at != std::string::npos) e.erase(at, 11);
        return e;
      },
      "NUMBER");
}

CLI::Validator count_check(long long lo, long long hi) {
  return CLI::Validator([=](const std::string& v) { return sim::check_count(v, lo, hi); }, "COUNT");
}

std::string check_bus(const std::string& v, bool real_only) {
  try {
    const sim::BusSpec spec = sim::parse_bus_spec(v);
    if (real_only && !spec.real()) return "expected can:IFACE or serial:PATH[@BAUD]";
    return sim::missing_backend(spec);  // a backend this build left out
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
}

sim::StepTiming check_loaded_scene(sim::Scene& scene, std::ostream& err) {
  const sim::StepTiming timing = sim::time_scene_step(scene);
  if (const auto slow = sim::step_timing_warning(timing)) scene.warnings.push_back(*slow);
  for (const std::string& w : scene.warnings) err << "numen: warning: " << w << "\n";
  err.flush();
  return timing;
}

}  // namespace numen::app
