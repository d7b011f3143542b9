#pragma once
/// @file standard_streams.hpp
/// The `numen` command's standard streams. What a command prints on stdout is its output (a
/// summary, `--json`, `--list`, a table): a write that fails is reported on stderr and ends the
/// command with a failing status (docs/outputs.md, "Standard output"), never lost with status 0.

#include <string>

namespace numen::app {

/// At start-up, before anything is opened: SIGPIPE is ignored, so that a write to a pipe whose
/// reader has gone fails with EPIPE (reported, the status kept equal to the one printed) instead
/// of killing the process after it printed a status it would not return; each of stdin,
/// stdout and stderr that is closed (`>&-`) is held by /dev/null opened read-only, so that no
/// file numen opens (a trace, a log) takes its descriptor and receives what was meant for it,
/// while a write to it still fails (EBADF); and std::cout gets a buffer of its own that writes
/// descriptor 1 with write(2) and keeps the reason of a failed write (C's stdio keeps only a
/// flag). The commands write their output with std::cout.
void guard_standard_streams() noexcept;

/// Flushes std::cout (and C's stdout, for anything printed through it); returns the system's
/// reason ("Broken pipe", "No space left on device", "Bad file descriptor") when any of what was
/// written on stdout since the last call did not reach it, else "". After a failure the
/// unwritten output is dropped and the error cleared: the next call, and exit(), do not try it
/// again.
std::string stdout_failure();

/// A command's exit status once its stdout is checked: `status` when stdout_failure() finds
/// nothing lost; else the failure is printed on stderr ("numen: stdout: cannot write the output
/// (Broken pipe)") and a status 0 becomes 1 (error; a failing status is kept).
int with_stdout_checked(int status);

}  // namespace numen::app
