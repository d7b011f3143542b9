/// @file signals.cpp

#include "signals.hpp"

#include <unistd.h>

#include <csignal>

namespace numen::app {
namespace {

std::atomic<bool> g_stop{false};  // lock-free: safe to store from a signal handler
static_assert(std::atomic<bool>::is_always_lock_free, "signal handlers store to std::atomic<bool>");
std::atomic<int> g_stop_signal{0};  // the signal that set g_stop
std::atomic<bool> g_rearm{false};   // SIGUSR1: the operator's re-arm (RunOptions::rearm)
/// True while the command loads its input (scene, trajectory, logs): nothing is open on a bus
/// and nothing was commanded, so a stop signal ends the process at once (loading a large file
/// must not make SIGINT / SIGTERM / SIGHUP wait). Cleared just before the bus is opened.
std::atomic<bool> g_loading{true};
static_assert(std::atomic<int>::is_always_lock_free, "signal handlers store to std::atomic<int>");

extern "C" void on_signal(int sig) {
  if (g_loading.load(std::memory_order_relaxed)) {
    // Async-signal-safe: write(2) and _exit(2) only.
    static const char msg[] = "numen: stopped by a signal while loading (nothing was commanded)\n";
    [[maybe_unused]] const ssize_t n = ::write(STDERR_FILENO, msg, sizeof msg - 1);
    ::_exit(128 + sig);
  }
  g_stop_signal.store(sig, std::memory_order_relaxed);
  g_stop.store(true, std::memory_order_relaxed);
}

extern "C" void on_rearm_signal(int) { g_rearm.store(true, std::memory_order_relaxed); }

}  // namespace

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGHUP, &sa, nullptr);  // the terminal or ssh session closed: as SIGTERM
  struct sigaction rearm {};
  rearm.sa_handler = on_rearm_signal;
  sigemptyset(&rearm.sa_mask);
  sigaction(SIGUSR1, &rearm, nullptr);
}

std::atomic<bool>& stop_flag() noexcept { return g_stop; }
int stop_signal() noexcept { return g_stop_signal.load(std::memory_order_relaxed); }
const std::atomic<int>& stop_signal_number() noexcept { return g_stop_signal; }
std::atomic<bool>& rearm_flag() noexcept { return g_rearm; }
void loading_done() noexcept { g_loading.store(false, std::memory_order_relaxed); }

}  // namespace numen::app
