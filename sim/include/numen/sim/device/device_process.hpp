#pragma once
/// @file device_process.hpp
/// `numen device SCENE --bus can:IFACE|serial:PATH[@BAUD]`: the scene's simulated instrument
/// (SimulatedInstrument: DeviceEmulator with its CiA 301 node models, heartbeat producers,
/// CiA 402 drives, encoders playing the scene's trajectory) as a process of its own on a real
/// bus, so that `numen run --bus ...` in another process (or on another host) talks to it as
/// to hardware (docs/protocol.md, docs/canopen.md; docs/hil.md).
///
/// Time: bus time is CLOCK_MONOTONIC ns (the transports stamp received frames with it);
/// trajectory time 0 is the first SYNC received. The process sleeps in poll(2) on the bus's
/// file descriptor and wakes for received frames and for its periodic tick (boot-up,
/// heartbeats, the drives' watch of the controller heartbeat, EMCY); it never spins.
#include <atomic>
#include <cstdint>
#include <optional>
#include <functional>
#include <string>
#include <vector>

#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

/// How to run the device.
struct DeviceOptions {
  std::string bus;             ///< "can:IFACE" or "serial:PATH[@BAUD]" (BusSpec::real()).
  double duration_s = -1.0;    ///< Wall time to run, s; < 0: until `stop`.
  /// Interval of the time-driven part (DeviceEmulator::tick()), ns, > 0: at most this late
  /// for a heartbeat or a boot-up (the heartbeat periods are 10 ms by default).
  std::int64_t tick_ns = 1'000'000;
  /// Set (SIGINT / SIGTERM / SIGHUP handler) to end the run; nullptr: none.
  const std::atomic<bool>* stop = nullptr;
  /// Called once, on run_device()'s thread, when the device answers: the bus is open and the
  /// first pass of the loop has run, so that a managed device's nodes have left initialisation
  /// and their boot-up messages are written (flushed, on a serial line). An SDO request sent
  /// after this call is answered; one sent before may reach a node still in initialisation,
  /// which ignores it as CiA 301 has it (counted in DeviceSummary::sdo_not_allowed). `numen
  /// device --ready` prints READY here. Empty: nothing is called.
  std::function<void()> on_ready;
};

/// What the device did.
struct DeviceSummary {
  std::string scene;
  std::string bus;
  double wall_time_s = 0.0;
  bool managed = false;
  std::int64_t syncs = 0;              ///< SYNCs received.
  std::int64_t syncs_answered = 0;     ///< SYNCs after which the encoder TPDOs went out.
  std::int64_t encoder_tpdos = 0;      ///< Encoder TPDOs written.
  std::int64_t drive_tpdos = 0;        ///< Drive TPDOs written.
  std::int64_t rpdos = 0;              ///< Drive / torque RPDOs received and decoded.
  std::int64_t rpdos_nonzero = 0;      ///< ... whose applied torque was non-zero on an axis.
  std::int64_t nmt_commands = 0;
  std::int64_t heartbeats_sent = 0;
  std::int64_t boot_ups_sent = 0;
  std::int64_t emcys_sent = 0;
  std::int64_t sdo_requests = 0;       ///< SDO requests a node's server took.
  /// SDO requests to a node in initialisation (before its boot-up) or stopped: ignored, no
  /// answer (CiA 301); the client's timeout ends its transfer.
  std::int64_t sdo_not_allowed = 0;
  std::int64_t controller_losses = 0;  ///< Controller heartbeat losses seen by the nodes.
  std::int64_t frames_malformed = 0;
  std::int64_t frames_ignored = 0;
  std::int64_t tx_would_block = 0;
  std::int64_t tx_errors = 0;
  std::int64_t port_rx = 0, port_tx = 0, port_dropped = 0, port_errors = 0;
  std::string transport;               ///< describe_transport_counters() of the port.
  std::vector<std::string> axis_torque_max;  ///< "axis: max |torque| applied" per driven axis.
  std::vector<std::string> node_states;      ///< "axis: NMT state" per axis at the end.
  std::vector<std::string> drive_states;     ///< "axis: CiA 402 state, states reached" per drive.
  std::int64_t drive_faults = 0;       ///< Drives that went through fault.
  std::int64_t wakeups = 0;            ///< poll(2) returns (frames or ticks).
  /// The latest a tick ran after it was due, s: the longest this process waited to be
  /// scheduled (a shared machine's stall shows here, not in the protocol's counts).
  double tick_late_max_s = 0.0;
  /// Set when the scene's [device.plant] closed the loop (the device moved under the received
  /// torques and the hand, PlantMotion): what it measured. Unset: replay.
  std::optional<PlantFigures> closed_loop;
};

/// Runs the scene's device on `options.bus` until the duration or the stop flag, then handles
/// the frames already queued on its port (answering their SYNCs) so that the summary counts
/// everything sent before the end, however far the device lagged. Throws InputError for a
/// scene with an admittance device (not emulated here), std::invalid_argument for a bus that
/// is not real, std::runtime_error from the transport.
DeviceSummary run_device(const Scene& scene, const DeviceOptions& options);

/// Readable multi-line summary.
std::string format_device_summary(const DeviceSummary& s);

}  // namespace numen::sim
