/// @file nmt_master.cpp
/// The NMT master and controller heartbeat of one CAN network, shared by its devices.

#include "numen/hal/device/nmt_master.hpp"

#include <stdexcept>
#include <string>

namespace numen::hal {
namespace {

// The slot of a CiA 301 command in the period's requests; kCommands for another byte.
std::size_t slot_of(NmtCommand command) noexcept {
  switch (command) {
    case NmtCommand::kStartRemoteNode:
      return 0;
    case NmtCommand::kStopRemoteNode:
      return 1;
    case NmtCommand::kEnterPreOperational:
      return 2;
    case NmtCommand::kResetNode:
      return 3;
    case NmtCommand::kResetCommunication:
      return 4;
  }
  return 5;
}

}  // namespace

std::array<std::int8_t, kMaxNodeId + 1> NmtMaster::make_owners() noexcept {
  std::array<std::int8_t, kMaxNodeId + 1> owners{};
  owners.fill(-1);
  return owners;
}

std::array<NmtMaster::Requests, NmtMaster::kCommands> NmtMaster::make_requests() noexcept {
  std::array<Requests, kCommands> requests{};
  for (Requests& r : requests) r.by_node.fill(-1);
  return requests;
}

int NmtMaster::add_device(const DeviceConfig& config) {
  const std::string dev = "device '" + config.name + "'";
  const CanopenConfig& co = config.canopen;
  if (!co.managed) throw std::invalid_argument(dev + ": the NMT master needs canopen.managed = true");
  if (num_devices_ + num_bystanders_ >= kMaxNmtDevices)
    throw std::invalid_argument(dev + ": more than " + std::to_string(kMaxNmtDevices) +
                                " devices on one bus");
  const std::int64_t heartbeat_ns =
      static_cast<std::int64_t>(co.controller_heartbeat_period_ms) * 1'000'000;
  if (heartbeat_) {
    if (heartbeat_->node_id() != co.controller_node_id || heartbeat_->period_ns() != heartbeat_ns)
      throw std::invalid_argument(
          dev + ": controller_node_id " + std::to_string(co.controller_node_id) +
          " and controller_heartbeat_period " + std::to_string(co.controller_heartbeat_period_ms) +
          " ms differ from device '" + names_[0] + "''s on this bus (" +
          std::to_string(heartbeat_->node_id()) + ", " +
          std::to_string(heartbeat_->period_ns() / 1'000'000) +
          " ms): one controller node per CAN network");
  }
  // Checked whole before anything is kept: a refused device leaves the network as it was.
  DeviceSlot slot;
  for (const CanopenAxisConfig& x : co.axes) {
    bool listed = false;
    for (std::size_t j = 0; j < slot.num_nodes; ++j) listed = listed || slot.nodes[j] == x.node_id;
    if (listed) continue;  // a node with several axes
    if (x.node_id < 1 || x.node_id > kMaxNodeId)
      throw std::invalid_argument(dev + ": node id " + std::to_string(x.node_id) +
                                  " out of range 1-127");
    const std::int8_t owner = owner_[x.node_id];
    if (owner >= 0)
      throw std::invalid_argument(dev + ": node " + std::to_string(x.node_id) +
                                  " is device '" + names_[static_cast<std::size_t>(owner)] +
                                  "''s on this bus too (a node id once per CAN network)");
    if (heartbeat_ && x.node_id == heartbeat_->node_id())
      throw std::invalid_argument(dev + ": node " + std::to_string(x.node_id) +
                                  " is the controller's node id on this bus");
    if (slot.num_nodes >= kMaxDeviceNodes)
      throw std::invalid_argument(dev + ": more than " + std::to_string(kMaxDeviceNodes) +
                                  " nodes");
    slot.nodes[slot.num_nodes++] = x.node_id;
  }
  for (std::size_t j = 0; j < slot.num_nodes; ++j)
    owner_[slot.nodes[j]] = static_cast<std::int8_t>(num_devices_);
  if (!heartbeat_) heartbeat_.emplace(co.controller_node_id, heartbeat_ns);
  devices_[num_devices_] = slot;
  names_[num_devices_] = config.name;
  return static_cast<int>(num_devices_++);
}

void NmtMaster::add_bystander(const DeviceConfig& config) {
  const std::string dev = "device '" + config.name + "'";
  if (config.canopen.managed)
    throw std::invalid_argument(dev + ": a managed device is add_device()'s, not a bystander");
  if (num_devices_ + num_bystanders_ >= kMaxNmtDevices)
    throw std::invalid_argument(dev + ": more than " + std::to_string(kMaxNmtDevices) +
                                " devices on one bus");
  ++num_bystanders_;
}

bool NmtMaster::request(int device, NmtCommand command, std::uint8_t node_id) noexcept {
  const std::size_t c = slot_of(command);
  if (device < 0 || static_cast<std::size_t>(device) >= num_devices_ || c >= kCommands ||
      node_id > kMaxNodeId)
    return false;
  Requests& r = requests_[c];
  if (!r.any) {
    order_[num_ordered_++] = command;
    r.any = true;
  }
  if (node_id == kNmtAllNodes) {
    r.whole[static_cast<std::size_t>(device)] = true;
  } else if (r.by_node[node_id] < 0) {
    r.by_node[node_id] = static_cast<std::int8_t>(device);
  }
  return true;
}

IoStatus NmtMaster::submit(int device, std::int64_t now_ns, Bus& bus) noexcept {
  if (device < 0 || static_cast<std::size_t>(device) >= num_devices_) return IoStatus::kError;
  devices_[static_cast<std::size_t>(device)].submitted = true;
  for (std::size_t d = 0; d < num_devices_; ++d)
    if (!devices_[d].submitted) return IoStatus::kOk;
  return flush(now_ns, bus);
}

IoStatus NmtMaster::take_status(int device) noexcept {
  if (device < 0 || static_cast<std::size_t>(device) >= num_devices_) return IoStatus::kOk;
  DeviceSlot& d = devices_[static_cast<std::size_t>(device)];
  const IoStatus s = d.status;
  d.status = IoStatus::kOk;
  return s;
}

IoStatus NmtMaster::send(const CanFrame& frame, Bus& bus, int device, bool heartbeat) noexcept {
  const IoStatus s = bus.write(frame);
  // A broadcast or the heartbeat (device < 0) is every device's frame.
  for (std::size_t d = 0; d < num_devices_; ++d) {
    if (device >= 0 && static_cast<std::size_t>(device) != d) continue;
    DeviceSlot& slot = devices_[d];
    slot.status = worst(slot.status, s);
    if (s == IoStatus::kOk) ++(heartbeat ? slot.counters.heartbeats_sent : slot.counters.nmt_sent);
    if (s == IoStatus::kWouldBlock) ++slot.counters.write_would_block;
    if (s == IoStatus::kError) ++slot.counters.write_errors;
  }
  return s;
}

IoStatus NmtMaster::send_command(NmtCommand command, std::uint8_t node, std::int64_t now_ns,
                                 Bus& bus, int device) noexcept {
  CanFrame f;
  if (!encode_nmt(command, node, now_ns, f)) return IoStatus::kError;  // not reached: checked
  const IoStatus s = send(f, bus, device, false);
  if (s == IoStatus::kOk && node == kNmtAllNodes) ++broadcasts_;
  return s;
}

IoStatus NmtMaster::flush(std::int64_t now_ns, Bus& bus) noexcept {
  IoStatus status = IoStatus::kOk;
  for (std::size_t k = 0; k < num_ordered_; ++k) {
    const NmtCommand command = order_[k];
    const Requests& r = requests_[slot_of(command)];
    // The whole network asked for it, and every node on it is a managed device's: one
    // message to all nodes (with a bystander on the bus, node id 0 would reach its nodes too).
    bool every_device = num_bystanders_ == 0;
    for (std::size_t d = 0; d < num_devices_; ++d) every_device = every_device && r.whole[d];
    if (every_device) {
      status = worst(status, send_command(command, kNmtAllNodes, now_ns, bus, -1));
      continue;
    }
    for (std::size_t node = 1; node <= kMaxNodeId; ++node) {
      const std::int8_t owner = owner_[node];
      int device = r.by_node[node];
      if (owner >= 0 && r.whole[static_cast<std::size_t>(owner)]) device = owner;
      if (device < 0) continue;
      status = worst(status,
                     send_command(command, static_cast<std::uint8_t>(node), now_ns, bus, device));
    }
  }
  clear_requests();
  if (!heartbeat_started_) {
    heartbeat_->start(now_ns);
    heartbeat_started_ = true;
  }
  CanFrame hb;
  if (heartbeat_->poll(now_ns, NmtState::kOperational, hb))
    status = worst(status, send(hb, bus, -1, true));
  return status;
}

void NmtMaster::clear_requests() noexcept {
  for (std::size_t k = 0; k < num_ordered_; ++k) {
    Requests& r = requests_[slot_of(order_[k])];
    r.by_node.fill(-1);
    r.whole.fill(false);
    r.any = false;
  }
  num_ordered_ = 0;
  for (std::size_t d = 0; d < num_devices_; ++d) devices_[d].submitted = false;
}

}  // namespace numen::hal
