/// @file run_options.cpp
/// The checks of a run's options (run_options.hpp): what a run would not apply, or could not
/// write, is refused before anything is opened.

#include "numen/sim/run/run_options.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "numen/sim/input/bus_spec.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/igtl_run.hpp"
#include "numen/sim/run/trace.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

std::size_t in_memory_trace_capacity(std::int64_t periods) {
  // One record per period kept until the run ends: a long --duration with --trace.
  const double bytes = static_cast<double>(periods) * static_cast<double>(sizeof(TraceRecord));
  if (bytes > static_cast<double>(kMaxInMemoryTraceBytes))
    throw InputError("", 0, 0, "--trace",
                     "a simulated run keeps one trace record (" +
                         std::to_string(sizeof(TraceRecord)) + " bytes) per period until it "
                         "ends: " + std::to_string(periods) + " periods need " +
                         std::to_string(static_cast<long long>(bytes / (1 << 20))) +
                         " MiB, more than the " + std::to_string(kMaxInMemoryTraceBytes >> 20) +
                         " MiB a trace may take; shorten --duration");
  return static_cast<std::size_t>(std::max<std::int64_t>(periods, 0));
}

namespace {

/// The thread a busy-wait option spins on: the option, its CPU option, the words the
/// messages use and the period it must stay below.
struct SpinThread {
  const char* key;         ///< "--spin", "--scene-spin"
  const char* cpu_option;  ///< "--cpu", "--scene-cpu"
  const char* period;      ///< "period", "scene period"
  const char* thread;      ///< "loop thread", "scene thread"
  const char* doc;         ///< docs/realtime.md's section
  const char* period_name; ///< "dt", "scene_dt"
  double period_s;
};

/// Refuses a spin that is negative, that would take a CPU the thread does not have to itself,
/// or that fills the whole period (InputError naming the option).
void check_spin(const SpinThread& t, std::int64_t spin_ns, bool own_cpu) {
  const std::string spin = format_input_number(static_cast<double>(spin_ns) * 1e-3) + " us";
  if (spin_ns < 0) throw InputError("", 0, 0, t.key, "must be >= 0 us (got " + spin + ")");
  if (!own_cpu)
    throw InputError("", 0, 0, t.key,
                     "busy-waits up to " + spin + " a " + t.period + " on the " + t.thread +
                         "'s CPU: give it a CPU of its own with " + t.cpu_option +
                         " (docs/realtime.md, \"" + t.doc + "\")");
  if (static_cast<double>(spin_ns) >= t.period_s * 1e9)
    throw InputError("", 0, 0, t.key,
                     spin + " must be below the " + t.period + " " + t.period_name + " = " +
                         format_input_number(t.period_s * 1e6) + " us");
}

/// Refuses a --spin that this run would not apply or that would take the loop's CPU from
/// others (InputError naming the option).
void check_pacing_options(const Scene& scene, const RunOptions& options, bool paced) {
  if (options.spin_ns == 0) return;
  if (options.spin_ns > 0 && !paced)
    throw InputError("", 0, 0, "--spin",
                     "ends a paced period's wait in a busy-wait; this run is offline (no "
                     "--realtime, no real bus)");
  check_spin({"--spin", "--cpu", "period", "loop thread", "Spinning the end of the wait", "dt",
              scene.model.dt},
             options.spin_ns, !options.rt.cpu_affinity.empty());
}

/// Refuses a --scene-spin that would take the scene thread's CPU from others or fill its
/// whole period (InputError naming the option); the scene thread runs (a paced multirate run).
void check_scene_spin(const MultirateScene& multirate, const platform::SceneThreadSettings& st) {
  if (st.spin_ns == 0) return;
  check_spin({"--scene-spin", "--scene-cpu", "scene period", "scene thread",
              "Paced on a 16-core machine", "scene_dt", multirate.scene_dt_s},
             st.spin_ns, !st.cpu_affinity.empty());
}

/// Refuses options that this run would not apply (InputError naming the option): nothing a
/// user asks for is dropped without a word.
void check_option_values(const Scene& scene, const RunOptions& options) {
  const double duration = options.duration_s >= 0.0 ? options.duration_s : scene.duration_s;
  if (std::llround(duration / scene.model.dt) < 1)
    throw InputError("", 0, 0, "--duration",
                     format_input_number(duration) + " s is less than half a period (dt = " +
                         format_input_number(scene.model.dt) + " s): the run would have none");
  // An admittance scene's real bus is refused by its runner (run_scene(): its harness).
  const bool paced =
      options.realtime || (!scene.admittance && parse_bus_spec(options.bus.spec).real());
  if (options.view_speed > 0.0 && paced)
    throw InputError("", 0, 0, "--speed",
                     "paces an offline run; this run is paced at real time already (--realtime "
                     "or a real bus)");
  // A paced offline run lasts duration / speed of wall time: at most kMaxRunDuration, the cap
  // of a paced run's --duration (--speed 1e-9 made a 30 s scene take 3e10 s).
  if (options.view_speed > 0.0 && duration / options.view_speed > kMaxRunDuration)
    throw InputError(
        "", 0, 0, "--speed",
        format_input_number(options.view_speed) + " paces the " + format_input_number(duration) +
            " s run to " + format_input_number(duration / options.view_speed) +
            " s of wall time, more than the " + format_input_number(kMaxRunDuration) +
            " s a run may last (at least " + format_input_number(duration / kMaxRunDuration) + ")");
  // SCHED_FIFO on a loop that is not paced (an offline run never sleeps) takes its CPU from
  // every thread of lower priority for the whole run: refused, as --timer-slack is.
  if (options.rt.fifo_priority != 0 && !paced)
    throw InputError("", 0, 0, "--rt-priority",
                     "gives a paced run's loop thread SCHED_FIFO; this run is offline (no "
                     "--realtime, no real bus): its loop is not paced to deadlines, and run "
                     "flat out under SCHED_FIFO it would hold its CPU from every thread of "
                     "lower priority");
  // Timer slack lets a wake-up come that late: more than a period, and the loop would wake a
  // period late or more (--timer-slack 1000000000: 60 periods in 60 s).
  if (paced && static_cast<double>(options.timer_slack_ns) > scene.model.dt * 1e9)
    throw InputError("", 0, 0, "--timer-slack",
                     std::to_string(options.timer_slack_ns) +
                         " ns must be at most the period dt = " +
                         std::to_string(std::llround(scene.model.dt * 1e9)) +
                         " ns: a timer may fire that late, and each period would wake late");
  compute_phase_override_ns(scene, options);  // --phase at or above dt
  check_pacing_options(scene, options, paced);
  // A simulated run's trace is kept in memory until it ends (a real bus streams it).
  if (!options.trace_path.empty() && (scene.admittance || !parse_bus_spec(options.bus.spec).real()))
    in_memory_trace_capacity(std::llround(duration / scene.model.dt));
  const platform::SceneThreadSettings& st = options.scene_thread;
  if (st.fifo_priority == 0 && st.cpu_affinity.empty() && st.spin_ns == 0) return;
  const std::string key = st.fifo_priority != 0    ? "--scene-rt-priority"
                          : !st.cpu_affinity.empty() ? "--scene-cpu"
                                                     : "--scene-spin";
  if (!scene.multirate)
    throw InputError("", 0, 0, key,
                     "scene \"" + scene.name + "\" has no [multirate]: there is no scene thread");
  if (!paced)
    throw InputError("", 0, 0, key,
                     "an offline run steps both loops on one thread: the scene thread runs in "
                     "paced runs only (--realtime or a real bus)");
  if (st.fifo_priority != 0 && st.fifo_priority >= options.rt.fifo_priority)
    throw InputError("", 0, 0, "--scene-rt-priority",
                     std::to_string(st.fifo_priority) + " must be below the loop thread's " +
                         (options.rt.fifo_priority == 0
                              ? std::string("(--rt-priority not given: not real-time)")
                              : "--rt-priority " + std::to_string(options.rt.fifo_priority)) +
                         ": the scene thread would pre-empt the device loop");
  check_scene_spin(*scene.multirate, st);
}

/// Refuses an output path (--trace, --record, --record-view) that cannot be written before the
/// run (InputError, key `key`), so that a long run does not end without its file, and the
/// error names the option. Touches nothing: an existing file keeps its bytes (the writers
/// replace it only when the run closes it, hal::LineFile), a missing one is not created.
void check_output_path(const std::string& path, const std::string& key) {
  auto refuse = [&](const std::string& why) {
    throw InputError("", 0, 0, key, path + ": cannot be opened for writing (" + why + ")");
  };
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) refuse(std::strerror(EISDIR));
    if (::access(path.c_str(), W_OK) != 0) refuse(std::strerror(errno));
    return;
  }
  if (errno != ENOENT) refuse(std::strerror(errno));
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  const std::string dir = parent.empty() ? "." : parent.string();
  if (::stat(dir.c_str(), &st) != 0) refuse(std::strerror(errno));
  if (!S_ISDIR(st.st_mode)) refuse(dir + " is not a directory");
  if (::access(dir.c_str(), W_OK | X_OK) != 0) refuse(dir + ": " + std::strerror(errno));
}

/// True when `a` and `b` name one regular file: the same inode when both exist, the same
/// absolute path (symbolic links of its existing part resolved) when neither does. A device or
/// FIFO is written in place and may take several outputs (`/dev/null`): never the same file.
bool same_regular_file(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  const bool a_exists = ::stat(a.c_str(), &sa) == 0;
  const bool b_exists = ::stat(b.c_str(), &sb) == 0;
  if (a_exists != b_exists) return false;
  if (a_exists)
    return S_ISREG(sa.st_mode) && S_ISREG(sb.st_mode) && sa.st_dev == sb.st_dev &&
           sa.st_ino == sb.st_ino;
  std::error_code ea, eb;
  const std::filesystem::path ca = std::filesystem::weakly_canonical(a, ea);
  const std::filesystem::path cb = std::filesystem::weakly_canonical(b, eb);
  return !ea && !eb && ca == cb;
}

/// Refuses an output on the file of another output (the one closed last would replace the
/// other's without a word) or on a file the run reads (the scene file, the `--bus log:` log:
/// the output would replace it). InputError at the later output's key.
void check_outputs_distinct(const Scene& scene, const RunOptions& options) {
  struct Output {
    const char* key;
    const std::string& path;
  };
  struct Input {
    std::string path, what;
  };
  std::vector<Input> inputs;
  if (!scene.file.empty()) inputs.push_back({scene.file, "the scene file"});
  const BusSpec bus = parse_bus_spec(options.bus.spec);
  if (bus.kind == BusKind::kLog)
    inputs.push_back({bus.target, "the replayed log (--bus " + options.bus.spec + ")"});
  std::vector<Output> outputs;
  if (!options.trace_path.empty()) outputs.push_back({"--trace", options.trace_path});
  if (!options.bus.record_path.empty() && !scene.admittance)
    outputs.push_back({"--record", options.bus.record_path});
  if (!options.record_view_path.empty())
    outputs.push_back({"--record-view", options.record_view_path});
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    for (const Input& in : inputs)
      if (same_regular_file(outputs[i].path, in.path))
        throw InputError("", 0, 0, outputs[i].key,
                         outputs[i].path + " is " + in.what + ": the output would replace it");
    for (std::size_t j = 0; j < i; ++j)
      if (same_regular_file(outputs[i].path, outputs[j].path))
        throw InputError("", 0, 0, outputs[i].key,
                         outputs[i].path + " is also " + outputs[j].key +
                             "'s file: each output needs a file of its own (the one closed "
                             "last would replace the other)");
  }
}

}  // namespace

std::int64_t compute_phase_override_ns(const Scene& scene, const RunOptions& options) {
  if (options.compute_phase_s < 0.0) return -1;
  if (!(options.compute_phase_s < scene.model.dt))
    throw InputError("", 0, 0, "--phase",
                     format_input_number(options.compute_phase_s) +
                         " s must be below the period dt = " + format_input_number(scene.model.dt) +
                         " s");
  return static_cast<std::int64_t>(std::llround(options.compute_phase_s * 1e9));
}

void check_run_options(const Scene& scene, const RunOptions& options) {
  if (!(options.view_rate_hz > 0.0))
    throw InputError("", 0, 0, "--view-rate", "must be > 0 frames per second (got " +
                                                  format_input_number(options.view_rate_hz) + ")");
  if (!(options.view_speed >= 0.0) || !std::isfinite(options.view_speed))
    throw InputError("", 0, 0, "--speed", "must be a finite factor >= 0 (got " +
                                              format_input_number(options.view_speed) + ")");
  // Every refusal comes before any output is opened, and the output checks touch nothing: a
  // refused run leaves every file as it was (docs/inputs.md, "Outputs").
  check_option_values(scene, options);
  if (const std::string why = igtl_run_refusal(scene, parse_bus_spec(options.bus.spec));
      !why.empty())
    throw InputError("", 0, 0, "--bus", why);
  if (!options.trace_path.empty()) check_output_path(options.trace_path, "--trace");
  // (an admittance run refuses --record: run_scene())
  if (!options.bus.record_path.empty() && !scene.admittance)
    check_output_path(options.bus.record_path, "--record");
  if (!options.record_view_path.empty())
    check_output_path(options.record_view_path, "--record-view");
  check_outputs_distinct(scene, options);
}

}  // namespace numen::sim
