#pragma once
/// @file run_verdict.hpp
/// The exit status of `numen run`: what a finished run's summary says about it, so that a
/// run that produced non-finite state, latched a safety stop, lost recorded records or was fed
/// rejected input never ends with status 0 (docs/inputs.md, "Exit statuses"). A script, a CI
/// job or the HIL suite reads the status; `--json` carries the same verdict.

#include <string>
#include <vector>

namespace numen::sim {

struct RunSummary;

/// Exit statuses of the `numen` command. When several conditions hold, the most severe one is
/// the status (non-finite and diverged first, then the order below) and every one is listed in the reasons.
enum class ExitStatus : int {
  kClean = 0,             ///< The run ended as asked, nothing was lost or rejected.
  kError = 1,             ///< An error that is not the input's (I/O, resources, internal).
  kInputRejected = 2,     ///< The input was refused before the run: scene, trajectory, bus log,
                          ///< command-line value (located message on stderr).
  kSafetyStop = 3,        ///< The safety supervisor latched a safe state (docs/safety.md) or
                          ///< the managed start-up failed.
  kNonFinite = 4,         ///< A step produced non-finite state (core::Data::nonfinite_steps),
                          ///< or the final state is not finite.
  kLostRecords = 5,       ///< Records of --record / --trace were dropped or not written, or
                          ///< the summary could not be written on stdout.
  kSamplesRejected = 6,   ///< Input samples were rejected during the run (encoder values out
                          ///< of range, jumps, non-finite; a step's device target not finite), no sample was ever valid in a run
                          ///< that was not stopped by a signal, or a replayed bus log gave no frame.
  kDiverged = 7,          ///< The divergence monitor latched: finite state that physics bounds
                          ///< (speeds, tie stretch, energy) say is not a simulation any more
                          ///< (divergence.hpp); the run stopped commanding torque there.
                          ///< Also a needle's tunnel (RunSummary::needle_tunnels: its tip
                          ///< through tissue without a puncture); that run goes on to its end.
};

/// Numeric value of `s` (the process exit status).
constexpr int code(ExitStatus s) noexcept { return static_cast<int>(s); }

/// Short name of `s` ("clean", "safety stop", ...).
const char* to_string(ExitStatus s) noexcept;

/// A run's status and every condition that holds, most severe first, as readable lines
/// ("non-finite state: 22 013 steps", ..., "stopped by a signal: SIGTERM (15)"); empty for a
/// clean run that was not stopped.
struct RunVerdict {
  ExitStatus status = ExitStatus::kClean;
  std::vector<std::string> reasons;
  /// The process exit status: code(status), or 128 + RunSummary::stop_signal for a run a
  /// signal ended (RunSummary::stopped, signal known) whose status is otherwise kClean (shell
  /// convention: 130 for SIGINT, 143 for SIGTERM).
  int exit_status = 0;
};

/// The verdict on a finished run from its summary. A run ended early by a signal
/// (RunSummary::stopped) is judged on what it ran; its reasons name the signal, and its
/// exit_status is 128 + the signal number when that verdict is clean.
RunVerdict run_verdict(const RunSummary& summary);

/// Sets `summary.exit_status` and `summary.exit_reasons` from run_verdict(summary) (run_scene()
/// does; the command again once it knows whether the summary reached stdout).
void judge_run(RunSummary& summary);

/// Name of a process exit status: to_string() of an ExitStatus, "stopped by a signal" for
/// 128 + a signal number (129..192), "?" for any other.
const char* exit_status_name(int status) noexcept;

/// "SIGINT", "SIGTERM", ... for the signals numen handles, else "signal N".
std::string signal_name(int signal);

}  // namespace numen::sim
