#pragma once
/// @file jigsaws_trials.hpp
/// The full JIGSAWS trials the tests read besides the shipped excerpt: they are not in the
/// repository, and are found through one environment variable only, NUMEN_JIGSAWS_DIR (a folder
/// of *.txt kinematics files; docs/testing.md, "Recorded trials"). CI sets it (.ci/run).

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

namespace numen::test {

/// The reason of a test skipped because NUMEN_JIGSAWS_DIR is unset.
inline constexpr const char* kNoJigsawsTrials =
    "NUMEN_JIGSAWS_DIR is unset: the full JIGSAWS trials are not in the repository; set it to "
    "their folder to run this (docs/testing.md)";

/// The folder NUMEN_JIGSAWS_DIR names, or nothing when it is unset or empty.
inline std::optional<std::filesystem::path> jigsaws_trials_dir() {
  const char* dir = std::getenv("NUMEN_JIGSAWS_DIR");
  if (dir == nullptr || *dir == '\0') return std::nullopt;
  return std::filesystem::path(dir);
}

/// The *.txt trials of NUMEN_JIGSAWS_DIR, sorted; empty when it is unset. Set, it must be a
/// folder holding at least one: otherwise the calling test fails, naming it (a variable that
/// names the wrong folder would silently test nothing).
inline std::vector<std::filesystem::path> jigsaws_trials() {
  std::vector<std::filesystem::path> out;
  const auto dir = jigsaws_trials_dir();
  if (!dir) return out;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(*dir, ec))
    if (e.path().extension() == ".txt") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  if (out.empty())
    ADD_FAILURE() << "NUMEN_JIGSAWS_DIR=" << dir->string() << ": no *.txt JIGSAWS trial there"
                  << (ec ? " (" + ec.message() + ")" : std::string());
  return out;
}

}  // namespace numen::test
