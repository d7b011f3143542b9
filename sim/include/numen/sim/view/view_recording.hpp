#pragma once
/// @file view_recording.hpp
/// View recordings (`numen run --record-view run.nmv`, replayed by `numen view run.nmv`): the
/// state stream of a run in a file (docs/viewer.md, "Recording file"):
///
///     8 bytes   magic "NMVREC01"
///     u32       length L of the scene message, then L bytes of it (JSON, view_scene.hpp)
///     repeated: u32 length F of a frame, then F bytes of it (state_frame.hpp)
///
/// Lengths are little-endian. The file ends after the last complete frame; a frame cut short
/// (a run killed mid-write) is an error the reader reports with its byte offset.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "numen/hal/transport/line_file.hpp"
#include "numen/platform/state_stream.hpp"
#include "numen/sim/view/view_server.hpp"

namespace numen::sim {

/// First bytes of a view recording.
inline constexpr char kViewRecordingMagic[8] = {'N', 'M', 'V', 'R', 'E', 'C', '0', '1'};
/// Largest scene message or frame a reader accepts, bytes (a frame of the largest net numen
/// builds is ~0.2 MB; this bounds what a corrupt length can make the reader allocate).
inline constexpr std::uint32_t kViewRecordMaxBytes = 64u << 20;

/// Writes a view recording: a platform::StateFrameSink for the run's StateStream.
class ViewRecordingWriter final : public platform::StateFrameSink {
 public:
  /// Creates (truncates) `path` and writes the magic and `scene_message`. Throws InputError
  /// at key "--record-view" naming the path and the system's reason when it cannot.
  ViewRecordingWriter(const std::string& path, const std::string& scene_message);
  /// Appends one frame (buffered). False on a write failure. Consumer thread.
  bool write_frame(std::span<const std::byte> frame) noexcept override;
  /// fflush(); false on failure.
  bool flush() noexcept override;
  /// Closes the file; false if the buffered tail could not be written. Idempotent.
  bool close() noexcept;
  /// Frames written so far.
  std::uint64_t frames() const noexcept { return frames_; }
  /// Write, flush and close failures so far.
  std::uint64_t io_errors() const noexcept { return io_errors_; }

 private:
  std::optional<hal::LineFile> file_;  // always set after construction
  std::uint64_t frames_ = 0;
  std::uint64_t io_errors_ = 0;
};

/// Reads a view recording. The constructor checks the whole file once (every frame decoded,
/// every frame of the scene message's layout, periods increasing) and keeps only an index;
/// frames are read on demand.
class ViewRecordingReader {
 public:
  /// Opens and checks `path`. Throws InputError (file = path, key empty) with the byte offset
  /// and what is wrong: cannot open, not a view recording, a length above kViewRecordMaxBytes,
  /// a scene message that is not a JSON object (the offset of the syntax error), a frame cut
  /// short, a malformed frame (StateFrameDecoder's reason), a frame whose bodies, nodes, axes,
  /// graspers, other devices, their axes, threads or thread nodes differ from the scene
  /// message's layout, a period not after its predecessor's, or a time
  /// before its predecessor's (found by fuzzing: frame_at_or_after() searched unsorted times). A member
  /// of the scene message that is missing or of the wrong JSON type or value names its key
  /// ("format": string "numen-view", "version": integer kViewSceneVersion, "layout": object,
  /// "layout.bodies", "layout.nodes", "layout.axes", "layout.grasps", "layout.extra_devices",
  /// "layout.extra_axes", "layout.threads", "layout.thread_nodes": whole numbers) with the
  /// message's offset; a recording of an older numen (an earlier "version") is refused at its
  /// "version", saying to record the run again.
  /// No other exception escapes but std::bad_alloc.
  explicit ViewRecordingReader(const std::string& path);
  ~ViewRecordingReader();
  ViewRecordingReader(const ViewRecordingReader&) = delete;
  ViewRecordingReader& operator=(const ViewRecordingReader&) = delete;

  /// The scene message (JSON text).
  const std::string& scene_message() const noexcept { return scene_message_; }
  /// Frames in the file.
  std::size_t size() const noexcept { return index_.size(); }
  /// Simulated time of frame i, ns (i < size()).
  std::int64_t time_ns(std::size_t i) const noexcept { return index_[i].time_ns; }
  /// Period index of frame i.
  std::uint64_t period(std::size_t i) const noexcept { return index_[i].period; }
  /// Reads frame i into `out` (resized). Throws InputError if the file changed under us.
  void frame(std::size_t i, std::vector<std::byte>& out) const;
  /// First frame whose time is >= t_ns (size() if none).
  std::size_t frame_at_or_after(std::int64_t t_ns) const noexcept;
  /// The path as given.
  const std::string& path() const noexcept { return path_; }

 private:
  struct Entry {
    std::uint64_t offset;  // of the frame's bytes (after its length)
    std::uint32_t bytes;
    std::uint64_t period;
    std::int64_t time_ns;
  };
  std::string path_;
  std::FILE* file_ = nullptr;
  std::string scene_message_;
  std::vector<Entry> index_;
};

/// A view recording as a replay's frame source (`numen view`, view_replay_series()): the
/// reader's frames, read on demand. The reader must outlive it; one thread at a time.
class ViewRecordingSource final : public ViewFrameSource {
 public:
  explicit ViewRecordingSource(const ViewRecordingReader& reader) : reader_(reader) {}
  std::size_t frame_count() const override { return reader_.size(); }
  std::int64_t frame_time_ns(std::size_t i) const override { return reader_.time_ns(i); }
  void read_frame(std::size_t i, std::vector<std::byte>& out) override { reader_.frame(i, out); }

 private:
  const ViewRecordingReader& reader_;
};

}  // namespace numen::sim
