/// @file device_emulator.cpp
/// Device-side emulation of an instrument's encoder nodes and drives: the minimal protocol and
/// the managed CANopen stack (NMT, heartbeats, EMCY, CiA 402 in cst, static PDO mappings).

#include "numen/hal/emulation/device_emulator.hpp"

#include <algorithm>
#include <string>
#include <cmath>
#include <utility>

#include "numen/hal/canopen/canopen.hpp"
#include "node_dictionary.hpp"

namespace numen::hal {
namespace {

// CiA 301 emergency codes the emulated nodes send.
constexpr std::uint16_t kEmcyHeartbeatError = 0x8130;  // life guard / heartbeat error
constexpr std::uint16_t kEmcyCommunication = 0x8100;   // communication (abort connection)

// Error register for an emergency code: generic bit + the class bit of CiA 301 §7.5.2.2.
std::uint8_t register_for(std::uint16_t code) noexcept {
  std::uint8_t r = ErrorRegisterBit::kGeneric;
  switch (emcy_error_class(code)) {
    case EmcyErrorClass::kCurrent:
      r |= ErrorRegisterBit::kCurrent;
      break;
    case EmcyErrorClass::kVoltage:
      r |= ErrorRegisterBit::kVoltage;
      break;
    case EmcyErrorClass::kTemperature:
      r |= ErrorRegisterBit::kTemperature;
      break;
    case EmcyErrorClass::kMonitoring:
      r |= ErrorRegisterBit::kCommunication;
      break;
    default:
      break;
  }
  return r;
}

bool energised(PowerState s) noexcept {
  return s == PowerState::kReadyToSwitchOn || s == PowerState::kSwitchedOn ||
         s == PowerState::kOperationEnabled || s == PowerState::kQuickStopActive;
}

Cia402DriveSettings drive_settings(const AxisConfig& a) {
  Cia402DriveSettings s;
  // The drive's own max torque 0x6072 at numen's saturation (a second, independent limit).
  const double pm = std::ceil(1000.0 * a.max_torque / a.rated_torque);
  s.max_torque_per_mille = static_cast<std::int16_t>(std::clamp(pm, 1.0, 32767.0));
  return s;
}

}  // namespace

DeviceEmulator::DeviceEmulator(DeviceConfig config) : config_(std::move(config)) {
  validate(config_);
  n_ = static_cast<int>(config_.axes.size());
  managed_ = config_.canopen.managed;
  last_torques_ = AxisVector::Zero(n_);
  drive_of_axis_.fill(-1);
  for (int i = 0; i < n_; ++i) {
    counts_[static_cast<std::size_t>(i)] =
        value_to_counts(config_.axes[static_cast<std::size_t>(i)], 0.0);
  }
  if (!managed_) return;
  const CanopenConfig& co = config_.canopen;
  const std::int64_t controller_timeout_ns =
      static_cast<std::int64_t>(co.effective_drive_heartbeat_timeout_ms()) * 1'000'000;
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const CanopenAxisConfig& x = co.axes[k];
    const AxisConfig& a = config_.axes[k];
    std::size_t node = nodes_.size();
    for (std::size_t j = 0; j < nodes_.size(); ++j) {
      if (nodes_[j].nmt.node_id() == x.node_id) node = j;
    }
    if (node == nodes_.size()) {
      nodes_.push_back(Node{NmtNodeModel(x.node_id),
                            HeartbeatProducer(x.node_id, heartbeat_ms_to_ns(x.heartbeat_period_ms)),
                            HeartbeatConsumer(), 0, nullptr});
    }
    if (a.has_drive() && nodes_[node].controller.node_id() == 0) {
      nodes_[node].controller = HeartbeatConsumer(co.controller_node_id, controller_timeout_ns);
    }
    node_of_axis_[k] = node;
    encoder_pdos_.push_back(PdoSlot{
        node, 0, a.encoder_cob_id, true,
        PdoMapping(std::span<const PdoEntry>(x.encoder_tpdo.data(), x.encoder_tpdo.size()),
                   "encoder TPDO")});
    if (a.has_drive()) {
      drive_of_axis_[k] = static_cast<int>(drives_.size());
      std::size_t m = 0;
      for (const Drive& d : drives_) m += d.node == node ? 1 : 0;
      drives_.push_back(Drive{
          i, node, m, Cia402Drive(drive_settings(a)),
          PdoSlot{node, 0, a.drive_cob_id, true,
                  PdoMapping(std::span<const PdoEntry>(x.drive_rpdo.data(), x.drive_rpdo.size()),
                             "drive RPDO")},
          PdoSlot{node, 0, x.drive_tpdo_cob_id, true,
                  PdoMapping(std::span<const PdoEntry>(x.drive_tpdo.data(), x.drive_tpdo.size()),
                             "drive TPDO")},
          0, 0, PowerState::kNotReadyToSwitchOn});
    }
  }
  // Each node's object dictionary (CiA 301 identity and communication objects, its PDOs, its
  // drives' objects), served over SDO.
  for (std::size_t j = 0; j < nodes_.size(); ++j) {
    Node& node = nodes_[j];
    const std::uint8_t id = node.nmt.node_id();
    bool has_drive = false;
    std::string axes;
    std::uint16_t heartbeat_ms = 0;
    for (int i = 0; i < n_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (co.axes[k].node_id != id) continue;
      has_drive = has_drive || config_.axes[k].has_drive();
      axes += (axes.empty() ? "" : ", ") + config_.axes[k].name;
      heartbeat_ms = static_cast<std::uint16_t>(co.axes[k].heartbeat_period_ms);
    }
    ObjectDictionary od;
    // 0x1000 device type: profile in the low word (402 drive / 406 encoder), additional
    // information high (0x0002 servo drive; 0x0002 multi-turn absolute rotary encoder).
    od.add_unsigned({0x1000, 0}, OdAccess::kReadOnly, has_drive ? 0x00020192u : 0x00020196u, 4);
    od.add_unsigned({0x1001, 0}, OdAccess::kReadOnly, 0, 1);
    const std::string name = std::string("numen emulated ") + (has_drive ? "drive" : "encoder") +
                             " (" + config_.name + ": " + axes + ")";
    od.add_string({0x1008, 0}, OdAccess::kReadOnly, name, name.size());
    od.add_string({0x100A, 0}, OdAccess::kReadOnly, "numen device emulator", 21);
    emulation::add_communication(
        od, heartbeat_ms, node.controller.node_id(),
        static_cast<std::uint16_t>(std::min<std::uint32_t>(co.effective_drive_heartbeat_timeout_ms(), 0xFFFF)));
    od.add_unsigned({0x1018, 0}, OdAccess::kReadOnly, 4, 1);
    od.add_unsigned({0x1018, 1}, OdAccess::kReadOnly, kEmulatorVendorId, 4);
    od.add_unsigned({0x1018, 2}, OdAccess::kReadOnly, has_drive ? 0x402u : 0x406u, 4);
    od.add_unsigned({0x1018, 3}, OdAccess::kReadOnly, 0x00010000u, 4);
    od.add_unsigned({0x1018, 4}, OdAccess::kReadOnly, id, 4);
    std::uint16_t tpdo = 0x1800;
    std::uint16_t rpdo = 0x1400;
    for (int i = 0; i < n_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (node_of_axis_[k] != j) continue;
      PdoSlot& enc = encoder_pdos_[k];
      enc.comm = tpdo++;
      emulation::add_pdo(od, enc.comm, enc.cob_id, enc.mapping);
      if (Drive* d = drive_of(i)) {
        d->tpdo.comm = tpdo++;
        emulation::add_pdo(od, d->tpdo.comm, d->tpdo.cob_id, d->tpdo.mapping);
        d->rpdo.comm = rpdo++;
        emulation::add_pdo(od, d->rpdo.comm, d->rpdo.cob_id, d->rpdo.mapping);
      }
    }
    emulation::add_position(od);
    for (const Drive& d : drives_) {
      if (d.node == j) {
        emulation::add_drive(od, d.m, d.drive.settings().modes_of_operation,
                             d.drive.settings().max_torque_per_mille);
      }
    }
    od.save_defaults();
    node.sdo = std::make_unique<NodeSdo>(id, std::move(od));
  }
  update_process_values();
}

void DeviceEmulator::apply_dictionary(std::size_t j) noexcept {
  Node& node = nodes_[j];
  const ObjectDictionary& od = node.sdo->dictionary;
  std::uint32_t v = 0;
  if (od.read_unsigned({0x1017, 0}, v)) (void)node.producer.set_period(heartbeat_ms_to_ns(v));
  if (node.controller.node_id() != 0 || od.find({0x1016, 1}) != nullptr) {
    if (od.read_unsigned({0x1016, 1}, v)) {
      const auto id = static_cast<std::uint8_t>(v >> 16);
      const std::int64_t ns = static_cast<std::int64_t>(v & 0xFFFFu) * 1'000'000;
      if (v == 0) {
        node.controller = HeartbeatConsumer();
        node.losses_seen = 0;
      } else if (id != node.controller.node_id() || ns != node.controller.timeout_ns()) {
        node.controller = HeartbeatConsumer(id, ns);  // the rules let only valid values in
        node.losses_seen = 0;
      }
    }
  }
  for (PdoSlot& p : encoder_pdos_) {
    if (p.node == j) emulation::read_pdo(od, p.comm, p.cob_id, p.enabled, p.mapping);
  }
  for (Drive& d : drives_) {
    if (d.node != j) continue;
    emulation::read_pdo(od, d.tpdo.comm, d.tpdo.cob_id, d.tpdo.enabled, d.tpdo.mapping);
    emulation::read_pdo(od, d.rpdo.comm, d.rpdo.cob_id, d.rpdo.enabled, d.rpdo.mapping);
    if (od.read_unsigned({emulation::drive_object(0x6060, d.m), 0}, v))
      d.drive.set_modes_of_operation(static_cast<std::int8_t>(v));
    if (od.read_unsigned({emulation::drive_object(0x6072, d.m), 0}, v))
      (void)d.drive.set_max_torque_per_mille(static_cast<std::int32_t>(v));
  }
}

void DeviceEmulator::update_process_values() noexcept {
  for (std::size_t j = 0; j < nodes_.size(); ++j) {
    ObjectDictionary& od = nodes_[j].sdo->dictionary;
    for (int i = n_ - 1; i >= 0; --i) {  // a node of several axes shows its first one
      const auto k = static_cast<std::size_t>(i);
      if (node_of_axis_[k] != j) continue;
      (void)od.set_unsigned({0x6004, 0}, static_cast<std::uint32_t>(counts_[k]));
      (void)od.set_unsigned({0x6064, 0}, static_cast<std::uint32_t>(counts_[k]));
    }
  }
  for (const Drive& d : drives_) {
    ObjectDictionary& od = nodes_[d.node].sdo->dictionary;
    (void)od.set_unsigned({emulation::drive_object(0x6041, d.m), 0}, d.drive.statusword());
    (void)od.set_unsigned({emulation::drive_object(0x6061, d.m), 0},
                          static_cast<std::uint8_t>(d.drive.modes_of_operation_display()));
    (void)od.set_unsigned({emulation::drive_object(0x6077, d.m), 0},
                          static_cast<std::uint16_t>(d.drive.applied_torque_per_mille()));
    (void)od.set_unsigned({emulation::drive_object(0x6040, d.m), 0}, d.controlword);
    (void)od.set_unsigned({emulation::drive_object(0x6071, d.m), 0}, static_cast<std::uint16_t>(d.target));
  }
}

const ObjectDictionary* DeviceEmulator::object_dictionary(std::uint8_t node_id) const noexcept {
  for (const Node& node : nodes_)
    if (node.nmt.node_id() == node_id && node.sdo) return &node.sdo->dictionary;
  return nullptr;
}

void DeviceEmulator::set_axis_values(const double* q) noexcept {
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    counts_[k] = value_to_counts(config_.axes[k], q[i]);
  }
}

void DeviceEmulator::set_axis_counts(const std::int32_t* counts) noexcept {
  for (int i = 0; i < n_; ++i) counts_[static_cast<std::size_t>(i)] = counts[i];
}

void DeviceEmulator::set_encoder_silent(int axis, bool silent) noexcept {
  if (axis >= 0 && axis < n_) silent_[static_cast<std::size_t>(axis)] = silent;
}

DeviceEmulator::Drive* DeviceEmulator::drive_of(int axis) noexcept {
  if (axis < 0 || axis >= n_) return nullptr;
  const int d = drive_of_axis_[static_cast<std::size_t>(axis)];
  return d < 0 ? nullptr : &drives_[static_cast<std::size_t>(d)];
}

const Cia402Drive* DeviceEmulator::drive(int axis) const noexcept {
  if (axis < 0 || axis >= n_) return nullptr;
  const int d = drive_of_axis_[static_cast<std::size_t>(axis)];
  return d < 0 ? nullptr : &drives_[static_cast<std::size_t>(d)].drive;
}

NmtState DeviceEmulator::node_state(int axis) const noexcept {
  if (!managed_ || axis < 0 || axis >= n_) return NmtState::kBootUp;
  return nodes_[node_of_axis_[static_cast<std::size_t>(axis)]].nmt.state();
}

void DeviceEmulator::write(Bus& port, const CanFrame& frame, std::uint64_t* sent) noexcept {
  const IoStatus s = port.write(frame);
  if (s == IoStatus::kOk && sent != nullptr) ++*sent;
  if (s == IoStatus::kWouldBlock) ++counters_.tx_would_block;
  if (s == IoStatus::kError) ++counters_.tx_errors;
}

void DeviceEmulator::on_frame_minimal(const CanFrame& frame, Bus& device_port) noexcept {
  if (has_standard_id(frame, kSyncCobId)) {
    if (!is_sync(frame)) {
      ++counters_.frames_malformed;
      return;
    }
    ++counters_.syncs;
    if (!responding_) {
      ++counters_.syncs_ignored;
      return;
    }
    for (int i = 0; i < n_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (silent_[k]) continue;
      write(device_port,
            encode_position_pdo(config_.axes[k].encoder_cob_id, counts_[k], frame.timestamp_ns),
            &counters_.tpdos_sent);
    }
    return;
  }
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const AxisConfig& a = config_.axes[k];
    if (!a.has_drive() || !has_standard_id(frame, a.drive_cob_id)) continue;
    std::int16_t pm = 0;
    if (decode_torque_pdo(frame, a.drive_cob_id, pm) == DecodeStatus::kOk) {
      ++counters_.rpdos;
      last_per_mille_[k] = pm;
      last_torques_[i] = per_mille_to_torque(a, pm);
    } else {
      ++counters_.frames_malformed;
    }
    return;
  }
  ++counters_.frames_ignored;
}

void DeviceEmulator::update_torque(const Drive& d) noexcept {
  const auto k = static_cast<std::size_t>(d.axis);
  last_per_mille_[k] = d.drive.applied_torque_per_mille();
  last_torques_[d.axis] = per_mille_to_torque(config_.axes[k], last_per_mille_[k]);
}

void DeviceEmulator::on_nmt(const CanFrame& frame) noexcept {
  bool malformed = false;
  for (std::size_t j = 0; j < nodes_.size(); ++j) {
    Node& node = nodes_[j];
    const NmtState before = node.nmt.state();
    const NmtApplyResult r = node.nmt.on_frame(frame);
    if (r == NmtApplyResult::kMalformed) malformed = true;
    if (r != NmtApplyResult::kApplied) continue;
    ++counters_.nmt_commands;
    const NmtState after = node.nmt.state();
    for (Drive& d : drives_) {
      if (d.node != j) continue;
      if (after == NmtState::kBootUp && node.nmt.last_reset() == NmtReset::kNode) {
        // Reset node: the application (the drive) restarts at power-on values.
        d.drive = Cia402Drive(d.drive.settings());
        d.controlword = 0;
        d.target = 0;
        d.previous = PowerState::kNotReadyToSwitchOn;
        update_torque(d);
      } else if (before == NmtState::kOperational && after != NmtState::kOperational &&
                 energised(d.drive.state())) {
        // Abort connection option 0x6007 = 1: the drive stops receiving its RPDOs while
        // energised → fault (never keeps applying the last target torque).
        d.drive.inject_fault(kEmcyCommunication);
        update_torque(d);
        queue_emcy(j, kEmcyCommunication, register_for(kEmcyCommunication));
      }
    }
    if (after == NmtState::kBootUp && node.sdo) {
      // CiA 301: reset communication restores the communication objects (0x1000–0x1FFF) to
      // their power-on values, reset node every object; what a DCF configured is gone.
      const bool all = node.nmt.last_reset() == NmtReset::kNode;
      node.sdo->dictionary.restore_defaults(0x1000, all ? 0xFFFF : 0x1FFF);
      apply_dictionary(j);
    }
    if (after == NmtState::kBootUp) node.losses_seen = node.controller.counters().losses;
  }
  if (malformed) ++counters_.frames_malformed;
}

void DeviceEmulator::on_sync_managed(const CanFrame& frame, Bus& port) noexcept {
  ++counters_.syncs;
  // Synchronous RPDOs take effect at SYNC: every drive steps with the controlword and target
  // torque received since the previous SYNC (held if none came, as a real drive's objects).
  for (Drive& d : drives_) {
    d.drive.step(d.controlword, d.target);
    update_torque(d);
  }
  update_process_values();
  if (!responding_) ++counters_.syncs_ignored;
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const Node& node = nodes_[node_of_axis_[k]];
    const PdoSlot& slot = encoder_pdos_[k];
    if (!node.nmt.allows(CommObject::kPdo) || !responding_ || silent_[k] || !slot.enabled) continue;
    const PdoMapping& m = slot.mapping;
    const Drive* d = drive_of(i);
    PdoValues v{};
    for (std::size_t e = 0; e < m.size(); ++e) {
      const PdoEntry& entry = m.entries()[e];
      if (same_object(entry, PdoObject::kPositionValue) ||
          same_object(entry, PdoObject::kPositionActualValue)) {
        v[e] = entry.is_signed ? static_cast<std::int64_t>(counts_[k])
                               : static_cast<std::int64_t>(static_cast<std::uint32_t>(counts_[k]));
      } else if (same_object(entry, PdoObject::kStatusword)) {
        v[e] = d != nullptr ? d->drive.statusword() : 0;
      } else if (same_object(entry, PdoObject::kTorqueActualValue)) {
        v[e] = d != nullptr ? d->drive.applied_torque_per_mille() : 0;
      } else if (same_object(entry, PdoObject::kModesOfOperationDisplay)) {
        v[e] = d != nullptr ? d->drive.modes_of_operation_display() : 0;
      }
    }
    CanFrame tx;
    tx.id = slot.cob_id;
    tx.timestamp_ns = frame.timestamp_ns;
    if (m.pack(std::span<const std::int64_t>(v.data(), m.size()), tx) == PdoStatus::kOk) {
      write(port, tx, &counters_.tpdos_sent);
    }
  }
  for (const Drive& d : drives_) {
    if (!nodes_[d.node].nmt.allows(CommObject::kPdo) || !d.tpdo.enabled) continue;
    const auto k = static_cast<std::size_t>(d.axis);
    const PdoMapping& m = d.tpdo.mapping;
    PdoValues v{};
    for (std::size_t e = 0; e < m.size(); ++e) {
      const PdoEntry& entry = m.entries()[e];
      if (same_object(entry, PdoObject::kStatusword)) v[e] = d.drive.statusword();
      if (same_object(entry, PdoObject::kTorqueActualValue)) {
        v[e] = d.drive.applied_torque_per_mille();
      }
      if (same_object(entry, PdoObject::kModesOfOperationDisplay)) {
        v[e] = d.drive.modes_of_operation_display();
      }
      if (same_object(entry, PdoObject::kPositionActualValue)) v[e] = counts_[k];  // INTEGER32
    }
    CanFrame tx;
    tx.id = d.tpdo.cob_id;
    tx.timestamp_ns = frame.timestamp_ns;
    if (m.pack(std::span<const std::int64_t>(v.data(), m.size()), tx) == PdoStatus::kOk) {
      write(port, tx, &counters_.drive_tpdos_sent);
    }
  }
}

void DeviceEmulator::on_frame(const CanFrame& frame, Bus& device_port) noexcept {
  if (killed_) {
    ++counters_.frames_while_killed;
    return;
  }
  if (is_sync(frame)) {  // where the device is at the SYNC, under the torques it holds
    commands_.torque = last_torques_;
    if (const DeviceMotionState* s = move(frame.timestamp_ns, commands_))
      set_axis_values(s->q.data());
  }
  if (!managed_) {
    on_frame_minimal(frame, device_port);
    return;
  }
  if (has_standard_id(frame, kNmtCobId)) {
    on_nmt(frame);
    return;
  }
  if (has_standard_id(frame, kSyncCobId)) {
    if (!is_sync(frame)) {
      ++counters_.frames_malformed;
      return;
    }
    on_sync_managed(frame, device_port);
    return;
  }
  if (is_standard_frame(frame) && frame.id > kHeartbeatBaseCobId &&
      frame.id <= kHeartbeatBaseCobId + kMaxNodeId) {
    bool consumed = false;
    for (Node& node : nodes_) {
      if (node.controller.node_id() != 0 && has_standard_id(frame, heartbeat_cob_id(node.controller.node_id()))) {
        consumed = true;
        if (node.nmt.state() != NmtState::kBootUp) node.controller.on_frame(frame);
      }
    }
    if (consumed || has_standard_id(frame, heartbeat_cob_id(config_.canopen.controller_node_id))) return;
  }
  for (Node& node : nodes_) {
    if (!node.sdo || !has_standard_id(frame, sdo_request_cob_id(node.nmt.node_id()))) continue;
    if (!node.nmt.allows(CommObject::kSdo)) {  // stopped, or not booted yet
      ++counters_.sdo_not_allowed;
      return;
    }
    ++counters_.sdo_requests;
    const std::uint64_t downloads = node.sdo->server.counters().downloads;
    node.sdo->server.on_frame(frame);
    if (node.sdo->server.counters().downloads != downloads)
      apply_dictionary(static_cast<std::size_t>(&node - nodes_.data()));
    CanFrame response;
    if (node.sdo->server.take_response(response, frame.timestamp_ns)) write(device_port, response, nullptr);
    return;
  }
  for (Drive& d : drives_) {
    if (!d.rpdo.enabled || !has_standard_id(frame, d.rpdo.cob_id)) continue;
    if (!nodes_[d.node].nmt.allows(CommObject::kPdo)) {
      ++counters_.rpdos_not_operational;
      return;
    }
    const PdoMapping& m = d.rpdo.mapping;
    PdoValues v{};
    if (m.unpack(frame, std::span<std::int64_t>(v.data(), m.size())) != PdoStatus::kOk) {
      ++counters_.frames_malformed;
      return;
    }
    ++counters_.rpdos;
    for (std::size_t e = 0; e < m.size(); ++e) {
      const PdoEntry& entry = m.entries()[e];
      if (same_object(entry, PdoObject::kControlword)) {
        d.controlword = static_cast<std::uint16_t>(v[e]);
      } else if (same_object(entry, PdoObject::kTargetTorque)) {
        d.target = static_cast<std::int16_t>(v[e]);
      } else if (same_object(entry, PdoObject::kModesOfOperation)) {
        d.drive.set_modes_of_operation(static_cast<std::int8_t>(v[e]));
      }
    }
    return;
  }
  ++counters_.frames_ignored;
}

void DeviceEmulator::queue_emcy(std::size_t node, std::uint16_t code,
                                std::uint8_t error_register) noexcept {
  if (emcy_count_ == kEmcyQueue) {
    ++counters_.emcys_dropped;
    return;
  }
  PendingEmcy& p = emcy_[emcy_count_++];
  p.node = node;
  p.message = EmcyMessage{};
  p.message.node_id = nodes_[node].nmt.node_id();
  p.message.error_code = code;
  p.message.error_register = error_register;
}

bool DeviceEmulator::inject_drive_fault(int axis, std::uint16_t code, bool persistent) noexcept {
  Drive* d = drive_of(axis);
  if (d == nullptr) return false;
  d->drive.inject_fault(code, persistent);
  update_torque(*d);
  queue_emcy(d->node, code, register_for(code));
  return true;
}

void DeviceEmulator::clear_drive_fault_condition(int axis) noexcept {
  if (Drive* d = drive_of(axis)) d->drive.clear_fault_condition();
}

void DeviceEmulator::power_cycle() noexcept {
  if (!managed_) return;
  for (Node& node : nodes_) {
    node.nmt = NmtNodeModel(node.nmt.node_id());
    node.producer = HeartbeatProducer(node.nmt.node_id(), node.producer.period_ns());
    if (node.controller.node_id() != 0) {
      node.controller = HeartbeatConsumer(node.controller.node_id(), node.controller.timeout_ns());
    }
    node.losses_seen = 0;
    if (node.sdo) {
      node.sdo->dictionary.restore_defaults(0x0000, 0xFFFF);
      apply_dictionary(static_cast<std::size_t>(&node - nodes_.data()));
    }
  }
  for (Drive& d : drives_) {
    d.drive = Cia402Drive(d.drive.settings());
    d.controlword = 0;
    d.target = 0;
    d.previous = PowerState::kNotReadyToSwitchOn;
    update_torque(d);
  }
  emcy_count_ = 0;
  killed_ = false;
}

void DeviceEmulator::tick(std::int64_t now_ns, Bus& port) noexcept {
  if (!managed_ || killed_) return;
  for (std::size_t j = 0; j < nodes_.size(); ++j) {
    Node& node = nodes_[j];
    CanFrame f;
    if (node.nmt.take_boot_up(now_ns, f)) {
      write(port, f, &counters_.boot_ups_sent);
      node.producer.start(now_ns);
    }
    if (node.producer.poll(now_ns, node.nmt.state(), f)) write(port, f, &counters_.heartbeats_sent);
    if (node.controller.node_id() != 0) {
      node.controller.poll(now_ns);
      const std::uint64_t losses = node.controller.counters().losses;
      if (losses > node.losses_seen) {
        // The node's consumer heartbeat time (1016h) for the controller expired: the drive's
        // own protection — fault, zero torque, EMCY 0x8130 (CiA 301 error behaviour 1029h).
        counters_.controller_losses += losses - node.losses_seen;
        node.losses_seen = losses;
        for (Drive& d : drives_) {
          if (d.node != j) continue;
          const PowerState s = d.drive.state();
          if (s == PowerState::kFault || s == PowerState::kFaultReactionActive) continue;
          d.drive.inject_fault(kEmcyHeartbeatError);
          update_torque(d);
        }
        queue_emcy(j, kEmcyHeartbeatError, register_for(kEmcyHeartbeatError));
      }
    }
  }
  // A drive that left fault (fault reset, transition 15) reports "error reset / no error".
  for (Drive& d : drives_) {
    const PowerState s = d.drive.state();
    if (d.previous == PowerState::kFault && s != PowerState::kFault &&
        s != PowerState::kFaultReactionActive) {
      queue_emcy(d.node, 0x0000, 0x00);
    }
    d.previous = s;
  }
  std::size_t kept = 0;
  for (std::size_t i = 0; i < emcy_count_; ++i) {
    const PendingEmcy& p = emcy_[i];
    const Node& node = nodes_[p.node];
    if (node.nmt.state() == NmtState::kBootUp) {
      emcy_[kept++] = p;  // not yet booted: sent after the boot-up message
      continue;
    }
    if (!node.nmt.allows(CommObject::kEmcy)) {
      ++counters_.emcys_dropped;  // stopped: EMCY not allowed (CiA 301 §7.3.2.2)
      continue;
    }
    CanFrame f;
    if (encode_emcy(p.message, now_ns, f)) write(port, f, &counters_.emcys_sent);
  }
  emcy_count_ = kept;
}

}  // namespace numen::hal
