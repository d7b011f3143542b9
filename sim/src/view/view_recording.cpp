#include "numen/sim/view/view_recording.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>

#include "input/json_input.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/view/view_scene.hpp"

namespace numen::sim {
namespace {

void put_u32(char out[4], std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) out[i] = static_cast<char>((v >> (8 * i)) & 0xFF);
}

std::uint32_t get_u32(const unsigned char in[4]) noexcept {
  return static_cast<std::uint32_t>(in[0]) | static_cast<std::uint32_t>(in[1]) << 8 |
         static_cast<std::uint32_t>(in[2]) << 16 | static_cast<std::uint32_t>(in[3]) << 24;
}

// LineFile throws std::runtime_error "path: cannot open for writing: <reason>".
hal::LineFile& open_checked(std::optional<hal::LineFile>& slot, const std::string& path) {
  try {
    slot.emplace(path);
  } catch (const std::runtime_error& e) {
    throw InputError("", 0, 0, "--record-view", e.what());
  }
  return *slot;
}

}  // namespace

ViewRecordingWriter::ViewRecordingWriter(const std::string& path, const std::string& scene_message) {
  hal::LineFile& file = open_checked(file_, path);
  char length[4];
  put_u32(length, static_cast<std::uint32_t>(scene_message.size()));
  if (!file.write(kViewRecordingMagic, sizeof kViewRecordingMagic) || !file.write(length, 4) ||
      !file.write(scene_message.data(), scene_message.size()) || !file.flush())
    throw InputError("", 0, 0, "--record-view", path + ": cannot write: " + std::strerror(errno));
}

bool ViewRecordingWriter::write_frame(std::span<const std::byte> frame) noexcept {
  char length[4];
  put_u32(length, static_cast<std::uint32_t>(frame.size()));
  const bool ok = file_->write(length, 4) &&
                  file_->write(reinterpret_cast<const char*>(frame.data()), frame.size());
  if (ok) ++frames_;
  else ++io_errors_;
  return ok;
}

bool ViewRecordingWriter::flush() noexcept {
  if (!file_->is_open()) return true;
  const bool ok = file_->flush();
  if (!ok) ++io_errors_;
  return ok;
}

bool ViewRecordingWriter::close() noexcept {
  if (!file_->is_open()) return true;
  const bool ok = file_->close();
  if (!ok) ++io_errors_;
  return ok;
}

ViewRecordingReader::ViewRecordingReader(const std::string& path) : path_(path) {
  auto fail = [&](std::uint64_t offset, const std::string& what) -> InputError {
    return InputError(path, 0, 0, "", "byte " + std::to_string(offset) + ": " + what);
  };
  file_ = std::fopen(path.c_str(), "rb");
  if (file_ == nullptr)
    throw InputError(path, 0, 0, "", std::string("cannot open: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(::fileno(file_), &st) == 0 && S_ISDIR(st.st_mode)) {
    std::fclose(file_);
    file_ = nullptr;
    throw InputError(path, 0, 0, "", "is a directory, not a numen view recording");
  }
  try {
    std::uint64_t at = 0;
    char magic[8];
    if (std::fread(magic, 1, 8, file_) != 8 || std::memcmp(magic, kViewRecordingMagic, 8) != 0)
      throw fail(0, "not a numen view recording (it does not start with NMVREC01)");
    at = 8;
    auto read_length = [&](const char* what) -> std::optional<std::uint32_t> {
      unsigned char b[4];
      const std::size_t got = std::fread(b, 1, 4, file_);
      if (got == 0 && std::feof(file_)) return std::nullopt;
      if (got != 4) throw fail(at, std::string("the length of ") + what + " is cut short");
      const std::uint32_t n = get_u32(b);
      if (n > kViewRecordMaxBytes)
        throw fail(at, std::string("the length of ") + what + " is " + std::to_string(n) +
                           " bytes, above the " + std::to_string(kViewRecordMaxBytes) + " a record may have");
      at += 4;
      return n;
    };
    const auto scene_bytes = read_length("the scene message");
    if (!scene_bytes) throw fail(at, "the file ends before the scene message");
    scene_message_.resize(*scene_bytes);
    if (std::fread(scene_message_.data(), 1, *scene_bytes, file_) != *scene_bytes)
      throw fail(at, "the scene message is cut short");
    // Every member is type-checked before it is read: json::value() and get<>() throw a
    // type_error naming no place, which would escape as an unlocated error.
    json_input::SyntaxError syntax;
    const auto scene = json_input::parse<nlohmann::json>(scene_message_, syntax);
    if (scene.is_discarded())
      throw fail(at + syntax.byte,
                 "the scene message is not a numen-view JSON object (" + syntax.reason + ")");
    if (!scene.is_object())
      throw fail(at, "the scene message is not a numen-view JSON object but " +
                         json_input::shown(scene));
    auto bad = [&](const std::string& key, const std::string& what) -> InputError {
      return InputError(path, 0, 0, key, "byte " + std::to_string(at) + ": " + what);
    };
    const auto format = scene.find("format");
    if (format == scene.end())
      throw bad("format", "missing: the scene message is not a numen-view JSON object");
    if (!format->is_string() || *format != "numen-view")
      throw bad("format", json_input::shown(*format) +
                              ", expected string \"numen-view\": not a numen-view scene message");
    const auto version = scene.find("version");
    if (version == scene.end()) throw bad("version", "missing");
    if (!version->is_number_integer() || *version != kViewSceneVersion)
      throw bad("version", "scene message version " + json_input::shown(*version) +
                               ", this reader knows integer " + std::to_string(kViewSceneVersion) +
                               (version->is_number_integer() && *version < kViewSceneVersion
                                    ? " (a recording of an older numen: record the run again "
                                      "with this one)"
                                    : ""));
    const auto layout = scene.find("layout");
    if (layout == scene.end()) throw bad("layout", "missing");
    if (!layout->is_object())
      throw bad("layout", json_input::shown(*layout) + ", expected an object of counts");
    auto count = [&](const char* key) -> std::uint64_t {
      const auto it = layout->find(key);
      const std::string name = std::string("layout.") + key;
      if (it == layout->end())
        throw bad(name, std::string("missing: the scene message's layout has no count \"") +
                            key + "\"");
      if (!it->is_number_unsigned())
        throw bad(name, json_input::shown(*it) + ", expected a count (a whole number >= 0)");
      return it->get<std::uint64_t>();
    };
    const std::uint64_t bodies = count("bodies"), nodes = count("nodes"), axes = count("axes"),
                        grasps = count("grasps"), extra_devices = count("extra_devices"),
                        extra_axes = count("extra_axes"), threads = count("threads"),
                        thread_nodes = count("thread_nodes");
    at += *scene_bytes;

    std::vector<std::byte> buffer;
    while (true) {
      const std::uint64_t record_at = at;
      const auto bytes = read_length("a frame");
      if (!bytes) break;
      buffer.resize(*bytes);
      if (std::fread(buffer.data(), 1, *bytes, file_) != *bytes)
        throw fail(record_at, "frame " + std::to_string(index_.size()) + " is cut short (" +
                                  std::to_string(*bytes) + " bytes announced)");
      platform::StateFrameView view;
      const auto result = platform::StateFrameDecoder::decode(buffer, view);
      if (!result.ok())
        throw fail(at, "frame " + std::to_string(index_.size()) + ": " + result.error);
      const auto& h = view.header();
      if (h.num_bodies != bodies || h.num_nodes != nodes || h.num_axes != axes ||
          h.num_grasps != grasps || h.num_extra_devices != extra_devices ||
          h.num_extra_axes != extra_axes || h.num_threads != threads ||
          h.num_thread_nodes != thread_nodes)
        throw fail(at, "frame " + std::to_string(index_.size()) + " has " + std::to_string(h.num_bodies) +
                           " bodies, " + std::to_string(h.num_nodes) + " nodes, " + std::to_string(h.num_axes) +
                           " axes, " + std::to_string(h.num_grasps) + " graspers, " +
                           std::to_string(h.num_extra_devices) + " other devices of " +
                           std::to_string(h.num_extra_axes) + " axes, " +
                           std::to_string(h.num_threads) + " threads of " +
                           std::to_string(h.num_thread_nodes) + " nodes; the scene message says " +
                           std::to_string(bodies) + ", " + std::to_string(nodes) + ", " +
                           std::to_string(axes) + ", " + std::to_string(grasps) + ", " +
                           std::to_string(extra_devices) + ", " + std::to_string(extra_axes) +
                           ", " + std::to_string(threads) + ", " + std::to_string(thread_nodes));
      if (!index_.empty() && h.period <= index_.back().period)
        throw fail(at, "frame " + std::to_string(index_.size()) + " is period " + std::to_string(h.period) +
                           ", not after the previous frame's " + std::to_string(index_.back().period));
      // frame_at_or_after() searches the times: they must not go back.
      if (!index_.empty() && h.time_ns < index_.back().time_ns)
        throw fail(at, "frame " + std::to_string(index_.size()) + " is at " + std::to_string(h.time_ns) +
                           " ns, before the previous frame's " + std::to_string(index_.back().time_ns) + " ns");
      index_.push_back(Entry{at, *bytes, h.period, h.time_ns});
      at += *bytes;
    }
  } catch (...) {
    std::fclose(file_);
    file_ = nullptr;
    throw;
  }
}

ViewRecordingReader::~ViewRecordingReader() {
  if (file_ != nullptr) std::fclose(file_);
}

void ViewRecordingReader::frame(std::size_t i, std::vector<std::byte>& out) const {
  const Entry& e = index_.at(i);
  out.resize(e.bytes);
  if (std::fseek(file_, static_cast<long>(e.offset), SEEK_SET) != 0 ||
      std::fread(out.data(), 1, e.bytes, file_) != e.bytes)
    throw InputError(path_, 0, 0, "",
                     "byte " + std::to_string(e.offset) + ": frame " + std::to_string(i) +
                         " can no longer be read (the file changed while it was replayed)");
}

std::size_t ViewRecordingReader::frame_at_or_after(std::int64_t t_ns) const noexcept {
  std::size_t lo = 0, hi = index_.size();
  while (lo < hi) {
    const std::size_t mid = lo + (hi - lo) / 2;
    if (index_[mid].time_ns < t_ns) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

}  // namespace numen::sim
