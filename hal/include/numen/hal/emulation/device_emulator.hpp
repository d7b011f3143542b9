#pragma once
/// @file device_emulator.hpp
/// DeviceEmulator: the device side of an instrument on a bus. Used by simulated instruments
/// and by tests in place of real CiA 406 encoders and CiA 402 drives. Two protocols, chosen by
/// DeviceConfig::canopen.managed (docs/protocol.md, docs/canopen.md):
///  - minimal: every encoder answers each SYNC with its 4-byte position TPDO; drives take
///    2-byte torque RPDOs. No NMT, no heartbeat.
///  - managed: one CiA 301 node per distinct node id (NmtNodeModel: boot-up message at power-on
///    and after a reset, PDOs only in operational, NMT commands obeyed; a HeartbeatProducer;
///    a HeartbeatConsumer of the controller on nodes with drives) and one CiA 402 drive per
///    driven axis (Cia402Drive in cst, fed at each SYNC by the controlword + target torque of
///    the last drive RPDO, answering with its drive TPDO — statusword, torque actual value);
///    encoder TPDOs by the static mappings of the config; EMCY on a drive fault; a drive whose
///    node loses the controller's heartbeat faults on its own (EMCY 0x8130, zero torque), and
///    an energised drive whose node leaves operational faults (CiA 402 abort connection option
///    0x6007 = 1, EMCY 0x8100); every node answers SDO on its default channel (SdoServer, in
///    pre-operational and operational) from its object dictionary (object_dictionary()):
///    0x1000 device type, 0x1001 error register, 0x1005 COB-ID SYNC, 0x1008 device name,
///    0x100A software version, 0x1016 consumer heartbeat time (nodes with a drive), 0x1017
///    producer heartbeat time, 0x1018 identity, the PDO communication and mapping parameters
///    (per axis of the node, in axis order: TPDO encoder, then on a driven axis TPDO drive and
///    RPDO drive; 0x1800 + n / 0x1A00 + n, 0x1400 + n / 0x1600 + n), 0x6004 / 0x6064
///    position, and per drive (m-th of the node at + m · 0x800) 0x6040, 0x6041, 0x6060,
///    0x6061, 0x6071, 0x6072, 0x6077 (process values kept current at each SYNC). Downloads
///    into them take effect at once — PDO COB-IDs and mappings (CiA 301 sequence enforced),
///    heartbeat period, the controller's consumer time, modes of operation, max torque — or are
///    refused with their CiA 301 abort code (docs/sdo.md). NMT reset
///    communication restores 0x1000–0x1FFF to the values of the configuration, reset node
///    every object.
/// Fault-injection hooks for tests: kill() (the device stops reading and sending entirely),
/// power_cycle(), inject_drive_fault(), set_encoder_silent() / set_responding().
/// Construction allocates and may throw; every other member is noexcept and allocation free.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "numen/hal/emulation/emulated_device.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/canopen/pdo_mapping.hpp"
#include "numen/hal/emulation/object_dictionary.hpp"
#include "numen/hal/emulation/sdo_server.hpp"

namespace numen::hal {

/// Counters of a DeviceEmulator since construction.
struct EmulatorCounters {
  std::uint64_t syncs = 0;          ///< SYNC frames received.
  std::uint64_t syncs_ignored = 0;  ///< SYNCs not answered by the encoders (set_responding(false)).
  std::uint64_t tpdos_sent = 0;     ///< Encoder TPDOs written with kOk.
  std::uint64_t tx_would_block = 0;  ///< Writes refused (queue full).
  std::uint64_t tx_errors = 0;       ///< Writes that failed.
  std::uint64_t rpdos = 0;  ///< Drive RPDOs decoded (torque RPDOs in the minimal protocol).
  std::uint64_t frames_malformed =
      0;                             ///< Frames on the SYNC, NMT or a drive RPDO COB-ID that failed
                                     ///< to decode (wrong length, not a data frame, bad command).
  std::uint64_t frames_ignored = 0;  ///< Frames of other ids.
  // Managed stack only.
  std::uint64_t nmt_commands = 0;           ///< NMT commands applied by a node (per node).
  std::uint64_t boot_ups_sent = 0;          ///< Boot-up messages written.
  std::uint64_t heartbeats_sent = 0;        ///< Heartbeats written.
  std::uint64_t drive_tpdos_sent = 0;       ///< Drive TPDOs written with kOk.
  std::uint64_t rpdos_not_operational = 0;  ///< Drive RPDOs dropped: node not operational.
  std::uint64_t emcys_sent = 0;             ///< EMCY messages written.
  std::uint64_t emcys_dropped = 0;          ///< EMCY messages lost: queue full or EMCY not allowed.
  std::uint64_t controller_losses = 0;      ///< Controller heartbeat losses seen by a node.
  std::uint64_t frames_while_killed = 0;    ///< Frames read and discarded while killed.
  std::uint64_t sdo_requests = 0;           ///< SDO requests a node took (pre-op or operational).
  std::uint64_t sdo_not_allowed = 0;        ///< SDO requests to a node in stopped or initialisation.
};

/// Identity the emulated nodes report in object 0x1018 (CiA 301 §7.5.2.21): vendor id 0 is
/// reserved by CiA for tests and prototypes; product code 0x402 for a node with a drive,
/// 0x406 for an encoder-only node; revision 0x00010000; serial number = the node id.
inline constexpr std::uint32_t kEmulatorVendorId = 0x00000000;

/// Emulated encoders and drives of one instrument. Not thread safe.
class DeviceEmulator final : public EmulatedDevice {
 public:
  /// Throws std::invalid_argument if validate(config) does. Axis values start at 0. Managed
  /// stack: every node powered on, in initialisation (its boot-up message goes out at the
  /// first tick()), every drive in not ready to switch on.
  explicit DeviceEmulator(DeviceConfig config);

  /// Sets the axis values to report, m or rad; `q` points to config().axes.size() values.
  /// Converted with value_to_counts() (rounded, saturated; no range check, so tests can feed
  /// out-of-range values).
  void set_axis_values(const double* q) noexcept;
  /// Sets the raw encoder counts to report; `counts` points to config().axes.size() values.
  void set_axis_counts(const std::int32_t* counts) noexcept;
  /// false: SYNCs are received but the encoders do not answer (a silent encoder set; drives,
  /// heartbeats and NMT go on in the managed stack).
  void set_responding(bool responding) noexcept { responding_ = responding; }
  /// Silences (true) or restores one axis's encoder TPDO. Out-of-range axes are ignored.
  void set_encoder_silent(int axis, bool silent) noexcept;

  /// Handles one frame read on the device port. Minimal protocol: a SYNC is answered by one
  /// position TPDO per axis stamped with the SYNC's timestamp; a torque RPDO updates
  /// last_torques(). Managed stack: NMT commands go to the nodes; a drive RPDO (node
  /// operational) sets the drive's controlword / target torque for the next SYNC; a SYNC steps
  /// every drive with them and, on operational nodes, sends the encoder and drive TPDOs; the
  /// controller's heartbeat feeds the nodes' consumers. Other frames are ignored. While
  /// killed every frame is discarded (counted in frames_while_killed). A SYNC first asks the
  /// motion (set_motion()) for the axis values at its timestamp, the drives holding
  /// last_torques(), and sets them (set_axis_values()).
  void on_frame(const CanFrame& frame, Bus& device_port) noexcept override;

  /// Managed stack, once per period at bus time `now_ns` (after poll()): boot-up messages of
  /// nodes in initialisation (power-on, reset) — the node enters pre-operational and starts its
  /// heartbeat producer —, due heartbeats, the controller-heartbeat consumers (a loss faults
  /// the node's drives), EMCY messages queued (injected faults, heartbeat loss, abort
  /// connection; an EMCY error reset 0x0000 after a drive's fault reset). Nothing while killed
  /// or in the minimal protocol.
  void tick(std::int64_t now_ns, Bus& device_port) noexcept override;

  /// Managed stack: drive of `axis` faults now (CiA 402 transition 13, error code `code`,
  /// zero torque); an EMCY {code, error register generic + the code's class bit} goes out at
  /// the next tick(). false if the axis has no drive (or the protocol is minimal).
  bool inject_drive_fault(int axis, std::uint16_t code, bool persistent = false) noexcept;
  /// Removes the cause of a persistent injected fault of `axis`'s drive.
  void clear_drive_fault_condition(int axis) noexcept;
  /// true: the device stops reading and sending entirely (unpowered, cable cut); frames that
  /// reach it are discarded. false: reading resumes where it was (use power_cycle() to reboot).
  void kill(bool killed) noexcept { killed_ = killed; }
  /// True while killed.
  bool killed() const noexcept { return killed_; }
  /// Managed stack: every node and drive back to power-on (initialisation, boot-up pending; not
  /// ready to switch on), controller consumers restarted, queued EMCYs dropped; un-kills.
  void power_cycle() noexcept;

  /// Last received / applied torque of each axis, N·m or N, n entries. Minimal protocol: the
  /// last torque RPDO; managed stack: the torque the CiA 402 drive applied at the last SYNC
  /// (0 outside operation enabled). 0 for axes without a drive.
  const AxisVector& last_torques() const noexcept { return last_torques_; }
  /// The same in per mille of the rated torque.
  const std::array<std::int16_t, kMaxAxes>& last_torque_per_mille() const noexcept {
    return last_per_mille_;
  }
  /// Encoder counts currently reported, n entries used.
  const std::array<std::int32_t, kMaxAxes>& counts() const noexcept { return counts_; }
  /// Managed stack: the drive of `axis`, or nullptr (no drive, minimal protocol, bad index).
  const Cia402Drive* drive(int axis) const noexcept;
  /// Managed stack: NMT state of the node of `axis` (kBootUp for a bad index / minimal).
  NmtState node_state(int axis) const noexcept;
  /// Managed stack: the object dictionary node `node_id` serves over SDO; nullptr for a node
  /// id the device does not have (or the minimal protocol).
  const ObjectDictionary* object_dictionary(std::uint8_t node_id) const noexcept;
  /// Counters.
  const EmulatorCounters& counters() const noexcept { return counters_; }
  /// The configuration.
  const DeviceConfig& config() const noexcept { return config_; }

 private:
  /// A node's dictionary and the server of it (heap: the server points into the dictionary,
  /// and nodes_ may move).
  struct NodeSdo {
    ObjectDictionary dictionary;
    SdoServer server;
    NodeSdo(std::uint8_t node_id, ObjectDictionary od)
        : dictionary(std::move(od)), server(node_id, dictionary) {}
  };
  struct Node {
    NmtNodeModel nmt;
    HeartbeatProducer producer;
    HeartbeatConsumer controller;  // node id 0 (unused) on nodes without a drive
    std::uint64_t losses_seen = 0;
    std::unique_ptr<NodeSdo> sdo;
  };
  /// One PDO of a node as its dictionary configures it.
  struct PdoSlot {
    std::size_t node = 0;
    std::uint16_t comm = 0;    // communication parameter index (0x1400 + n / 0x1800 + n)
    std::uint32_t cob_id = 0;  // 11-bit
    bool enabled = true;
    PdoMapping mapping;
  };
  struct Drive {
    int axis = 0;
    std::size_t node = 0;
    std::size_t m = 0;  // drive number on its node (CiA 402 object offset m · 0x800)
    Cia402Drive drive;
    PdoSlot rpdo;
    PdoSlot tpdo;
    std::uint16_t controlword = 0;
    std::int16_t target = 0;
    PowerState previous = PowerState::kNotReadyToSwitchOn;
  };
  struct PendingEmcy {
    std::size_t node = 0;
    EmcyMessage message;
  };
  static constexpr std::size_t kEmcyQueue = 16;

  void on_frame_minimal(const CanFrame& frame, Bus& port) noexcept;
  void on_sync_managed(const CanFrame& frame, Bus& port) noexcept;
  void on_nmt(const CanFrame& frame) noexcept;
  void apply_dictionary(std::size_t node) noexcept;
  void update_process_values() noexcept;
  void queue_emcy(std::size_t node, std::uint16_t code, std::uint8_t error_register) noexcept;
  void write(Bus& port, const CanFrame& frame, std::uint64_t* sent) noexcept;
  void update_torque(const Drive& d) noexcept;
  Drive* drive_of(int axis) noexcept;

  DeviceConfig config_;
  int n_ = 0;
  bool managed_ = false;
  bool responding_ = true;
  bool killed_ = false;
  std::array<bool, kMaxAxes> silent_{};
  std::array<std::int32_t, kMaxAxes> counts_{};
  AxisVector last_torques_;
  DriveCommands commands_;  // what the motion is told at a SYNC (torque = last_torques_)
  std::array<std::int16_t, kMaxAxes> last_per_mille_{};
  // Managed stack.
  std::vector<Node> nodes_;
  std::vector<Drive> drives_;
  std::vector<PdoSlot> encoder_pdos_;  // per axis
  std::array<std::size_t, kMaxAxes> node_of_axis_{};
  std::array<int, kMaxAxes> drive_of_axis_{};  // index into drives_, -1 without
  std::array<PendingEmcy, kEmcyQueue> emcy_{};
  std::size_t emcy_count_ = 0;
  EmulatorCounters counters_;
};

}  // namespace numen::hal
