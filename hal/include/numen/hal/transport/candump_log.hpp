#pragma once
/// @file candump_log.hpp
/// The log file format of can-utils' `candump -l` (read by `canplayer` and `log2asc`): one
/// frame per line,
///
///     (SECONDS.MICROSECONDS) IFACE FRAME[ DIR]
///     (1436509052.249713) vcan0 123#DEADBEEF
///
/// FRAME is the compact text of can-utils lib.c (`sprint_canframe` / `parse_canframe`):
///  - `123#DEADBEEF`      standard (11-bit) id, 3 hex digits; 0–8 data bytes, 2 hex digits each;
///  - `12345678#0102`     extended (29-bit) id, 8 hex digits;
///  - `123#R`, `123#R4`   remote request, optionally with its length digit 1–8;
///  - `123##1AABB`        CAN FD: `##`, one flags nibble (BRS 0x1, ESI 0x2), 0–64 data bytes
///                        (a valid FD length);
///  - `20000004#0004...`  error report: CAN_ERR_FLAG 0x20000000 in the 8-digit id, error
///                        class in the low 29 bits (linux/can/error.h).
/// Output is upper-case hex without separators, seconds zero padded to 10 digits (as candump
/// writes them); input also accepts lower case and '.' between data bytes (lib.c). DIR is
/// the optional ` R` / ` T` marker of `candump -x` (received / transmitted), which canplayer
/// ignores. Not supported, rejected with a clear error: Classic CAN raw DLC 9–15 (`_` suffix,
/// len8_dlc) and CAN XL frames (5-digit priority id, `###`).
///
/// The line codec is noexcept and allocation free (usable on the real-time path);
/// load_candump_log() is setup code.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/transport/line_reader.hpp"

namespace numen::hal {

/// Longest interface name, characters: IFNAMSIZ − 1 (linux/if.h); canplayer refuses longer.
inline constexpr std::size_t kCandumpMaxIfaceLength = 15;

/// Longest line format_candump_line() writes, characters, without the terminating NUL:
/// "(" 10 "." 6 ")" + " " + 15-char iface + " " + 8-digit id "##" flags + 64 bytes + " T".
inline constexpr std::size_t kCandumpMaxLineLength =
    19 + 1 + kCandumpMaxIfaceLength + 1 + (8 + 2 + 1 + 2 * kMaxFdLen) + 2;
/// Buffer size that always suffices for format_candump_line() (line + NUL).
inline constexpr std::size_t kCandumpLineBufferSize = kCandumpMaxLineLength + 1;

/// CAN_ERR_FLAG of linux/can.h: marks an error report in the 32-bit id of the text format.
inline constexpr std::uint32_t kCandumpErrorFlag = 0x20000000u;

/// An interface name stored inline (no heap): 1–15 printable ASCII characters, none of them
/// whitespace, '/', ':' (refused by Linux) or '#' (reserved: it marks the frame field).
struct CandumpIface {
  std::array<char, kCandumpMaxIfaceLength> chars{};  ///< The name; bytes >= size are zero.
  std::uint8_t size = 0;                             ///< Characters in use, 1–15 (0: unset).

  /// The name as a view into `chars`.
  std::string_view view() const noexcept { return {chars.data(), size}; }
  friend bool operator==(const CandumpIface& a, const CandumpIface& b) noexcept {
    return a.view() == b.view();
  }
};

/// Sets `out` to `name` if it is a valid interface name (see CandumpIface); returns false
/// and leaves `out` unchanged otherwise. noexcept, no allocation.
bool to_candump_iface(std::string_view name, CandumpIface& out) noexcept;

/// The interface name `name`; throws std::invalid_argument naming `what` and the rule broken.
/// Setup code.
CandumpIface make_candump_iface(std::string_view name, const char* what = "interface name");

/// Direction marker of a log line (`candump -x`: " R" received, " T" transmitted).
enum class CandumpDirection : std::uint8_t {
  kUnmarked,     ///< No marker (plain `candump -l` output).
  kReceived,     ///< " R": the frame was read from the bus.
  kTransmitted,  ///< " T": the frame was written to the bus by the logging node.
};

/// One log line.
struct CandumpRecord {
  /// Log time, ns since the epoch of the recording's clock (candump: CLOCK_REALTIME; numen:
  /// the bus clock, see bus_recorder.hpp). Microsecond resolution (the format's).
  std::int64_t timestamp_ns = 0;
  /// Interface the frame was seen on.
  CandumpIface iface;
  /// The frame; its timestamp_ns equals `timestamp_ns`.
  CanFrame frame;
  /// Direction marker, if the line had one.
  CandumpDirection direction = CandumpDirection::kUnmarked;
};

/// Why format_candump_line() wrote nothing.
enum class CandumpFormatError : std::uint8_t {
  kNone,               ///< Line written.
  kBufferTooSmall,     ///< `out` cannot hold the line and its NUL (kCandumpLineBufferSize does).
  kNegativeTimestamp,  ///< timestamp_ns < 0: the format has no sign.
  kBadIface,           ///< `iface` is unset (size 0) or holds an invalid name.
  kMalformedFrame,     ///< check_frame(frame) != FrameError::kNone.
  kErrorFrameFlags,    ///< An error report flagged remote, FD, BRS or ESI (SocketCAN error
                       ///< frames are classic data frames).
};

/// Outcome of format_candump_line().
struct CandumpFormatResult {
  CandumpFormatError error = CandumpFormatError::kNone;
  /// Characters written, without the NUL; 0 unless error == kNone.
  std::size_t length = 0;
  bool ok() const noexcept { return error == CandumpFormatError::kNone; }
};

/// Writes the log line of `frame` (without a line feed) and a terminating NUL into `out`:
/// `(SSSSSSSSSS.UUUUUU) IFACE FRAME` plus " R" / " T" for a marked direction. `timestamp_ns`
/// is truncated to microseconds; frame.timestamp_ns is not used. An error frame prints its id
/// as 0x20000000 | (id & 0x1FFFFFFF) with 8 digits; a remote request prints `R` plus its
/// length digit when len is 1–8 (lib.c). Hex is upper case, without '.' separators.
/// noexcept, no allocation; on error `out` is left unspecified and nothing is returned.
CandumpFormatResult format_candump_line(std::int64_t timestamp_ns, const CandumpIface& iface,
                                        const CanFrame& frame, CandumpDirection direction,
                                        std::span<char> out) noexcept;

/// What is wrong with a log line (parse_candump_line()). The column says where.
enum class CandumpError : std::uint8_t {
  kNone,                  ///< Parsed.
  kMissingOpenParen,      ///< The line does not start with '('.
  kBadTimestamp,          ///< Not `digits.6digits`.
  kTimestampOutOfRange,   ///< More than int64 nanoseconds (year 2262).
  kMissingCloseParen,     ///< No ')' after the timestamp.
  kMissingIface,          ///< No interface name before the frame.
  kIfaceTooLong,          ///< Interface name longer than 15 characters (IFNAMSIZ − 1).
  kBadIface,              ///< Interface name with a character Linux refuses ('/', ':').
  kMissingFrame,          ///< Nothing after the interface name.
  kBadId,                 ///< Identifier not 3 or 8 hex digits, or a non-hex character in it.
  kIdTooLong,             ///< More than 8 identifier digits.
  kIdOutOfRange,          ///< 3 digits above 0x7FF, or 8 digits above 0x1FFFFFFF (besides
                          ///< the error flag 0x20000000).
  kMissingIdDelimiter,    ///< No '#' after the identifier.
  kBadHexDigit,           ///< A data character that is neither a hex digit nor one '.'.
  kOddHexDigits,          ///< A data byte with one hex digit only.
  kDataTooLong,           ///< More than 8 data bytes (classic) or 64 (FD).
  kInvalidFdLength,       ///< FD payload of 9–63 bytes that is not 12, 16, 20, 24, 32 or 48.
  kBadFdFlags,            ///< Missing or non-hex flags nibble after `##`, or bit 0x8 set
                          ///< (defined: BRS 0x1, ESI 0x2, FDF 0x4).
  kBadRemoteLength,       ///< After `R`: anything but one length digit 0–8.
  kLen8DlcUnsupported,    ///< `_` raw DLC 9–15 after 8 bytes (len8_dlc): not supported.
  kCanXlUnsupported,      ///< CAN XL frame (5-digit priority id or `###`): not supported.
  kErrorFrameNotClassic,  ///< Error report written as remote request or FD frame.
  kTrailingText,          ///< Something after the frame other than one `R` / `T` marker.
};

/// Outcome of parse_candump_line().
struct CandumpParseResult {
  CandumpError error = CandumpError::kNone;
  /// 1-based column (byte) of the offending character; one past the end of the line when
  /// something is missing there. 0 when error == kNone.
  std::size_t column = 0;
  bool ok() const noexcept { return error == CandumpError::kNone; }
};

/// Parses one log line (a trailing "\n" or "\r\n" is allowed) into `record`, which is
/// changed only on success. Stricter than canplayer (sscanf plus lib.c parse_canframe,
/// which silently drops what it cannot use): exactly 6 fraction digits, id range, data
/// length, flags nibble and trailing text are checked. Spaces or tabs separate the fields
/// (candump pads the interface name to the longest one). noexcept, no allocation.
CandumpParseResult parse_candump_line(std::string_view line, CandumpRecord& record) noexcept;

/// Short English description of a CandumpError (static string).
const char* to_string(CandumpError error) noexcept;
/// Short English description of a CandumpFormatError (static string).
const char* to_string(CandumpFormatError error) noexcept;

/// Line counts of one load_candump_log() call.
struct CandumpLoadStats {
  std::size_t lines = 0;    ///< Lines in the file.
  std::size_t records = 0;  ///< Frame lines loaded.
  std::size_t skipped = 0;  ///< Blank lines, '#' comments and DROPCOUNT notes.
  /// candump's "DROPCOUNT: dropped N CAN frame(s) ..." notes: the recording itself lost
  /// frames (the socket's receive queue overflowed while candump wrote the log).
  std::size_t drop_notes = 0;
  /// Sum of N over the DROPCOUNT notes: frames the recording lost. N is candump's 32-bit
  /// counter: a note whose N does not fit in 32 bits, or a sum beyond int64, is an error at
  /// the note's line and the column of N.
  std::uint64_t dropped_frames = 0;
  /// Records earlier than the latest record before them, on another interface or direction
  /// (a stream of its own; within the allowed CandumpLoadLimits::max_gap_ns), or on the same
  /// one by at most CandumpLoadLimits::max_backward_ns. LogBus replays each such record
  /// together with its predecessor.
  std::size_t out_of_order = 0;
};

/// Plausibility limits of the record times of a log (load_candump_log()).
struct CandumpLoadLimits {
  /// Largest step, ns (> 0), of a record's time away from the latest record time before it,
  /// forward or back. Default 1 h: a recording with an hour of silence between two frames,
  /// or a timestamp 9e9 s ahead, is a broken or spliced log (replay would stall), not a
  /// control session.
  std::int64_t max_gap_ns = 3'600'000'000'000;
  /// Largest step back, ns (>= 0), of a record's time against the previous record of the same
  /// interface and direction (a stream). Default 0: can-utils' candump writes each
  /// interface's frames in kernel receive order, and numen's recorder each direction in call
  /// order, so a stream's times never decrease; a step back means an edited or spliced log,
  /// or a wall-clock step during a candump recording (raise the limit to load such a log).
  std::int64_t max_backward_ns = 0;
};

/// Longest line CandumpLogReader (and load_candump_log()) reads, bytes, without the line
/// feed. A record is at most kCandumpMaxLineLength characters plus the blanks between its
/// fields; a longer line that is not a '#' comment or a DROPCOUNT note is an error at column
/// kCandumpMaxReadLine + 1 (a comment or note is skipped whatever its length). Bounds the
/// reader's memory.
inline constexpr std::size_t kCandumpMaxReadLine = 65536;

/// Reads a candump log one record at a time, in constant memory (a LineReader's fixed
/// 128 KiB buffer and one entry per interface and direction seen), with the checks of load_candump_log(): line
/// syntax, record time plausibility against CandumpLoadLimits, skipped lines counted. Setup
/// code or a reader thread (LogBus streaming replay): allocates and throws. Not thread safe.
class CandumpLogReader {
 public:
  /// Opens `path`. Throws std::invalid_argument if `limits` are out of range,
  /// std::runtime_error "path: cannot open: <errno text>" if the file cannot be read.
  explicit CandumpLogReader(std::string path, const CandumpLoadLimits& limits = {});
  ~CandumpLogReader();
  CandumpLogReader(const CandumpLogReader&) = delete;
  CandumpLogReader& operator=(const CandumpLogReader&) = delete;

  /// Reads up to the next record: true with `record` set, false at the end of the file (an
  /// empty log is not refused here: stats().records says how many were read). Throws
  /// std::runtime_error "path:line:column: <what>" for a bad line (load_candump_log()) and
  /// "path:line: read error: <errno text>" if reading fails.
  bool next(CandumpRecord& record);
  /// Counts so far (records read, lines, skipped lines, DROPCOUNT notes, out of order).
  const CandumpLoadStats& stats() const noexcept { return counts_; }
  /// The path as given.
  const std::string& path() const noexcept { return path_; }

 private:
  struct StreamTime;  // latest time of one interface and direction
  std::runtime_error located(std::size_t column, const std::string& what) const;

  std::string path_;
  CandumpLoadLimits limits_;
  LineReader lines_;
  CandumpLoadStats counts_;
  std::vector<StreamTime> streams_;
  std::int64_t latest_ns_ = 0;
  std::size_t latest_line_ = 0;
};

/// Reads a whole candump log into memory (setup code). Stricter than canplayer, which
/// silently skips every line not starting with '(': only blank lines, '#' comments and the
/// "DROPCOUNT: ..." notes candump writes into its log are skipped (the notes are counted in
/// `stats`); every other line must parse as a record. The record times are checked against
/// `limits` (CandumpLoadLimits): a step of more than max_gap_ns from the latest time so far,
/// or a step back within one interface and direction of more than max_backward_ns, is an
/// error at the offending line. A log without any record (empty, only comments) is an error.
/// Throws std::runtime_error "path: cannot open: <errno text>", "path: no frame records ..."
/// or "path:line:column: <what>" for the first bad line (CandumpLogReader). Memory:
/// sizeof(CandumpRecord) (~112 bytes) per frame: to replay a large log, give its path to
/// LogBus (log_bus.hpp), which streams it. Throws std::invalid_argument if `limits` are out
/// of range.
std::vector<CandumpRecord> load_candump_log(const std::string& path,
                                            CandumpLoadStats* stats = nullptr,
                                            const CandumpLoadLimits& limits = {});

}  // namespace numen::hal
