#pragma once
/// @file commands.hpp
/// The subcommands of `numen`, one class each (one file each: run_command.cpp,
/// device_command.cpp, info_command.cpp, figures_command.cpp, study_command.cpp,
/// view_command.cpp, scan_command.cpp, sdo_command.cpp, igtl_replay_command.cpp). A command
/// declares its options on construction and does its work in execute(), which returns the
/// exit status (docs/inputs.md, "Exit statuses") and may throw (run_guarded()). The options
/// are bound to the command's members: construct it in place and keep it there.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "numen/platform/multirate_threads.hpp"
#include "numen/platform/realtime_setup.hpp"
#include "numen/sim/view/view_server.hpp"

namespace numen::sim {
struct Scene;
struct StepTiming;
}  // namespace numen::sim

namespace numen::app {

/// Runs a subcommand's body, which returns its exit status; an exception ends it with 2 for
/// bad input (InputError: scene, trajectory, option values) or 1 for any other error (I/O,
/// out of memory, internal), printed as "numen: what". Then stdout is flushed: if any of the
/// body's output did not reach it (closed, a full disk, a pipe whose reader has gone), that is
/// printed ("numen: stdout: cannot write the output (Broken pipe)") and a status 0 becomes 1.
int run_guarded(const std::function<int()>& body);
/// The scene flags of the commands that load a closed-loop scene (docs/device_plant.md):
/// `--replay` (SceneOverrides::replay; null: not offered) and `--strict`
/// (SceneOverrides::strict).
void add_scene_flags(CLI::App* command, bool* replay, bool& strict);
/// CLI11 check of a time in seconds (numen::sim::check_seconds): finite, in [lo, hi] or (lo, hi].
CLI::Validator seconds_check(double lo, double hi, bool lo_exclusive);
/// CLI11 check of a plain number (a rate, a factor): finite, in [lo, hi] (or (lo, hi] when
/// `lo_exclusive`); "nan" and "inf" are refused.
CLI::Validator number_check(double lo, double hi, bool lo_exclusive);
/// CLI11 check of a whole number in [lo, hi] (numen::sim::check_count): names the range where
/// CLI11's conversion would only say "Could not convert".
CLI::Validator count_check(long long lo, long long hi);
/// CLI11 check of a --bus spec; `real_only`: only can:IFACE or serial:PATH[@BAUD].
std::string check_bus(const std::string& v, bool real_only);

/// `numen run [SCENE] ...`: runs a scene and prints its summary (text, or --json).
class RunCommand {
 public:
  explicit RunCommand(CLI::App& parent);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

  /// The stack a paced run prefaults on its loop thread unless --prefault-stack is given.
  static constexpr std::size_t kPacedPrefaultStackBytes = 256 * 1024;

 private:
  /// The loop thread's real-time settings as asked (--rt-priority, --lock-memory, ...), with a
  /// `paced` run's defaults: memory locked (unless --no-lock-memory) and
  /// kPacedPrefaultStackBytes of stack prefaulted (unless --prefault-stack).
  platform::RealtimeSettings paced_realtime_settings(bool paced) const;

  CLI::App* cli_;
  std::string scene_path_, trace_path_, coupling_, bus_ = "sim", record_path_, record_view_path_, view_;
  std::string igtl_;  // --igtl [HOST:]PORT: the world out over OpenIGTLink
  double igtl_organ_rate_ = 30.0;  // --igtl-organ-rate HZ: POLYDATA updates per simulated second
  std::string igtl_names_ = "numen";  // --igtl-names numen|plus: how the TRANSFORMs are named
  double duration_ = -1.0, phase_ = -1.0, view_rate_ = 60.0, speed_ = 0.0, spin_us_ = 0.0,
         scene_spin_us_ = 0.0;
  std::int64_t timer_slack_ns_ = 1;
  std::int32_t cpu_dma_latency_us_ = 0;  // --cpu-dma-latency US: a paced run's PM QoS request
  bool no_lock_memory_ = false, no_cpu_dma_latency_ = false;  // a paced run's defaults left
  std::string wait_for_viewer_;  // --wait-for-viewer[=S] as given (a flag: CLI11 would round a number)
  bool json_ = false, realtime_ = false, replay_ = false, strict_ = false;
  platform::RealtimeSettings rt_;
  platform::SceneThreadSettings scene_thread_;
  std::uint32_t overrun_limit_ = 3;
};

/// The viewer page's folder: share/numen/viewer of the installed prefix, else the build
/// tree's (build/viewer, sim/CMakeLists.txt); sim::shipped_viewer_dir().
std::string viewer_page_dir();
/// When a scene has loaded (`numen run`, `numen info`): times its step (sim::time_scene_step()),
/// adds step_timing_warning() to its warnings when the step does not fit the period, and prints
/// each of its warnings on `err` as "numen: warning: …" (a run keeps them in its summary too).
/// Returns the timing.
sim::StepTiming check_loaded_scene(sim::Scene& scene, std::ostream& err);
/// Prints a warning on `err` when `what` (the viewer, the OpenIGTLink world) listens on a `host`
/// that is not a loopback address.
void warn_if_exposed(const std::string& host, std::ostream& err, const char* what = "the viewer");
/// What the viewer's server turned away, for its closing line: ", N HTTP connections shed (more
/// than M open), K accepts failed (out of descriptors or memory)", each part only when not 0;
/// "" when none.
std::string viewer_overload(const sim::ViewServerCounters& c, std::size_t max_http_connections);

/// `numen view FILE.nmv [--port P] [--host H]`: serves a view recording to the browser.
class ViewCommand {
 public:
  explicit ViewCommand(CLI::App& parent);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string file_, host_ = "127.0.0.1", page_dir_;
  std::uint16_t port_ = 8080;
};

/// `numen device [SCENE] --bus ...`: the scene's simulated instrument on a real bus.
class DeviceCommand {
 public:
  explicit DeviceCommand(CLI::App& parent);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string scene_, bus_;
  double duration_ = -1.0;
  bool ready_ = false, replay_ = false, strict_ = false;
};

/// `numen scan --bus ...`: the CANopen nodes on a bus and their identities (SDO reads; never
/// starts or stops a node).
class ScanCommand {
 public:
  explicit ScanCommand(CLI::App& parent);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string bus_;
  double listen_s_ = 1.5, timeout_s_ = 0.5;
  bool json_ = false;
};

/// `numen igtl-replay [SCENE] [--host H] [--port P] [--rate HZ] [--duration S] [--realtime]
/// [--stall-at S --stall S]`: plays the scene's trajectory as an OpenIGTLink tracker server (sim/device/igtl_replay.hpp;
/// docs/openigtlink.md).
class IgtlReplayCommand {
 public:
  explicit IgtlReplayCommand(CLI::App& parent);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string scene_, host_ = "127.0.0.1";
  int port_ = 18944;
  double rate_ = 0.0, duration_ = -1.0, accept_timeout_ = 30.0;
  double stall_at_ = 0.0, stall_ = 0.0;  // --stall-at, --stall (IgtlReplaySettings)
  bool realtime_ = false;
  std::string message_ = "transform";  // --message transform|position|qtrans
};

/// `numen sdo --bus ... NODE read|write INDEX:SUB [VALUE] [--type T]`: one SDO transfer.
class SdoCommand {
 public:
  explicit SdoCommand(CLI::App& parent);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string bus_, action_, address_, value_, type_;
  int node_ = 0;
  double timeout_s_ = 0.5;
};

/// `numen info [SCENE] [--json]`: what a scene compiles to.
class InfoCommand {
 public:
  explicit InfoCommand(CLI::App& parent);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string scene_;
  bool json_ = false, strict_ = false;
};

/// `numen figures`: the table of a run's summary figures (run_figures()) as Markdown;
/// `--all`: every output's names (record_lists.hpp).
class FiguresCommand {
 public:
  explicit FiguresCommand(CLI::App& parent);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  bool all_ = false;
};

/// `numen study accuracy ...`: work-precision data per integrator.
class AccuracyStudyCommand {
 public:
  explicit AccuracyStudyCommand(CLI::App& study);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string out_ = "accuracy";
  bool quick_ = false;
  std::vector<std::string> cases_;
  std::string shard_;  ///< "I/N" or "" (then SLURM_ARRAY_TASK_ID/COUNT, or the whole study).
  bool list_ = false;
};

/// `numen study stability ...`: stiff and extreme cases, a verdict per run.
class StabilityStudyCommand {
 public:
  explicit StabilityStudyCommand(CLI::App& study);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string out_ = "stability";
  bool quick_ = false;
  std::vector<std::string> families_;
  std::string shard_;  ///< "I/N" or "" (then SLURM_ARRAY_TASK_ID/COUNT, or the whole study).
  bool list_ = false;
};

/// `numen study passivity ...`: the Z-width of a 1-DOF impedance device (docs/passivity.md).
class PassivityStudyCommand {
 public:
  explicit PassivityStudyCommand(CLI::App& study);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string out_ = "passivity";
  bool quick_ = false;
  std::string shard_;  ///< "I/N" or "" (then SLURM_ARRAY_TASK_ID/COUNT, or the whole study).
  bool list_ = false;
};

/// `numen study merge DIR`: the shard files of a study (docs/studies.md) checked and merged
/// into the one-process run's CSV files.
class MergeStudyCommand {
 public:
  explicit MergeStudyCommand(CLI::App& study);
  bool parsed() const { return cli_->parsed(); }
  int execute() const;

 private:
  CLI::App* cli_;
  std::string dir_;
  std::string out_;  ///< "" = dir_.
};

}  // namespace numen::app
