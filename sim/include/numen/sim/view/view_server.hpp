#pragma once
/// @file view_server.hpp
/// ViewServer: the viewer's HTTP and WebSocket server (docs/viewer.md, "Server"). It serves the
/// page's static files from a folder and, on one WebSocket path, the state stream: on connect
/// the scene message (one text message, JSON), a session message (text, JSON: live or replay),
/// then state frames as binary messages, each one frame exactly as encode_state_frame() wrote
/// it (state_frame.hpp).
///
/// Live: the server is a platform::StateFrameSink of the run's StateStream. write_frame() is
/// called on the stream's thread; it copies the frame once and queues it on each client's
/// bounded queue, never waiting for a client: a client whose queue is full loses its oldest
/// queued frame (counted per client and in total). The loop never sees the server at all.
///
/// Replay: the server is given a ViewFrameSource (a recording) instead, sends its frame index
/// in the session message, and answers the page's frame requests (the only client message it
/// accepts, "Replay" in docs/viewer.md); the page paces playback.
///
/// Read-only: nothing a client sends reaches the run. Live, a text message of valid JSON up to
/// max_client_message_bytes, its arrays and objects nested at most 64 deep, is ignored; a
/// binary message, text that is not JSON, JSON nested deeper, a message above the limit, and
/// in replay any message that is not a valid request, close that connection and are counted
/// (closed_bad_input).
///
/// Bounded: at most max_http_connections HTTP connections (a new one past them closes the one
/// that has waited longest for its request) and max_clients WebSocket clients; an accept that
/// fails (out of file descriptors or memory: EMFILE, ENFILE, ENOBUFS, ENOMEM) pauses accepting
/// (kViewAcceptBackoff, doubling with each failure in a row up to kViewAcceptBackoffMax; a
/// connection that closes ends the pause) instead of retrying at once, so that a flood of
/// connections never makes the I/O thread spin beside the run's loop.
///
/// Threads: one I/O thread of its own (SCHED_OTHER) runs every socket; start(), stop() and
/// the destructor belong to the setup thread; write_frame() to one producer thread (the
/// stream's); counters() to any thread. Boost.Beast stays in view_server.cpp (pimpl).

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "numen/platform/state_stream.hpp"

namespace numen::sim {

/// Where a replay's frames come from (a view recording, view_recording.hpp). Called by the
/// server's constructor (the index) and then only on its I/O thread, one call at a time.
class ViewFrameSource {
 public:
  virtual ~ViewFrameSource() = default;
  /// Frames available.
  virtual std::size_t frame_count() const = 0;
  /// Simulated time of frame i (i < frame_count()), ns.
  virtual std::int64_t frame_time_ns(std::size_t i) const = 0;
  /// Reads frame i (i < frame_count()) into `out` (resized). May throw on an I/O error: the
  /// request's connection is then closed and the error counted (source_errors).
  virtual void read_frame(std::size_t i, std::vector<std::byte>& out) = 0;
};

/// Settings of a ViewServer (checked by its constructor).
struct ViewServerSettings {
  /// Address to bind: an IPv4 or IPv6 literal. Default loopback only; any other address
  /// exposes the viewer to the network (the caller warns: is_loopback_address()).
  std::string host = "127.0.0.1";
  /// TCP port; 0 picks a free one (port() tells which).
  std::uint16_t port = 8080;
  /// Folder of the page's static files (index.html, viewer.js, vendor/...). Empty: no files,
  /// only the WebSocket (every other path answers 404).
  std::string static_dir;
  /// Path of the WebSocket.
  std::string stream_path = "/stream";
  /// Frames a client's queue holds at most, >= 1 (8 at 60 Hz: 133 ms of lag at most).
  std::size_t client_queue_frames = 8;
  /// Largest message a client may send, bytes, >= 16 (text commands are a few tens of bytes).
  std::size_t max_client_message_bytes = 256;
  /// Clients served at once, >= 1; a further WebSocket upgrade is answered 503.
  std::size_t max_clients = 16;
  /// HTTP connections open at once, >= 1: each waits for its request (a keep-alive connection
  /// for its next one, at most 30 s) or is being answered; a WebSocket client is no longer one.
  /// A connection accepted past it closes the one that has waited longest for its request, or
  /// is closed itself when all of them are being answered (counted: connections_shed).
  std::size_t max_http_connections = 64;
};

/// The accept loop's first pause after a failed accept (out of descriptors or memory); each
/// further failure in a row doubles it, up to kViewAcceptBackoffMax. A connection of the server
/// that closes (a descriptor freed) ends the pause at once; a successful accept resets it.
inline constexpr std::chrono::milliseconds kViewAcceptBackoff{10};
/// The accept loop's longest pause after failed accepts.
inline constexpr std::chrono::milliseconds kViewAcceptBackoffMax{1000};

/// Counters of a ViewServer since start() (relaxed atomics; each consistent on its own).
struct ViewServerCounters {
  std::uint64_t clients_connected = 0;  ///< WebSocket clients connected now.
  std::uint64_t clients_total = 0;      ///< WebSocket clients accepted since start().
  std::uint64_t clients_refused = 0;    ///< Upgrades refused (max_clients reached).
  std::uint64_t http_requests = 0;      ///< HTTP requests answered (files, 404s, ...).
  std::uint64_t frames_offered = 0;     ///< write_frame() calls (live).
  std::uint64_t frames_sent = 0;        ///< Frames written to a client (summed over clients).
  std::uint64_t frames_dropped = 0;     ///< Frames a full client queue lost (summed).
  std::uint64_t closed_bad_input = 0;   ///< Connections closed for a bad or oversized message.
  std::uint64_t requests = 0;           ///< Replay frame requests answered.
  std::uint64_t source_errors = 0;      ///< Replay frames the source failed to read.
  /// Accepts that failed (EMFILE, ENFILE, ENOBUFS, ENOMEM, ...), each followed by a pause.
  std::uint64_t accept_failures = 0;
  /// HTTP connections closed because max_http_connections were open (the one waiting longest
  /// for its request, or the new one).
  std::uint64_t connections_shed = 0;
};

/// One connected client's counters (ViewServer::clients()).
struct ViewClientCounters {
  std::uint64_t id = 0;          ///< 1, 2, ... in order of connection.
  std::string remote;            ///< Peer address:port.
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_dropped = 0;
};

/// Largest HTTP request header a connection reads, bytes (a longer one closes it).
inline constexpr std::size_t kViewHttpHeaderLimit = 8 * 1024;
/// Largest HTTP request body a connection reads, bytes (the server reads none; a longer one
/// closes the connection).
inline constexpr std::size_t kViewHttpBodyLimit = 1024;

/// What the server answers an HTTP request (after Boost.Beast parsed it).
struct ViewHttpAnswer {
  enum class Kind : std::uint8_t {
    kUpgrade,          ///< A WebSocket upgrade on stream_path: becomes a client.
    kFile,             ///< GET or HEAD of a file name we serve: `file` (404 if it is absent).
    kNotFound,         ///< 404: no static folder, a target we do not serve, an upgrade elsewhere.
    kNotAllowed,       ///< 405: any method but GET and HEAD (the server is read-only).
    kTooManyViewers,   ///< 503: an upgrade while max_clients clients are connected.
  };
  Kind kind = Kind::kNotFound;
  /// kFile: the target as a path relative to static_dir (only [A-Za-z0-9._/-], no "..", no
  /// empty segment; "/" and ".../" name index.html).
  std::string file;
};

/// The server's answer to a request of method `method` ("GET", ...) for `target` (as sent,
/// query included), `websocket_upgrade` when it asks for one, while `clients` clients are
/// connected. Pure (the sessions' decision, testable and fuzzed without a socket:
/// tests/fuzz/view_server_fuzz.cpp).
ViewHttpAnswer answer_view_http_request(const ViewServerSettings& settings,
                                        std::string_view method, std::string_view target,
                                        bool websocket_upgrade, std::size_t clients);

/// What the server makes of one WebSocket message of a client.
struct ViewClientRequest {
  enum class Kind : std::uint8_t {
    kIgnored,  ///< Live: any text message that is JSON nested at most 64 deep.
    kFrame,    ///< Replay: {"frame": I} with I < the frame count: send frame I.
    kBad,      ///< Anything else: the connection is closed and counted (closed_bad_input).
  };
  Kind kind = Kind::kBad;
  std::uint64_t frame = 0;  ///< kFrame: I.
};

/// Reads a client's message `message` (`text`: a text message, else binary) for a live server
/// (`frame_count` unused) or a replay server of `frame_count` frames (see the file comment).
/// Pure; never throws but std::bad_alloc.
ViewClientRequest read_view_client_message(std::string_view message, bool text, bool replay,
                                           std::size_t frame_count);

/// The server; see the file comment.
class ViewServer final : public platform::StateFrameSink {
 public:
  /// Live server: sends `scene_message` (view_scene.hpp) to each client, then the frames given
  /// to write_frame(). Throws std::invalid_argument naming a setting out of range.
  ViewServer(const ViewServerSettings& settings, std::string scene_message);
  /// Replay server: sends `scene_message`, the index of `source` (not owned; must outlive the
  /// server) and `series` as the session message's "series" (a JSON object's text,
  /// view_replay_series() in view_series.hpp; empty: none), then the frames each client
  /// requests. Throws std::invalid_argument when `series` is not a JSON object.
  ViewServer(const ViewServerSettings& settings, std::string scene_message,
             ViewFrameSource& source, const std::string& series = {});
  /// stop().
  ~ViewServer() override;
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  /// Binds, listens and starts the I/O thread. Throws std::runtime_error naming the address
  /// and the system's reason when the address is not an IP literal or cannot be bound.
  void start();
  /// Closes the listener and every connection and joins the I/O thread. Idempotent.
  void stop();
  /// The bound port (after start()).
  std::uint16_t port() const noexcept;
  /// http://HOST:PORT/ (after start()).
  std::string url() const;
  /// Blocks the calling (setup) thread until a WebSocket client is connected — one already is,
  /// or one connects — or `timeout_s` seconds (> 0) have passed. True when a client is
  /// connected (`numen run --view --wait-for-viewer`: the run starts when the first page
  /// connects, so that page sees every frame).
  bool wait_for_client(double timeout_s);

  /// Live: copies `frame` once and queues it for every connected client (see the file comment).
  /// Never waits for a client. False only when the copy could not be allocated.
  bool write_frame(std::span<const std::byte> frame) noexcept override;

  /// Counters (see ViewServerCounters).
  ViewServerCounters counters() const noexcept;
  /// The connected clients' counters (allocates; not for the loop).
  std::vector<ViewClientCounters> clients() const;

  /// True for 127.0.0.0/8, ::1 and "localhost": addresses that do not reach the network.
  static bool is_loopback_address(const std::string& host);
  /// True for what start() can listen on: an IPv4 or IPv6 address literal, or "localhost"
  /// (127.0.0.1). Host names are not resolved.
  static bool is_address(const std::string& host);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace numen::sim
