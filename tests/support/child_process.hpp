#pragma once
/// @file child_process.hpp
/// Runs a program (the `numen` command) as a child process for end-to-end tests: its
/// stdout / stderr go to files, a signal can be sent to it once a condition holds, and the
/// result carries its exit status, its peak resident memory and whether it had to be killed.
/// Header-only, for test files; POSIX (posix_spawn, wait4) and Linux's /proc/PID/status.

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace numen::test {

/// What a child process did.
struct ChildResult {
  int status = -1;          ///< Exit status, or 128 + signal if a signal ended it.
  bool timed_out = false;   ///< It was still running at the deadline and was killed.
  /// Peak resident set size of the program itself (KiB): the last VmHWM of
  /// /proc/PID/status read while it ran (every 10 ms, so at most the last 10 ms are missed).
  /// wait4's ru_maxrss is only the fallback for a child gone before the first read: Linux
  /// keeps the spawning process's high-water mark across exec, so it is at least this test
  /// binary's own RSS (~35 MB), which floored every figure and hid growth below it.
  long max_rss_kib = 0;
  double wall_s = 0.0;      ///< Wall time from spawn to exit (s).
  std::string out;          ///< Its stdout.
  std::string err;          ///< Its stderr.
};

/// When to send a signal to the child: `signal` once `ready()` returns true (polled every
/// 10 ms; no condition: at once), or never if `signal` is 0.
struct ChildSignal {
  int signal = 0;
  std::function<bool()> ready;
};

/// Where the child's stdout goes.
enum class ChildStdout {
  kFile,        ///< A file in the test's directory, read back into ChildResult::out.
  kBrokenPipe,  ///< A pipe whose read end is closed before the child starts: every write to
                ///< it fails (EPIPE, and SIGPIPE unless the child ignores it); `out` stays "".
};

/// VmHWM of process `pid` (KiB) from /proc/PID/status, or 0 when it cannot be read.
inline long own_peak_rss_kib(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::atol(line.c_str() + 6);
  return 0;
}

inline std::string read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream os;
  os << f.rdbuf();
  return os.str();
}

/// Runs `argv` (argv[0] a path) with stdout / stderr redirected to files in `dir` (stdout as
/// `stdout_to` says); kills it (SIGKILL) if it runs past `deadline_s`.
inline ChildResult run_child(const std::vector<std::string>& argv, const std::string& dir,
                             double deadline_s, const ChildSignal& send = {},
                             ChildStdout stdout_to = ChildStdout::kFile) {
  const std::string out_path = dir + "/child.out", err_path = dir + "/child.err";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  int pipe_ends[2] = {-1, -1};
  if (stdout_to == ChildStdout::kBrokenPipe && ::pipe2(pipe_ends, O_CLOEXEC) == 0) {
    ::close(pipe_ends[0]);  // no reader, from before the child's first write
    posix_spawn_file_actions_adddup2(&actions, pipe_ends[1], STDOUT_FILENO);
  } else {
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out_path.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err_path.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  ChildResult r;
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&t0] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  pid_t pid = -1;
  const int spawned = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (pipe_ends[1] >= 0) ::close(pipe_ends[1]);
  if (spawned != 0) {
    r.err = "posix_spawn failed for " + argv[0];
    return r;
  }
  bool signalled = send.signal == 0;
  int wstatus = 0;
  struct rusage usage {};
  long own_peak_kib = 0;
  for (;;) {
    if (const long hwm = own_peak_rss_kib(pid); hwm > 0) own_peak_kib = hwm;  // still running
    const pid_t done = ::wait4(pid, &wstatus, WNOHANG, &usage);
    if (done == pid) break;
    if (!signalled && (!send.ready || send.ready())) {
      ::kill(pid, send.signal);
      signalled = true;
    }
    if (elapsed() > deadline_s) {
      r.timed_out = true;
      ::kill(pid, SIGKILL);
      ::wait4(pid, &wstatus, 0, &usage);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  r.wall_s = elapsed();
  r.max_rss_kib = own_peak_kib > 0 ? own_peak_kib : usage.ru_maxrss;
  r.status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
  r.out = pipe_ends[1] >= 0 ? std::string() : read_file(out_path);
  r.err = read_file(err_path);
  return r;
}

}  // namespace numen::test
