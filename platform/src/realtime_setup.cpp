/// @file realtime_setup.cpp
/// SCHED_FIFO, mlockall, stack prefault, CPU affinity and timer slack for the calling thread,
/// each step checked and reported (sched(7), mlockall(2), sched_setaffinity(2),
/// pthread_getattr_np(3), prctl(2) PR_SET_TIMERSLACK); the PM QoS CPU latency request
/// (/dev/cpu_dma_latency) held for a run.

#include "numen/platform/realtime_setup.hpp"

#include <alloca.h>
#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/sysinfo.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace numen::platform {
namespace {

constexpr std::size_t kStackMargin = 64 * 1024;  // left untouched below the prefaulted bytes

std::string errno_text(int err) { return std::strerror(err); }

std::int64_t soft_limit(int resource) {
  rlimit r{};
  if (getrlimit(resource, &r) != 0) return 0;
  return r.rlim_cur == RLIM_INFINITY ? -1 : static_cast<std::int64_t>(r.rlim_cur);
}

std::string limit_text(std::int64_t v, const char* unit) {
  if (v < 0) return "unlimited";
  return std::to_string(v) + unit;
}

/// "0-3,6" style list of the CPUs in `set`.
std::string cpu_list(const cpu_set_t& set) {
  std::string out;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (!CPU_ISSET(c, &set)) continue;
    int last = c;
    while (last + 1 < CPU_SETSIZE && CPU_ISSET(last + 1, &set)) ++last;
    if (!out.empty()) out += ',';
    out += std::to_string(c);
    if (last > c) out += '-' + std::to_string(last);
    c = last;
  }
  return out.empty() ? "none" : out;
}

RealtimeStep applied(std::string message) {
  return RealtimeStep{RealtimeStepStatus::kApplied, 0, std::move(message)};
}

RealtimeStep failed(int err, std::string message) {
  return RealtimeStep{RealtimeStepStatus::kFailed, err, std::move(message)};
}

RealtimeStep apply_affinity(const std::vector<int>& cpus) {
  const int present = get_nprocs_conf();
  cpu_set_t want;
  CPU_ZERO(&want);
  for (int cpu : cpus) {
    if (cpu < 0 || cpu >= CPU_SETSIZE)
      return failed(EINVAL, "CPU " + std::to_string(cpu) + " is not a valid CPU index (0.." +
                                std::to_string(CPU_SETSIZE - 1) + ")");
    if (cpu >= present)
      return failed(EINVAL, "CPU " + std::to_string(cpu) + " is not present: this machine has " +
                                std::to_string(present) + " CPU(s), 0.." +
                                std::to_string(present - 1));
    CPU_SET(cpu, &want);
  }
  cpu_set_t before;
  CPU_ZERO(&before);
  if (sched_getaffinity(0, sizeof(before), &before) != 0) {
    const int err = errno;
    return failed(err, "sched_getaffinity: " + errno_text(err));
  }
  if (sched_setaffinity(0, sizeof(want), &want) != 0) {
    const int err = errno;
    if (err == EINVAL)
      return failed(err, "CPU affinity " + cpu_list(want) +
                             " refused: none of these CPUs is online and allowed to this "
                             "process (cgroup cpuset, docker --cpuset-cpus, taskset of the "
                             "parent); the thread's affinity stays " +
                             cpu_list(before));
    return failed(err, "CPU affinity " + cpu_list(want) + " refused: " + errno_text(err));
  }
  cpu_set_t got;
  CPU_ZERO(&got);
  if (sched_getaffinity(0, sizeof(got), &got) != 0) {
    const int err = errno;
    return failed(err, "sched_getaffinity after setting: " + errno_text(err));
  }
  if (!CPU_EQUAL(&got, &want)) {
    // The kernel keeps the usable part of a mask silently; a partial affinity is not what
    // was configured, so undo it.
    cpu_set_t missing;
    CPU_XOR(&missing, &want, &got);
    sched_setaffinity(0, sizeof(before), &before);
    return failed(EINVAL, "CPU affinity " + cpu_list(want) + " refused: CPU(s) " +
                              cpu_list(missing) +
                              " offline or not allowed to this process (cgroup cpuset, "
                              "isolcpus with a restricted cpuset); the thread's affinity "
                              "stays " +
                              cpu_list(before));
  }
  return applied("CPU affinity " + cpu_list(got));
}

RealtimeStep apply_memory_lock(std::int64_t memlock_limit) {
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0)
    return applied("mlockall(MCL_CURRENT|MCL_FUTURE): every page of the process stays in RAM");
  const int err = errno;
  std::string m = "mlockall(MCL_CURRENT|MCL_FUTURE) refused: " + errno_text(err);
  const std::string hint =
      "; raise it (ulimit -l unlimited; /etc/security/limits.conf: @realtime - memlock "
      "unlimited; systemd: LimitMEMLOCK=infinity) or give the process CAP_IPC_LOCK";
  if (err == EPERM) {
    m += " — the locked-memory limit (ulimit -l) is " + limit_text(memlock_limit, " bytes") +
         " and the process lacks CAP_IPC_LOCK" + hint;
  } else if (err == ENOMEM) {
    m += " — the process maps more than the locked-memory limit (ulimit -l) of " +
         limit_text(memlock_limit, " bytes") + hint;
  }
  return failed(err, m);
}

/// Touches `bytes` of stack below this frame, one write per page.
__attribute__((noinline)) void touch_stack(std::size_t bytes) noexcept {
  auto* p = static_cast<volatile unsigned char*>(alloca(bytes));
  const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  for (std::size_t i = 0; i < bytes; i += page) p[i] = 0;
  p[bytes - 1] = 0;
}

RealtimeStep apply_stack_prefault(std::size_t bytes) {
  pthread_attr_t attr;
  const int err = pthread_getattr_np(pthread_self(), &attr);
  if (err != 0) return failed(err, "pthread_getattr_np: " + errno_text(err));
  void* base = nullptr;
  std::size_t size = 0;
  pthread_attr_getstack(&attr, &base, &size);
  pthread_attr_destroy(&attr);
  volatile char here = 0;
  const auto sp = reinterpret_cast<std::uintptr_t>(&here);
  const auto low = reinterpret_cast<std::uintptr_t>(base);
  const std::size_t room = sp > low ? sp - low : 0;
  if (bytes > room || room - bytes < kStackMargin)  // not bytes + margin: it could wrap
    return failed(ENOMEM, "stack prefault of " + std::to_string(bytes) + " bytes refused: only " +
                              std::to_string(room) +
                              " bytes of stack are left below the caller (thread stack " +
                              std::to_string(size) +
                              " bytes, 64 KiB kept as margin); raise the stack size (ulimit -s, "
                              "or pthread_attr_setstacksize of the loop thread) or prefault less");
  touch_stack(bytes);
  return applied(std::to_string(bytes) + " bytes touched (thread stack " + std::to_string(size) +
                 " bytes)");
}

RealtimeStep apply_scheduling(int priority, std::int64_t rtprio_limit) {
  sched_param param{};
  param.sched_priority = priority;
  const std::string what = "SCHED_FIFO priority " + std::to_string(priority);
  const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  if (err == EPERM) {
    std::string m = what + " refused: " + errno_text(err) +
                    " — run as root, or give the user an rtprio limit "
                    "(/etc/security/limits.conf: @realtime - rtprio 98; systemd: "
                    "LimitRTPRIO=98) or CAP_SYS_NICE (RLIMIT_RTPRIO is now " +
                    limit_text(rtprio_limit, "") + ")";
    if (geteuid() == 0)
      m += "; as root this means the capability was dropped (container without "
           "CAP_SYS_NICE) or the cgroup has no real-time budget (cpu.rt_runtime_us = 0)";
    return failed(err, m);
  }
  if (err != 0) return failed(err, what + " refused: " + errno_text(err));
  int policy = -1;
  sched_param got{};
  const int gerr = pthread_getschedparam(pthread_self(), &policy, &got);
  if (gerr != 0) return failed(gerr, what + ": pthread_getschedparam: " + errno_text(gerr));
  if (policy != SCHED_FIFO || got.sched_priority != priority)
    return failed(EINVAL, what + " set but the thread reports policy " + std::to_string(policy) +
                              " priority " + std::to_string(got.sched_priority));
  return applied(what);
}

RealtimeStep apply_timer_slack(std::int64_t ns) {
  const std::int64_t before = current_timer_slack_ns();
  if (prctl(PR_SET_TIMERSLACK, static_cast<unsigned long>(ns), 0, 0, 0) != 0) {
    const int err = errno;
    return failed(err, "timer slack " + std::to_string(ns) + " ns refused: " + errno_text(err));
  }
  const std::int64_t got = current_timer_slack_ns();
  if (got != ns)
    return failed(EINVAL, "timer slack " + std::to_string(ns) + " ns set but the thread reports " +
                              std::to_string(got) + " ns");
  return applied(std::to_string(got) + " ns (was " + std::to_string(before) + " ns)");
}

const char* status_text(RealtimeStepStatus s) {
  switch (s) {
    case RealtimeStepStatus::kNotRequested:
      return "not requested";
    case RealtimeStepStatus::kApplied:
      return "applied";
    case RealtimeStepStatus::kFailed:
      return "FAILED";
  }
  return "?";
}

std::string step_line(const char* name, const RealtimeStep& s) {
  std::string line = std::string(name) + ": " + status_text(s.status);
  if (!s.message.empty()) line += ": " + s.message;
  return line;
}

}  // namespace

KernelRealtime classify_kernel(const char* sysfs_text, const std::string& uname_version) {
  KernelRealtime k;
  k.sysfs_present = sysfs_text != nullptr;
  if (sysfs_text != nullptr) {
    const char* p = sysfs_text;
    while (*p == ' ' || *p == '\t') ++p;
    k.sysfs_realtime = p[0] == '1' && (p[1] == '\0' || p[1] == '\n' || p[1] == ' ');
  }
  k.uname_version = uname_version;
  k.uname_preempt_rt = uname_version.find("PREEMPT_RT") != std::string::npos;
  return k;
}

KernelRealtime check_kernel_realtime() {
  char text[16] = {};
  const char* sysfs = nullptr;
  if (std::FILE* f = std::fopen("/sys/kernel/realtime", "r")) {
    const std::size_t n = std::fread(text, 1, sizeof(text) - 1, f);
    text[n] = '\0';
    std::fclose(f);
    sysfs = text;
  }
  utsname u{};
  std::string version;
  if (uname(&u) == 0) version = u.version;
  return classify_kernel(sysfs, version);
}

bool any_step_requested(const RealtimeSettings& settings) noexcept {
  return settings.fifo_priority != 0 || settings.lock_memory ||
         settings.prefault_stack_bytes > 0 || !settings.cpu_affinity.empty() ||
         settings.timer_slack_ns > 0;
}

std::int64_t current_timer_slack_ns() noexcept {
  const int v = prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0);
  return v < 0 ? -1 : static_cast<std::int64_t>(v);
}

RealtimeReport apply_realtime(const RealtimeSettings& settings) {
  if (settings.fifo_priority < 0 || settings.fifo_priority > 99)
    throw std::invalid_argument(
        "RealtimeSettings.fifo_priority must be 0 (SCHED_OTHER) or "
        "1..99 (SCHED_FIFO), got " +
        std::to_string(settings.fifo_priority));
  if (settings.timer_slack_ns < 0)
    throw std::invalid_argument("RealtimeSettings.timer_slack_ns must be >= 0 (0: leave it), got " +
                                std::to_string(settings.timer_slack_ns));
  RealtimeReport r;
  r.rtprio_limit = soft_limit(RLIMIT_RTPRIO);
  r.memlock_limit_bytes = soft_limit(RLIMIT_MEMLOCK);
  if (!settings.cpu_affinity.empty()) r.affinity = apply_affinity(settings.cpu_affinity);
  if (settings.lock_memory) r.memory_lock = apply_memory_lock(r.memlock_limit_bytes);
  if (settings.prefault_stack_bytes > 0)
    r.stack_prefault = apply_stack_prefault(settings.prefault_stack_bytes);
  if (settings.timer_slack_ns > 0) r.timer_slack = apply_timer_slack(settings.timer_slack_ns);
  if (settings.fifo_priority > 0)
    r.scheduling = apply_scheduling(settings.fifo_priority, r.rtprio_limit);
  r.kernel = check_kernel_realtime();
  if (settings.strict && !r.ok()) {
    std::string m = "real-time setup failed (strict):";
    for (const std::string& line : describe(r)) m += "\n  " + line;
    throw std::runtime_error(m);
  }
  return r;
}

std::vector<std::string> describe(const RealtimeReport& r) {
  std::vector<std::string> lines;
  lines.push_back(step_line("scheduling", r.scheduling));
  lines.push_back(step_line("memory lock", r.memory_lock));
  lines.push_back(step_line("stack prefault", r.stack_prefault));
  lines.push_back(step_line("cpu affinity", r.affinity));
  std::string k = r.kernel.realtime() ? "kernel: real-time (" : "kernel: not real-time (";
  k += !r.kernel.sysfs_present   ? "no /sys/kernel/realtime"
       : r.kernel.sysfs_realtime ? "/sys/kernel/realtime = 1"
                                 : "/sys/kernel/realtime not 1";
  k += "; uname -v: " + r.kernel.uname_version + ")";
  if (!r.kernel.realtime())
    k += " — wake-up latency is bounded only on a PREEMPT_RT kernel (Debian: linux-image-rt-amd64)";
  lines.push_back(k);
  lines.push_back("limits: RLIMIT_RTPRIO " + limit_text(r.rtprio_limit, "") + ", RLIMIT_MEMLOCK " +
                  limit_text(r.memlock_limit_bytes, " bytes"));
  lines.push_back(step_line("timer slack", r.timer_slack));
  return lines;
}

namespace {

/// The 32-bit latency (µs) that `fd` reads at offset 0, or -1 if it reads none.
std::int64_t read_latency(int fd) {
  std::int32_t v = 0;
  return pread(fd, &v, sizeof v, 0) == static_cast<ssize_t>(sizeof v) ? v : -1;
}

}  // namespace

CpuLatencyRequest::CpuLatencyRequest(std::int32_t max_latency_us, const std::string& path) {
  if (max_latency_us < 0)
    throw std::invalid_argument("CPU latency request must be >= 0 us, got " +
                                std::to_string(max_latency_us));
  const std::string what = path + " " + std::to_string(max_latency_us) + " us";
  const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    std::string m = "cannot open " + path + ": " + errno_text(err);
    if (err == EACCES || err == EPERM)
      m += " — run as root, or let the user write it (udev rule: KERNEL==\"cpu_dma_latency\", "
           "GROUP=\"realtime\", MODE=\"0660\"); without it an idle CPU may halt between periods "
           "and wake later";
    else if (err == ENOENT)
      m += " — the kernel has no CPU latency QoS device, or a container lacks it (docker run "
           "--device /dev/cpu_dma_latency)";
    step_ = failed(err, m);
    return;
  }
  const std::int64_t before = read_latency(fd);
  const std::int32_t v = max_latency_us;
  if (::write(fd, &v, sizeof v) != static_cast<ssize_t>(sizeof v)) {
    const int err = errno;
    ::close(fd);
    step_ = failed(err, what + " refused: " + errno_text(err));
    return;
  }
  const std::int64_t now = read_latency(fd);
  if (now > max_latency_us) {
    ::close(fd);
    step_ = failed(EINVAL,
                   what + " written but the kernel's limit reads " + std::to_string(now) + " us");
    return;
  }
  fd_ = fd;
  std::string m = what + " held for the run";
  if (before >= 0) m += " (the kernel's limit was " + std::to_string(before) + " us)";
  m += max_latency_us == 0 ? ": idle CPUs poll instead of halting"
                           : ": idle CPUs stay in states they leave within it";
  step_ = applied(std::move(m));
}

CpuLatencyRequest::~CpuLatencyRequest() {
  if (fd_ >= 0) ::close(fd_);
}

CpuLatencyRequest::CpuLatencyRequest(CpuLatencyRequest&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), step_(std::move(other.step_)) {}

CpuLatencyRequest& CpuLatencyRequest::operator=(CpuLatencyRequest&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    step_ = std::move(other.step_);
  }
  return *this;
}

std::string describe_cpu_latency(const CpuLatencyRequest& request) {
  return step_line("cpu latency", request.step());
}

}  // namespace numen::platform
