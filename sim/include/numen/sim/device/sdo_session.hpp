#pragma once
/// @file sdo_session.hpp
/// Bring-up over SDO (docs/sdo.md; `numen sdo`, `numen scan`): running one transfer
/// of hal::SdoClient to its end on a bus, and scanning a bus for CANopen nodes and their
/// identities. Blocking and allocating: setup code, never in the control period.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/canopen/sdo.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_filter.hpp"

namespace numen::sim {

/// A bus as bring-up code uses it: frames, a clock, and a way to wait for frames. On a real
/// bus (real_link()): CLOCK_MONOTONIC and wait_bus(); in tests, a SimBus whose other end is
/// advanced while "waiting".
struct BringUpLink {
  hal::Bus* bus = nullptr;
  /// Time now, ns (the clock of the SDO timeouts and the scan's listening window).
  std::function<std::int64_t()> now_ns;
  /// Waits up to the given ns for something to read (may return early).
  std::function<void(std::int64_t)> wait;
};

/// The link of a real bus: CLOCK_MONOTONIC, wait_bus(). `bus` must outlive the link.
BringUpLink real_link(hal::Bus& bus);

/// The filters a bring-up tool reads through: every SDO response channel (0x581–0x5FF) and
/// every heartbeat / boot-up (0x701–0x77F), as two range filters.
std::vector<hal::CanFilter> bring_up_filters();

/// Runs the transfer `client` has started until it ends: sends its requests, feeds it the
/// frames read, waits on the link between them and polls its timeout. Returns the final status
/// (kDone or kAborted; the client says why). Frames of other ids are read and dropped.
hal::SdoStatus run_sdo_transfer(const BringUpLink& link, hal::SdoClient& client);

/// One node a scan found, and what it answered.
struct ScannedNode {
  std::uint8_t node_id = 0;
  hal::NmtState state = hal::NmtState::kBootUp;  ///< The last boot-up or heartbeat heard.
  bool answered = false;            ///< Answered SDO at all (0x1000 read, or an abort).
  std::uint32_t device_type = 0;    ///< 0x1000 (low word: the CiA profile, e.g. 402, 406).
  std::uint32_t vendor_id = 0, product_code = 0, revision = 0, serial = 0;  ///< 0x1018:1–4.
  std::string name;                 ///< 0x1008 manufacturer device name ("" if not read).
  std::string software_version;     ///< 0x100A ("" if not read).
  /// Objects that could not be read: "0x1008:00: <abort name>" (optional objects of CiA 301
  /// are allowed to be missing; a missing 0x1000 or 0x1018 is a non-conformant node).
  std::vector<std::string> errors;
};

/// Settings of scan_nodes().
struct ScanSettings {
  std::int64_t listen_ns = 1'500'000'000;    ///< How long to listen for boot-ups / heartbeats.
  std::int64_t sdo_timeout_ns = 500'000'000;  ///< Per SDO transfer.
};

/// Listens on the link for boot-up and heartbeat messages (0x701–0x77F) for
/// settings.listen_ns, then reads 0x1000, 0x1018:1–4, 0x1008 and 0x100A of each node heard,
/// by SDO, one node after another, in node order. Never sends NMT: no node is started or
/// stopped.
std::vector<ScannedNode> scan_nodes(const BringUpLink& link, const ScanSettings& settings = {});

/// The scan as a table, one line per node (node, state, device type and profile, vendor,
/// product, revision, serial, name, software version), then the errors.
std::string format_scan_table(const std::vector<ScannedNode>& nodes);
/// The scan as JSON: {"nodes": [{"node_id", "state", "answered", "device_type", "profile",
/// "vendor_id", "product_code", "revision", "serial", "name", "software_version", "errors"}]}.
std::string format_scan_json(const std::vector<ScannedNode>& nodes);

/// Parses "INDEX:SUB" in CANopen's hexadecimal notation ("1018:01", "0x6060:0"). Throws
/// std::invalid_argument naming the text on anything else.
hal::SdoAddress parse_sdo_address(const std::string& text);

}  // namespace numen::sim
