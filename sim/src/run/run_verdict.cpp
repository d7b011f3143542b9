/// @file run_verdict.cpp
/// The exit status of a finished run (see run_verdict.hpp).

#include "numen/sim/run/run_verdict.hpp"

#include <csignal>
#include <cstdio>
#include <iomanip>
#include <sstream>
#include <string>
#include <utility>

#include "numen/sim/run/run_summary.hpp"

namespace numen::sim {

const char* to_string(ExitStatus s) noexcept {
  switch (s) {
    case ExitStatus::kClean: return "clean";
    case ExitStatus::kError: return "error";
    case ExitStatus::kInputRejected: return "input rejected";
    case ExitStatus::kSafetyStop: return "safety stop";
    case ExitStatus::kNonFinite: return "non-finite state";
    case ExitStatus::kLostRecords: return "lost records";
    case ExitStatus::kSamplesRejected: return "samples rejected";
    case ExitStatus::kDiverged: return "diverged";
  }
  return "?";
}

RunVerdict run_verdict(const RunSummary& s) {
  RunVerdict v;
  auto add = [&v](ExitStatus status, const std::string& why) {
    v.reasons.push_back(std::string(to_string(status)) + ": " + why);
    // Severity order: non-finite, diverged, safety stop, lost records, samples rejected.
    auto rank = [](ExitStatus x) {
      switch (x) {
        case ExitStatus::kNonFinite: return 5;
        case ExitStatus::kDiverged: return 4;
        case ExitStatus::kSafetyStop: return 3;
        case ExitStatus::kLostRecords: return 2;
        case ExitStatus::kSamplesRejected: return 1;
        default: return 0;
      }
    };
    if (rank(status) > rank(v.status)) v.status = status;
  };
  const auto n = [](std::int64_t x) { return std::to_string(x); };
  if (s.nonfinite_steps > 0) add(ExitStatus::kNonFinite, n(s.nonfinite_steps) + " steps");
  else if (s.nan_detected) add(ExitStatus::kNonFinite, "the final state is not finite");
  if (s.divergence.latched) {
    char why[320];
    const std::string& cause = s.divergence.cause;
    // A device axis is prismatic (m/s) or revolute (rad/s): its speed is in the axis's unit.
    const char* unit = cause == "energy"         ? "J"
                       : cause == "tie stretch"  ? "m"
                       : cause == "device plant" ? "m/s or rad/s"
                                                 : "m/s";
    // 4 significant digits, more where the value and its limit would read the same (a speed of
    // 200.008 just past its limit 200: "200.01 above its limit 200", not "200 above ... 200").
    const auto significant = [](double v, int digits) {
      std::ostringstream os;
      os << std::setprecision(digits) << v;  // as printf's %.<digits>g
      return os.str();
    };
    int digits = 4;
    while (digits < 17 &&
           significant(s.divergence.value, digits) == significant(s.divergence.limit, digits))
      ++digits;
    std::snprintf(why, sizeof why, "%s of %s: %s above its limit %s (%s) at %.4f s", cause.c_str(),
                  s.divergence.subject.c_str(), significant(s.divergence.value, digits).c_str(),
                  significant(s.divergence.limit, digits).c_str(), unit, s.divergence.time_s);
    add(ExitStatus::kDiverged, why);
  }
  if (s.needle_tunnels > 0)  // docs/suturing.md: a needle through tissue without a puncture
    add(ExitStatus::kDiverged, n(s.needle_tunnels) +
                                   " needle tunnel(s): a needle's tip went into tissue without puncturing it "
                                   "(the warnings name the needle)");
  if (s.faults > 0)
    add(ExitStatus::kSafetyStop, n(s.faults) + " safe state(s) latched, first: " + s.first_fault);
  for (std::size_t i = 1; i < s.devices.size(); ++i)
    if (s.devices[i].faults > 0)
      add(ExitStatus::kSafetyStop,
          n(s.devices[i].faults) + " safe state(s) latched (device \"" + s.devices[i].name + "\")");
  if (s.managed && s.startup.rfind("failed", 0) == 0)
    add(ExitStatus::kSafetyStop, "start-up " + s.startup);
  if (s.bus_record_dropped > 0)
    add(ExitStatus::kLostRecords, "--record: " + n(s.bus_record_dropped) + " frames dropped");
  if (s.bus_record_io_errors > 0 || s.bus_record_format_errors > 0 ||
      s.bus_record_written < s.bus_frames_recorded)
    add(ExitStatus::kLostRecords,
        "--record: " + n(s.bus_record_written) + " of " + n(s.bus_frames_recorded) +
            " frames written (" + n(s.bus_record_io_errors) + " I/O errors, " +
            n(s.bus_record_format_errors) + " not formattable)");
  if (s.view_recorded && (s.view_frames_dropped > 0 || s.view_record_io_errors > 0 ||
                          s.view_record_frames < s.view_frames_published))
    add(ExitStatus::kLostRecords, "--record-view: " + n(s.view_record_frames) + " of " +
                                      n(s.view_frames_published + s.view_frames_dropped) +
                                      " due frames written (" + n(s.view_frames_dropped) +
                                      " dropped, " + n(s.view_record_io_errors) + " I/O errors)");
  if (s.trace_dropped > 0 || s.trace_io_errors > 0 || s.trace_written < s.trace_pushed)
    add(ExitStatus::kLostRecords, "--trace: " + n(s.trace_written) + " of " +
                                      n(s.trace_pushed + s.trace_dropped) + " records written (" +
                                      n(s.trace_io_errors) + " I/O errors)");
  if (!s.stdout_error.empty())
    add(ExitStatus::kLostRecords, "stdout: the summary was not written (" + s.stdout_error + ")");
  if (s.rejected_samples > 0)
    add(ExitStatus::kSamplesRejected,
        n(s.rejected_samples) + " axis samples rejected" +
            (s.rejected_causes.empty() ? "" : ": " + s.rejected_causes));
  for (std::size_t i = 1; i < s.devices.size(); ++i)  // device 0's are the summary's own
    if (s.devices[i].rejected_samples > 0)
      add(ExitStatus::kSamplesRejected,
          n(s.devices[i].rejected_samples) + " axis samples rejected (device \"" +
              s.devices[i].name + "\")" +
              (s.devices[i].rejected_causes.empty() ? "" : ": " + s.devices[i].rejected_causes));
  if (s.invalid_target_steps > 0)  // core::kInvalidTarget: the step skipped the coupling
    add(ExitStatus::kSamplesRejected, n(s.invalid_target_steps) +
                                          " steps with a non-finite device target (coupling "
                                          "skipped, feedback held)");
  // Frames on an encoder's COB-ID of the wrong kind or length: each rejected its axis's
  // sample. Named, whatever else the run latched (every encoder frame sent as CAN FD read
  // "first: drive stuck" and nothing about the frames).
  if (const std::int64_t bad =
          s.encoder_frames_fd + s.encoder_frames_remote + s.encoder_frames_wrong_length;
      bad > 0)
    add(ExitStatus::kSamplesRejected,
        n(bad) + " encoder frames rejected (CAN FD " + n(s.encoder_frames_fd) + ", remote " +
            n(s.encoder_frames_remote) + ", wrong length " + n(s.encoder_frames_wrong_length) +
            "): encoder TPDOs are classic CAN data frames of their mapped length");
  // A run a signal ended (perhaps before the first sample arrived) is not judged on this.
  if (s.steps > 0 && s.invalid_periods >= s.steps && !s.stopped) {
    // The managed stack's encoders send once the start-up has made them operational: a run
    // that ends before that has no sample, through no fault of the frames. A run stopped by
    // its divergence would not have been longer: a longer --duration does not help it.
    if (s.managed && s.startup.rfind("operational", 0) != 0 && s.startup.rfind("failed", 0) != 0)
      add(ExitStatus::kSamplesRejected,
          "no period had a valid sample: " +
              (s.divergence.latched
                   ? "the divergence stopped the run after " + n(s.steps) + " periods, before"
                   : "the run's " + n(s.steps) + " periods ended before") +
              " the CANopen start-up finished (still in phase '" + s.startup +
              "'); the encoders send once their nodes are operational" +
              (s.divergence.latched ? "" : ": run longer"));
    else
      add(ExitStatus::kSamplesRejected, "no period had a valid sample");
  }
  // The OpenIGTLink tracker (--bus igtl): every message rejected, pose lost, connection lost
  // and a tool never heard of is input the run did not get (docs/openigtlink.md).
  if (!s.igtl.empty()) {
    if (s.igtl_faults > 0) {
      std::string where;
      for (const std::string& r : s.igtl_fault_records) where += (where.empty() ? "" : "; ") + r;
      add(ExitStatus::kSamplesRejected,
          n(s.igtl_faults) + " OpenIGTLink messages rejected (" + where + ")");
    }
    if (s.igtl_dropped > 0)
      add(ExitStatus::kSamplesRejected,
          n(s.igtl_dropped) + " OpenIGTLink poses dropped: the queue was full (a flood)");
    // Poses refused for their timestamps, per reason (the stream went on with the next pose).
    if (const std::int64_t refused =
            s.igtl_stamps_backwards + s.igtl_stamps_ahead + s.igtl_stamps_unstamped;
        refused > 0)
      add(ExitStatus::kSamplesRejected,
          n(refused) + " tracker poses refused for their timestamps (" +
              n(s.igtl_stamps_backwards) + " before the last pose taken, " +
              n(s.igtl_stamps_ahead) + " more than 10 s after it, " + n(s.igtl_stamps_unstamped) +
              " unstamped while following the tracker's clock; " + n(s.igtl_stamp_resyncs) +
              " re-basings on a clock that jumped)");
    // Following a replay, its end is the stream's: a fault only when the run outlasted it.
    if (s.igtl_disconnects > 0 && !s.igtl_follows)
      add(ExitStatus::kSamplesRejected,
          "the OpenIGTLink server " + s.igtl + " closed the connection " + n(s.igtl_disconnects) +
              " times");
    if (s.igtl_periods_after_end > 0 && s.igtl_poses > 0)
      add(ExitStatus::kSamplesRejected,
          "the tracker's stream ended " + n(s.igtl_periods_after_end) +
              " periods before the run did (" + n(s.igtl_disconnects) + " connection(s) lost)");
    if (s.igtl_wait_timeouts > 0)
      add(ExitStatus::kSamplesRejected,
          n(s.igtl_wait_timeouts) + " waits for the tracker ran out (the run went on without "
                                     "its poses, at its pace, until one came)");
    if (s.igtl_poses == 0) {
      std::string names;
      for (const std::string& x : s.igtl_names_seen) names += (names.empty() ? "'" : ", '") + x + "'";
      add(ExitStatus::kSamplesRejected,
          s.igtl_connects == 0
              ? "no connection to the OpenIGTLink server " + s.igtl + " (" +
                    n(s.igtl_connect_failures) + " attempts refused or timed out)"
              : "no pose (TRANSFORM, POSITION or QTRANS) of the tool " + s.igtl + " in " +
                    n(s.igtl_messages) + " messages" +
                    (names.empty() ? "" : " (device names sent: " + names + ")"));
    }
  }
  if (s.bus.rfind("log:", 0) == 0 && s.bus_frames_replayed == 0)
    add(ExitStatus::kSamplesRejected, "the bus log gave no frame");
  v.exit_status = code(v.status);
  if (s.stopped) {
    v.reasons.push_back(s.stop_signal > 0 ? "stopped by a signal: " + signal_name(s.stop_signal) +
                                                " (" + n(s.stop_signal) + ") after " +
                                                n(s.steps) + " periods"
                                          : "stopped early (RunOptions::stop) after " +
                                                n(s.steps) + " periods");
    if (v.status == ExitStatus::kClean && s.stop_signal > 0) v.exit_status = 128 + s.stop_signal;
  }
  return v;
}

void judge_run(RunSummary& s) {
  RunVerdict verdict = run_verdict(s);
  s.exit_status = verdict.exit_status;
  s.exit_reasons = std::move(verdict.reasons);
}

const char* exit_status_name(int status) noexcept {
  if (status > 128 && status <= 128 + 64) return "stopped by a signal";
  if (status < 0 || status > code(ExitStatus::kDiverged)) return "?";
  return to_string(static_cast<ExitStatus>(status));
}

std::string signal_name(int signal) {
  switch (signal) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    case SIGQUIT: return "SIGQUIT";
    case SIGUSR1: return "SIGUSR1";
    case SIGUSR2: return "SIGUSR2";
    default: return "signal " + std::to_string(signal);
  }
}

}  // namespace numen::sim
