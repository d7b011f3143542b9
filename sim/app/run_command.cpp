/// @file run_command.cpp
/// `numen run`: loads a scene, runs it (run_scene) and prints its summary.

#include <sched.h>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "commands.hpp"
#include "numen/hal/features.hpp"
#include "numen/sim/input/bus_spec.hpp"
#include "numen/sim/input/cli_values.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/input/view_address.hpp"
#include "numen/sim/view/igtl_world_server.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/run/step_timing.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_scene.hpp"
#include "numen/sim/view/view_server.hpp"
#include "signals.hpp"
#include "standard_streams.hpp"

namespace numen::app {

RunCommand::RunCommand(CLI::App& parent)
    : cli_(parent.add_subcommand("run", "Run a scene on the simulated bus and print a summary")) {
  CLI::App* run = cli_;
  run->footer(
      "Signals: SIGINT / SIGTERM / SIGHUP end the run cleanly (zero torque, drives disabled); "
      "SIGUSR1 re-arms after a latched safe state (docs/safety.md).");
  run->add_option("scene", scene_path_, "Scene file (TOML); default: the shipped default scene");
  run->add_option("--duration", duration_, "Simulated time in seconds (default: the scene's)")
      ->check(seconds_check(0.0, sim::kMaxRunDuration, true));
  run->add_option("--trace", trace_path_, "Write a per-step CSV trace to this file");
  run->add_flag("--json", json_, "Print exactly one JSON object on stdout (summary to stderr)");
  run->add_flag("--realtime", realtime_, "Pace the loop to wall-clock time");
  run->add_option("--bus", bus_,
                  "The controller's bus: sim (simulated instrument, default), log:FILE "
                  "(replay a candump log's encoder frames), can:IFACE (SocketCAN), "
                  "serial:PATH[@BAUD] (serial line) or igtl[:[HOST:]PORT] (the scene's "
                  "[device.igtl] OpenIGTLink tracker); a real bus is paced to CLOCK_MONOTONIC")
      ->check([](const std::string& v) { return check_bus(v, false); });
  run->add_option("--phase", phase_,
                  "Seconds after the SYNC to read the device's answers and step (any bus; "
                  "default: the scene's [bus] compute_phase)")
      ->check(seconds_check(0.0, 1.0, false));
  run->add_option("--rt-priority", rt_.fifo_priority,
                  "Paced run: SCHED_FIFO priority 1-99 of the loop thread (0: leave the scheduler "
                  "alone); refused in an offline run (no --realtime, no real bus)")
      ->check(CLI::Range(0, 99));
  CLI::Option* lock =
      run->add_flag("--lock-memory", rt_.lock_memory,
                    "mlockall(MCL_CURRENT|MCL_FUTURE) before the loop (a paced run's default)");
  run->add_flag("--no-lock-memory", no_lock_memory_,
                "Paced run: leave the process's memory unlocked (default: locked)")
      ->excludes(lock);
  run->add_option("--prefault-stack", rt_.prefault_stack_bytes,
                  "Bytes of the loop thread's stack to touch before the loop, at most 1 GiB "
                  "(a paced run's default: 262144; 0: none)")
      ->check(CLI::Range(0.0, 1073741824.0));  // checked as a number: "-1" would wrap to SIZE_MAX
  run->add_option("--cpu", rt_.cpu_affinity, "CPUs the loop thread may run on, e.g. --cpu 1 or --cpu 2,3")
      ->delimiter(',')
      ->check(CLI::Range(0, CPU_SETSIZE - 1));
  run->add_flag("--rt-strict", rt_.strict,
                "Fail instead of reporting when a real-time step fails (the loop thread's and the "
                "scene thread's)");
  run->add_option("--timer-slack", timer_slack_ns_,
                  "Paced run: timer slack in ns of the loop and scene threads (prctl "
                  "PR_SET_TIMERSLACK), whatever their scheduling; default 1, 0 leaves the "
                  "kernel's (50000 for SCHED_OTHER); at most the period dt (1000000 at 1 kHz)")
      ->check(CLI::Range(std::int64_t{0}, std::int64_t{1'000'000'000}));
  CLI::Option* latency =
      run->add_option("--cpu-dma-latency", cpu_dma_latency_us_,
                      "Paced run: PM QoS CPU latency in us held while it runs "
                      "(/dev/cpu_dma_latency, as cyclictest); default 0: idle CPUs poll instead "
                      "of halting (docs/realtime.md)")
          ->check(CLI::Range(0, 2'000'000'000));
  run->add_flag("--no-cpu-dma-latency", no_cpu_dma_latency_,
                "Paced run: leave the host's CPU latency (idle CPUs may halt between periods)")
      ->excludes(latency);
  run->add_option("--spin", spin_us_,
                  "Paced run with --cpu: end each period's wait in a busy-wait of this many "
                  "microseconds before the deadline (default 0: sleep to it; docs/realtime.md)")
      ->check(number_check(0.0, 1e6, false));
  run->add_option("--scene-rt-priority", scene_thread_.fifo_priority,
                  "Multirate scene, paced run: SCHED_FIFO priority 1-99 of the scene thread (0: "
                  "leave the scheduler alone; below the loop thread's)")
      ->check(CLI::Range(0, 99));
  run->add_option("--scene-cpu", scene_thread_.cpu_affinity,
                  "Multirate scene, paced run: CPUs the scene thread may run on, e.g. --scene-cpu 0")
      ->delimiter(',')
      ->check(CLI::Range(0, CPU_SETSIZE - 1));
  run->add_option("--scene-spin", scene_spin_us_,
                  "Multirate scene, paced run with --scene-cpu: end each scene period's wait in a "
                  "busy-wait of this many microseconds before its deadline (default 0: sleep to "
                  "it; docs/realtime.md)")
      ->check(number_check(0.0, 1e6, false));
  run->add_option("--record", record_path_,
                  "Record the controller's bus traffic into this candump log (can-utils format); "
                  "a paced run drops (and counts) what its writer cannot keep up with, an offline "
                  "run waits for it");
  run->add_option("--record-view", record_view_path_,
                  "Write the run's state stream (scene message and frames, docs/viewer.md) to "
                  "this view recording (.nmv), for `numen view`");
  run->add_option("--view", view_,
                  "Serve the live 3D viewer on [HOST:]PORT (default host 127.0.0.1, an IPv6 "
                  "host in brackets: [::1]:8080; docs/viewer.md); an offline run is then paced "
                  "at real time (--speed to change)")
      ->check([](const std::string& v) -> std::string {
        try {
          (void)sim::parse_view_address(v);
          return {};
        } catch (const std::invalid_argument& e) {
          return e.what();
        }
      });
  run->add_option("--igtl", igtl_,
                  "Serve the god-object world over OpenIGTLink on [HOST:]PORT (default host "
                  "127.0.0.1; localhost, or an IPv6 host in brackets: [::1]:18944): a TRANSFORM "
                  "per body and per target, each deformable's surface as POLYDATA, faults and "
                  "events as STATUS and STRING, in mm, for 3D Slicer (docs/openigtlink.md); an "
                  "offline run is then paced at real time (--speed)")
      ->check([](const std::string& v) -> std::string {
        try {
          (void)sim::parse_view_address(v);
          if (!hal::kWithOpenIgtLink)
            return "needs OpenIGTLink: this build has NUMEN_WITH_OPENIGTLINK=OFF";
          return {};
        } catch (const std::invalid_argument& e) {
          return e.what();
        }
      });
  run->add_option("--igtl-organ-rate", igtl_organ_rate_,
                  "With --igtl: POLYDATA updates of each deformable per second of simulated time "
                  "(default 30; 0: the shape once per client); at most the stream's --view-rate")
      ->check(number_check(0.0, 1e6, false));
  run->add_option("--igtl-names", igtl_names_,
                  "With --igtl: how the TRANSFORMs are named: numen (default: '<body>', "
                  "'<body>_target') or plus (PLUS's and Slicer's '<From>To<To>': "
                  "'<Body>ToScene', '<Body>TargetToScene')")
      ->check(CLI::IsMember({"numen", "plus"}));
  run->add_flag("--wait-for-viewer{60}", wait_for_viewer_,
               "With --view: start the run when the first page connects, waiting at most this "
               "many seconds (--wait-for-viewer=S; default 60); none connected: exit 1")
      ->check(seconds_check(0.0, 86400.0, true));
  run->add_option("--view-rate", view_rate_,
                  "Frames per second of simulated time in the state stream (default 60)")
      ->check(number_check(0.0, 1e6, true));
  run->add_option("--speed", speed_,
                  "Pace an offline run at this factor of real time (e.g. 1 for a live viewer; "
                  "default: as fast as it goes); the paced run, duration / speed, may last at "
                  "most 1e7 s of wall time")
      ->check(number_check(0.0, 1e6, true));
  run->add_option("--overrun-limit", overrun_limit_,
                  "Paced run: consecutive overruns that latch the safe state (default 3); 0 counts "
                  "and reports overruns without latching (a host that cannot hold the period)")
      ->check(count_check(0, std::numeric_limits<std::uint32_t>::max()));
  run->add_option("--coupling", coupling_, "Override the scene's coupling mode")
      ->check(CLI::IsMember({"god-object", "first-order", "direct"}));
  add_scene_flags(run, &replay_, strict_);
}

platform::RealtimeSettings RunCommand::paced_realtime_settings(bool paced) const {
  platform::RealtimeSettings rt = rt_;
  if (!paced) return rt;
  // A paced run locks its memory and prefaults its loop thread's stack unless told otherwise,
  // as cyclictest -m does: no page fault in the loop's first periods (docs/realtime.md).
  if (!no_lock_memory_) rt.lock_memory = true;
  if (cli_->count("--prefault-stack") == 0) rt.prefault_stack_bytes = kPacedPrefaultStackBytes;
  return rt;
}

int RunCommand::execute() const {
  // Modifiers of something not asked for would do nothing: refused (status 2).
  if (cli_->count("--view-rate") > 0 && view_.empty() && igtl_.empty() && record_view_path_.empty())
    throw sim::InputError("", 0, 0, "--view-rate",
                          "sets the state stream's rate; without --view, --igtl or --record-view "
                          "there is no stream");
  if (cli_->count("--igtl-organ-rate") > 0 && igtl_.empty())
    throw sim::InputError("", 0, 0, "--igtl-organ-rate",
                          "sets the rate of the OpenIGTLink world's POLYDATA; without --igtl "
                          "there is none");
  if (cli_->count("--igtl-names") > 0 && igtl_.empty())
    throw sim::InputError("", 0, 0, "--igtl-names",
                          "names the OpenIGTLink world's TRANSFORMs; without --igtl there are "
                          "none");
  if (cli_->count("--wait-for-viewer") > 0 && view_.empty())
    throw sim::InputError("", 0, 0, "--wait-for-viewer",
                          "waits for a page of the live viewer; without --view there is none");
  const bool paced = realtime_ || sim::parse_bus_spec(bus_).real();
  const platform::RealtimeSettings rt = paced_realtime_settings(paced);
  const bool rt_asked = platform::any_step_requested(rt) || scene_thread_.fifo_priority != 0 ||
                        !scene_thread_.cpu_affinity.empty();
  if (rt_.strict && !rt_asked)
    throw sim::InputError("", 0, 0, "--rt-strict",
                          "makes a failed real-time step fatal; no real-time step was asked "
                          "(--rt-priority, --lock-memory, --prefault-stack, --cpu, "
                          "--scene-rt-priority, --scene-cpu)");
  // What only a paced run does (an offline run has no deadlines).
  const std::pair<const char*, const char*> paced_only[] = {
      {"--timer-slack", "sets the timer slack of a paced run's threads"},
      {"--cpu-dma-latency", "sets the CPU latency a paced run holds"},
      {"--no-cpu-dma-latency", "leaves the CPU latency a paced run would hold"},
      {"--no-lock-memory", "leaves a paced run's memory unlocked"}};
  for (const auto& [key, what] : paced_only)
    if (cli_->count(key) > 0 && !paced)
      throw sim::InputError(
          "", 0, 0, key, std::string(what) + "; this run is offline (no --realtime, no real bus)");
  sim::SceneOverrides overrides;
  if (!coupling_.empty()) overrides.coupling = sim::parse_coupling_mode(coupling_);
  overrides.replay = replay_;
  overrides.strict = strict_;
  const std::string path = scene_path_.empty() ? sim::default_scene_path() : scene_path_;
  sim::Scene scene = sim::load_scene(path, overrides);
  // The load's warnings on stderr now (a paced run may last half an hour), and in the summary.
  check_loaded_scene(scene, std::cerr);
  if (cli_->count("--view-rate") > 0 && view_rate_ * scene.model.dt > 1.0)
    std::cerr << "numen: --view-rate " << view_rate_ << " is above the device rate ("
              << 1.0 / scene.model.dt << " Hz): the stream sends every period" << std::endl;
  sim::RunOptions options;
  options.duration_s = duration_;
  options.realtime = realtime_;
  options.trace_path = trace_path_;
  options.bus.spec = bus_;
  options.bus.record_path = record_path_;
  options.rt = rt;
  options.scene_thread = scene_thread_;
  options.scene_thread.strict = rt_.strict;
  options.scene_thread.spin_ns = std::llround(scene_spin_us_ * 1e3);
  options.timer_slack_ns = timer_slack_ns_;
  options.cpu_dma_latency_us = no_cpu_dma_latency_ ? -1 : cpu_dma_latency_us_;
  options.spin_ns = std::llround(spin_us_ * 1e3);
  options.stop = &stop_flag();
  options.stop_signal = &stop_signal_number();
  options.compute_phase_s = phase_;
  options.overrun_limit = overrun_limit_;
  options.rearm = &rearm_flag();
  options.record_view_path = record_view_path_;
  if (!view_.empty() || !record_view_path_.empty())
    for (const std::string& line : sim::view_scene_warnings(scene))
      std::cerr << "numen: warning: " << line << std::endl;
  options.view_rate_hz = view_rate_;
  options.view_speed = speed_;
  std::unique_ptr<sim::ViewServer> viewer;
  sim::ViewServerSettings vs;
  if (!view_.empty()) {
    const sim::ViewAddress address = sim::parse_view_address(view_);  // checked by the option
    vs.host = address.host;
    vs.port = address.port;
    vs.static_dir = viewer_page_dir();
    warn_if_exposed(vs.host, std::cerr);
    viewer = std::make_unique<sim::ViewServer>(
        vs, sim::view_scene_message(scene, sim::view_frame_layout(scene), view_rate_));
    viewer->start();
    std::cerr << "numen: viewer on " << viewer->url() << std::endl;
    const double wait_s = wait_for_viewer_.empty() ? 0.0 : std::stod(wait_for_viewer_);
    if (wait_s > 0.0) {
      std::cerr << "numen: waiting up to " << wait_s << " s for a page at "
                << viewer->url() << " (--wait-for-viewer)" << std::endl;
      if (!viewer->wait_for_client(wait_s)) {
        std::cerr << "numen: no viewer connected to " << viewer->url() << " within "
                  << wait_s << " s (--wait-for-viewer): the run did not start"
                  << std::endl;
        return sim::code(sim::ExitStatus::kError);
      }
      std::cerr << "numen: a viewer connected: the run starts" << std::endl;
    }
    options.view_sinks.push_back(viewer.get());
    // An offline run is paced at real time for the viewer; a paced run already is.
    if (options.view_speed <= 0.0 && !realtime_ && !sim::parse_bus_spec(bus_).real())
      options.view_speed = 1.0;
  }
  std::unique_ptr<sim::IgtlWorldServer> igtl_world;
  if (!igtl_.empty()) {
    const sim::ViewAddress address = sim::parse_view_address(igtl_);  // checked by the option
    sim::IgtlWorldSettings ws;
    ws.host = address.host;
    ws.port = address.port;
    ws.organ_rate_hz = igtl_organ_rate_;
    ws.names = igtl_names_ == "plus" ? sim::IgtlNameStyle::kPlus : sim::IgtlNameStyle::kNumen;
    ws.device_names.push_back(scene.device.name);  // the other devices' STATUS name them
    for (const sim::SceneDevice& d : scene.extra_devices) ws.device_names.push_back(d.device.name);
    warn_if_exposed(ws.host, std::cerr, "the OpenIGTLink world");
    igtl_world = std::make_unique<sim::IgtlWorldServer>(scene.model, ws);
    const bool v6 = ws.host.find(':') != std::string::npos;
    std::cerr << "numen: OpenIGTLink world on " << (v6 ? "[" : "") << ws.host << (v6 ? "]" : "")
              << ":" << igtl_world->port() << std::endl;
    options.view_sinks.push_back(igtl_world.get());
    if (options.view_speed <= 0.0 && !realtime_ && !sim::parse_bus_spec(bus_).real())
      options.view_speed = 1.0;
  }
  loading_done();  // from here a signal ends the run cleanly
  sim::RunSummary summary = sim::run_scene(scene, options);
  // The summary on stdout first: if it cannot be written, the run lost its record (status 5 at
  // least), and the summary printed on stderr says so with the status the process returns.
  if (json_) {
    std::cout << sim::format_summary_json(summary) << '\n';
    summary.stdout_error = stdout_failure();
    if (!summary.stdout_error.empty()) sim::judge_run(summary);
    std::cerr << sim::format_summary(summary);
  } else {
    std::cout << sim::format_summary(summary);
    if (!trace_path_.empty()) std::cout << "  trace: " << trace_path_ << "\n";
    summary.stdout_error = stdout_failure();
    if (!summary.stdout_error.empty()) {
      sim::judge_run(summary);
      std::cerr << "numen: stdout: cannot write the summary (" << summary.stdout_error
                << "); it follows on stderr\n"
                << sim::format_summary(summary);
    }
  }
  if (viewer) {
    viewer->stop();
    const sim::ViewServerCounters c = viewer->counters();
    std::cerr << "  viewer: " << c.clients_total << " clients, " << c.frames_sent
              << " frames sent, " << c.frames_dropped << " dropped (slow clients), "
              << c.closed_bad_input << " connections closed for bad input"
              << viewer_overload(c, vs.max_http_connections) << "\n";
  }
  if (igtl_world) {
    const sim::IgtlWorldCounters& c = igtl_world->counters();
    std::cerr << "  OpenIGTLink world: " << c.clients_total << " clients, " << c.messages
              << " TRANSFORMs, " << c.polydata << " POLYDATA, " << c.statuses << " STATUS, "
              << c.strings << " STRING (" << c.events << " events), " << c.frames_skipped
              << " client-frames skipped (slow clients), " << c.clients_refused
              << " clients refused\n";
  }
  // A run stopped by a signal and otherwise clean exits 128 + the signal (shell convention):
  // run_verdict() put that status, and the signal's name, in the summary.
  return summary.exit_status;
}

}  // namespace numen::app
