/// @file canopen_master.cpp
/// The controller's side of the managed CANopen stack: NMT start-up, heartbeats, EMCY, CiA 402
/// drive masters and their static PDOs.

#include "numen/hal/device/canopen_master.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/sdo.hpp"

namespace numen::hal {
namespace {


std::int64_t ms_to_ns(std::uint32_t ms) noexcept {
  return static_cast<std::int64_t>(ms) * 1'000'000;
}

}  // namespace

const char* to_string(StartupPhase phase) noexcept {
  switch (phase) {
    case StartupPhase::kResetCommunication:
      return "reset communication";
    case StartupPhase::kWaitBootUp:
      return "wait boot-up";
    case StartupPhase::kStartNodes:
      return "start nodes";
    case StartupPhase::kWaitOperational:
      return "wait operational";
    case StartupPhase::kOperational:
      return "operational";
    case StartupPhase::kFailed:
      return "failed";
    case StartupPhase::kConfigure:
      return "configure";
  }
  return "unknown";
}

CanopenMaster::CanopenMaster(const DeviceConfig& config, std::int64_t period_ns,
                             const Cia402MasterSettings& drive_settings, NmtMaster* network) {
  validate(config);
  const std::string dev = "device '" + config.name + "'";
  if (!config.canopen.managed) {
    throw std::invalid_argument(dev + ": CanopenMaster needs canopen.managed = true");
  }
  if (period_ns <= 0) {
    throw std::invalid_argument(dev + ": CanopenMaster period_ns must be > 0 (got " +
                                std::to_string(period_ns) + ")");
  }
  if (network == nullptr) {
    own_nmt_ = std::make_unique<NmtMaster>();
    network = own_nmt_.get();
  }
  nmt_device_ = network->add_device(config);
  nmt_ = network;
  const CanopenConfig& co = config.canopen;
  retry_ns_ = ms_to_ns(co.startup_retry_ms);
  timeout_ns_ = ms_to_ns(co.startup_timeout_ms);
  for (std::size_t i = 0; i < config.axes.size(); ++i) {
    const CanopenAxisConfig& x = co.axes[i];
    const AxisConfig& a = config.axes[i];
    if (node_index(x.node_id) < 0) {
      node_ids_[num_nodes_] = x.node_id;
      if (x.dcf) {
        nodes_[num_nodes_].configurator = static_cast<int>(plans_.size());
        plans_.push_back(std::make_unique<DcfConfiguration>(x.dcf));
      }
      ++num_nodes_;
      monitor_.add(x.node_id, ms_to_ns(x.effective_heartbeat_timeout_ms()));
    }
    if (!a.has_drive()) continue;
    Drive d{static_cast<int>(i),
            a.drive_cob_id,
            x.drive_tpdo_cob_id,
            PdoMapping(std::span<const PdoEntry>(x.drive_rpdo.data(), x.drive_rpdo.size()),
                       dev + " axis '" + a.name + "' drive RPDO"),
            PdoMapping(std::span<const PdoEntry>(x.drive_tpdo.data(), x.drive_tpdo.size()),
                       dev + " axis '" + a.name + "' drive TPDO"),
            -1,
            -1,
            -1,
            -1,
            -1,
            Cia402Master(drive_settings),
            0,
            0};
    d.cw_index = find_mapped(d.rpdo.entries(), PdoObject::kControlword);
    d.torque_index = find_mapped(d.rpdo.entries(), PdoObject::kTargetTorque);
    d.mode_index = find_mapped(d.rpdo.entries(), PdoObject::kModesOfOperation);
    d.sw_index = find_mapped(d.tpdo.entries(), PdoObject::kStatusword);
    d.actual_index = find_mapped(d.tpdo.entries(), PdoObject::kTorqueActualValue);
    drives_.push_back(std::move(d));
  }
  configurators_.reserve(plans_.size());
  for (std::size_t j = 0; j < num_nodes_; ++j) {
    if (nodes_[j].configurator >= 0) {
      configurators_.emplace_back(*plans_[static_cast<std::size_t>(nodes_[j].configurator)],
                                  node_ids_[j], ms_to_ns(co.sdo_timeout_ms));
    }
  }
  if (co.sdo_poll_period_ms > 0) {
    // Every node's error register, every drive's statusword, at the period nearest the rate.
    const auto every = static_cast<std::uint32_t>(std::max<std::int64_t>(
        1, (ms_to_ns(co.sdo_poll_period_ms) + period_ns / 2) / period_ns));
    std::vector<PeriodicRead> reads;
    for (std::size_t j = 0; j < num_nodes_; ++j) reads.push_back({node_ids_[j], {0x1001, 0}, every});
    for (const Drive& d : drives_) reads.push_back({co.axes[static_cast<std::size_t>(d.axis)].node_id, {0x6041, 0}, every});
    poller_ = std::make_unique<SdoPoller>(reads, ms_to_ns(co.sdo_timeout_ms));
  }
  restart_startup();
  startup_.attempts = 0;
}

int CanopenMaster::node_index(std::uint8_t node_id) const noexcept {
  for (std::size_t j = 0; j < num_nodes_; ++j) {
    if (node_ids_[j] == node_id) return static_cast<int>(j);
  }
  return -1;
}

void CanopenMaster::restart_startup() noexcept {
  startup_.phase = StartupPhase::kResetCommunication;
  startup_.missing_node = 0;
  startup_.configuration_failed = false;
  startup_.configure_ns = 0;
  for (std::size_t j = 0; j < num_nodes_; ++j) {
    const int c = nodes_[j].configurator;
    nodes_[j] = NodeState{};
    nodes_[j].configurator = c;
  }
}

const NodeConfigurator* CanopenMaster::configurator(std::uint8_t node_id) const noexcept {
  const int j = node_index(node_id);
  if (j < 0 || nodes_[static_cast<std::size_t>(j)].configurator < 0) return nullptr;
  return &configurators_[static_cast<std::size_t>(nodes_[static_cast<std::size_t>(j)].configurator)];
}

std::string CanopenMaster::configuration_error() const {
  for (const NodeConfigurator& c : configurators_) {
    if (c.status() == ConfigurationStatus::kFailed) return c.error();
  }
  return {};
}

void CanopenMaster::enter_configure(std::int64_t now_ns) noexcept {
  startup_.phase = StartupPhase::kConfigure;
  configure_began_ns_ = now_ns;
  for (NodeConfigurator& c : configurators_) c.start(now_ns);
  for (std::size_t j = 0; j < num_nodes_; ++j) nodes_[j].reconfigure = false;
}

void CanopenMaster::update_configure(std::int64_t now_ns) noexcept {
  bool all_done = true;
  for (std::size_t j = 0; j < num_nodes_; ++j) {
    NodeState& n = nodes_[j];
    if (n.configurator < 0) continue;
    NodeConfigurator& c = configurators_[static_cast<std::size_t>(n.configurator)];
    if (n.reconfigure) {  // it booted again: its communication objects are back to defaults
      n.reconfigure = false;
      c.start(now_ns);
    }
    const bool was_done = c.status() == ConfigurationStatus::kDone;
    c.poll(now_ns);
    if (c.status() == ConfigurationStatus::kFailed) {
      startup_.configuration_failed = true;
      startup_.configure_ns += now_ns - configure_began_ns_;
      finish(StartupPhase::kFailed, node_ids_[j], now_ns);
      return;
    }
    if (c.status() == ConfigurationStatus::kDone && !was_done) ++counters_.configurations;
    all_done = all_done && c.status() == ConfigurationStatus::kDone;
  }
  if (all_done) {
    startup_.configure_ns += now_ns - configure_began_ns_;
    startup_.phase = StartupPhase::kStartNodes;
  }
}

IoStatus CanopenMaster::send(const CanFrame& frame, Bus& bus, std::uint64_t* sent) noexcept {
  const IoStatus s = bus.write(frame);
  if (s == IoStatus::kOk) ++*sent;
  if (s == IoStatus::kWouldBlock) ++counters_.write_would_block;
  if (s == IoStatus::kError) ++counters_.write_errors;
  return s;
}

void CanopenMaster::ask_nmt(NmtCommand command, std::uint8_t node) noexcept {
  (void)nmt_->request(nmt_device_, command, node);  // valid: its own nodes, or request_nmt()'s
}

CanopenMasterCounters CanopenMaster::counters() const noexcept {
  CanopenMasterCounters c = counters_;
  const NmtDeviceCounters& n = nmt_->counters(nmt_device_);
  c.nmt_sent = n.nmt_sent;
  c.heartbeats_sent = n.heartbeats_sent;
  c.write_would_block += n.write_would_block;
  c.write_errors += n.write_errors;
  return c;
}

IoStatus CanopenMaster::begin_period(std::int64_t now_ns, Bus& bus) noexcept {
  IoStatus status = IoStatus::kOk;
  last_now_ns_ = now_ns;
  switch (startup_.phase) {
    case StartupPhase::kResetCommunication:
      ask_nmt(NmtCommand::kResetCommunication, kNmtAllNodes);
      startup_.phase = StartupPhase::kWaitBootUp;
      startup_.began_ns = now_ns;
      startup_.began_period = periods_;
      ++startup_.attempts;
      for (std::size_t j = 0; j < num_nodes_; ++j) nodes_[j].last_command_ns = now_ns;
      break;
    case StartupPhase::kWaitBootUp:
      // A node that has not booted after startup_retry_ms is reset again (a lost frame).
      for (std::size_t j = 0; j < num_nodes_; ++j) {
        NodeState& n = nodes_[j];
        if (n.booted || now_ns - n.last_command_ns < retry_ns_) continue;
        ask_nmt(NmtCommand::kResetCommunication, node_ids_[j]);
        n.last_command_ns = now_ns;
        ++counters_.nmt_retries;
      }
      break;
    case StartupPhase::kStartNodes:
      ask_nmt(NmtCommand::kStartRemoteNode, kNmtAllNodes);
      startup_.phase = StartupPhase::kWaitOperational;
      for (std::size_t j = 0; j < num_nodes_; ++j) nodes_[j].last_command_ns = now_ns;
      break;
    case StartupPhase::kWaitOperational:
      for (std::size_t j = 0; j < num_nodes_; ++j) {
        NodeState& n = nodes_[j];
        const HeartbeatConsumer* c = monitor_.find(node_ids_[j]);
        const bool op = c != nullptr && c->status() == HeartbeatStatus::kAlive &&
                        c->last_state() == NmtState::kOperational;
        if (op && !n.restart) continue;
        if (!n.restart && now_ns - n.last_command_ns < retry_ns_) continue;
        ask_nmt(NmtCommand::kStartRemoteNode, node_ids_[j]);
        n.last_command_ns = now_ns;
        n.restart = false;
        ++counters_.nmt_retries;
      }
      break;
    case StartupPhase::kConfigure:
      for (NodeConfigurator& c : configurators_) {
        CanFrame f;
        while (c.take_request(f, now_ns)) status = worst(status, send(f, bus, &counters_.sdo_requests));
      }
      break;
    case StartupPhase::kOperational:
      if (poller_) poller_->begin_period(now_ns, bus);
      break;
    case StartupPhase::kFailed:
      break;
  }
  if (nmt_queued_) {
    nmt_queued_ = false;
    ask_nmt(queued_.command, queued_.node_id);
  }
  // The network's NMT master sends the period's commands and the controller heartbeat once
  // every device on the bus has submitted (at once for a private one).
  (void)nmt_->submit(nmt_device_, now_ns, bus);
  return worst(status, take_nmt_status());  // its part of what was sent
}

bool CanopenMaster::on_frame(const CanFrame& frame) noexcept {
  for (Drive& d : drives_) {
    if (!has_standard_id(frame, d.tpdo_cob_id)) continue;
    PdoValues v{};
    if (d.tpdo.unpack(frame, std::span<std::int64_t>(v.data(), d.tpdo.size())) != PdoStatus::kOk) {
      ++counters_.drive_tpdos_malformed;
      return true;
    }
    ++counters_.drive_tpdos;
    d.statusword = static_cast<std::uint16_t>(v[static_cast<std::size_t>(d.sw_index)]);
    if (d.actual_index >= 0) {
      d.torque_actual = static_cast<std::int16_t>(v[static_cast<std::size_t>(d.actual_index)]);
    }
    return true;
  }
  // Error reports and 29-bit frames are no CANopen traffic of ours (can_frame.hpp).
  if (!is_standard_frame(frame)) return false;
  if (frame.id > kSdoResponseBaseCobId && frame.id <= kSdoResponseBaseCobId + kMaxNodeId) {
    for (NodeConfigurator& c : configurators_) {
      if (c.on_frame(frame)) {
        ++counters_.sdo_responses;
        return true;
      }
    }
    return poller_ != nullptr && poller_->on_frame(frame);
  }
  if (frame.id > kHeartbeatBaseCobId && frame.id <= kHeartbeatBaseCobId + kMaxNodeId) {
    const int j = node_index(static_cast<std::uint8_t>(frame.id - kHeartbeatBaseCobId));
    if (j < 0) {
      ++counters_.unknown_nodes;
      return true;
    }
    NodeState& n = nodes_[static_cast<std::size_t>(j)];
    std::uint8_t node = 0;
    NmtState state = NmtState::kBootUp;
    const bool boot_up = decode_heartbeat(frame, node, state) == HeartbeatDecodeStatus::kOk &&
                         state == NmtState::kBootUp;
    const bool waiting = startup_.phase == StartupPhase::kResetCommunication ||
                         startup_.phase == StartupPhase::kWaitBootUp;
    if (!n.booted) {
      // Only the boot-up message that follows our reset starts the node's monitoring.
      if (!(waiting && boot_up && frame.timestamp_ns >= startup_.began_ns)) {
        ++counters_.frames_before_boot;
        return true;
      }
      n.booted = true;
    } else if (boot_up && waiting) {
      // A second boot-up while the nodes boot: the answer to a repeated reset (the first
      // answer was late, e.g. a slow device process). Expected, not a reset fault.
      monitor_.expect_boot_up(node);
    } else if (boot_up && n.configurator >= 0 &&
               (startup_.phase == StartupPhase::kConfigure ||
                startup_.phase == StartupPhase::kStartNodes ||
                startup_.phase == StartupPhase::kWaitOperational)) {
      // A configured node reset again: its communication objects are back to their defaults
      // (CiA 301 reset communication), so it is configured again before it is started.
      n.reconfigure = true;
      if (startup_.phase != StartupPhase::kConfigure) {
        startup_.phase = StartupPhase::kConfigure;
        configure_began_ns_ = frame.timestamp_ns;
      }
      monitor_.expect_boot_up(node);
    } else if (boot_up && (startup_.phase == StartupPhase::kConfigure ||
                          startup_.phase == StartupPhase::kStartNodes ||
                          startup_.phase == StartupPhase::kWaitOperational)) {
      // It reset again while being started: start it again. The start-up handles it, so
      // the consumer does not report it as a fault.
      n.restart = true;
      monitor_.expect_boot_up(node);
    }
    monitor_.on_frame(frame);
    return true;
  }
  if (frame.id > kEmcyBaseCobId && frame.id <= kEmcyBaseCobId + kMaxNodeId) {
    emcy_.on_frame(frame);
    return true;
  }
  return false;
}

void CanopenMaster::finish(StartupPhase phase, std::uint8_t missing, std::int64_t now_ns) noexcept {
  startup_.phase = phase;
  startup_.missing_node = missing;
  startup_.done_period = periods_;
  startup_.done_ns = now_ns;
}

bool CanopenMaster::all_nodes_operational() const noexcept {
  for (const HeartbeatConsumer& c : monitor_.consumers()) {
    if (c.status() != HeartbeatStatus::kAlive || c.last_state() != NmtState::kOperational) {
      return false;
    }
  }
  return num_nodes_ > 0;
}

void CanopenMaster::update(std::int64_t now_ns) noexcept {
  monitor_.poll(now_ns);
  const bool timed_out = now_ns - startup_.began_ns - startup_.configure_ns >= timeout_ns_;
  if (startup_.phase == StartupPhase::kConfigure) {
    update_configure(now_ns);
  } else if (startup_.phase == StartupPhase::kWaitBootUp) {
    std::uint8_t missing = 0;
    for (std::size_t j = 0; j < num_nodes_ && missing == 0; ++j) {
      if (!nodes_[j].booted) missing = node_ids_[j];
    }
    if (missing == 0 && !configurators_.empty()) {
      enter_configure(now_ns);
    } else if (missing == 0) {
      startup_.phase = StartupPhase::kStartNodes;
    } else if (timed_out) {
      finish(StartupPhase::kFailed, missing, now_ns);
    }
  } else if (startup_.phase == StartupPhase::kWaitOperational) {
    std::uint8_t missing = 0;
    for (std::size_t j = 0; j < num_nodes_ && missing == 0; ++j) {
      const HeartbeatConsumer* c = monitor_.find(node_ids_[j]);
      if (c == nullptr || c->status() != HeartbeatStatus::kAlive ||
          c->last_state() != NmtState::kOperational || nodes_[j].restart) {
        missing = node_ids_[j];
      }
    }
    if (missing == 0) {
      finish(StartupPhase::kOperational, 0, now_ns);
    } else if (timed_out) {
      finish(StartupPhase::kFailed, missing, now_ns);
    }
  }
  if (poller_ && startup_.phase == StartupPhase::kOperational) poller_->update(now_ns);
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    outputs_[i] = drives_[i].master.update(drives_[i].statusword);
  }
  ++periods_;
}

void CanopenMaster::request_drives(Cia402Target target) noexcept {
  for (Drive& d : drives_) d.master.request(target);
}

void CanopenMaster::request_fault_reset() noexcept {
  for (Drive& d : drives_) d.master.request_fault_reset();
}

IoStatus CanopenMaster::write_drive_rpdos(std::int64_t now_ns,
                                          std::span<const std::int16_t> per_mille,
                                          Bus& bus) noexcept {
  IoStatus status = IoStatus::kOk;
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    const Drive& d = drives_[i];
    const Cia402MasterOutput& out = outputs_[i];
    const auto axis = static_cast<std::size_t>(d.axis);
    const std::int16_t torque = axis < per_mille.size() ? per_mille[axis] : 0;
    PdoValues v{};
    v[static_cast<std::size_t>(d.cw_index)] = out.controlword;
    v[static_cast<std::size_t>(d.torque_index)] = torque;
    if (d.mode_index >= 0) v[static_cast<std::size_t>(d.mode_index)] = kModeCyclicSynchronousTorque;
    CanFrame f;
    f.id = d.rpdo_cob_id;
    f.timestamp_ns = now_ns;
    if (d.rpdo.pack(std::span<const std::int64_t>(v.data(), d.rpdo.size()), f) != PdoStatus::kOk) {
      status = IoStatus::kError;  // not reached: every value fits its mapped object
      continue;
    }
    status = worst(status, send(f, bus, &counters_.rpdos_sent));
  }
  return status;
}

bool CanopenMaster::request_nmt(NmtCommand command, std::uint8_t node_id) noexcept {
  if (nmt_queued_ || !is_nmt_command(static_cast<std::uint8_t>(command)) || node_id > kMaxNodeId) {
    return false;
  }
  queued_ = NmtMessage{command, node_id};
  nmt_queued_ = true;
  return true;
}

}  // namespace numen::hal
