#pragma once
/// @file json_input.hpp
/// What the readers of JSON a user hands numen share (the scene message of a view recording,
/// view_recording.cpp; study shard files, study_shard.cpp): parsing without an exception
/// escaping (a syntax error as its byte offset and reason), the 1-based line and column of a
/// byte, and a member's value quoted short for a message. Every reader checks each member's
/// JSON type itself before it reads it (never json::value() or get<>() on an unchecked type:
/// those throw json::type_error, which carries no place). Internal to numen::sim; allocates.

#include <algorithm>
#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>

namespace numen::sim::json_input {

/// A syntax error of parse(): where and why.
struct SyntaxError {
  std::size_t byte = 0;  ///< 0-based offset in the text of the byte the parser stopped at.
  std::string reason;    ///< nlohmann's description ("syntax error while parsing value - …").
};

/// Parses `text` as one JSON value. On a syntax error, or a number beyond a double's range,
/// returns a discarded value (is_discarded()) and fills `error`. Never throws a json exception.
template <class Json>
Json parse(std::string_view text, SyntaxError& error) {
  try {
    return Json::parse(text.begin(), text.end());
  } catch (const nlohmann::json::parse_error& e) {
    error.byte = e.byte == 0 ? 0 : std::min<std::size_t>(e.byte - 1, text.size());
    const std::string what = e.what();
    const std::size_t at = what.find("parse error");
    const std::size_t colon = at == std::string::npos ? std::string::npos : what.find(": ", at);
    error.reason = colon == std::string::npos ? what : what.substr(colon + 2);
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

/// `j` as a message quotes it: its JSON type and compact text, cut to 40 bytes ("…" after),
/// e.g. "object {\"a\":1}" or "string \"1\"".
template <class Json>
std::string shown(const Json& j) {
  std::string text = j.dump(-1, ' ', false, Json::error_handler_t::replace);
  if (text.size() > 40) text = text.substr(0, 40) + "...";
  return std::string(j.type_name()) + " " + text;
}

}  // namespace numen::sim::json_input
