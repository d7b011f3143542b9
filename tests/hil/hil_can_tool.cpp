// numen_hil_can: a small command-line client of SocketCanBus for the hardware-in-the-loop
// scenario scripts (tests/hil/scenarios/*.sh), run inside the qemu guest next to can-utils.
// Frames are printed one per line in can-utils' compact log form (lib.c, sprint_canframe as
// written by `candump -L`, without the time and interface columns):
//   123#11223344      11-bit data frame      12345678#R5   29-bit remote request, len 5
//   123##1AABB        CAN FD, flags nibble (1 = BRS, 2 = ESI), then the data
//   20000040#00...    error frame (CAN_ERR_FLAG | class bits, 8 data bytes)
//
// Usage:
//   numen_hil_can send IFACE
//       Writes the fixed pattern below (classic, extended, remote and FD frames) and prints
//       each frame as written. Exit 0 if all were written.
//   numen_hil_can recv IFACE [--filter ID:MASK]... [--idle-ms N] [--max-ms N] [--timestamps 1]
//       Reads with kernel filters (ID and MASK in hex, CanFilter layout: bit 31 extended,
//       bit 30 remote) until no frame came for --idle-ms after the first one (default 500)
//       or --max-ms passed (default 10000), printing every frame (with --timestamps 1 preceded
//       by its receive time "(seconds.microseconds) ", CLOCK_MONOTONIC); then prints
//       "RECV frames=N dropped=N malformed=N errors=N" on stderr. Exit 0 unless read() failed.
#include <time.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

#include "numen/hal/transport/socketcan_bus.hpp"

namespace {

using numen::hal::CanFilter;
using numen::hal::CanFlag;
using numen::hal::CanFrame;
using numen::hal::IoStatus;
using numen::hal::SocketCanBus;

std::int64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleep_ns(std::int64_t ns) {
  timespec ts{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
  nanosleep(&ts, nullptr);
}

std::string compact(const CanFrame& f) {
  char buf[200];
  int n = 0;
  if (f.error_frame()) {
    n = std::snprintf(buf, sizeof(buf), "%08X#", f.id | 0x20000000u);
  } else if (f.extended()) {
    n = std::snprintf(buf, sizeof(buf), "%08X#", f.id);
  } else {
    n = std::snprintf(buf, sizeof(buf), "%03X#", f.id);
  }
  if (f.remote()) {
    buf[n++] = 'R';
    if (f.len > 0) n += std::snprintf(buf + n, sizeof(buf) - n, "%X", f.len);
    return std::string(buf, n);
  }
  if (f.fd()) {
    unsigned flags = 0;
    if ((f.flags & CanFlag::kBitRateSwitch) != 0) flags |= 1;
    if ((f.flags & CanFlag::kErrorStateIndicator) != 0) flags |= 2;
    n += std::snprintf(buf + n, sizeof(buf) - n, "#%X", flags);
  }
  for (std::uint8_t i = 0; i < f.len; ++i) {
    n += std::snprintf(buf + n, sizeof(buf) - n, "%02X", f.data[i]);
  }
  return std::string(buf, n);
}

// The pattern `send` writes: 64 frames cycling through four kinds.
std::vector<CanFrame> pattern() {
  static constexpr std::uint8_t kFdLen[16] = {0, 1,  2,  3,  4,  5,  6,  7,
                                              8, 12, 16, 20, 24, 32, 48, 64};
  std::vector<CanFrame> frames;
  for (std::uint32_t i = 0; i < 64; ++i) {
    CanFrame f;
    switch (i % 4) {
      case 0:  // 11-bit classic, lengths 0..8
        f.id = 0x100 + i;
        f.len = static_cast<std::uint8_t>(i % 9);
        break;
      case 1:  // 29-bit classic
        f.id = 0x1000000 + i;
        f.flags = CanFlag::kExtendedId;
        f.len = 8;
        break;
      case 2:  // FD, every length, bit-rate switch on every other one
        f.id = 0x200 + i;
        f.flags = CanFlag::kFd | ((i / 4) % 2 ? CanFlag::kBitRateSwitch : 0);
        f.len = kFdLen[(i / 4) % 16];
        break;
      default:  // remote request
        f.id = 0x300 + i;
        f.flags = CanFlag::kRemote;
        f.len = static_cast<std::uint8_t>(i % 9);
        break;
    }
    if (!f.remote()) {
      for (std::uint8_t b = 0; b < f.len; ++b) f.data[b] = static_cast<std::uint8_t>(i * 13 + b);
    }
    frames.push_back(f);
  }
  return frames;
}

int cmd_send(const std::string& iface) {
  SocketCanBus bus(iface);
  for (const CanFrame& f : pattern()) {
    IoStatus s = IoStatus::kWouldBlock;
    for (int tries = 0; tries < 1000 && s == IoStatus::kWouldBlock; ++tries) {
      s = bus.write(f);
      if (s == IoStatus::kWouldBlock) sleep_ns(1'000'000);
    }
    if (s != IoStatus::kOk) {
      std::fprintf(stderr, "numen_hil_can: write %s on %s: %s (errno %d)\n", compact(f).c_str(),
                   iface.c_str(), numen::hal::to_string(s), bus.socketcan_counters().last_errno);
      return 1;
    }
    std::printf("%s\n", compact(f).c_str());
  }
  return 0;
}

int cmd_recv(const std::string& iface, int argc, char** argv) {
  std::vector<CanFilter> filters;
  std::int64_t idle_ms = 500;
  std::int64_t max_ms = 10000;
  bool timestamps = false;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) throw std::invalid_argument("missing value after " + a);
    const char* v = argv[++i];
    if (a == "--filter") {
      char* end = nullptr;
      CanFilter f;
      f.id = static_cast<std::uint32_t>(std::strtoul(v, &end, 16));
      if (end == nullptr || *end != ':') throw std::invalid_argument("--filter wants ID:MASK");
      f.mask = static_cast<std::uint32_t>(std::strtoul(end + 1, &end, 16));
      if (*end != '\0') throw std::invalid_argument("--filter wants ID:MASK (hex)");
      filters.push_back(f);
    } else if (a == "--idle-ms") {
      idle_ms = std::atoll(v);
    } else if (a == "--max-ms") {
      max_ms = std::atoll(v);
    } else if (a == "--timestamps") {
      timestamps = std::atoi(v) != 0;
    } else {
      throw std::invalid_argument("unknown option " + a);
    }
  }
  SocketCanBus bus(iface, filters);
  std::printf("READY\n");
  std::fflush(stdout);
  const std::int64_t start = mono_ns();
  std::int64_t last = start;
  bool any = false;
  bool failed = false;
  CanFrame f;
  while (mono_ns() - start < max_ms * 1'000'000) {
    const IoStatus s = bus.read(f);
    if (s == IoStatus::kOk) {
      any = true;
      last = mono_ns();
      if (timestamps) {
        std::printf("(%lld.%06lld) ", static_cast<long long>(f.timestamp_ns / 1'000'000'000),
                    static_cast<long long>(f.timestamp_ns % 1'000'000'000 / 1000));
      }
      std::printf("%s\n", compact(f).c_str());
      continue;
    }
    if (s == IoStatus::kError) {
      failed = true;
      break;
    }
    if (any && mono_ns() - last > idle_ms * 1'000'000) break;
    bus.wait_readable(20'000'000);
  }
  std::fflush(stdout);
  const auto c = bus.counters();
  std::fprintf(stderr, "RECV frames=%llu dropped=%llu malformed=%llu errors=%llu\n",
               static_cast<unsigned long long>(c.frames_rx),
               static_cast<unsigned long long>(c.dropped),
               static_cast<unsigned long long>(bus.socketcan_counters().malformed_rx),
               static_cast<unsigned long long>(c.errors));
  return failed ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc >= 3 && std::strcmp(argv[1], "send") == 0) return cmd_send(argv[2]);
    if (argc >= 3 && std::strcmp(argv[1], "recv") == 0)
      return cmd_recv(argv[2], argc - 3, argv + 3);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "numen_hil_can: %s\n", e.what());
    return 2;
  }
  std::fprintf(stderr,
               "usage: numen_hil_can send IFACE\n"
               "       numen_hil_can recv IFACE [--filter ID:MASK]... [--idle-ms N] [--max-ms N]"
               " [--timestamps 1]\n");
  return 2;
}
