#pragma once
/// @file fuzz_input.hpp
/// What the libFuzzer harnesses (tests/fuzz/*_fuzz.cpp) share: the fuzz input as a temporary
/// file for the loaders that read a path, and as a sequence of CAN frames and clock steps for
/// the CANopen frame consumers. Input bytes are split with LLVM's FuzzedDataProvider (numbers
/// from the end of the input, bytes from the front). Harness code only: allocates, not
/// real-time.

#include <fuzzer/FuzzedDataProvider.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/device/device_config.hpp"

namespace numen::fuzz {

/// Writes `size` bytes at `data` to this process's own temporary file (named by the pid, under
/// the system temp dir, ending in `suffix` such as ".toml") and returns its path; the same file
/// (one per suffix) is rewritten on every call and removed at exit. Aborts if the file cannot be
/// written: a harness that fuzzes nothing must not pass.
inline const std::string& input_file(const std::uint8_t* data, std::size_t size,
                                     const char* suffix) {
  static std::map<std::string, std::string> paths;  // suffix -> path
  std::string& path = paths[suffix];
  if (path.empty()) {
    path = (std::filesystem::temp_directory_path() /
            ("numen_fuzz_" + std::to_string(::getpid()) + suffix))
               .string();
    if (paths.size() == 1)
      std::atexit([] {
        for (const auto& [s, p] : paths) std::remove(p.c_str());
      });
  }
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) {
    std::perror(path.c_str());
    std::abort();
  }
  return path;
}

/// The longest error message a harness of a located-error loader accepts (bytes): a message
/// names the file, the place and the key, and quotes a bounded prefix of what it refuses
/// (json_input::shown(): 40 bytes), however large or deep the input is.
inline constexpr std::size_t kMaxMessageBytes = 1024;

/// Reports a finding that is not a sanitizer's (a broken invariant): prints `what` and
/// `detail` to stderr and aborts, which libFuzzer saves as a crash input.
[[noreturn]] inline void finding(const char* what, std::string_view detail = {}) {
  std::fprintf(stderr, "fuzz finding: %s: '%.*s'\n", what, static_cast<int>(detail.size()),
               detail.data());
  std::abort();
}

/// Calls `f(line)` for every '\n'-separated line of `text`, the line feed excluded (a text
/// ending in '\n' ends with an empty line).
template <class F>
void for_each_line(std::string_view text, F f) {
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    f(text.substr(start, end - start));
    start = end + 1;
  }
}

/// For a line-based format: runs `load(path)` on the input written as a file (input_file())
/// when its size is divisible by 8, so that an input always takes the same path; writing the
/// file costs more than parsing the lines, and the loader's own code is the line loop. The
/// loader's located error, std::runtime_error, is the expected failure.
template <class Load>
void load_file_sometimes(const std::uint8_t* data, std::size_t size, const char* suffix,
                         Load load) {
  if (size % 8 != 0) return;
  try {
    (void)load(input_file(data, size, suffix));
  } catch (const std::runtime_error&) {
    // a located error: the expected outcome for a bad file
  }
}

/// COB-IDs a CANopen network of nodes 1..max_node uses (CiA 301 predefined connection set):
/// NMT 0x000, SYNC 0x080, EMCY 0x080 + n, TPDO1–4 0x180/0x280/0x380/0x480 + n, RPDO1–4
/// 0x200/0x300/0x400/0x500 + n, SDO 0x580/0x600 + n, heartbeat 0x700 + n; plus `extra`.
inline std::vector<std::uint32_t> canopen_cob_ids(int max_node,
                                                  const std::vector<std::uint32_t>& extra = {}) {
  std::vector<std::uint32_t> ids{0x000, 0x080};
  for (std::uint32_t n = 1; n <= static_cast<std::uint32_t>(max_node); ++n) {
    for (std::uint32_t base : {0x080u, 0x180u, 0x200u, 0x280u, 0x300u, 0x380u, 0x400u, 0x480u,
                               0x500u, 0x580u, 0x600u, 0x700u}) {
      ids.push_back(base + n);
    }
  }
  ids.insert(ids.end(), extra.begin(), extra.end());
  return ids;
}

/// One frame made of the input: mostly on one of `ids` (otherwise any 11- or 29-bit id), any
/// CanFlag bits now and then, a length of 0–8 bytes (0–64 with kFd) and the data bytes that
/// follow in the input (zeros past its end), stamped `timestamp_ns`. Not necessarily
/// well-formed (check_frame()): a consumer must cope with whatever a bus hands it.
inline hal::CanFrame next_frame(FuzzedDataProvider& in, const std::vector<std::uint32_t>& ids,
                                std::int64_t timestamp_ns) {
  hal::CanFrame f;
  f.timestamp_ns = timestamp_ns;
  const std::uint8_t how = in.ConsumeIntegral<std::uint8_t>();
  f.flags = (how & 0xC0) == 0xC0 ? in.ConsumeIntegral<std::uint8_t>() : 0;
  if ((how & 0x30) != 0x30 && !ids.empty()) {
    f.id = ids[in.ConsumeIntegralInRange<std::size_t>(0, ids.size() - 1)];
  } else {
    f.id = in.ConsumeIntegral<std::uint32_t>() &
           (f.extended() ? hal::kExtendedIdMask : hal::kStandardIdMask);
  }
  f.len = in.ConsumeIntegralInRange<std::uint8_t>(0, f.fd() ? hal::kMaxFdLen : hal::kMaxClassicLen);
  const std::vector<std::uint8_t> bytes = in.ConsumeBytes<std::uint8_t>(f.len);
  for (std::size_t i = 0; i < bytes.size(); ++i) f.data[i] = bytes[i];
  return f;
}

/// The device a frame-consumer harness runs: `choice` % 3 picks the default trocar
/// instrument, pose tracker or phantom (hal/device/device_config.hpp, nodes from 1), (`choice` / 3) % 2
/// the managed CANopen stack (0) or the minimal protocol (1). 1 ms period.
inline hal::DeviceConfig device_config(std::uint8_t choice) {
  hal::DeviceConfig c = choice % 3 == 0   ? hal::make_default_trocar_config(1)
                        : choice % 3 == 1 ? hal::make_default_pose_tracker_config(1)
                                          : hal::make_default_phantom_config(1);
  c.control_period_s = 1e-3;
  c.canopen.managed = (choice / 3) % 2 == 0;
  return c;
}

/// Reads and drops every frame waiting on `port` (the far side of a harness's bus, so that
/// the rings never fill up).
inline void drain(hal::Bus& port) {
  hal::CanFrame f;
  while (port.read(f) == hal::IoStatus::kOk) {
  }
}

/// Runs the input as events until it is used up: mostly a frame for `on_frame(frame)`
/// (next_frame() on `ids`), sometimes a clock step of 0–5 ms followed by `on_tick(now_ns)`.
template <class OnFrame, class OnTick>
void run_events(FuzzedDataProvider& in, const std::vector<std::uint32_t>& ids, OnFrame on_frame,
                OnTick on_tick) {
  std::int64_t now_ns = 0;
  while (in.remaining_bytes() > 0) {
    if (in.ConsumeIntegralInRange<int>(0, 7) == 0) {
      now_ns += in.ConsumeIntegralInRange<std::int64_t>(0, 5'000'000);
      on_tick(now_ns);
    } else {
      on_frame(next_frame(in, ids, now_ns));
    }
  }
}

}  // namespace numen::fuzz
