/// @file study_shard_fuzz.cpp
/// libFuzzer harness of the study shard files and their merge (sim/study/study_shard.hpp,
/// study_shard_json.hpp; `numen study merge DIR`): the input as the shard files of a directory
/// of this process's own, merged by merge_stability_shards(), merge_accuracy_shards() or
/// merge_passivity_shards(). The input's last byte picks the study (bits 0 and 2: 01
/// accuracy, 10 passivity, otherwise stability) and, bit 1, the split: one file (shard 0 of
/// 1), or two (shards 0 and 1 of 2, split at the first NUL byte). The only accepted failure is
/// InputError (the file and the line and column or the key); a json exception or any other
/// escaping is a finding.
/// Seeds: one-shard files of the three studies as numen writes them, each ending in the byte
/// that picks it (corpus/study_shard).

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "fuzz_input.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/study/study_accuracy.hpp"
#include "numen/sim/study/study_passivity.hpp"
#include "numen/sim/study/study_stability.hpp"

namespace {

/// This process's directory of shard files (emptied on each call, removed at exit).
const std::filesystem::path& shard_dir() {
  static const std::filesystem::path dir = [] {
    const auto d = std::filesystem::temp_directory_path() /
                   ("numen_fuzz_shards_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    static std::filesystem::path to_remove;
    to_remove = d;
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(to_remove, ec);
    });
    return d;
  }();
  return dir;
}

void write(const std::filesystem::path& path, std::string_view text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) numen::fuzz::finding("study shard: cannot write the input file");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::uint8_t how = data[size - 1];
  const std::string_view text(reinterpret_cast<const char*>(data), size - 1);
  const int pick = (how & 1) + 2 * ((how >> 2) % 2);  // 0, 1, 2, 3
  const std::string study = pick == 1 ? "accuracy" : pick == 2 ? "passivity" : "stability";
  const auto& dir = shard_dir();
  for (const auto& e : std::filesystem::directory_iterator(dir)) std::filesystem::remove(e.path());
  const std::size_t nul = text.find('\0');
  if ((how & 2) != 0 && nul != std::string_view::npos) {
    write(dir / (study + "-shard-0-of-2.json"), text.substr(0, nul));
    write(dir / (study + "-shard-1-of-2.json"), text.substr(nul + 1));
  } else {
    write(dir / (study + "-shard-0-of-1.json"), text);
  }
  try {
    if (study == "stability") (void)numen::sim::merge_stability_shards(dir.string());
    else if (study == "accuracy") (void)numen::sim::merge_accuracy_shards(dir.string());
    else (void)numen::sim::merge_passivity_shards(dir.string());
  } catch (const numen::sim::InputError& e) {
    // a located error: the expected outcome for a damaged file; it quotes a bounded prefix of
    // what it refuses, whatever the size or depth of the input
    if (std::strlen(e.what()) > numen::fuzz::kMaxMessageBytes)
      numen::fuzz::finding("study shard: an error message quotes the input unbounded");
  }
  return 0;
}
