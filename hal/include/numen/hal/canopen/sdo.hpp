#pragma once
/// @file sdo.hpp
/// CANopen service data objects (SDO), CiA 301 §7.2.4: reading (upload) and writing
/// (download) one object dictionary entry of a node, confirmed, over the node's default SDO
/// channel (predefined connection set): client → server on COB-ID 0x600 + node id, server →
/// client on 0x580 + node id, every frame 8 bytes. Expedited transfers carry up to 4 bytes in
/// the initiate frames; segmented transfers carry 7 bytes per segment with an alternating
/// toggle bit. Block transfers (CiA 301 §7.2.4.3.9 ff.) are not implemented: a client never
/// starts one, and numen's server answers their requests with abort 0x05040001.
///
/// This file: the frame layouts (encode/decode of each request and response, byte-exact to
/// CiA 301), the abort codes with their standard names, and SdoClient, the client's state
/// machine. Used at bring-up (configuration, `numen sdo`, `numen scan`), and allocation-free
/// and non-blocking so that the loop may advance one transfer per period. No I/O here: the
/// caller moves frames between the client and a Bus. See docs/sdo.md.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// Base COB-ID of the default server SDO's receive channel (client → server): 0x600 + node.
inline constexpr std::uint32_t kSdoRequestBaseCobId = 0x600;
/// Base COB-ID of the default server SDO's transmit channel (server → client): 0x580 + node.
inline constexpr std::uint32_t kSdoResponseBaseCobId = 0x580;
/// Payload of every SDO frame, bytes (CiA 301: always 8, unused bytes 0).
inline constexpr std::uint8_t kSdoFrameLen = 8;
/// Data bytes of an expedited transfer, at most.
inline constexpr std::size_t kSdoExpeditedMax = 4;
/// Data bytes of one segment, at most.
inline constexpr std::size_t kSdoSegmentMax = 7;

/// COB-ID of requests to node `node_id` (1–127).
constexpr std::uint32_t sdo_request_cob_id(std::uint8_t node_id) noexcept {
  return kSdoRequestBaseCobId + node_id;
}
/// COB-ID of responses from node `node_id` (1–127).
constexpr std::uint32_t sdo_response_cob_id(std::uint8_t node_id) noexcept {
  return kSdoResponseBaseCobId + node_id;
}

/// SDO abort codes, CiA 301 §7.2.4.3.17 (table "SDO abort codes").
struct SdoAbort {
  static constexpr std::uint32_t kToggleBit = 0x05030000;          ///< Toggle bit not alternated.
  static constexpr std::uint32_t kTimeout = 0x05040000;            ///< SDO protocol timed out.
  static constexpr std::uint32_t kCommandSpecifier = 0x05040001;   ///< Command specifier not valid or unknown.
  static constexpr std::uint32_t kBlockSize = 0x05040002;          ///< Invalid block size (block mode).
  static constexpr std::uint32_t kSequenceNumber = 0x05040003;     ///< Invalid sequence number (block mode).
  static constexpr std::uint32_t kCrc = 0x05040004;                ///< CRC error (block mode).
  static constexpr std::uint32_t kOutOfMemory = 0x05040005;        ///< Out of memory.
  static constexpr std::uint32_t kUnsupportedAccess = 0x06010000;  ///< Unsupported access to an object.
  static constexpr std::uint32_t kWriteOnly = 0x06010001;          ///< Attempt to read a write only object.
  static constexpr std::uint32_t kReadOnly = 0x06010002;           ///< Attempt to write a read only object.
  static constexpr std::uint32_t kNoObject = 0x06020000;           ///< Object does not exist in the dictionary.
  static constexpr std::uint32_t kNotMappable = 0x06040041;        ///< Object cannot be mapped to the PDO.
  static constexpr std::uint32_t kPdoLength = 0x06040042;          ///< Mapped objects would exceed the PDO length.
  static constexpr std::uint32_t kParameterIncompatible = 0x06040043;  ///< General parameter incompatibility.
  static constexpr std::uint32_t kInternalIncompatible = 0x06040047;   ///< General internal incompatibility.
  static constexpr std::uint32_t kHardware = 0x06060000;           ///< Access failed due to a hardware error.
  static constexpr std::uint32_t kLengthMismatch = 0x06070010;     ///< Data type / length of service parameter does not match.
  static constexpr std::uint32_t kLengthTooHigh = 0x06070012;      ///< Length of service parameter too high.
  static constexpr std::uint32_t kLengthTooLow = 0x06070013;       ///< Length of service parameter too low.
  static constexpr std::uint32_t kNoSubIndex = 0x06090011;         ///< Sub-index does not exist.
  static constexpr std::uint32_t kInvalidValue = 0x06090030;       ///< Invalid value for parameter (download).
  static constexpr std::uint32_t kValueTooHigh = 0x06090031;       ///< Value written too high (download).
  static constexpr std::uint32_t kValueTooLow = 0x06090032;        ///< Value written too low (download).
  static constexpr std::uint32_t kMaxBelowMin = 0x06090036;        ///< Maximum value is less than minimum value.
  static constexpr std::uint32_t kNoConnection = 0x060A0023;       ///< Resource not available: SDO connection.
  static constexpr std::uint32_t kGeneral = 0x08000000;            ///< General error.
  static constexpr std::uint32_t kCannotStore = 0x08000020;        ///< Data cannot be transferred or stored.
  static constexpr std::uint32_t kLocalControl = 0x08000021;       ///< ... because of local control.
  static constexpr std::uint32_t kDeviceState = 0x08000022;        ///< ... because of the present device state.
  static constexpr std::uint32_t kNoDictionary = 0x08000023;       ///< Object dictionary not present / generation failed.
  static constexpr std::uint32_t kNoData = 0x08000024;             ///< No data available.
};

/// The standard name of abort code `code` (CiA 301 table "SDO abort codes"; static string),
/// e.g. "object does not exist in the object dictionary" for 0x06020000; "unknown abort code"
/// for a code outside the table.
const char* sdo_abort_name(std::uint32_t code) noexcept;

/// The multiplexer of an SDO transfer: which object dictionary entry.
struct SdoAddress {
  std::uint16_t index = 0;    ///< Object index (0x1000–0xFFFF in practice).
  std::uint8_t subindex = 0;  ///< Sub-index.
  friend constexpr bool operator==(SdoAddress, SdoAddress) = default;
};

/// "0x1018:01": an entry as messages and reports name it (allocates: setup and reports only).
std::string to_string(SdoAddress address);

/// What an SDO frame is, by its command specifier and direction.
enum class SdoFrameKind : std::uint8_t {
  kInitiateDownloadRequest,   ///< ccs 1.
  kDownloadSegmentRequest,    ///< ccs 0.
  kInitiateUploadRequest,     ///< ccs 2.
  kUploadSegmentRequest,      ///< ccs 3.
  kInitiateDownloadResponse,  ///< scs 3.
  kDownloadSegmentResponse,   ///< scs 1.
  kInitiateUploadResponse,    ///< scs 2.
  kUploadSegmentResponse,     ///< scs 0.
  kAbort,                     ///< cs 4, either direction.
  kBlock,                     ///< cs 5 or 6 (block upload / download): not implemented.
  kUnknown,                   ///< cs 7.
};

/// One SDO frame, decoded (the fields the kind uses; the others 0).
struct SdoFrame {
  SdoFrameKind kind = SdoFrameKind::kUnknown;
  SdoAddress address;               ///< Initiate frames and aborts.
  bool expedited = false;           ///< Initiate: e bit (data in bytes 4–7).
  bool size_indicated = false;      ///< Initiate: s bit (expedited: n valid; else bytes 4–7 = size).
  bool toggle = false;              ///< Segments: t bit.
  bool last = false;                ///< Segments: c bit (no more segments).
  std::uint32_t size = 0;           ///< Initiate, segmented with s: the total size, bytes.
  std::uint32_t abort_code = 0;     ///< Abort: the code.
  std::uint8_t data_len = 0;        ///< Expedited or segment: data bytes in `data`.
  std::uint8_t data[kSdoSegmentMax] = {};  ///< Expedited (≤ 4) or segment (≤ 7) data.
};

/// Outcome of decode_sdo().
enum class SdoDecodeStatus : std::uint8_t {
  kOk,            ///< Decoded.
  kWrongId,       ///< Not the channel asked for (or an error report / 29-bit frame).
  kNotDataFrame,  ///< On the channel but remote or CAN FD.
  kWrongLength,   ///< Not 8 bytes.
};

/// Decodes `frame` as an SDO frame of the channel `cob_id` (0x580 + node for responses, 0x600 +
/// node for requests; the direction decides how the command specifier reads). `out` is
/// unchanged unless kOk. A frame with an unknown specifier decodes as kUnknown or kBlock
/// (the caller aborts with kCommandSpecifier).
SdoDecodeStatus decode_sdo(const CanFrame& frame, std::uint32_t cob_id, SdoFrame& out) noexcept;

/// Encodes `f` as the 8-byte frame on `cob_id` stamped `timestamp_ns`. Field ranges: an
/// expedited initiate or a segment carries f.data_len bytes (1–4, 0–7); unused bytes are 0.
/// Returns false (out unchanged) for a kind that cannot be encoded (kBlock, kUnknown) or a
/// data length out of range.
bool encode_sdo(const SdoFrame& f, std::uint32_t cob_id, std::int64_t timestamp_ns,
                CanFrame& out) noexcept;

/// State of an SdoClient's transfer.
enum class SdoStatus : std::uint8_t {
  kIdle,     ///< No transfer started yet.
  kPending,  ///< A transfer runs: requests to send or a response awaited.
  kDone,     ///< The last transfer completed (upload: transferred() bytes in the buffer).
  kAborted,  ///< The last transfer was aborted: abort_code(), aborted_by_server().
};

/// Short English name of an SdoStatus (static string).
const char* to_string(SdoStatus status) noexcept;

/// Counters of an SdoClient since construction.
struct SdoClientCounters {
  std::uint64_t transfers = 0;          ///< Transfers started.
  std::uint64_t completed = 0;          ///< Transfers that completed.
  std::uint64_t server_aborts = 0;      ///< Transfers the server aborted.
  std::uint64_t client_aborts = 0;      ///< Transfers this client aborted (protocol error, cancel).
  std::uint64_t timeouts = 0;           ///< Transfers aborted by the response timeout.
  std::uint64_t frames_ignored = 0;     ///< Frames on the response channel with no transfer pending.
  std::uint64_t frames_malformed = 0;   ///< Remote / FD / short frames on the response channel.
};

/// The client side of one node's default SDO channel, one transfer at a time (CiA 301 allows
/// one per channel). Usage, per transfer: start_upload() or start_download(); then, until
/// status() is no longer kPending, send what take_request() gives, feed every received frame
/// to on_frame(), and call poll(now) to time out a silent server. A protocol error (wrong
/// specifier, multiplexer or toggle, a size beyond the buffer) aborts the transfer: the abort
/// request to send is then given by take_request().
///
/// Every member is noexcept and allocation-free; the buffers are the caller's and must outlive
/// the transfer. Not thread-safe: one thread (the loop's, or the bring-up code's).
class SdoClient {
 public:
  /// Client of node `server_node` (1–127; other values: every start_* returns false),
  /// aborting with 0x05040000 when a response takes more than `timeout_ns` (> 0; CiA 301
  /// leaves it to the application: 500 ms is common, numen's default).
  explicit SdoClient(std::uint8_t server_node, std::int64_t timeout_ns = 500'000'000) noexcept;

  /// Starts reading `address` into `buffer` at time `now_ns`. False (nothing started) while
  /// a transfer is pending or for an invalid node.
  bool start_upload(SdoAddress address, std::span<std::uint8_t> buffer, std::int64_t now_ns) noexcept;
  /// Starts writing `data` (1 byte or more) to `address`: expedited up to 4 bytes, segmented
  /// above. False (nothing started) while a transfer is pending, for an invalid node or empty
  /// data.
  bool start_download(SdoAddress address, std::span<const std::uint8_t> data,
                      std::int64_t now_ns) noexcept;
  /// Aborts the pending transfer with `code` (an abort request is queued). No-op when idle.
  void cancel(std::uint32_t code, std::int64_t now_ns) noexcept;

  /// The next request to send, stamped `now_ns`; false if there is none. Sending it starts
  /// the response timeout.
  bool take_request(CanFrame& out, std::int64_t now_ns) noexcept;
  /// Takes a received frame. True if it was on this client's response channel (0x580 + node),
  /// whether it was used, ignored (no transfer pending) or aborted the transfer.
  bool on_frame(const CanFrame& frame) noexcept;
  /// Aborts the pending transfer (0x05040000) if its response is more than timeout_ns late.
  void poll(std::int64_t now_ns) noexcept;

  /// The state of the current (or last) transfer.
  SdoStatus status() const noexcept { return status_; }
  /// The abort code of an aborted transfer (0 otherwise).
  std::uint32_t abort_code() const noexcept { return abort_code_; }
  /// True when the server sent the abort (false: this client aborted).
  bool aborted_by_server() const noexcept { return aborted_by_server_; }
  /// Bytes transferred so far (upload: written into the buffer).
  std::size_t transferred() const noexcept { return done_; }
  /// Upload: the size the server announced (0 if it did not).
  std::size_t announced_size() const noexcept { return announced_; }
  /// The entry of the current (or last) transfer.
  SdoAddress address() const noexcept { return address_; }
  /// The server node.
  std::uint8_t server_node() const noexcept { return node_; }
  /// Counters since construction.
  const SdoClientCounters& counters() const noexcept { return counters_; }

 private:
  enum class Phase : std::uint8_t { kNone, kInitiateUpload, kUploadSegment, kInitiateDownload, kDownloadSegment };
  void begin(SdoAddress address, Phase phase, std::int64_t now_ns) noexcept;
  void queue(const SdoFrame& f) noexcept;
  /// Ends the transfer with `code`, queues the abort request, counts it in `counter`.
  void abort_local(std::uint32_t code, std::uint64_t& counter) noexcept;
  void abort_local(std::uint32_t code) noexcept { abort_local(code, counters_.client_aborts); }
  void finish() noexcept;
  void on_upload_response(const SdoFrame& f) noexcept;
  void on_download_response(const SdoFrame& f) noexcept;
  void queue_download_segment() noexcept;

  std::uint8_t node_ = 0;
  std::int64_t timeout_ns_ = 0;
  SdoStatus status_ = SdoStatus::kIdle;
  Phase phase_ = Phase::kNone;
  SdoAddress address_;
  std::span<std::uint8_t> upload_;
  std::span<const std::uint8_t> download_;
  std::size_t done_ = 0;
  std::size_t announced_ = 0;
  bool toggle_ = false;
  bool awaiting_ = false;       // a request was sent and its response is awaited
  std::int64_t sent_ns_ = 0;    // when that request was taken
  bool have_request_ = false;   // queued request not yet taken
  SdoFrame request_;
  bool final_after_send_ = false;  // the queued request is an abort: no response follows
  std::uint32_t abort_code_ = 0;
  bool aborted_by_server_ = false;
  SdoClientCounters counters_;
};

}  // namespace numen::hal
