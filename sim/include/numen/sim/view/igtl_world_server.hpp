#pragma once
/// @file igtl_world_server.hpp
/// The god-object world out over OpenIGTLink (`numen run --igtl [HOST:]PORT`;
/// docs/openigtlink.md): a state-stream sink (platform::StateFrameSink, fed as the browser view
/// is, on the stream's thread, never the loop's) that serves each frame to every connected client
/// (3D Slicer's OpenIGTLinkIF, any OpenIGTLink client):
///
/// - TRANSFORM, every frame: one per body (its pose: the god-object) and one per body with a
///   target (where the device puts it: the ghost), named by IgtlNameStyle: "<body>" and
///   "<body>_target" (numen's names, the default), or PLUS's "<Body>ToScene" and
///   "<Body>TargetToScene" (igtl_world_transform_name()). A suture needle is a body: its
///   TRANSFORM is its body's ("needle"; its arc in that frame: docs/openigtlink.md).
/// - POLYDATA, every frame, one per suture thread named after it (core::ThreadModel::name): its
///   segments + 1 node positions as points and one LINES cell, the polyline through them in
///   order; a thread that broke, two (the pieces either side of its broken segment; a piece of
///   one node is left out).
/// - POLYDATA, one per deformable named after it: its surface (the fine surface when the net
///   carries one, docs/fine-surface.md; else the net's nodes and
///   triangles), points and triangles, to each client when it connects (at the frame it is
///   first served), then at `organ_rate_hz` per second of simulated time (0: never again). Each
///   update is the whole POLYDATA, triangles included: OpenIGTLink has no points-only update
///   that a reader applies to a model it has (Slicer rebuilds the model's polydata from each
///   message). Fine-surface vertices are placed from the frame's float32 node positions through
///   the map (core::net_surface_position()).
/// - STATUS (device "numen") and STRING (device "numen_events"), at the frame that shows a change:
///   the device's safe state latched (code 3, panic mode; subcode the hal::FaultCause; error
///   name the cause) or cleared (code 1); samples rejected (the frame's sample_faults:
///   code 7, time out, when stale, else 2, unknown error; subcode the hal::FaultMask bits) or
///   valid again (code 1); the device's bus down (StateFrameFlag kFrameBusDown: a tracker's
///   connection lost, a CAN bus off; code 7) or back (code 1). A grasp or a release (the held
///   body changes) is a STRING only. A client that connects gets the current state as a STATUS
///   (code 1, or the latched fault's) at its first frame.
/// - The same for each of the loop's other devices (the frame's extra_device items): its STATUS
///   under its own device name, igtl_world_status_name() ("numen_1", "numen_2", ...: device 0's
///   STATUS stays "numen"), its STRING on "numen_events" naming it ("device 1 'psm_left' latched
///   its safe state at t = ..."), and its current state to a client that connects.
///
/// In each client's stream, per frame: the shapes (at its first frame, then when due), its state
/// (at its first frame), the TRANSFORMs, the threads' POLYDATA, the frame's STATUS and STRING.
///
/// Translations and points in millimetres (Slicer's unit), world frame; rotations as they are;
/// the timestamp is the frame's simulated time (ns since the run's start). The period never
/// waits for a client: the stream drops frames for the sinks when they are busy (paced runs),
/// and a client whose output backlog is above its limit (max_backlog_bytes, raised to twice a
/// frame's messages when one frame is larger) misses frames (counted) instead of growing memory;
/// the STATUS and STRING of a frame it misses are still queued (a few hundred bytes) up to
/// 64 KiB above the limit (then counted as missed too). Clients
/// connect at any time (late, again after leaving); a client that closes or errs is dropped. Not
/// thread safe: the stream's thread owns it (accept_clients() before the run starts, from the
/// same thread that then starts the run).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "numen/core/model.hpp"
#include "numen/core/net_state.hpp"
#include "numen/platform/state_stream.hpp"

namespace numen::sim {

/// Device name of the world's STATUS messages (device 0's: the loop's first device).
inline constexpr const char* kIgtlStatusDevice = "numen";

/// Device name of the STATUS messages of the loop's device `device`: kIgtlStatusDevice for
/// device 0, "numen_<device>" for the others ("numen_1"; at most 20 characters for any device
/// index a loop has).
std::string igtl_world_status_name(std::size_t device);
/// Device name of the world's STRING messages (events in words).
inline constexpr const char* kIgtlEventsDevice = "numen_events";

/// How the world's TRANSFORMs are named (`numen run --igtl-names`; docs/openigtlink.md).
enum class IgtlNameStyle : std::uint8_t {
  /// "<body>" and "<body>_target" (the body's name as the scene gives it): numen's names, the
  /// default, kept as they are (clients configured for them).
  kNumen,
  /// PLUS's and 3D Slicer's "<From>To<To>": the transform that maps the From frame's
  /// coordinates into the To frame's; From is the body ("<Body>", its name with the first letter
  /// upper case) or its target ("<Body>Target"), To is "Scene" (numen's world, the frame a
  /// "TrackerToScene" registration maps into): "StylusToScene", "StylusTargetToScene".
  kPlus,
};

/// The TRANSFORM device name of body `body`'s pose (`target`: of its target's) in `style`.
/// Throws std::invalid_argument naming the body when the name would not be a valid one:
/// longer than OpenIGTLink's 20 characters (kNumen: a body name of more than 13 characters, for
/// "<body>_target"; kPlus: more than 7, for "<Body>TargetToScene"), or, kPlus, a body name that
/// does not start with an ASCII letter or that holds "To" followed by a character that is not
/// a lower-case letter (PLUS's transform-name parser takes exactly one such "To": the one
/// before "Scene").
std::string igtl_world_transform_name(const std::string& body, bool target, IgtlNameStyle style);

/// Creation settings of an IgtlWorldServer.
struct IgtlWorldSettings {
  /// Address to listen on: an IPv4 or IPv6 literal or a name (getaddrinfo(), e.g. localhost);
  /// loopback by default.
  std::string host = "127.0.0.1";
  std::uint16_t port = 18944;       ///< TCP port; 0: an ephemeral one (port()).
  std::size_t max_clients = 8;      ///< Clients served at once (more are refused, counted).
  std::size_t max_backlog_bytes = std::size_t{1} << 20;  ///< Per client, unsent bytes.
  /// POLYDATA updates of each deformable per second of simulated time (≥ 0, finite; 0: the
  /// shape once per client only). At most one per frame: the stream's rate (--view-rate) bounds
  /// it.
  double organ_rate_hz = 30.0;
  /// How the TRANSFORMs are named.
  IgtlNameStyle names = IgtlNameStyle::kNumen;
  /// The loop's devices' names in its order (Scene::device, then Scene::extra_devices): the
  /// other devices' STRING and STATUS messages name them. Missing ones are "device <i>" only.
  std::vector<std::string> device_names;
};

/// Counters of an IgtlWorldServer.
struct IgtlWorldCounters {
  std::uint64_t clients_total = 0;     ///< Clients accepted.
  std::uint64_t clients_refused = 0;   ///< Beyond max_clients.
  std::uint64_t clients_gone = 0;      ///< Clients that closed or erred (dropped).
  std::uint64_t frames = 0;            ///< Frames taken from the stream.
  std::uint64_t frames_bad = 0;        ///< Frames that did not decode (not served).
  std::uint64_t messages = 0;          ///< TRANSFORMs queued for clients.
  std::uint64_t polydata = 0;          ///< POLYDATA queued for clients.
  std::uint64_t statuses = 0;          ///< STATUS queued for clients.
  std::uint64_t strings = 0;           ///< STRING queued for clients.
  std::uint64_t events = 0;            ///< Changes seen in the frames (each a STATUS or STRING).
  std::uint64_t frames_skipped = 0;    ///< Client-frames missed: the client's backlog was full.
  std::uint64_t events_skipped = 0;    ///< Client-frames whose events were missed as well (a
                                       ///< client 64 KiB above its limit).
};

struct DimpleSphere;  // a sphere pressing an organ's drawn surface (src/view/tissue_dimple.hpp)

/// The world as OpenIGTLink messages (see the file comment).
class IgtlWorldServer final : public platform::StateFrameSink {
 public:
  /// `model`: the run's model (its bodies in order are the frames' body indices, its nets the
  /// deformables; kept by reference: it must outlive the server). Binds and listens; throws
  /// std::runtime_error naming the address when it cannot (or when the build has no
  /// OpenIGTLink), std::invalid_argument for a body name that igtl_world_transform_name()
  /// refuses in settings.names, a deformable's or a thread's name empty or longer than 20, or an
  /// organ rate not finite and ≥ 0.
  IgtlWorldServer(const core::Model& model, IgtlWorldSettings settings);
  ~IgtlWorldServer() override;
  IgtlWorldServer(const IgtlWorldServer&) = delete;
  IgtlWorldServer& operator=(const IgtlWorldServer&) = delete;

  /// The port it listens on.
  std::uint16_t port() const noexcept { return port_; }
  /// Accepts the clients waiting (non-blocking); write_frame() does it too. Returns the
  /// clients connected.
  std::size_t accept_clients() noexcept;
  /// The frame's messages to every client (see the file comment); false if it did not decode.
  bool write_frame(std::span<const std::byte> frame) noexcept override;
  /// Pushes the clients' backlogs out as far as their sockets take them (non-blocking).
  bool flush() noexcept override;
  /// Counters.
  const IgtlWorldCounters& counters() const noexcept { return counters_; }

 private:
  struct Client {
    int fd = -1;
    std::string backlog;  // bytes not yet sent (bounded, see the file comment)
    bool fresh = true;    // not served a frame yet: gets the shapes and the state first
  };
  struct Organ;
  struct Thread;
  struct Last {  // what the previous frame showed (the events are its changes)
    bool seen = false;
    std::uint8_t fault_cause = 0;
    std::uint8_t sample_faults = 0;
    bool bus_down = false;
    std::int32_t held_body = -1;
  };
  // One device's changes between `was` and `now` (device `device` of the loop) into events_.
  void add_device_events(std::size_t device, const Last& was, const Last& now, std::int64_t t_ns);
  // A new client's STATUS of device `device`'s state `now` into intro_.
  void add_device_intro(std::size_t device, const Last& now, std::int64_t t_ns);
  // "the device" (device 0, as ever) or "device 1 'psm_left'".
  std::string device_words(std::size_t device) const;
  void send_some(Client& c) noexcept;
  void drop_gone() noexcept;
  void add_events(const platform::StateFrameView& view);
  // A STATUS under device `device`'s name (igtl_world_status_name()).
  void add_status(std::string& out, std::int64_t t_ns, int code, std::int64_t subcode,
                  const std::string& name, const std::string& message, std::size_t device = 0);
  void add_string(std::string& out, std::int64_t t_ns, const std::string& text);
  void add_organs(std::string& out, const platform::StateFrameView& view);
  // Every thread's POLYDATA at this frame's thread nodes into `out`; returns the messages added.
  std::uint64_t add_threads(std::string& out, const platform::StateFrameView& view);

  const core::Model& model_;
  std::vector<std::string> names_;         // the bodies' names (events' text)
  std::vector<std::string> pose_names_;    // their TRANSFORMs' device names
  std::vector<std::string> target_names_;  // their targets'
  IgtlWorldSettings settings_;
  int listen_fd_ = -1;
  std::uint16_t port_ = 0;
  std::vector<Client> clients_;
  std::vector<Organ> organs_;
  std::vector<Thread> threads_;
  std::vector<core::NodeState> nodes_;  // the frame's node positions (m), for the fine surfaces
  std::vector<DimpleSphere> dimple_spheres_;  // the bodies' spheres (mm), for an organ's dimples
  std::int64_t organ_due_ns_ = 0;       // next frame time an organ update is due
  bool organ_sent_ = false;
  Last last_;
  std::vector<Last> extra_last_;  // the loop's other devices' (sized at the frames' count)
  std::string batch_;   // one frame's TRANSFORMs for every client (reused)
  std::string events_;  // one frame's STATUS / STRING (reused)
  std::string intro_;   // a new client's STATUS of the current state (reused)
  std::uint64_t batch_transforms_ = 0, batch_polydata_ = 0, events_statuses_ = 0, events_strings_ = 0;
  IgtlWorldCounters counters_;
};

}  // namespace numen::sim
