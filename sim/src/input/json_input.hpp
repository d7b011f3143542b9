#pragma once
/// @file json_input.hpp
/// What the readers of JSON a user hands numen share (the scene message of a view recording,
/// view_recording.cpp; study shard files, study_shard.cpp; the viewer page's messages,
/// view_server.cpp): parsing without an exception escaping (a syntax error as its byte offset
/// and reason), a bounded nesting depth (kMaxDepth: a value nested deeper is refused where it
/// opens, so that nothing recursive — nlohmann's copy, comparison, dump() — meets a depth that
/// could overflow the stack), the 1-based line and column of a byte, and a member's value quoted
/// short for a message. Every reader checks each member's JSON type itself before it reads it
/// (never json::value() or get<>() on an unchecked type: those throw json::type_error, which
/// carries no place). Internal to numen::sim; allocates.

#include <algorithm>
#include <cstddef>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>

namespace numen::sim::json_input {

/// Deepest nesting of arrays and objects parse() accepts: the top-level value is depth 1.
/// numen's own JSON nests 5 deep at most (a shard file's results[k].rows[i].<list>).
inline constexpr int kMaxDepth = 64;

/// Bytes of the input a message quotes (shown(), a syntax error's last token).
inline constexpr std::size_t kShownBytes = 40;

/// A syntax error of parse(): where and why.
struct SyntaxError {
  std::size_t byte = 0;  ///< 0-based offset in the text of the byte the parser stopped at.
  std::string reason;    ///< nlohmann's description ("syntax error while parsing value - …").
  /// The text is JSON, but an array or object at `byte` opens nesting level kMaxDepth + 1.
  bool too_deep = false;
};

namespace detail {

/// A pointer into the text that tells parse() how far nlohmann's lexer has read: every copy
/// writes its position to one shared cursor on each step (the lexer reads byte by byte, and
/// reads no byte past a '[' or '{' before the parser reports it).
class TrackedChars {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  TrackedChars(const char* at, const char** cursor) noexcept : at_(at), cursor_(cursor) {}
  reference operator*() const noexcept { return *at_; }
  TrackedChars& operator++() noexcept {
    *cursor_ = ++at_;
    return *this;
  }
  TrackedChars operator++(int) noexcept {
    TrackedChars before = *this;
    ++*this;
    return before;
  }
  bool operator==(const TrackedChars& other) const noexcept { return at_ == other.at_; }
  bool operator!=(const TrackedChars& other) const noexcept { return at_ != other.at_; }

 private:
  const char* at_;
  const char** cursor_;
};

/// Thrown by parse()'s callback at the first array or object below kMaxDepth.
struct TooDeep {};

}  // namespace detail

/// Parses `text` as one JSON value. On a syntax error, a number beyond a double's range, or
/// arrays and objects nested deeper than kMaxDepth, returns a discarded value (is_discarded())
/// and fills `error`. Never throws a json exception; the depth is checked while parsing, before
/// any value deeper than kMaxDepth is built.
template <class Json>
Json parse(std::string_view text, SyntaxError& error) {
  const char* cursor = text.data();
  try {
    // nlohmann's callback gets the depth of an array or object as it opens: the number of
    // arrays and objects around it (0 for the top-level value).
    const auto depth_check = [](int depth, nlohmann::json::parse_event_t event, Json&) {
      if ((event == nlohmann::json::parse_event_t::array_start ||
           event == nlohmann::json::parse_event_t::object_start) &&
          depth >= kMaxDepth)
        throw detail::TooDeep{};
      return true;
    };
    return Json::parse(detail::TrackedChars(text.data(), &cursor),
                       detail::TrackedChars(text.data() + text.size(), &cursor), depth_check);
  } catch (const detail::TooDeep&) {
    // The lexer has read the '[' or '{' that opened the level: it is the byte before the cursor.
    const auto read = static_cast<std::size_t>(cursor - text.data());
    error.byte = read == 0 ? 0 : read - 1;
    error.reason = "arrays and objects nested more than " + std::to_string(kMaxDepth) + " deep";
    error.too_deep = true;
    return Json(nlohmann::json::value_t::discarded);
  } catch (const nlohmann::json::parse_error& e) {
    error.byte = e.byte == 0 ? 0 : std::min<std::size_t>(e.byte - 1, text.size());
    const std::string what = e.what();
    const std::size_t at = what.find("parse error");
    const std::size_t colon = at == std::string::npos ? std::string::npos : what.find(": ", at);
    error.reason = colon == std::string::npos ? what : what.substr(colon + 2);
    // nlohmann quotes the token it was reading ("last read: '…'"), whole: a string of 16 MB
    // without its closing quote would be quoted whole. Its first kShownBytes bytes are.
    constexpr std::string_view kLastRead = "last read: '";
    if (const std::size_t quote = error.reason.find(kLastRead); quote != std::string::npos) {
      const std::size_t from = quote + kLastRead.size();
      // nlohmann's own suffix ("'; expected end of input", "… '[', '{', or a literal") is
      // short: a longer tail after an "'; expected " is the token's own text (a string that
      // holds those bytes), quoted with the rest of the token.
      constexpr std::size_t kSuffixBytes = 64;
      const std::size_t expected = error.reason.rfind("'; expected ");
      const std::size_t to = expected != std::string::npos && expected >= from &&
                                     error.reason.size() - expected <= kSuffixBytes
                                 ? expected
                                 : error.reason.size() - 1;  // the closing '
      if (to > from + kShownBytes)
        error.reason.replace(from + kShownBytes, to - from - kShownBytes, "...");
    }
    return Json(nlohmann::json::value_t::discarded);
  } catch (const nlohmann::json::out_of_range& e) {
    // A number beyond a double's range ("1e999": out_of_range.406, "number overflow parsing
    // '1e999'") carries no byte offset; the number it quotes is found in the text (the first
    // occurrence is the one that overflowed: the parser stops there).
    const std::string what = e.what();
    const std::size_t close = what.rfind('\'');
    const std::size_t open = close == std::string::npos || close == 0
                                 ? std::string::npos
                                 : what.rfind('\'', close - 1);
    const std::string number =
        open == std::string::npos ? std::string() : what.substr(open + 1, close - open - 1);
    const std::size_t at = number.empty() ? std::string::npos : text.find(number);
    error.byte = at == std::string::npos ? 0 : at;
    const std::size_t bracket = what.find("] ");
    error.reason = bracket == std::string::npos ? what : what.substr(bracket + 2);
    return Json(nlohmann::json::value_t::discarded);
  }
}

/// 1-based (line, column) of byte `offset` of `text` (column counted in bytes).
inline std::pair<int, int> line_column(std::string_view text, std::size_t offset) {
  int line = 1, column = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return {line, column};
}

namespace detail {

/// Appends JSON string `text` (quoted and escaped; invalid UTF-8 replaced), at most the first
/// `limit` + 1 − out.size() bytes of it, to `out`.
template <class Json>
void quote_string(std::string_view text, std::string& out, std::size_t limit) {
  const std::size_t room = out.size() > limit ? 0 : limit + 1 - out.size();
  out +=
      Json(std::string(text.substr(0, room))).dump(-1, ' ', false, Json::error_handler_t::replace);
}

/// Appends the compact JSON text of `j` to `out` (as dump() writes it) until `out` holds more
/// than `limit` bytes: arrays and objects are walked member by member and each level writes
/// its bracket before it descends, so that neither the work nor the recursion grows with the
/// size or the depth of `j` past the limit.
template <class Json>
void quote(const Json& j, std::string& out, std::size_t limit) {
  if (j.is_array() || j.is_object()) {
    out += j.is_array() ? '[' : '{';
    bool first = true;
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (out.size() > limit) return;
      if (!first) out += ',';
      first = false;
      if (j.is_object()) {
        quote_string<Json>(it.key(), out, limit);
        out += ':';
      }
      quote(it.value(), out, limit);
    }
    out += j.is_array() ? ']' : '}';
  } else if (j.is_string()) {
    quote_string<Json>(j.template get_ref<const typename Json::string_t&>(), out, limit);
  } else {
    out += j.dump(-1, ' ', false, Json::error_handler_t::replace);
  }
}

}  // namespace detail

/// `j` as a message quotes it: its JSON type and compact text, cut to kShownBytes bytes
/// ("..." after), e.g. "object {\"a\":1}" or "string \"1\"". Reads only the prefix it
/// quotes: any size and depth of `j` costs at most ~kShownBytes steps.
template <class Json>
std::string shown(const Json& j) {
  std::string text;
  detail::quote(j, text, kShownBytes);
  if (text.size() > kShownBytes) text = text.substr(0, kShownBytes) + "...";
  return std::string(j.type_name()) + " " + text;
}

}  // namespace numen::sim::json_input
