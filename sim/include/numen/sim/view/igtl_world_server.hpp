#pragma once
/// @file igtl_world_server.hpp
/// The god-object world out over OpenIGTLink (`numen run --igtl [HOST:]PORT`;
/// docs/openigtlink.md): a state-stream sink (platform::StateFrameSink, fed as the browser view
/// is, on the stream's thread, never the loop's) that serves each frame to every connected client
/// (3D Slicer's OpenIGTLinkIF, any OpenIGTLink client) as TRANSFORM messages: one per body named
/// after the body (its pose: the god-object), and one per body with a target named
/// "<body>_target" (where the device puts it: the ghost). Translations in millimetres (Slicer's
/// unit), rotations as they are; the timestamp is the frame's simulated time (ns since the run's
/// start). The period never waits for a client: the stream drops frames for the sinks when they
/// are busy (paced runs), and a client whose output backlog is above max_backlog_bytes misses
/// frames (counted) instead of growing memory. Clients connect at any time (late, again after
/// leaving); a client that closes or errs is dropped. Not thread safe: the stream's thread owns
/// it (accept_clients() before the run starts, from the same thread that then starts the run).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "numen/platform/state_stream.hpp"

namespace numen::sim {

/// Creation settings of an IgtlWorldServer.
struct IgtlWorldSettings {
  std::string host = "127.0.0.1";   ///< IPv4 address to listen on (loopback by default).
  std::uint16_t port = 18944;       ///< TCP port; 0: an ephemeral one (port()).
  std::size_t max_clients = 8;      ///< Clients served at once (more are refused, counted).
  std::size_t max_backlog_bytes = std::size_t{1} << 20;  ///< Per client, unsent bytes.
};

/// Counters of an IgtlWorldServer.
struct IgtlWorldCounters {
  std::uint64_t clients_total = 0;     ///< Clients accepted.
  std::uint64_t clients_refused = 0;   ///< Beyond max_clients.
  std::uint64_t clients_gone = 0;      ///< Clients that closed or erred (dropped).
  std::uint64_t frames = 0;            ///< Frames taken from the stream.
  std::uint64_t frames_bad = 0;        ///< Frames that did not decode (not served).
  std::uint64_t messages = 0;          ///< TRANSFORMs queued for clients.
  std::uint64_t frames_skipped = 0;    ///< Client-frames missed: the client's backlog was full.
};

/// The world as OpenIGTLink TRANSFORMs (see the file comment).
class IgtlWorldServer final : public platform::StateFrameSink {
 public:
  /// `body_names`: the model's bodies in order (the frames' body indices). Binds and listens;
  /// throws std::runtime_error naming the address when it cannot (or when the build has no
  /// OpenIGTLink), std::invalid_argument for a name longer than OpenIGTLink's 20 characters
  /// less "_target" (13).
  IgtlWorldServer(std::vector<std::string> body_names, IgtlWorldSettings settings);
  ~IgtlWorldServer() override;
  IgtlWorldServer(const IgtlWorldServer&) = delete;
  IgtlWorldServer& operator=(const IgtlWorldServer&) = delete;

  /// The port it listens on.
  std::uint16_t port() const noexcept { return port_; }
  /// Accepts the clients waiting (non-blocking); write_frame() does it too. Returns the
  /// clients connected.
  std::size_t accept_clients() noexcept;
  /// The frame's TRANSFORMs to every client (see the file comment); false if it did not decode.
  bool write_frame(std::span<const std::byte> frame) noexcept override;
  /// Pushes the clients' backlogs out as far as their sockets take them (non-blocking).
  bool flush() noexcept override;
  /// Counters.
  const IgtlWorldCounters& counters() const noexcept { return counters_; }

 private:
  struct Client {
    int fd = -1;
    std::string backlog;  // bytes not yet sent (bounded by max_backlog_bytes)
  };
  void send_some(Client& c) noexcept;
  void drop_gone() noexcept;

  std::vector<std::string> names_;
  IgtlWorldSettings settings_;
  int listen_fd_ = -1;
  std::uint16_t port_ = 0;
  std::vector<Client> clients_;
  std::string batch_;  // one frame's messages (reused)
  IgtlWorldCounters counters_;
};

}  // namespace numen::sim
