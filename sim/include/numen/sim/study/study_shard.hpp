#pragma once
/// @file study_shard.hpp
/// Studies on a cluster (docs/studies.md): the cases of a study (`numen study stability`,
/// `numen study accuracy`) split into N shards, case k (0-based, in the order of the one-process
/// run) to shard k mod N. Each shard writes one file, <study>-shard-<I>-of-<N>.json, atomically
/// (a temporary file in the same directory, then rename); `numen study merge DIR` checks that the
/// N files are present and consistent and writes the one-process run's CSV files. Every case is
/// deterministic (no random numbers; its inputs depend on the case only, never on the shard), so a
/// case's row is the same whichever shard runs it. Study code: allocates and throws; not
/// real-time.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace numen::sim {

/// One case of a study: the unit a shard runs and `numen study … --list` prints.
struct StudyCase {
  std::int64_t index = 0;  ///< Position in the one-process run (0-based).
  std::string family;  ///< Stability: the family ("coupling", …); accuracy: the case ("wall").
  std::string name;    ///< Stability: the row's case ("coupling-undamped"); accuracy: integrator.
  std::string parameters;  ///< "integrator=implicit-euler h=0.0001 m=0.001 k=10 zeta=0".
};

/// Shard `index` of `count`: the cases k with k mod count = index. {0, 1}: the whole study.
struct Shard {
  int index = 0;
  int count = 1;
  /// True when case `case_index` (≥ 0) belongs to this shard.
  bool owns(std::int64_t case_index) const noexcept { return case_index % count == index; }
};

/// Largest number of shards accepted (a Slurm array is at most MaxArraySize, 1001 by default).
inline constexpr int kMaxShards = 1000000;

/// Parses "I/N": decimal integers, 0 ≤ I < N, 1 ≤ N ≤ kMaxShards, nothing else (no sign, no
/// space). Throws InputError (key `key`, e.g. "--shard") saying what is wrong.
Shard parse_shard(std::string_view text, const std::string& key = "--shard");

/// Throws InputError (key "shard") unless 1 ≤ shard.count and 0 ≤ shard.index < shard.count (a
/// Shard built in code, e.g. through the Python bindings, rather than parsed).
void check_shard(const Shard& shard);

/// The shard of a Slurm array task: I = SLURM_ARRAY_TASK_ID, N = SLURM_ARRAY_TASK_COUNT, read
/// through `lookup` (std::getenv in the CLI; nullptr = unset). std::nullopt when neither is set.
/// Throws InputError whose key is the variable's name when only one is set, a value is not a
/// decimal integer, N < 1 or I ≥ N (an array numbered from 1: submit with --array=0-(N-1)).
std::optional<Shard> shard_from_environment(const std::function<const char*(const char*)>& lookup);

/// "<study>-shard-<I>-of-<N>.json", e.g. "stability-shard-2-of-4.json".
std::string shard_file_name(const std::string& study, const Shard& shard);

/// Writes `content` to `path` atomically: into a temporary file in the same directory (mkstemp),
/// flushed to disk (fsync), then renamed onto `path`; a reader sees the old file or the complete
/// new one, never a part. Throws std::runtime_error naming the path and the system's reason.
void write_file_atomically(const std::filesystem::path& path, std::string_view content);

/// Files to write into one directory: (file name, content) in order.
using OutputFiles = std::vector<std::pair<std::string, std::string>>;

/// Writes every file of `files` into `dir` as a set: each into a temporary file beside it
/// (write_file_atomically()), then, once all are written and flushed, each renamed onto its
/// name. A failure to write any of them (disk full, no permission) leaves every file of `dir`
/// as it was and no temporary file; only a failed rename (which needs no space) can leave the
/// files before it replaced. Throws std::runtime_error naming the file and the system's reason.
void write_files_atomically(const std::filesystem::path& dir, const OutputFiles& files);

/// One line of `--list` (no newline): "<index>\t<family>\t<name>\t<parameters>".
std::string format_case_line(const StudyCase& c);

/// The study ("stability", "accuracy" or "passivity") whose shard files are in `dir`. Throws
/// std::runtime_error naming `dir` when it holds none, or files of both studies.
std::string study_of_shard_dir(const std::filesystem::path& dir);

}  // namespace numen::sim
