#pragma once
/// @file nmt_master.hpp
/// NmtMaster: the NMT master of one CAN network (CiA 301 §7.2.8.3.1, §7.3.2: one NMT master per
/// network, the only sender of NMT node control messages on it) and the controller's heartbeat
/// producer (CiA 301 §7.2.8.3.2: one producer per COB-ID). Several managed devices on one bus
/// (the CanopenMaster of each, docs/canopen.md "Several devices on one bus") share one, so that
/// one device's NMT commands reach that device's nodes only:
///
///   each period, each device's CanopenMaster requests the NMT commands its start-up and its
///   caller need (request(): one node, or kNmtAllNodes for every node of that device), then
///   submits (submit()). When every device of the network has submitted, the period's commands
///   go out in the order first requested:
///     - a command every device of the network asked for all of its nodes: one broadcast
///       (node id 0), as one device alone sends its start-up's reset communication and start
///       — unless the network also carries a device it does not manage (add_bystander(): the
///       minimal protocol's self-starting nodes), which a broadcast would reach too;
///     - otherwise one node-addressed message per node asked for (ascending node id), so
///       re-arming one device never resets, stops or starts another device's nodes;
///   then the controller's heartbeat when due.
///
/// A CanopenMaster built without one owns a private NmtMaster of one device: its frames are
/// those of a lone NMT master. Registration (add_device()) allocates and may throw;
/// every other member is noexcept, allocation free, lock free and never blocks. Not thread
/// safe: one control loop owns the devices of a network.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/transport/bus.hpp"

namespace numen::hal {

/// Most devices sharing one NmtMaster (platform::kMaxLoopDevices devices on one bus).
inline constexpr std::size_t kMaxNmtDevices = 4;
/// Most nodes of one device (one per axis at most).
inline constexpr std::size_t kMaxDeviceNodes = static_cast<std::size_t>(kMaxAxes);

/// Counters of one device of an NmtMaster since construction.
struct NmtDeviceCounters {
  std::uint64_t nmt_sent = 0;         ///< NMT messages written with kOk that carried a command
                                      ///< of the device (a broadcast counts for every device).
  std::uint64_t heartbeats_sent = 0;  ///< Controller heartbeats written with kOk (every device).
  std::uint64_t write_would_block = 0;  ///< Those writes refused (queue full).
  std::uint64_t write_errors = 0;       ///< Those writes that failed (kError).
};

/// The NMT master and controller heartbeat of one CAN network (see the file comment).
class NmtMaster {
 public:
  /// Registers a managed device (its nodes, CanopenConfig::axes' node ids) and returns its
  /// index in the network (0, 1, …). The first device sets the controller's node id and
  /// heartbeat period (CanopenConfig::controller_node_id, controller_heartbeat_period_ms).
  /// Throws std::invalid_argument naming the devices if `config` is not managed, if the network
  /// has kMaxNmtDevices devices already, if a node id is another device's or the controller's,
  /// or if its controller node id or heartbeat period differs from the first device's (one
  /// controller node per network). Construction only.
  int add_device(const DeviceConfig& config);

  /// Registers a device on the network that this master does not manage (canopen.managed =
  /// false: the minimal protocol, whose self-starting nodes no NMT command is meant for): from
  /// then on no command is broadcast, every command is addressed to the nodes of the devices
  /// that asked for it (CiA 301 §7.2.8.3.1: node id 0 reaches every node of the network, the
  /// bystander's too — a reset communication would restart its encoders, an enter
  /// pre-operational would stop their TPDOs). Throws std::invalid_argument naming the device if
  /// `config` is managed, or if the network has kMaxNmtDevices devices (managed or not)
  /// already. Construction only.
  void add_bystander(const DeviceConfig& config);
  /// Devices registered with add_bystander().
  int num_bystanders() const noexcept { return static_cast<int>(num_bystanders_); }

  /// Asks for `command` to `node_id` (1–127; kNmtAllNodes: every node of `device`) in this
  /// period, sent once every device has submitted. A node asked for twice in a period gets one
  /// message. False for a bad device index, node id or command.
  bool request(int device, NmtCommand command, std::uint8_t node_id) noexcept;

  /// Device `device` made its requests of the period at `now_ns`. Once every device of the
  /// network has submitted since the last sending, sends the period's commands (see the file
  /// comment) and the controller's heartbeat when due (production starts at the first
  /// submit()) on `bus`, and starts the next period's requests. Returns what its writes
  /// returned (the worst: kError, then kWouldBlock), kOk when it sent nothing; each device's
  /// part is also kept for take_status().
  IoStatus submit(int device, std::int64_t now_ns, Bus& bus) noexcept;

  /// The worst status of the writes that carried device `device`'s commands or the heartbeat
  /// since the last call (kOk: none failed), then cleared: how a device that submitted before
  /// the last one learns of a failed write.
  IoStatus take_status(int device) noexcept;

  /// The number of devices registered.
  int num_devices() const noexcept { return static_cast<int>(num_devices_); }
  /// Device `device`'s counters (0 ≤ device < num_devices()).
  const NmtDeviceCounters& counters(int device) const noexcept {
    return devices_[static_cast<std::size_t>(device)].counters;
  }
  /// NMT messages sent to every node (node id 0) with kOk.
  std::uint64_t broadcasts() const noexcept { return broadcasts_; }

 private:
  // The five CiA 301 commands, each one slot of the period's requests.
  static constexpr std::size_t kCommands = 5;
  struct DeviceSlot {
    std::array<std::uint8_t, kMaxDeviceNodes> nodes{};
    std::size_t num_nodes = 0;
    bool submitted = false;
    IoStatus status = IoStatus::kOk;
    NmtDeviceCounters counters;
  };
  // One command's requests in this period.
  struct Requests {
    std::array<std::int8_t, kMaxNodeId + 1> by_node{};  // requesting device per node, -1: none
    std::array<bool, kMaxNmtDevices> whole{};           // asked for every node of the device
    bool any = false;
  };

  void clear_requests() noexcept;
  IoStatus send(const CanFrame& frame, Bus& bus, int device, bool heartbeat) noexcept;
  IoStatus send_command(NmtCommand command, std::uint8_t node, std::int64_t now_ns, Bus& bus,
                        int device) noexcept;
  IoStatus flush(std::int64_t now_ns, Bus& bus) noexcept;

  std::array<DeviceSlot, kMaxNmtDevices> devices_{};
  std::array<std::string, kMaxNmtDevices> names_;  // for the messages of add_device()
  std::size_t num_devices_ = 0;
  std::size_t num_bystanders_ = 0;  // devices on the network it does not manage: no broadcast
  std::array<std::int8_t, kMaxNodeId + 1> owner_ = make_owners();  // device per node, -1: none
  std::array<Requests, kCommands> requests_ = make_requests();
  std::array<NmtCommand, kCommands> order_{};  // commands in the order first requested
  std::size_t num_ordered_ = 0;
  std::optional<HeartbeatProducer> heartbeat_;
  bool heartbeat_started_ = false;
  std::uint64_t broadcasts_ = 0;

  static std::array<std::int8_t, kMaxNodeId + 1> make_owners() noexcept;
  static std::array<Requests, kCommands> make_requests() noexcept;
};

}  // namespace numen::hal
