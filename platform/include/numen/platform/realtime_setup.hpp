#pragma once
/// @file realtime_setup.hpp
/// Making the calling thread a real-time thread on Linux, step by step, and saying what
/// happened: SCHED_FIFO priority (pthread_setschedparam, POSIX.1-2017 "Scheduling Policies";
/// sched(7)), memory locking (mlockall(2): MCL_CURRENT | MCL_FUTURE), stack prefaulting (the
/// pages are touched once so the loop takes no page fault on them later), CPU affinity
/// (sched_setaffinity(2) with pid 0: the calling thread), the thread's timer slack
/// (prctl(2) PR_SET_TIMERSLACK: how late the kernel may fire its timers to coalesce wake-ups,
/// 50 µs by default for a SCHED_OTHER thread). And whether the kernel itself is PREEMPT_RT
/// (/sys/kernel/realtime, uname -v). Apart: the PM QoS CPU latency request that a paced run
/// holds while it lasts (CpuLatencyRequest, /dev/cpu_dma_latency).
///
/// Lack of privilege is not an exception: every step is reported as not requested, applied
/// or failed (errno and a message that says how to grant the privilege), and a non-real-time
/// run goes on unless the caller asks for `strict`. All of this is setup code: it allocates
/// (messages) and must run before the loop's first period, on the loop's own thread.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace numen::platform {

/// What the caller asks for. The default asks for nothing.
struct RealtimeSettings {
  /// 0: leave the thread's policy alone (normally SCHED_OTHER). 1–99: SCHED_FIFO at this
  /// priority (sched(7); Linux's range is sched_get_priority_min/max(SCHED_FIFO) = 1..99).
  /// Anything else is a configuration error (std::invalid_argument).
  int fifo_priority = 0;
  /// mlockall(MCL_CURRENT | MCL_FUTURE): every page of the process, now and later, stays in
  /// RAM. Process-wide, not per thread. With MCL_FUTURE an unprivileged process whose
  /// RLIMIT_MEMLOCK is then exhausted gets failing mmap/brk (allocations fail) — size the
  /// limit for the whole process or run with CAP_IPC_LOCK.
  bool lock_memory = false;
  /// Bytes of the calling thread's stack (below the current frame) to touch now, so that
  /// the loop's later stack use takes no page fault; 0: none. Done after mlockall, so the
  /// pages are also locked. Refused (step failed) if the thread's stack has not that much
  /// room left below the caller plus a 64 KiB margin.
  std::size_t prefault_stack_bytes = 0;
  /// CPUs (indices as in /sys/devices/system/cpu/cpuN) the thread may run on; empty: leave
  /// the affinity alone. Every index must be present and allowed (cpuset/cgroup); otherwise
  /// the step fails and the previous affinity is kept (the kernel would silently drop
  /// unusable CPUs from a mask; this does not).
  std::vector<int> cpu_affinity;
  /// Timer slack of the calling thread in ns (prctl(PR_SET_TIMERSLACK)); 0: leave it alone.
  /// The kernel may fire a SCHED_OTHER thread's timers up to this late so that wake-ups
  /// coalesce: its default of 50 µs made every wake-up of a 100 µs loop 54–66 µs late on a
  /// 16-core PREEMPT_DYNAMIC machine where SCHED_FIFO was refused (docs/realtime.md "Timer
  /// slack"). 1 is the minimum (the kernel reads 0 as "back to the default"). Applied whatever
  /// the scheduling policy, and read back (PR_GET_TIMERSLACK).
  std::int64_t timer_slack_ns = 0;
  /// True: apply_realtime() throws std::runtime_error if any requested step failed (the
  /// message is describe() of the report). False: failures are only reported.
  bool strict = false;
};

/// Outcome of one step.
enum class RealtimeStepStatus {
  kNotRequested,  ///< The settings did not ask for this step.
  kApplied,       ///< Done and checked.
  kFailed,        ///< Asked for and not done; see error / message.
};

/// Result of one step of apply_realtime().
struct RealtimeStep {
  RealtimeStepStatus status = RealtimeStepStatus::kNotRequested;
  int error = 0;        ///< errno (or the pthread error code) of the failure; 0 otherwise.
  std::string message;  ///< One line: what was done, or what failed, why and what to do.
  bool failed() const noexcept { return status == RealtimeStepStatus::kFailed; }
};

/// Whether the running kernel is a real-time (PREEMPT_RT) kernel.
struct KernelRealtime {
  bool sysfs_present = false;   ///< /sys/kernel/realtime exists (only PREEMPT_RT kernels have it).
  bool sysfs_realtime = false;  ///< ... and reads "1".
  bool uname_preempt_rt = false;  ///< uname -v (utsname.version) contains "PREEMPT_RT".
  std::string uname_version;      ///< utsname.version as read, e.g. "#1 SMP PREEMPT_DYNAMIC ...".
  /// Real-time kernel: either sign says so.
  bool realtime() const noexcept { return sysfs_realtime || uname_preempt_rt; }
};

/// Everything apply_realtime() did, step by step, and the limits it saw.
struct RealtimeReport {
  RealtimeStep scheduling;      ///< SCHED_FIFO (fifo_priority).
  RealtimeStep memory_lock;     ///< mlockall (lock_memory).
  RealtimeStep stack_prefault;  ///< stack touch (prefault_stack_bytes).
  RealtimeStep affinity;        ///< CPU affinity (cpu_affinity).
  RealtimeStep timer_slack;     ///< Timer slack (timer_slack_ns).
  KernelRealtime kernel;        ///< The kernel check (always done).
  /// RLIMIT_RTPRIO soft limit when the report was made (-1: unlimited).
  std::int64_t rtprio_limit = 0;
  /// RLIMIT_MEMLOCK soft limit in bytes (-1: unlimited).
  std::int64_t memlock_limit_bytes = 0;
  /// No requested step failed.
  bool ok() const noexcept {
    return !scheduling.failed() && !memory_lock.failed() && !stack_prefault.failed() &&
           !affinity.failed() && !timer_slack.failed();
  }
};

/// True if `settings` asks for any step (a priority, the memory lock, a stack prefault, CPUs
/// or a timer slack); `strict` alone asks for none.
bool any_step_requested(const RealtimeSettings& settings) noexcept;

/// Applies `settings` to the calling thread (scheduling, affinity, stack, timer slack) and
/// process (memory lock), in the order affinity → memory lock → stack prefault → timer slack →
/// scheduling (pages
/// are faulted on the CPU the loop will run on; the thread becomes FIFO last), and
/// checks the kernel. Never throws for lack of privilege or a CPU that cannot be used: those
/// are failed steps. Throws std::invalid_argument if fifo_priority is outside 0..99, and —
/// only with settings.strict — std::runtime_error when a step failed. Allocates.
RealtimeReport apply_realtime(const RealtimeSettings& settings);

/// Reads /sys/kernel/realtime and uname(2) (see KernelRealtime). Never throws for a missing
/// file (that is the usual non-RT case).
KernelRealtime check_kernel_realtime();

/// The decision of check_kernel_realtime() from its inputs (for tests and other sources):
/// `sysfs_text` is the content of /sys/kernel/realtime or nullptr if absent; `uname_version`
/// is utsname.version.
KernelRealtime classify_kernel(const char* sysfs_text, const std::string& uname_version);

/// Human-readable lines: one per step, one for the kernel, one for the limits, then the timer
/// slack's step. Example:
///   "scheduling: applied: SCHED_FIFO priority 80"
///   "memory lock: FAILED: mlockall(MCL_CURRENT|MCL_FUTURE) refused: ..."
///   "kernel: not real-time (no /sys/kernel/realtime; uname -v: #1 SMP PREEMPT_DYNAMIC ...)"
///   "limits: RLIMIT_RTPRIO 0, RLIMIT_MEMLOCK 8388608 bytes"
///   "timer slack: applied: 1 ns (was 50000 ns)"
std::vector<std::string> describe(const RealtimeReport& report);

/// The calling thread's timer slack in ns (prctl(PR_GET_TIMERSLACK)); -1 if it cannot be read.
std::int64_t current_timer_slack_ns() noexcept;

/// The kernel's PM QoS CPU latency file (Linux Documentation/power/pm_qos_interface.rst): a
/// process that opens it and writes a 32-bit latency in µs keeps every CPU out of the idle
/// states that take longer than that to leave, until it closes the file.
inline constexpr const char* kCpuDmaLatencyPath = "/dev/cpu_dma_latency";

/// A PM QoS CPU latency request, held while this object lives (what cyclictest does by
/// default, and the reason its wake-up latency on an idle virtual machine was half numen's:
/// docs/realtime.md "CPU latency"). With 0 µs an idle CPU polls
/// (cpuidle's POLL state) instead of halting, so a timer's wake-up needs no exit from a halt;
/// on a virtual machine a halted vCPU is descheduled by the host. Machine-wide (every CPU),
/// at the price of idle CPUs that never sleep while it is held. The request ends when the file
/// is closed: by the destructor, or by the kernel when the process ends however it ends.
/// Setup code: allocates (its message); the loop only keeps it alive. Move-only.
class CpuLatencyRequest {
 public:
  /// Holds nothing; step() is "not requested".
  CpuLatencyRequest() = default;
  /// Opens `path` (read-write) and writes `max_latency_us` as a native 32-bit integer, then
  /// reads back the latency the kernel now enforces (the smallest request of any process):
  /// step() is applied with it and the value before, or failed with the errno and what to do
  /// (no privilege: root, or a udev rule giving a group write access; no such file: a kernel
  /// without CPU latency QoS or a container without the device). Never throws for these;
  /// std::invalid_argument if `max_latency_us` < 0.
  explicit CpuLatencyRequest(std::int32_t max_latency_us,
                             const std::string& path = kCpuDmaLatencyPath);
  /// Closes the file: the request ends.
  ~CpuLatencyRequest();
  CpuLatencyRequest(CpuLatencyRequest&& other) noexcept;
  CpuLatencyRequest& operator=(CpuLatencyRequest&& other) noexcept;
  CpuLatencyRequest(const CpuLatencyRequest&) = delete;
  CpuLatencyRequest& operator=(const CpuLatencyRequest&) = delete;
  /// The outcome, as a step of apply_realtime() (describe_cpu_latency() gives its line).
  const RealtimeStep& step() const noexcept { return step_; }
  /// The request is held (the file is open and was written).
  bool held() const noexcept { return fd_ >= 0; }

 private:
  int fd_ = -1;
  RealtimeStep step_;
};

/// The line of a CPU latency request's step, as describe()'s lines:
///   "cpu latency: applied: /dev/cpu_dma_latency 0 us held for the run (the kernel's limit was
///    2000000000 us): idle CPUs poll instead of halting"
std::string describe_cpu_latency(const CpuLatencyRequest& request);

}  // namespace numen::platform
