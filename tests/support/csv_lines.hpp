#pragma once
// Reading the CSV files a test wrote: the lines of a file, the cells of a line.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace numen::test {

/// The cells of one CSV line (no quoting; a trailing separator gives a last empty cell).
inline std::vector<std::string> split_csv(const std::string& line, char sep = ',') {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, sep)) out.push_back(cell);
  if (!line.empty() && line.back() == sep) out.push_back("");
  return out;
}

/// The lines of a file (empty when it cannot be read).
inline std::vector<std::string> read_lines(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

/// The index of column `name` in a CSV header `header`; adds a test failure (and gives 0) when
/// the header has no such column.
inline std::size_t csv_column(const std::vector<std::string>& header, const std::string& name) {
  const auto it = std::find(header.begin(), header.end(), name);
  if (it == header.end()) {
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
  return static_cast<std::size_t>(it - header.begin());
}

}  // namespace numen::test
