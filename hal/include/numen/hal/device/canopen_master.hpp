#pragma once
/// @file canopen_master.hpp
/// CanopenMaster: the controller's side of the managed CANopen stack for one device's nodes
/// (docs/protocol.md, docs/canopen.md). It runs the NMT start-up of the nodes and is their
/// heartbeat consumer, the EMCY consumer and the CiA 402 master of each drive; its NMT commands
/// and the controller's heartbeat go out through the network's NmtMaster (nmt_master.hpp: its
/// own, or the one the devices on its bus share, so that its commands reach its nodes only):
///
///   start-up (once, and again on restart_startup()):
///     reset communication of its nodes (alone on its network: 000#8200) → every node's
///     boot-up message (0x700 + id, 00) → [nodes with a DCF: configured over SDO and read
///     back, kConfigure] → start remote node of its nodes (alone: 000#0100) → every node heard
///     in operational → kOperational. On a shared network a command goes to all nodes (id 0)
///     only when every device asks for it in the same period (NmtMaster), otherwise to each
///     of its nodes (000#82<id>, 000#01<id>).
///     The configuration (dcf_configuration.hpp) runs one SDO transfer per node at a time, all
///     nodes in parallel, advanced once per period; a refused write, a silent node (the
///     transfer's sdo_timeout_ms) or a read-back mismatch fails the start-up at once (kFailed,
///     configuration_error() says where in which DCF). A node that boots again meanwhile, or
///     while being started, is configured again. startup_timeout_ms does not count the time
///     spent configuring.
///     NMT commands a node has not acted on are repeated to that node every startup_retry_ms;
///   once operational, with canopen.sdo_poll_period_ms > 0: every node's error register
///     0x1001 and every drive's statusword 0x6041 read over SDO at that rate (SdoPoller, one
///     transfer per node, advanced in begin_period / on_frame / update like the rest);
///     a node that boots again while being started is started again; past startup_timeout_ms
///     the start-up has failed (kFailed, with the first missing node).
///   every period:
///     begin_period(): NMT commands due, submitted to the NmtMaster (which sends them and the
///       controller's heartbeat when due once every device of the network has submitted);
///     on_frame(): drive TPDOs (statusword, torque actual) by their static mapping, heartbeats
///       (HeartbeatMonitor; a node's frames reach it only from its boot-up after the reset on,
///       so earlier heartbeats cannot read as an unexpected reset), EMCY (EmcyLog);
///     update(): heartbeat consumers polled, start-up progress, each Cia402Master updated with
///       its drive's newest statusword;
///     write_drive_rpdos(): controlword (from the Cia402Master) + the target torque it is given
///       in each drive's RPDO mapping (gated and clamped before, by hal::ImpedanceDevice::write(), which
///       asks drive_outputs()[i].torque_allowed).
///
/// Construction allocates and may throw std::invalid_argument (config not managed or invalid);
/// every other member is noexcept, allocation free, lock free and never blocks.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/canopen/dcf_configuration.hpp"
#include "numen/hal/canopen/sdo_poller.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/device/nmt_master.hpp"
#include "numen/hal/canopen/pdo_mapping.hpp"

#include "numen/hal/device/device_status.hpp"

namespace numen::hal {


/// What the last start-up did.
/// Its base, StartupStatus (device_status.hpp), is what a DeviceReport carries of it.
struct StartupReport : StartupStatus {
  std::uint64_t began_period = 0;  ///< update() index of the period the start-up began in.
  std::int64_t began_ns = 0;       ///< Time the reset communication was sent, ns.
  std::int64_t done_ns = 0;        ///< Its time, ns.
  std::int64_t configure_ns = 0;   ///< Time spent in kConfigure in this start-up, ns.
};

/// Counters of a CanopenMaster since construction.
struct CanopenMasterCounters {
  std::uint64_t nmt_sent = 0;         ///< NMT messages written with kOk that carried a command
                                      ///< of this device (NmtDeviceCounters::nmt_sent).
  std::uint64_t nmt_retries = 0;      ///< NMT commands repeated to a node during a start-up.
  std::uint64_t heartbeats_sent = 0;  ///< Controller heartbeats written with kOk (the network's).
  std::uint64_t drive_tpdos = 0;      ///< Drive TPDOs unpacked.
  std::uint64_t drive_tpdos_malformed =
      0;                                 ///< Frames on a drive TPDO COB-ID refused by its mapping.
  std::uint64_t rpdos_sent = 0;          ///< Drive RPDOs written with kOk.
  std::uint64_t frames_before_boot = 0;  ///< Heartbeats of a node dropped while waiting for its
                                         ///< boot-up after the reset.
  std::uint64_t unknown_nodes = 0;       ///< Heartbeats of nodes the device does not have.
  std::uint64_t write_would_block = 0;   ///< Writes refused (queue full), its NMT part included.
  std::uint64_t write_errors = 0;        ///< Writes that failed (kError), its NMT part included.
  std::uint64_t sdo_requests = 0;        ///< SDO requests written with kOk (configuration).
  std::uint64_t sdo_responses = 0;       ///< SDO responses taken (configuration).
  std::uint64_t configurations = 0;      ///< Node configurations completed (read back equal).
};

/// The controller's side of the managed CANopen stack of one device (see the file comment).
/// Not thread safe: one control loop owns it.
class CanopenMaster {
 public:
  /// Builds the nodes, heartbeat consumers (timeout per node), drive mappings and CiA 402
  /// masters from `config` (validated; must be managed). `period_ns` (> 0) is the control
  /// period, used to turn the start-up times into periods. `network`: the NMT master the
  /// devices on this device's bus share (must outlive this master; the device is registered
  /// there, NmtMaster::add_device()); nullptr: a private one (the device alone on its bus).
  /// Throws std::invalid_argument naming the device otherwise, or as add_device() does.
  CanopenMaster(const DeviceConfig& config, std::int64_t period_ns,
                const Cia402MasterSettings& drive_settings = {}, NmtMaster* network = nullptr);

  /// Start of a period at `now_ns`: the start-up's NMT command due (reset communication, start,
  /// repeats) and a command queued by request_nmt(), submitted to the NmtMaster, which sends
  /// them and the controller's heartbeat when due (producer started at the first sending) once
  /// every device of the network has submitted — at once for a private one. Write failures
  /// are counted; returns kError if a write failed, else kWouldBlock if one was refused, else
  /// kOk (its NMT part as far as known: take_nmt_status()).
  IoStatus begin_period(std::int64_t now_ns, Bus& bus) noexcept;
  /// The worst status of the writes of the network's NmtMaster that carried this device's
  /// commands or the heartbeat since the last call (NmtMaster::take_status()): on a shared
  /// network they go out at the last device's begin_period(), so an earlier device learns of a
  /// failure here (ManagedDevice::supervise()).
  IoStatus take_nmt_status() noexcept { return nmt_->take_status(nmt_device_); }

  /// Takes one received frame if it is a drive TPDO, a heartbeat / boot-up message (0x701–
  /// 0x77F) or an EMCY (0x081–0x0FF) on its 11-bit identifier (can_frame.hpp, frame
  /// acceptance); returns false for any other frame (e.g. an encoder TPDO, for the
  /// InstrumentDevice), and for every error report and 29-bit frame.
  bool on_frame(const CanFrame& frame) noexcept;

  /// After the period's frames, at `now_ns`: polls the heartbeat consumers, advances the
  /// start-up, updates every Cia402Master with its drive's newest statusword.
  void update(std::int64_t now_ns) noexcept;

  /// Sets the CiA 402 target of every drive (SafetySupervisor::drive_target()).
  void request_drives(Cia402Target target) noexcept;
  /// Asks every drive's master for a fault reset (Cia402Master::request_fault_reset()).
  void request_fault_reset() noexcept;

  /// Writes each drive's RPDO stamped `now_ns`: the controlword of its master's last update(),
  /// target torque per_mille[axis] as given (0 for an axis past the span; the caller gated it
  /// with drive_outputs()[i].torque_allowed, see hal::ImpedanceDevice::write()); modes of operation (if
  /// mapped) 10. Returns as begin_period().
  IoStatus write_drive_rpdos(std::int64_t now_ns, std::span<const std::int16_t> per_mille,
                             Bus& bus) noexcept;

  /// Queues an NMT command for `node_id` (0 = every node of this device: all nodes when it is
  /// alone on its network), sent at the next begin_period(). One command is queued at a time;
  /// false if one is already queued or the command is invalid.
  bool request_nmt(NmtCommand command, std::uint8_t node_id) noexcept;
  /// Runs the start-up again from reset communication (after a failure, or to bring back nodes
  /// that reset or were stopped).
  void restart_startup() noexcept;

  /// After a start-up failed by a node's configuration: the located error (DCF file, line,
  /// section, key, node, what was refused or read back; NodeConfigurator::error()). Empty
  /// otherwise. Allocates: reports only.
  std::string configuration_error() const;
  /// The in-loop SDO reads (canopen.sdo_poll_period_ms), nullptr when off.
  const SdoPoller* sdo_poller() const noexcept { return poller_.get(); }
  /// The configurator of node `node_id`, nullptr if the node has no DCF.
  const NodeConfigurator* configurator(std::uint8_t node_id) const noexcept;

  /// True once every node has been heard operational (phase kOperational).
  bool operational() const noexcept { return startup_.phase == StartupPhase::kOperational; }
  /// True if every node's newest heartbeat reports operational and it is alive.
  bool all_nodes_operational() const noexcept;
  /// The start-up report.
  const StartupReport& startup() const noexcept { return startup_; }
  /// The heartbeat consumers, one per node (SafetyInputs::heartbeats).
  std::span<const HeartbeatConsumer> heartbeats() const noexcept { return monitor_.consumers(); }
  /// The heartbeat monitor.
  const HeartbeatMonitor<kMaxDeviceNodes>& monitor() const noexcept { return monitor_; }
  /// The EMCY log.
  const EmcyLog<>& emcy_log() const noexcept { return emcy_; }
  /// Each drive's Cia402Master output of the last update() (SafetyInputs::drives).
  std::span<const Cia402MasterOutput> drive_outputs() const noexcept {
    return {outputs_.data(), drives_.size()};
  }
  /// Number of drives.
  std::size_t num_drives() const noexcept { return drives_.size(); }
  /// Axis of drive `i` (i < num_drives()).
  int drive_axis(std::size_t i) const noexcept { return drives_[i].axis; }
  /// Newest statusword of drive `i` (0 before its first TPDO).
  std::uint16_t drive_statusword(std::size_t i) const noexcept { return drives_[i].statusword; }
  /// Newest torque actual value of drive `i`, per mille (0 if not mapped / not received).
  std::int16_t drive_torque_actual(std::size_t i) const noexcept {
    return drives_[i].torque_actual;
  }
  /// The master of drive `i`.
  const Cia402Master& drive_master(std::size_t i) const noexcept { return drives_[i].master; }
  /// Node ids, in first-axis order.
  std::span<const std::uint8_t> node_ids() const noexcept { return {node_ids_.data(), num_nodes_}; }
  /// update() calls so far.
  std::uint64_t periods() const noexcept { return periods_; }
  /// Counters (its NMT and heartbeat part from the NmtMaster).
  CanopenMasterCounters counters() const noexcept;

 private:
  struct NodeState {
    bool booted = false;   // boot-up received since the last reset communication
    bool restart = false;  // booted again while being started: start it again
    bool reconfigure = false;  // booted again after its configuration began: configure again
    int configurator = -1;     // index into configurators_, -1 without a DCF
    std::int64_t last_command_ns = 0;
  };
  struct Drive {
    int axis = 0;
    std::uint32_t rpdo_cob_id = 0;
    std::uint32_t tpdo_cob_id = 0;
    PdoMapping rpdo;
    PdoMapping tpdo;
    int cw_index = -1;      // in rpdo
    int torque_index = -1;  // in rpdo
    int mode_index = -1;    // in rpdo, -1 if not mapped
    int sw_index = -1;      // in tpdo
    int actual_index = -1;  // in tpdo, -1 if not mapped
    Cia402Master master;
    std::uint16_t statusword = 0;
    std::int16_t torque_actual = 0;
  };

  // Asks the network's NmtMaster for `command` to `node` (kNmtAllNodes: its own nodes).
  void ask_nmt(NmtCommand command, std::uint8_t node) noexcept;
  IoStatus send(const CanFrame& frame, Bus& bus, std::uint64_t* sent) noexcept;
  int node_index(std::uint8_t node_id) const noexcept;
  void finish(StartupPhase phase, std::uint8_t missing, std::int64_t now_ns) noexcept;
  void enter_configure(std::int64_t now_ns) noexcept;
  void update_configure(std::int64_t now_ns) noexcept;

  std::int64_t retry_ns_ = 0;
  std::int64_t timeout_ns_ = 0;
  std::array<std::uint8_t, kMaxDeviceNodes> node_ids_{};
  std::array<NodeState, kMaxDeviceNodes> nodes_{};
  std::size_t num_nodes_ = 0;
  std::vector<Drive> drives_;
  std::vector<std::unique_ptr<DcfConfiguration>> plans_;  // one per node with a DCF
  std::vector<NodeConfigurator> configurators_;          // same order
  std::int64_t configure_began_ns_ = 0;
  std::unique_ptr<SdoPoller> poller_;
  std::array<Cia402MasterOutput, kMaxDeviceNodes> outputs_{};
  HeartbeatMonitor<kMaxDeviceNodes> monitor_;
  std::unique_ptr<NmtMaster> own_nmt_;  // without a shared one
  NmtMaster* nmt_ = nullptr;            // the network's (own_nmt_ or the shared one)
  int nmt_device_ = 0;                  // this device's index there
  EmcyLog<> emcy_;
  StartupReport startup_;
  bool nmt_queued_ = false;
  NmtMessage queued_{};
  std::int64_t last_now_ns_ = 0;
  std::uint64_t periods_ = 0;
  CanopenMasterCounters counters_;
};

}  // namespace numen::hal
