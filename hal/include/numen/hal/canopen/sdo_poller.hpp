#pragma once
/// @file sdo_poller.hpp
/// Occasional SDO reads inside the control loop (docs/sdo.md "SDO in the loop"): a fixed
/// list of objects (e.g. every node's error register 0x1001, a drive's statusword 0x6041),
/// each read again every `every_periods` periods, through one SdoClient per node (CiA 301: one
/// transfer per channel at a time; the reads of a node queue behind each other). The state
/// machine is advanced once per period — begin_period() sends, on_frame() takes responses,
/// update() finishes transfers, times out silent nodes and starts the reads that are due —
/// and never waits. Construction allocates; every other member is noexcept, allocation-free,
/// lock-free and non-blocking. Not thread-safe: the loop's thread.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "numen/hal/canopen/sdo.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// One object read periodically.
struct PeriodicRead {
  std::uint8_t node_id = 0;          ///< 1–127.
  SdoAddress address;                ///< The object (up to 4 bytes are kept).
  std::uint32_t every_periods = 1;   ///< Read again this many periods after the last start, >= 1.
};

/// What the reads of one PeriodicRead gave so far.
struct PeriodicReadResult {
  std::uint32_t value = 0;           ///< The last value read (little endian, ≤ 4 bytes).
  std::uint8_t size = 0;             ///< Its length, bytes (0 before the first read).
  std::uint64_t reads = 0;           ///< Reads completed.
  std::uint64_t aborts = 0;          ///< Reads aborted (by the node, or timed out).
  std::uint32_t last_abort = 0;      ///< The last abort code (sdo_abort_name()).
  std::uint64_t last_period = 0;     ///< update() index of the last completed read.
};

/// Counters of an SdoPoller since construction.
struct SdoPollerCounters {
  std::uint64_t started = 0;     ///< Reads started.
  std::uint64_t completed = 0;   ///< Reads completed.
  std::uint64_t aborted = 0;     ///< Reads aborted by a node.
  std::uint64_t timeouts = 0;    ///< Reads aborted because the node did not answer.
  std::uint64_t requests = 0;    ///< Requests written with kOk.
  std::uint64_t write_errors = 0;  ///< Requests the bus refused (the read then times out).
};

/// The periodic reads of a list (see the file comment).
class SdoPoller {
 public:
  /// Reads `reads` (each every_periods >= 1, node 1–127; std::invalid_argument naming the
  /// entry otherwise), each transfer timing out after `timeout_ns` (> 0). The first read of
  /// each entry is due at the first update().
  SdoPoller(std::span<const PeriodicRead> reads, std::int64_t timeout_ns);

  /// Sends the requests of the period's transfers at `now_ns`.
  void begin_period(std::int64_t now_ns, Bus& bus) noexcept;
  /// Takes a received frame; true if it was the response channel of one of the nodes.
  bool on_frame(const CanFrame& frame) noexcept;
  /// At `now_ns`, after the period's frames: finishes completed transfers, times out silent
  /// nodes, starts the reads that are due (one per idle node).
  void update(std::int64_t now_ns) noexcept;

  /// The reads, in the order given.
  std::span<const PeriodicRead> reads() const noexcept { return reads_; }
  /// Their results, same order.
  std::span<const PeriodicReadResult> results() const noexcept { return results_; }
  /// Counters.
  const SdoPollerCounters& counters() const noexcept { return counters_; }

 private:
  struct Channel {
    SdoClient client;
    int read = -1;  // index of the read in flight, -1 idle
    std::array<std::uint8_t, 4> buffer{};
  };
  std::vector<PeriodicRead> reads_;
  std::vector<PeriodicReadResult> results_;
  std::vector<std::uint64_t> last_start_;  // update() index each read last started (+1; 0 never)
  std::vector<std::size_t> channel_of_;    // per read
  std::vector<Channel> channels_;          // per distinct node
  std::uint64_t periods_ = 0;
  SdoPollerCounters counters_;
};

}  // namespace numen::hal
