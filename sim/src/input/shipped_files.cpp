/// @file shipped_files.cpp
/// Installed prefix first, build tree second (shipped_files.hpp).

#include "numen/sim/input/shipped_files.hpp"

#include <system_error>

#ifndef NUMEN_SOURCE_SIM_DIR
#define NUMEN_SOURCE_SIM_DIR "sim"
#endif
#ifndef NUMEN_DATA_FROM_BIN  // GNUInstallDirs: DATADIR/numen relative to BINDIR
#define NUMEN_DATA_FROM_BIN "../share/numen"
#endif

namespace numen::sim {
namespace {

/// `<from>/<relative>` if `probe` exists under it; empty otherwise (and for an empty `from`).
std::filesystem::path dir_holding(const std::filesystem::path& from,
                                  const std::filesystem::path& relative,
                                  const std::filesystem::path& probe) {
  if (from.empty()) return {};
  const std::filesystem::path dir = (from / relative).lexically_normal();
  std::error_code ec;
  return std::filesystem::exists(dir / probe, ec) ? dir : std::filesystem::path{};
}

/// `<executable dir>/NUMEN_DATA_FROM_BIN` if `probe` exists under it; empty otherwise.
std::filesystem::path installed_dir_holding(const std::filesystem::path& probe) {
  return dir_holding(executable_dir(), NUMEN_DATA_FROM_BIN, probe);
}

}  // namespace

std::filesystem::path executable_dir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path{} : exe.parent_path();
}

std::filesystem::path shipped_data_dir() {
  std::filesystem::path dir = installed_dir_holding("scenes/default.toml");
  // A program built on the installed package: its prefix's (numenConfig.cmake's hook).
  if (dir.empty() && numen_installed_data_dir != nullptr)
    dir = dir_holding(numen_installed_data_dir(), ".", "scenes/default.toml");
  return dir.empty() ? std::filesystem::path(NUMEN_SOURCE_SIM_DIR) : dir;
}

std::filesystem::path shipped_data_dir_from(const std::filesystem::path& module_dir,
                                            const std::filesystem::path& data_from_module) {
  std::filesystem::path dir = dir_holding(module_dir, data_from_module, "scenes/default.toml");
  return dir.empty() ? shipped_data_dir() : dir;
}

std::filesystem::path shipped_viewer_dir(const std::filesystem::path& build_tree_dir) {
  const std::filesystem::path dir = installed_dir_holding("viewer/index.html");
  return dir.empty() ? build_tree_dir : dir / "viewer";
}

}  // namespace numen::sim
