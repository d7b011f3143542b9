#pragma once
/// @file signals.hpp
/// The `numen` command's signal handling. SIGINT / SIGTERM / SIGHUP (a closed terminal or ssh
/// session): while the input loads, the process ends at once (status 128 + signal; nothing is
/// open on a bus yet); once a run or device has started (loading_done()), they set stop_flag()
/// and the command ends cleanly. SIGUSR1 sets rearm_flag() (the operator's re-arm,
/// RunOptions::rearm). SIGPIPE is ignored from the start (standard_streams.hpp).

#include <atomic>

namespace numen::app {

/// Installs the handlers (setup; the studies keep the default: a signal ends them at once).
void install_signal_handlers();
/// Set by SIGINT / SIGTERM / SIGHUP once loading is done (RunOptions::stop,
/// DeviceOptions::stop).
std::atomic<bool>& stop_flag() noexcept;
/// The signal that set stop_flag() (0: none).
int stop_signal() noexcept;
/// The same number as an atomic, for RunOptions::stop_signal (read once the run has stopped).
const std::atomic<int>& stop_signal_number() noexcept;
/// Set by SIGUSR1 (RunOptions::rearm).
std::atomic<bool>& rearm_flag() noexcept;
/// From here on a stop signal ends the command cleanly instead of at once: call it just
/// before the bus is opened.
void loading_done() noexcept;

}  // namespace numen::app
