/// @file managed_device.cpp
/// The managed CANopen stack behind hal::ImpedanceDevice: CanopenMaster + SafetySupervisor.

#include "numen/hal/device/managed_device.hpp"

#include <cstdio>
#include <span>

#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/heartbeat.hpp"

namespace numen::hal {
namespace {

SafetySettings safety_settings(const InstrumentDevice& instrument, const ImpedanceSettings& s) {
  SafetySettings out;
  static_cast<SupervisionSettings&>(out) = s;  // the device's supervision settings, as they are
  out.num_axes = static_cast<std::size_t>(instrument.num_axes());
  return out;
}

}  // namespace

ManagedDevice::ManagedDevice(InstrumentDevice& instrument, Bus& bus, std::int64_t period_ns,
                             const ImpedanceSettings& settings, NmtMaster* network)
    : ImpedanceDevice(instrument, bus),
      master_(std::make_unique<CanopenMaster>(instrument.config(), period_ns,
                                              settings.drive_settings, network)),
      supervisor_(std::make_unique<SafetySupervisor>(safety_settings(instrument, settings))),
      settings_(settings) {
  drive_of_axis_.fill(-1);
  for (std::size_t i = 0; i < master_->num_drives(); ++i) {
    drive_of_axis_[static_cast<std::size_t>(master_->drive_axis(i))] = static_cast<int>(i);
  }
  supervisor_->configure();  // kUnconfigured → kInactive: read and supervised, zero torque
}

DeviceSupervision ManagedDevice::supervise(std::int64_t now_ns, bool overrun) noexcept {
  CanopenMaster& m = *master_;
  SafetySupervisor& sup = *supervisor_;
  const DeviceSample& sample = instrument_->last_sample();
  m.update(now_ns);
  SafetyInputs in;
  const auto n = static_cast<std::size_t>(instrument_->num_axes());
  in.periods_since_accepted = std::span<const std::uint32_t>(sample.periods_since_accepted.data(), n);
  in.axis_faults = std::span<const FaultMask>(sample.axis_faults.data(), n);
  in.heartbeats = m.heartbeats();
  in.emcy_faults = m.emcy_log().counters().faults;
  in.emcy_last_fault = newest_emcy_fault(m.emcy_log());
  in.drives = m.drive_outputs();
  in.overrun = overrun;
  in.bus_state = bus_->state();
  note(m.take_nmt_status());  // on a shared bus its NMT frames went out after its begin_period
  in.io_error = take_io_error();
  DeviceSupervision out;
  const LifecycleUpdate u = sup.update(now_ns, in);
  out.entered_safe_stop = u.entered_safe_stop;
  if (fault_reset_after_startup_ && m.operational()) {
    m.request_fault_reset();  // the re-arm's start-up is done: the drives now take it
    fault_reset_after_startup_ = false;
  }
  if (rearm_pending_ && sup.state() == LifecycleState::kFault && m.operational() &&
      sup.rearm() == LifecycleResult::kOk) {
    rearm_pending_ = false;
  }
  if (!shutting_down() && !activation_held() && settings_.auto_activate &&
      sup.state() == LifecycleState::kInactive &&
      m.operational() && sup.blocking().cause == FaultCause::kNone) {
    out.activated = sup.activate() == LifecycleResult::kOk;
  }
  if (out.activated) restart_soft_start();  // torque enabled: ramp it in (start-up, re-arm)
  m.request_drives(sup.drive_target());
  out.lifecycle = sup.state();
  out.startup = m.startup().phase;
  return out;
}

LifecycleResult ManagedDevice::activate() noexcept {
  const LifecycleResult r = supervisor_->activate();
  if (r == LifecycleResult::kOk) restart_soft_start();
  return r;
}

bool ManagedDevice::torque_allowed(int axis) const noexcept {
  const int d = drive_of_axis_[static_cast<std::size_t>(axis)];
  return supervisor_->torque_allowed() && d >= 0 &&
         master_->drive_outputs()[static_cast<std::size_t>(d)].torque_allowed;
}

void ManagedDevice::on_non_finite_torque(int axis) noexcept {
  supervisor_->trip_non_finite_torque(static_cast<std::size_t>(axis));
}

void ManagedDevice::on_shutdown() noexcept {
  rearm_pending_ = false;
  fault_reset_after_startup_ = false;
  if (supervisor_->state() == LifecycleState::kActive) (void)supervisor_->deactivate();
}

IoStatus ManagedDevice::send(const SentTorques& torques, std::int64_t now_ns) noexcept {
  const auto n = static_cast<std::size_t>(instrument_->num_axes());
  return master_->write_drive_rpdos(
      now_ns, std::span<const std::int16_t>(torques.per_mille.data(), n), *bus_);
}

RearmResult ManagedDevice::rearm() noexcept {
  const bool failed = master_->startup().phase == StartupPhase::kFailed;
  const bool latched = supervisor_->lifecycle().latched();
  if (!latched && !failed) return RearmResult::kNotLatched;
  master_->request_fault_reset();
  if (failed || !master_->all_nodes_operational()) {
    master_->restart_startup();
    fault_reset_after_startup_ = true;  // again once it is operational (supervise())
  }
  rearm_pending_ = latched;
  return RearmResult::kAccepted;
}

bool ManagedDevice::drives_disabled() const noexcept {
  for (const Cia402MasterOutput& d : master_->drive_outputs()) {
    switch (d.state) {
      case PowerState::kSwitchOnDisabled:
      case PowerState::kReadyToSwitchOn:
      case PowerState::kNotReadyToSwitchOn:
      case PowerState::kFault:
        break;
      default:
        return false;
    }
  }
  return true;
}


DeviceReport ManagedDevice::report() const noexcept {
  const CanopenMaster& m = *master_;
  const SafetySupervisor& sup = *supervisor_;
  DeviceReport r;
  r.managed = true;
  r.startup = m.startup();  // its StartupStatus part
  r.lifecycle = sup.state();
  r.latches = sup.counters().latches;
  r.fault_records = sup.counters().records;
  r.emcys = m.emcy_log().counters().received;
  r.emcy_faults = m.emcy_log().counters().faults;
  if (const EmcyRecord* e = m.emcy_log().newest()) {
    r.has_emcy = true;
    r.newest_emcy_node = e->message.node_id;
    r.newest_emcy_code = e->message.error_code;
  }
  r.configured_nodes = m.counters().configurations;
  if (const SdoPoller* p = m.sdo_poller()) {
    r.sdo_polled = true;
    r.sdo_reads = p->counters().completed;
    r.sdo_read_errors = p->counters().aborted + p->counters().timeouts;
  }
  for (const HeartbeatConsumer& c : m.heartbeats()) r.heartbeat_losses += c.counters().losses;
  r.malformed_drive_frames = m.counters().drive_tpdos_malformed;
  return r;
}

DeviceNotes ManagedDevice::notes() const {
  const CanopenMaster& m = *master_;
  const DeviceConfig& config = instrument_->config();
  DeviceNotes n;
  if (m.startup().configuration_failed) n.configuration_error = m.configuration_error();
  for (std::size_t i = 0; i < m.emcy_log().size(); ++i) {
    const EmcyRecord& r = *m.emcy_log().at(i);
    // A drive node's codes by the CiA 402 table (its device profile), others by CiA 301's.
    std::uint16_t profile = 301;
    for (std::size_t d = 0; d < m.num_drives(); ++d) {
      const auto axis = static_cast<std::size_t>(m.drive_axis(d));
      if (config.canopen.axes[axis].node_id == r.message.node_id) profile = 402;
    }
    char line[200];
    std::snprintf(line, sizeof line, "node %d at %.3f s: 0x%04X %s (register 0x%02X)",
                  r.message.node_id, static_cast<double>(r.timestamp_ns) * 1e-9,
                  r.message.error_code, describe_emcy_code(r.message.error_code, profile),
                  r.message.error_register);
    n.emcy_messages.push_back(line);
  }
  for (std::size_t i = 0; i < m.num_drives(); ++i) {
    const int axis = m.drive_axis(i);
    n.drive_states.push_back(config.axes[static_cast<std::size_t>(axis)].name + ": " +
                             to_string(m.drive_outputs()[i].state));
  }
  return n;
}

}  // namespace numen::hal
