/// @file candump_log.cpp
/// candump log lines (can-utils lib.c text format): formatter, parser, file loader.

#include "numen/hal/transport/candump_log.hpp"

#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <utility>

#include "../text_chars.hpp"

namespace numen::hal {
namespace {

constexpr char kHexUpper[] = "0123456789ABCDEF";

using detail::hex_value;
using detail::is_blank;
using detail::is_digit;

// Characters of an interface name: printable ASCII without space, and not '/', ':' (Linux
// dev_valid_name) or '#' (reserved for the frame field).
constexpr bool is_iface_char(char c) noexcept {
  return c > ' ' && c < 0x7F && c != '/' && c != ':' && c != '#';
}

// Largest whole second count whose nanoseconds fit in int64.
constexpr std::int64_t kMaxSeconds = std::numeric_limits<std::int64_t>::max() / 1'000'000'000;

// Appends characters to a fixed buffer; remembers overflow instead of writing past the end.
class Writer {
 public:
  explicit Writer(std::span<char> out) noexcept : out_(out) {}
  void put(char c) noexcept {
    if (pos_ < out_.size()) out_[pos_] = c;
    ++pos_;
  }
  void put(std::string_view s) noexcept {
    for (char c : s) put(c);
  }
  // `digits` upper-case hex digits of `value`, most significant first.
  void hex(std::uint32_t value, int digits) noexcept {
    for (int d = digits - 1; d >= 0; --d) put(kHexUpper[(value >> (4 * d)) & 0xFu]);
  }
  // `digits` decimal digits of `value`, zero padded (value < 10^digits).
  void decimal(std::uint64_t value, int digits) noexcept {
    char tmp[20];
    for (int d = digits - 1; d >= 0; --d) {
      tmp[d] = static_cast<char>('0' + value % 10);
      value /= 10;
    }
    for (int d = 0; d < digits; ++d) put(tmp[d]);
  }
  std::size_t size() const noexcept { return pos_; }

 private:
  std::span<char> out_;
  std::size_t pos_ = 0;
};

CandumpParseResult fail(CandumpError error, std::size_t index) noexcept {
  return CandumpParseResult{error, index + 1};
}

// Parses the frame field line[begin, end) into `frame`.
CandumpParseResult parse_frame(std::string_view line, std::size_t begin, std::size_t end,
                               CanFrame& frame) noexcept {
  // Identifier: hex digits up to '#'.
  std::size_t k = begin;
  std::uint32_t id = 0;
  while (k < end && hex_value(line[k]) >= 0) {
    if (k - begin == 8) return fail(CandumpError::kIdTooLong, k);
    id = (id << 4) | static_cast<std::uint32_t>(hex_value(line[k]));
    ++k;
  }
  if (k == end) return fail(CandumpError::kMissingIdDelimiter, k);
  if (line[k] != '#') return fail(CandumpError::kBadId, k);
  const std::size_t digits = k - begin;
  if (digits == 5) return fail(CandumpError::kCanXlUnsupported, begin);  // XL priority/VCID
  if (digits != 3 && digits != 8) return fail(CandumpError::kBadId, begin);
  if (digits == 3) {
    if (id > kStandardIdMask) return fail(CandumpError::kIdOutOfRange, begin);
    frame.id = id;
  } else if ((id & kCandumpErrorFlag) != 0) {
    if ((id & ~(kCandumpErrorFlag | kExtendedIdMask)) != 0) {
      return fail(CandumpError::kIdOutOfRange, begin);
    }
    frame.id = id & kExtendedIdMask;
    frame.flags |= CanFlag::kErrorFrame;
  } else {
    if (id > kExtendedIdMask) return fail(CandumpError::kIdOutOfRange, begin);
    frame.id = id;
    frame.flags |= CanFlag::kExtendedId;
  }
  const std::size_t id_delim = k;
  ++k;

  // Remote request: R, optional length digit 0-8.
  if (k < end && (line[k] == 'R' || line[k] == 'r')) {
    if (frame.error_frame()) return fail(CandumpError::kErrorFrameNotClassic, k);
    frame.flags |= CanFlag::kRemote;
    ++k;
    if (k < end && line[k] >= '0' && line[k] <= '8') {
      frame.len = static_cast<std::uint8_t>(line[k] - '0');
      ++k;
      if (k < end && line[k] == '_' && frame.len == kMaxClassicLen) {
        return fail(CandumpError::kLen8DlcUnsupported, k);
      }
    }
    if (k < end) return fail(CandumpError::kBadRemoteLength, k);
    return {};
  }

  // CAN FD: '#', flags nibble.
  std::size_t max_len = kMaxClassicLen;
  if (k < end && line[k] == '#') {
    if (k + 1 < end && line[k + 1] == '#') return fail(CandumpError::kCanXlUnsupported, id_delim);
    if (frame.error_frame()) return fail(CandumpError::kErrorFrameNotClassic, k);
    ++k;
    const int nibble = k < end ? hex_value(line[k]) : -1;
    if (nibble < 0 || (nibble & 0x8) != 0) return fail(CandumpError::kBadFdFlags, k);
    frame.flags |= CanFlag::kFd;
    if ((nibble & 0x1) != 0) frame.flags |= CanFlag::kBitRateSwitch;
    if ((nibble & 0x2) != 0) frame.flags |= CanFlag::kErrorStateIndicator;
    // 0x4 (CANFD_FDF, set by newer kernels) is implied by '##'.
    ++k;
    max_len = kMaxFdLen;
  }

  // Data bytes, each optionally preceded by one '.'; one trailing '.' allowed (lib.c).
  const std::size_t data_begin = k;
  std::size_t count = 0;
  while (k < end) {
    if (line[k] == '.') {
      ++k;
      if (k == end) break;
    }
    if (count == max_len) {
      if (!frame.fd() && line[k] == '_') return fail(CandumpError::kLen8DlcUnsupported, k);
      return fail(CandumpError::kDataTooLong, k);
    }
    const int hi = hex_value(line[k]);
    if (hi < 0) return fail(CandumpError::kBadHexDigit, k);
    if (k + 1 == end || line[k + 1] == '.') return fail(CandumpError::kOddHexDigits, k);
    const int lo = hex_value(line[k + 1]);
    if (lo < 0) return fail(CandumpError::kBadHexDigit, k + 1);
    frame.data[count++] = static_cast<std::uint8_t>((hi << 4) | lo);
    k += 2;
  }
  if (frame.fd() && !is_valid_fd_length(static_cast<std::uint8_t>(count))) {
    return fail(CandumpError::kInvalidFdLength, data_begin);
  }
  frame.len = static_cast<std::uint8_t>(count);
  return {};
}

}  // namespace

bool to_candump_iface(std::string_view name, CandumpIface& out) noexcept {
  if (name.empty() || name.size() > kCandumpMaxIfaceLength) return false;
  for (char c : name) {
    if (!is_iface_char(c)) return false;
  }
  CandumpIface iface;
  for (std::size_t i = 0; i < name.size(); ++i) iface.chars[i] = name[i];
  iface.size = static_cast<std::uint8_t>(name.size());
  out = iface;
  return true;
}

CandumpIface make_candump_iface(std::string_view name, const char* what) {
  CandumpIface iface;
  if (!to_candump_iface(name, iface)) {
    throw std::invalid_argument(std::string(what) + " '" + std::string(name) +
                                "' must be 1-15 printable characters without whitespace, "
                                "'/', ':' or '#'");
  }
  return iface;
}

CandumpFormatResult format_candump_line(std::int64_t timestamp_ns, const CandumpIface& iface,
                                        const CanFrame& frame, CandumpDirection direction,
                                        std::span<char> out) noexcept {
  if (timestamp_ns < 0) return {CandumpFormatError::kNegativeTimestamp, 0};
  CandumpIface checked;
  if (iface.size > kCandumpMaxIfaceLength || !to_candump_iface(iface.view(), checked)) {
    return {CandumpFormatError::kBadIface, 0};
  }
  if (check_frame(frame) != FrameError::kNone) return {CandumpFormatError::kMalformedFrame, 0};
  if (frame.error_frame() &&
      (frame.flags & (CanFlag::kRemote | CanFlag::kFd | CanFlag::kBitRateSwitch |
                      CanFlag::kErrorStateIndicator)) != 0) {
    return {CandumpFormatError::kErrorFrameFlags, 0};
  }

  Writer w(out);
  const auto t = static_cast<std::uint64_t>(timestamp_ns);
  w.put('(');
  w.decimal(t / 1'000'000'000u, 10);  // int64 seconds have at most 10 digits
  w.put('.');
  w.decimal((t % 1'000'000'000u) / 1000u, 6);
  w.put(") ");
  w.put(iface.view());
  w.put(' ');

  if (frame.error_frame()) {
    w.hex(kCandumpErrorFlag | (frame.id & kExtendedIdMask), 8);
  } else if (frame.extended()) {
    w.hex(frame.id, 8);
  } else {
    w.hex(frame.id, 3);
  }
  w.put('#');
  if (frame.remote()) {
    w.put('R');
    if (frame.len >= 1 && frame.len <= kMaxClassicLen) w.put(static_cast<char>('0' + frame.len));
  } else {
    if (frame.fd()) {
      std::uint32_t nibble = 0;
      if ((frame.flags & CanFlag::kBitRateSwitch) != 0) nibble |= 0x1;
      if ((frame.flags & CanFlag::kErrorStateIndicator) != 0) nibble |= 0x2;
      w.put('#');
      w.hex(nibble, 1);
    }
    for (std::size_t i = 0; i < frame.len; ++i) w.hex(frame.data[i], 2);
  }
  if (direction == CandumpDirection::kReceived) w.put(" R");
  if (direction == CandumpDirection::kTransmitted) w.put(" T");

  const std::size_t length = w.size();
  if (length + 1 > out.size()) return {CandumpFormatError::kBufferTooSmall, 0};
  out[length] = '\0';
  return {CandumpFormatError::kNone, length};
}

CandumpParseResult parse_candump_line(std::string_view line, CandumpRecord& record) noexcept {
  if (!line.empty() && line.back() == '\n') line.remove_suffix(1);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  const std::size_t n = line.size();
  CandumpRecord rec;

  // (seconds.microseconds)
  if (n == 0 || line[0] != '(') return fail(CandumpError::kMissingOpenParen, 0);
  std::size_t i = 1;
  const std::size_t sec_begin = i;
  std::int64_t seconds = 0;
  while (i < n && is_digit(line[i])) {
    seconds = seconds * 10 + (line[i] - '0');
    if (seconds > kMaxSeconds) return fail(CandumpError::kTimestampOutOfRange, sec_begin);
    ++i;
  }
  if (i == sec_begin || i == n || line[i] != '.') return fail(CandumpError::kBadTimestamp, i);
  ++i;
  const std::size_t frac_begin = i;
  std::int64_t micros = 0;
  while (i < n && is_digit(line[i])) {
    if (i - frac_begin == 6) return fail(CandumpError::kBadTimestamp, i);
    micros = micros * 10 + (line[i] - '0');
    ++i;
  }
  if (i - frac_begin != 6) return fail(CandumpError::kBadTimestamp, i);
  if (i == n || line[i] != ')') return fail(CandumpError::kMissingCloseParen, i);
  ++i;
  if (seconds == kMaxSeconds &&
      micros * 1000 > std::numeric_limits<std::int64_t>::max() - kMaxSeconds * 1'000'000'000) {
    return fail(CandumpError::kTimestampOutOfRange, sec_begin);
  }
  rec.timestamp_ns = seconds * 1'000'000'000 + micros * 1000;

  // Interface name.
  while (i < n && is_blank(line[i])) ++i;
  const std::size_t iface_begin = i;
  while (i < n && !is_blank(line[i])) ++i;
  const std::string_view iface = line.substr(iface_begin, i - iface_begin);
  if (iface.empty() || iface.find('#') != std::string_view::npos) {
    return fail(CandumpError::kMissingIface, iface_begin);  // a frame where the name belongs
  }
  if (iface.size() > kCandumpMaxIfaceLength) {
    return fail(CandumpError::kIfaceTooLong, iface_begin + kCandumpMaxIfaceLength);
  }
  for (std::size_t c = 0; c < iface.size(); ++c) {
    if (!is_iface_char(iface[c])) return fail(CandumpError::kBadIface, iface_begin + c);
  }
  to_candump_iface(iface, rec.iface);

  // Frame.
  while (i < n && is_blank(line[i])) ++i;
  if (i == n) return fail(CandumpError::kMissingFrame, i);
  const std::size_t frame_begin = i;
  while (i < n && !is_blank(line[i])) ++i;
  const CandumpParseResult frame_result = parse_frame(line, frame_begin, i, rec.frame);
  if (!frame_result.ok()) return frame_result;
  rec.frame.timestamp_ns = rec.timestamp_ns;

  // Optional direction marker (candump -x).
  while (i < n && is_blank(line[i])) ++i;
  if (i < n) {
    const bool marker = (line[i] == 'R' || line[i] == 'T') && (i + 1 == n || is_blank(line[i + 1]));
    if (!marker) return fail(CandumpError::kTrailingText, i);
    rec.direction = line[i] == 'R' ? CandumpDirection::kReceived : CandumpDirection::kTransmitted;
    ++i;
    while (i < n && is_blank(line[i])) ++i;
    if (i < n) return fail(CandumpError::kTrailingText, i);
  }
  record = rec;
  return {};
}

const char* to_string(CandumpError error) noexcept {
  switch (error) {
    case CandumpError::kNone:
      return "no error";
    case CandumpError::kMissingOpenParen:
      return "line does not start with '(' before the timestamp";
    case CandumpError::kBadTimestamp:
      return "timestamp is not seconds.microseconds (digits, '.', exactly 6 digits)";
    case CandumpError::kTimestampOutOfRange:
      return "timestamp does not fit in int64 nanoseconds";
    case CandumpError::kMissingCloseParen:
      return "missing ')' after the timestamp";
    case CandumpError::kMissingIface:
      return "missing interface name before the frame";
    case CandumpError::kIfaceTooLong:
      return "interface name longer than 15 characters";
    case CandumpError::kBadIface:
      return "character not allowed in an interface name";
    case CandumpError::kMissingFrame:
      return "missing frame after the interface name";
    case CandumpError::kBadId:
      return "identifier must be 3 (11-bit) or 8 (29-bit) hex digits followed by '#'";
    case CandumpError::kIdTooLong:
      return "identifier longer than 8 hex digits";
    case CandumpError::kIdOutOfRange:
      return "identifier out of range (11-bit > 0x7FF or 29-bit > 0x1FFFFFFF)";
    case CandumpError::kMissingIdDelimiter:
      return "missing '#' after the identifier";
    case CandumpError::kBadHexDigit:
      return "expected a hex digit in the data";
    case CandumpError::kOddHexDigits:
      return "odd number of hex digits: data byte with one digit";
    case CandumpError::kDataTooLong:
      return "data longer than 8 bytes (classic CAN) or 64 bytes (CAN FD)";
    case CandumpError::kInvalidFdLength:
      return "CAN FD data length is not 0-8, 12, 16, 20, 24, 32, 48 or 64 bytes";
    case CandumpError::kBadFdFlags:
      return "CAN FD flags nibble after '##' missing, not hex, or with reserved bit 0x8";
    case CandumpError::kBadRemoteLength:
      return "remote request length after 'R' must be one digit 0-8";
    case CandumpError::kLen8DlcUnsupported:
      return "raw DLC 9-15 ('_' suffix, len8_dlc) is not supported";
    case CandumpError::kCanXlUnsupported:
      return "CAN XL frames are not supported";
    case CandumpError::kErrorFrameNotClassic:
      return "error frame (id with 0x20000000) written as remote request or CAN FD";
    case CandumpError::kTrailingText:
      return "unexpected text after the frame (only an 'R' or 'T' direction marker)";
  }
  return "unknown candump log error";
}

const char* to_string(CandumpFormatError error) noexcept {
  switch (error) {
    case CandumpFormatError::kNone:
      return "no error";
    case CandumpFormatError::kBufferTooSmall:
      return "output buffer too small for the line";
    case CandumpFormatError::kNegativeTimestamp:
      return "negative timestamp";
    case CandumpFormatError::kBadIface:
      return "invalid interface name";
    case CandumpFormatError::kMalformedFrame:
      return "malformed frame";
    case CandumpFormatError::kErrorFrameFlags:
      return "error frame flagged remote or CAN FD";
  }
  return "unknown candump format error";
}

namespace {

// "SECONDS.MICROSECONDS" of a non-negative time or duration in ns (the log's own notation).
std::string log_seconds(std::int64_t ns) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%lld.%06lld", static_cast<long long>(ns / 1'000'000'000),
                static_cast<long long>(ns % 1'000'000'000 / 1000));
  return buf;
}

const char* direction_name(CandumpDirection d) noexcept {
  switch (d) {
    case CandumpDirection::kReceived:
      return "received";
    case CandumpDirection::kTransmitted:
      return "transmitted";
    case CandumpDirection::kUnmarked:
      break;
  }
  return "unmarked";
}

// Lines a candump log may hold besides records: blank, '#' comment, DROPCOUNT note.
bool is_blank_line(std::string_view line) noexcept {
  for (char c : line) {
    if (!is_blank(c) && c != '\r') return false;
  }
  return true;
}

constexpr std::string_view kDropNote = "DROPCOUNT:";

// Largest N of a DROPCOUNT note: candump prints a __u32 counter difference ("%u").
constexpr std::uint64_t kMaxDropNote = 0xFFFFFFFFu;

// N of candump's "DROPCOUNT: dropped N CAN frame(s) on 'IF' socket (total drops T)"; 0 if
// the note does not have that shape (it is still counted as a note). `column` gets the
// 1-based column of N's first digit. Returns false if N has more than 32 bits.
bool dropped_in_note(std::string_view line, std::uint64_t& n, std::size_t& column) noexcept {
  constexpr std::string_view kDropped = "dropped ";
  n = 0;
  std::size_t i = kDropNote.size();
  while (i < line.size() && is_blank(line[i])) ++i;
  if (line.substr(i, kDropped.size()) != kDropped) return true;
  i += kDropped.size();
  column = i + 1;
  for (; i < line.size() && is_digit(line[i]); ++i) {
    n = n * 10 + static_cast<std::uint64_t>(line[i] - '0');
    if (n > kMaxDropNote) return false;  // checked per digit: n * 10 + 9 cannot wrap
  }
  return true;
}

// `limits` if they are in range (CandumpLoadLimits); throws std::invalid_argument otherwise.
const CandumpLoadLimits& checked(const CandumpLoadLimits& limits) {
  if (limits.max_gap_ns <= 0 || limits.max_backward_ns < 0) {
    throw std::invalid_argument("CandumpLoadLimits: max_gap_ns must be > 0 and max_backward_ns "
                                ">= 0 (got " + std::to_string(limits.max_gap_ns) + ", " +
                                std::to_string(limits.max_backward_ns) + ")");
  }
  return limits;
}

}  // namespace

// The latest record time of one interface and direction so far.
struct CandumpLogReader::StreamTime {
  CandumpIface iface;
  CandumpDirection direction = CandumpDirection::kUnmarked;
  std::int64_t time_ns = 0;
  std::size_t line = 0;
};

CandumpLogReader::CandumpLogReader(std::string path, const CandumpLoadLimits& limits)
    : path_(std::move(path)), limits_(checked(limits)), lines_(path_, kCandumpMaxReadLine) {}

CandumpLogReader::~CandumpLogReader() = default;

std::runtime_error CandumpLogReader::located(std::size_t column, const std::string& what) const {
  return std::runtime_error(path_ + ":" + std::to_string(counts_.lines) + ":" +
                            std::to_string(column) + ": " + what);
}

bool CandumpLogReader::next(CandumpRecord& record) {
  std::string_view text;
  bool overlong = false;
  while (lines_.next(text, overlong)) {
    ++counts_.lines;
    if (text.empty() || text[0] == '#' || (!overlong && is_blank_line(text))) {
      ++counts_.skipped;
      continue;
    }
    if (text.substr(0, kDropNote.size()) == kDropNote) {
      ++counts_.skipped;
      ++counts_.drop_notes;
      std::uint64_t n = 0;
      std::size_t column = 0;
      if (!dropped_in_note(text, n, column)) {
        throw located(column, "DROPCOUNT note: the dropped-frame count does not fit in 32 bits "
                              "(candump writes an unsigned 32-bit count): not a candump note");
      }
      if (n > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()) -
                  counts_.dropped_frames) {
        throw located(column, "DROPCOUNT note: the frames lost by the recording add up to more "
                              "than 2^63 - 1");
      }
      counts_.dropped_frames += n;
      continue;
    }
    if (text[0] != '(') {
      throw located(1, "not a candump log line: a record starts with '(' (besides records, only "
                       "blank lines, '#' comments and DROPCOUNT notes)");
    }
    if (overlong) {
      throw located(kCandumpMaxReadLine + 1,
                    "line longer than " + std::to_string(kCandumpMaxReadLine) +
                        " characters: not a candump record");
    }
    CandumpRecord rec;
    const CandumpParseResult r = parse_candump_line(text, rec);
    if (!r.ok()) throw located(r.column, to_string(r.error));

    // Time plausibility. Column 2: where the timestamp starts.
    const std::int64_t t = rec.timestamp_ns;
    if (latest_line_ != 0) {
      const bool ahead = t > latest_ns_;
      const std::int64_t step = ahead ? t - latest_ns_ : latest_ns_ - t;
      if (step > limits_.max_gap_ns) {
        throw located(2, "timestamp " + log_seconds(t) + " s is " + log_seconds(step) + " s " +
                             (ahead ? "after" : "before") + " the latest record (line " +
                             std::to_string(latest_line_) + ", " + log_seconds(latest_ns_) +
                             " s): more than the " + log_seconds(limits_.max_gap_ns) +
                             " s allowed between records");
      }
    }
    StreamTime* stream = nullptr;
    for (StreamTime& s : streams_) {
      if (s.iface == rec.iface && s.direction == rec.direction) stream = &s;
    }
    if (stream != nullptr && t < stream->time_ns) {
      if (stream->time_ns - t > limits_.max_backward_ns) {
        throw located(2, "timestamp " + log_seconds(t) + " s goes back " +
                             log_seconds(stream->time_ns - t) + " s against line " +
                             std::to_string(stream->line) + " (" + log_seconds(stream->time_ns) +
                             " s) of the same interface '" + std::string(rec.iface.view()) +
                             "' and direction (" + direction_name(rec.direction) +
                             "): a recording's times never decrease there");
      }
      ++counts_.out_of_order;
    } else if (latest_line_ != 0 && t < latest_ns_) {
      ++counts_.out_of_order;
    }
    if (stream == nullptr) {
      streams_.push_back(StreamTime{rec.iface, rec.direction, t, counts_.lines});
    } else if (t >= stream->time_ns) {
      stream->time_ns = t;
      stream->line = counts_.lines;
    }
    if (latest_line_ == 0 || t >= latest_ns_) {
      latest_ns_ = t;
      latest_line_ = counts_.lines;
    }
    ++counts_.records;
    record = rec;
    return true;
  }
  return false;
}

std::vector<CandumpRecord> load_candump_log(const std::string& path, CandumpLoadStats* stats,
                                            const CandumpLoadLimits& limits) {
  CandumpLogReader reader(path, limits);
  std::vector<CandumpRecord> records;
  CandumpRecord rec;
  while (reader.next(rec)) records.push_back(rec);
  const CandumpLoadStats& counts = reader.stats();
  if (records.empty()) {
    throw std::runtime_error(path + ": no frame records (" + std::to_string(counts.lines) +
                             " lines: blank, '#' comments or DROPCOUNT notes): nothing to "
                             "replay");
  }
  if (stats != nullptr) *stats = counts;
  return records;
}

}  // namespace numen::hal
