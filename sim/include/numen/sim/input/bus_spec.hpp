#pragma once
/// @file bus_spec.hpp
/// The real buses of `numen run --bus` and `numen device --bus`: parsing of the spec
/// ("can:IFACE", "serial:PATH[@BAUD]"), the acceptance filters each end of the link needs
/// (from the device's COB-IDs, docs/protocol.md, docs/canopen.md), opening the port (SocketCanBus,
/// docs/transports.md; SerialBus, the same page) and waiting on it without spinning.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_filter.hpp"
#include "numen/hal/device/bus_filters.hpp"
#include "numen/hal/device/device_config.hpp"

namespace numen::sim {

/// What a `--bus` spec names.
enum class BusKind : std::uint8_t {
  kSim,     ///< "sim": the scene's SimBus (numen run only).
  kLog,     ///< "log:FILE": a candump log replayed (numen run only).
  kCan,     ///< "can:IFACE": a SocketCAN interface (can0, vcan0, ...).
  kSerial,  ///< "serial:PATH[@BAUD]": a serial line (tty, USB adapter, pseudo-terminal).
  /// "igtl", "igtl:PORT" or "igtl:HOST:PORT": the scene's OpenIGTLink tracker ([device.igtl])
  /// read as the pose tracker's encoders (hal/igtl/igtl_tracker_bus.hpp; numen run only), at
  /// the scene's server or this one.
  kIgtl,
};

/// A parsed `--bus` spec.
struct BusSpec {
  BusKind kind = BusKind::kSim;
  /// kLog: the file; kCan: the interface name; kSerial: the device path.
  std::string target;
  /// kSerial: line speed, bit/s (default 1 000 000; one of hal::serial_supported_bauds()).
  std::uint32_t baud = 1'000'000;
  /// kIgtl: the server's host ("" : the scene's) and port (0: the scene's).
  std::string igtl_host;
  std::uint16_t igtl_port = 0;
  /// True for kCan and kSerial: a bus shared with a device in another process (or real
  /// hardware), on which time is CLOCK_MONOTONIC and the periods are paced.
  bool real() const noexcept { return kind == BusKind::kCan || kind == BusKind::kSerial; }
};

/// Parses "sim", "log:FILE", "can:IFACE", "serial:PATH[@BAUD]" (BAUD decimal bit/s) or
/// "igtl[:[HOST:]PORT]" (PORT decimal 1..65535; HOST a host name or IPv4 address of letters,
/// digits, '.', '-' and '_', or an IPv6 address, bare or in brackets: BusSpec::igtl_host has it
/// without them). Throws std::invalid_argument naming the spec and what is wrong (empty target,
/// unknown prefix, a baud that is not a number or not a supported termios speed, a port out of
/// range, a host that is none of those, such as "127.0.0.1:19098" of "igtl:127.0.0.1:19098:5").
BusSpec parse_bus_spec(const std::string& spec);

/// The acceptance filters of each side of a device's bus (hal/device/bus_filters.hpp): what the
/// controller reads (a real bus opened for `numen run`) and what the device reads (`numen
/// device`).
using hal::controller_filters;
using hal::device_filters;

/// Empty if this build has the backend `spec` needs (hal/features.hpp), else the error:
/// "bus 'can:vcan0' needs SocketCAN: this build has NUMEN_WITH_SOCKETCAN=OFF" (likewise
/// serial: with NUMEN_WITH_SERIAL). Always empty for sim and log: specs.
std::string missing_backend(const BusSpec& spec);

/// Opens the port of a real `spec` (kCan: SocketCanBus with kernel filters, loopback on,
/// own messages off; kSerial: SerialBus with user-space filters). Throws
/// std::invalid_argument for a spec that is not real or whose backend this build left out
/// (missing_backend()), std::runtime_error from the transport (naming the interface or path
/// and the failing call).
std::unique_ptr<hal::Bus> open_real_bus(const BusSpec& spec,
                                        const std::vector<hal::CanFilter>& filters);

/// Waits up to `timeout_ns` (>= 0) for `bus` to have something to read: poll(2) on its file
/// descriptor (SocketCanBus::native_handle(), SerialBus::native_handle()). Returns true if
/// readable (or hung up / in error: read() then reports it), false on timeout or EINTR. Other
/// buses: sleeps for the timeout and returns true. Blocks: not for the control period.
bool wait_bus(hal::Bus& bus, std::int64_t timeout_ns) noexcept;

/// Counters of a real bus beyond hal::BusCounters, as summary text: SocketCAN (error frames,
/// bus off, restarts, link down, malformed, reopens, last errno) or serial (frames decoded,
/// chunks rejected, bytes discarded, filtered). Empty for other buses. Not real-time.
std::string describe_transport_counters(const hal::Bus& bus);

/// Transport-level events that a run should count as "link trouble" (SocketCAN: link-down
/// transitions; serial: 0 until the line is gone, then 1). For summaries.
std::uint64_t link_down_events(const hal::Bus& bus) noexcept;

}  // namespace numen::sim
