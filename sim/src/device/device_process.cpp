/// @file device_process.cpp
/// `numen device`: the simulated instrument as its own process on a real bus.

#include "numen/sim/device/device_process.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/features.hpp"
#include "numen/hal/canopen/nmt.hpp"
#if NUMEN_WITH_SERIAL
#include "numen/hal/transport/serial_bus.hpp"
#endif
#include "numen/platform/monotonic_clock.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/input/bus_spec.hpp"
#include "numen/sim/input/input_error.hpp"

namespace numen::sim {

DeviceSummary run_device(const Scene& scene, const DeviceOptions& options) {
  // This process emulates an impedance instrument (encoders, torque drives); an admittance
  // device (force sensor, csp drives) is emulated inside `numen run` on the simulated bus only.
  if (scene.admittance)
    throw InputError(scene.file, 0, 0, "scene",
                     "scene \"" + scene.name + "\" has an admittance device: numen device emulates "
                     "impedance instruments only (run it with numen run on the simulated bus)");
  if (!scene.extra_devices.empty())
    throw InputError(scene.file, 0, 0, "device",
                     "scene \"" + scene.name + "\" has " + std::to_string(num_devices(scene)) +
                         " devices ([[device]]): numen device emulates one instrument (run the "
                         "scene with numen run on the simulated bus)");
  if (scene.servo)
    throw InputError(scene.file, 0, 0, "device",
                     "scene \"" + scene.name + "\": device \"" + scene.device.name +
                         "\"'s hand has a servo ([device.trajectory.servo]): it watches the scene's "
                         "bodies, which numen device has not (run the scene with numen run on the "
                         "simulated bus)");
  const BusSpec spec = parse_bus_spec(options.bus);
  if (!spec.real())
    throw std::invalid_argument("numen device --bus '" + options.bus +
                                "': expected can:IFACE or serial:PATH[@BAUD]");
  if (options.tick_ns <= 0) throw std::invalid_argument("DeviceOptions::tick_ns must be > 0");
  const std::unique_ptr<hal::Bus> port = open_real_bus(spec, device_filters(scene.device));
  SimulatedInstrument instrument(scene.device, scene.trajectory,
                                 scene.plant ? &*scene.plant : nullptr, scene.hand);
  instrument.start_at_next_sync();
  hal::DeviceEmulator& emu = instrument.emulator();
  const std::size_t n = scene.device.axes.size();

  DeviceSummary s;
  s.scene = scene.name;
  s.bus = options.bus;
  s.managed = scene.device.canopen.managed;
  std::array<double, hal::kMaxAxes> torque_max{};
  std::array<std::uint32_t, hal::kMaxAxes> states_seen{};  // bit per hal::PowerState
  std::array<bool, hal::kMaxAxes> faulted{};

  const std::int64_t t0 = platform::monotonic_now_ns();
  const std::int64_t end =
      options.duration_s >= 0.0 ? t0 + static_cast<std::int64_t>(options.duration_s * 1e9) : -1;
  std::int64_t next_tick = t0;
  // Counts of one pass of the loop: SYNCs answered, torque maxima, drive states.
  const auto account = [&](const hal::EmulatorCounters& before) {
    const hal::EmulatorCounters& after = emu.counters();
    const auto syncs = static_cast<std::int64_t>(after.syncs - before.syncs);
    const auto tpdos = static_cast<std::int64_t>(after.tpdos_sent - before.tpdos_sent);
    if (n > 0) s.syncs_answered += std::min(syncs, tpdos / static_cast<std::int64_t>(n));
    const hal::AxisVector& tau = emu.last_torques();
    bool nonzero = false;
    for (std::size_t a = 0; a < n; ++a) {
      const double v = std::abs(tau[static_cast<Eigen::Index>(a)]);
      torque_max[a] = std::max(torque_max[a], v);
      nonzero = nonzero || v != 0.0;
      if (const hal::Cia402Drive* d = emu.drive(static_cast<int>(a))) {
        states_seen[a] |= 1u << static_cast<unsigned>(d->state());
        faulted[a] = faulted[a] || d->state() == hal::PowerState::kFault;
      }
    }
    if (after.rpdos > before.rpdos && nonzero) ++s.rpdos_nonzero;
  };
#if NUMEN_WITH_SERIAL
  auto* const serial = dynamic_cast<hal::SerialBus*>(port.get());
#endif
  // One pass: the queued frames handled (and, for `tick_at` ≥ 0, the period's frames sent at
  // that time), a serial port's output flushed, the counts taken.
  const auto pump = [&](std::int64_t tick_at) {
    const hal::EmulatorCounters before = emu.counters();
    instrument.poll(*port, tick_at);
#if NUMEN_WITH_SERIAL
    if (serial != nullptr) serial->flush();
#endif
    account(before);
  };
  // The first pass before anything is announced: the nodes leave initialisation in their
  // first tick (boot-up message, then pre-operational), and a node in initialisation ignores
  // SDO requests. Announced before it, a client's first request could reach a node that never
  // answers it (interop_device_server under load: node 1's first upload timed out).
  pump(t0);
  next_tick += options.tick_ns;
  if (options.on_ready) options.on_ready();
  while (!(options.stop != nullptr && options.stop->load(std::memory_order_relaxed))) {
    std::int64_t now = platform::monotonic_now_ns();
    if (end >= 0 && now >= end) break;
    if (now < next_tick) {
      wait_bus(*port, std::min(next_tick - now, end >= 0 ? end - now : next_tick - now));
      ++s.wakeups;
      now = platform::monotonic_now_ns();
    }
    const bool tick = now >= next_tick;
    pump(tick ? now : -1);
    if (tick) {
      s.tick_late_max_s = std::max(s.tick_late_max_s, static_cast<double>(now - next_tick) * 1e-9);
      next_tick += options.tick_ns;
      if (next_tick <= now) next_tick = now + options.tick_ns;  // re-phase after a stall
    }
  }
  // Frames already queued when the run ended (a device that lags the bus, e.g. a stalled
  // guest, may hold the last periods' SYNCs): handled before the summary, so that its
  // counts cover everything the controller sent. No tick: nothing is sent unasked.
  pump(-1);
  s.wall_time_s = static_cast<double>(platform::monotonic_now_ns() - t0) * 1e-9;
  if (const PlantMotion* plant = instrument.plant()) s.closed_loop = plant->figures();
  const hal::EmulatorCounters& c = emu.counters();
  s.syncs = static_cast<std::int64_t>(c.syncs);
  s.encoder_tpdos = static_cast<std::int64_t>(c.tpdos_sent);
  s.drive_tpdos = static_cast<std::int64_t>(c.drive_tpdos_sent);
  s.rpdos = static_cast<std::int64_t>(c.rpdos);
  s.nmt_commands = static_cast<std::int64_t>(c.nmt_commands);
  s.heartbeats_sent = static_cast<std::int64_t>(c.heartbeats_sent);
  s.boot_ups_sent = static_cast<std::int64_t>(c.boot_ups_sent);
  s.emcys_sent = static_cast<std::int64_t>(c.emcys_sent);
  s.sdo_requests = static_cast<std::int64_t>(c.sdo_requests);
  s.sdo_not_allowed = static_cast<std::int64_t>(c.sdo_not_allowed);
  s.controller_losses = static_cast<std::int64_t>(c.controller_losses);
  s.frames_malformed = static_cast<std::int64_t>(c.frames_malformed);
  s.frames_ignored = static_cast<std::int64_t>(c.frames_ignored);
  s.tx_would_block = static_cast<std::int64_t>(c.tx_would_block);
  s.tx_errors = static_cast<std::int64_t>(c.tx_errors);
  const hal::BusCounters pc = port->counters();
  s.port_rx = static_cast<std::int64_t>(pc.frames_rx);
  s.port_tx = static_cast<std::int64_t>(pc.frames_tx);
  s.port_dropped = static_cast<std::int64_t>(pc.dropped);
  s.port_errors = static_cast<std::int64_t>(pc.errors);
  s.transport = describe_transport_counters(*port);
  for (std::size_t a = 0; a < n; ++a) {
    const std::string& name = scene.device.axes[a].name;
    if (s.managed)
      s.node_states.push_back(name + ": " + hal::to_string(emu.node_state(static_cast<int>(a))));
    if (scene.device.axes[a].drive_cob_id == 0) continue;
    std::ostringstream t;
    t << std::setprecision(4) << name << ": " << torque_max[a];
    s.axis_torque_max.push_back(t.str());
    if (const hal::Cia402Drive* d = emu.drive(static_cast<int>(a))) {
      std::string line = name + ": " + hal::to_string(d->state()) + " (reached";
      for (unsigned b = 0; b < 32; ++b)
        if (states_seen[a] & (1u << b))
          line += std::string(" ") + hal::to_string(static_cast<hal::PowerState>(b)) + ";";
      line += ")";
      s.drive_states.push_back(line);
      if (faulted[a]) ++s.drive_faults;
    }
  }
  return s;
}

std::string format_device_summary(const DeviceSummary& s) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(3);
  os << "device " << s.scene << " on " << s.bus << ": " << s.wall_time_s << " s, "
     << (s.managed ? "managed CANopen stack" : "minimal protocol") << "\n";
  os << "  SYNCs " << s.syncs << ", answered " << s.syncs_answered << "; encoder TPDOs "
     << s.encoder_tpdos << ", drive TPDOs " << s.drive_tpdos << "; RPDOs " << s.rpdos
     << " (non-zero torque " << s.rpdos_nonzero << ")\n";
  os << "  NMT commands " << s.nmt_commands << ", boot-ups " << s.boot_ups_sent << ", heartbeats "
     << s.heartbeats_sent << ", EMCY " << s.emcys_sent << ", controller heartbeat losses "
     << s.controller_losses << ", drive faults " << s.drive_faults << "\n";
  os << "  SDO requests " << s.sdo_requests << ", ignored before boot-up or while stopped "
     << s.sdo_not_allowed << "\n";
  os << "  frames malformed " << s.frames_malformed << ", ignored " << s.frames_ignored
     << "; writes would-block " << s.tx_would_block << ", errors " << s.tx_errors << "\n";
  os << "  port: rx " << s.port_rx << ", tx " << s.port_tx << ", dropped " << s.port_dropped
     << ", errors " << s.port_errors << "; wake-ups " << s.wakeups << ", ticks late by up to "
     << std::setprecision(1) << s.tick_late_max_s * 1e3 << std::setprecision(3) << " ms\n";
  if (!s.transport.empty()) os << "  " << s.transport << "\n";
  os << "  torque max:";
  for (const std::string& t : s.axis_torque_max) os << " " << t << ";";
  os << "\n";
  for (const std::string& t : s.node_states) os << "  node " << t << "\n";
  for (const std::string& t : s.drive_states) os << "  drive " << t << "\n";
  if (const auto& f = s.closed_loop) {
    const LimitCycleDetector& c = f->limit_cycle;
    os << "  device loop closed: force on the hand max " << f->handle_force_max_n
       << " N, port energy " << f->port_energy_j << " J (min " << f->port_energy_min_j
       << " J), limit cycle " << (c.detected() ? "yes" : "no") << " ("
       << c.amplitude_m() * 1e3 << " mm at " << c.frequency_hz() << " Hz), plant "
       << (f->diverged ? "diverged" : "bounded") << "\n";
  } else {
    os << "  device loop replay\n";
  }
  return os.str();
}

}  // namespace numen::sim
