#pragma once
/// @file sdo_server.hpp
/// The server side of a node's default SDO channel (CiA 301 §7.2.4), serving an
/// ObjectDictionary: expedited and segmented upload and download, the toggle bit checked, one
/// transfer at a time; block transfers and unknown command specifiers are answered with abort
/// 0x05040001. numen's emulated devices answer SDO with it (the counterpart of SdoClient in
/// tests and on the simulated bus). Every member but the constructor is noexcept and
/// allocation-free.

#include <cstdint>
#include <vector>

#include "numen/hal/canopen/sdo.hpp"
#include "numen/hal/emulation/object_dictionary.hpp"
#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// Counters of an SdoServer since construction.
struct SdoServerCounters {
  std::uint64_t requests = 0;         ///< SDO requests taken (frames on 0x600 + node).
  std::uint64_t uploads = 0;          ///< Uploads completed.
  std::uint64_t downloads = 0;        ///< Downloads completed (the dictionary written).
  std::uint64_t aborts_sent = 0;      ///< Aborts this server sent.
  std::uint64_t aborts_received = 0;  ///< Aborts the client sent.
  std::uint64_t frames_malformed = 0; ///< Remote / FD / not-8-byte frames on the channel.
};

/// Serves `dictionary` (not owned; must outlive the server) as node `node_id` (1–127).
class SdoServer {
 public:
  /// Allocates the staging buffer of segmented downloads (the dictionary's largest entry).
  SdoServer(std::uint8_t node_id, ObjectDictionary& dictionary);

  /// Takes a frame; true if it was on this server's request channel (0x600 + node). A
  /// response (or an abort) is then available from take_response().
  bool on_frame(const CanFrame& frame) noexcept;
  /// The response to send, stamped `now_ns`; false if none.
  bool take_response(CanFrame& out, std::int64_t now_ns) noexcept;
  /// Counters since construction.
  const SdoServerCounters& counters() const noexcept { return counters_; }

 private:
  enum class Phase : std::uint8_t { kIdle, kUpload, kDownload };
  void respond(const SdoFrame& f) noexcept;
  void abort(SdoAddress address, std::uint32_t code) noexcept;
  void on_initiate_upload(const SdoFrame& f) noexcept;
  void on_upload_segment(const SdoFrame& f) noexcept;
  void on_initiate_download(const SdoFrame& f) noexcept;
  void on_download_segment(const SdoFrame& f) noexcept;

  std::uint8_t node_;
  ObjectDictionary* od_;
  Phase phase_ = Phase::kIdle;
  SdoAddress address_;
  const OdEntry* entry_ = nullptr;      // upload
  std::size_t offset_ = 0;
  bool toggle_ = false;
  std::size_t size_ = 0;                // download: announced size (0: not indicated)
  std::vector<std::uint8_t> staging_;   // download: segments gathered here, capacity fixed
  std::size_t staged_ = 0;
  bool have_response_ = false;
  SdoFrame response_;
  SdoServerCounters counters_;
};

}  // namespace numen::hal
