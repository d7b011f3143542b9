#pragma once
/// @file markdown_cell.hpp
/// Text in a Markdown table cell: '|' escaped as "\|". Internal to numen::sim (the generated
/// tables of run_figures.cpp, trace_columns.cpp, record_lists.cpp).

#include <string>
#include <string_view>

namespace numen::sim {

/// Appends `text` to `out` with every '|' escaped.
inline void append_markdown_cell(std::string& out, std::string_view text) {
  for (const char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
}

}  // namespace numen::sim
