#pragma once
/// @file igtl_replay.hpp
/// A tracker replayed over OpenIGTLink (`numen igtl-replay`; docs/openigtlink.md): an
/// OpenIGTLink server that plays a scene's trajectory (its recorded or scripted motion) as the
/// TRANSFORMs (or POSITIONs, QTRANSs: IgtlReplaySettings::message) of the scene's tracked tool
/// ([device.igtl] device_name), as a PLUS server plays a
/// tracker — so that `numen run --bus igtl` on that scene runs the sim-bus run's motion through
/// the network, and the tests run it on loopback.
///
/// Message k (k = 0, 1, ...) carries the pose the simulated pose tracker's encoders would latch
/// at the k-th SYNC: the tracked frame (the tip) P at trajectory time k·T + the scene's bus
/// latency (SimulatedInstrument::controlled_pose_at() · tool_offset⁻¹; T = 1 / rate), turned
/// into the marker's pose in the tracker's frame, M = registration⁻¹ · P · calibration⁻¹, its
/// translation in the scene's
/// units, and stamped T0 + k·T (T0: CLOCK_REALTIME when the client connected). A follower
/// (hal::IgtlTrackerBus, offline) then takes message k at its period k exactly. A stall
/// (IgtlReplaySettings::stall_at_s, stall_s) leaves a gap in the stream, in its stamps and in
/// wall time, as a tracker that loses its marker for a while.

#include <atomic>
#include <cstdint>
#include <string>

#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

/// The pose message a replay sends (docs/openigtlink.md "Pose messages").
enum class IgtlReplayMessage : std::uint8_t {
  kTransform,  ///< TRANSFORM (as PLUS sends), the default.
  kPosition,   ///< POSITION, 28 bytes (position and quaternion).
  kQtrans,     ///< QTRANS.
};

/// Settings of a replay.
struct IgtlReplaySettings {
  std::string host = "127.0.0.1";  ///< Address to listen on (loopback by default).
  std::uint16_t port = 18944;      ///< TCP port; 0: an ephemeral one (IgtlReplayServer::port()).
  double rate_hz = 0.0;            ///< Messages per second of trajectory; 0: 1 / the scene's dt.
  double duration_s = -1.0;        ///< Trajectory time to play; < 0: the scene's duration.
  /// Send message k at k·T after the start (a live tracker); false: as fast as the client reads.
  bool paced = false;
  /// Longest wait for a client, s (> 0).
  double accept_timeout_s = 30.0;
  /// Stop after this many messages and close (a server that goes away mid-run); < 0: never.
  std::int64_t disconnect_after = -1;
  /// The message each pose is sent as.
  IgtlReplayMessage message = IgtlReplayMessage::kTransform;
  /// A stall (a marker hidden from the camera, a tracker that hangs): from trajectory time
  /// stall_at_s (s, >= 0) the server sends nothing for stall_s (s, >= 0; 0: no stall) of wall
  /// time, and the poses of that stretch are never sent — the tracker's clock goes on, the next
  /// message is the first one at or after stall_at_s + stall_s, stamped as ever (T0 + k·T).
  double stall_at_s = 0.0;
  double stall_s = 0.0;  ///< See stall_at_s.
};

/// What a replay did.
struct IgtlReplayResult {
  std::int64_t messages_sent = 0;  ///< Messages sent in full.
  bool client_connected = false;   ///< A client connected before the timeout.
  bool client_gone = false;        ///< The client closed the connection before the end.
};

/// An OpenIGTLink server playing one scene (see the file comment). One client at a time.
class IgtlReplayServer {
 public:
  /// Binds and listens (SO_REUSEADDR). Throws InputError (key "igtl") if the scene has no
  /// [device.igtl], std::invalid_argument for bad settings (rate not finite and >= 0, a stall's
  /// time or length not finite and >= 0), and
  /// std::runtime_error naming the address if binding fails or the build has no OpenIGTLink.
  IgtlReplayServer(const Scene& scene, IgtlReplaySettings settings);
  ~IgtlReplayServer();
  IgtlReplayServer(const IgtlReplayServer&) = delete;
  IgtlReplayServer& operator=(const IgtlReplayServer&) = delete;

  /// The port it listens on (the ephemeral one when settings.port was 0).
  std::uint16_t port() const noexcept { return port_; }
  /// Waits for a client (accept_timeout_s) and plays the trajectory to it; returns when done,
  /// when the client leaves, or when `stop` (if not null) becomes true. Blocks.
  IgtlReplayResult serve(const std::atomic<bool>* stop = nullptr);

 private:
  const Scene* scene_;
  IgtlReplaySettings settings_;
  int listen_fd_ = -1;
  std::uint16_t port_ = 0;
};

}  // namespace numen::sim
