#pragma once
/// @file shipped_files.hpp
/// Where the files shipped with numen are found at run time: the scenes, their data
/// (recordings) and the viewer page. An installed `numen` finds them relative to its own
/// executable, `<prefix>/bin/../share/numen/...` (docs/package.md);
/// a program run from the build tree falls back to the source tree's sim/ and the build
/// tree's viewer/.

#include <filesystem>

/// The installed package's data directory (`<prefix>/share/numen`, CMake's numen_DATA_DIR) as
/// a program built on it sees it: defined (weak) by a source that the installed
/// numenConfig.cmake adds to every target linking numen::sim (its INTERFACE_SOURCES), so that
/// shipped_data_dir() and default_scene_path() find the prefix's files wherever the program
/// runs from. Not defined in numen's own build (its address is then null).
extern "C" [[gnu::weak]] const char* numen_installed_data_dir() noexcept;

namespace numen::sim {

/// Directory of the running executable (/proc/self/exe resolved); empty if it cannot be read.
std::filesystem::path executable_dir();

/// The root of the shipped scenes and data: `<executable dir>/<bin → share/numen>` (e.g.
/// /usr/bin/../share/numen) when it holds scenes/default.toml (the installed `numen`); else, in
/// a program built on an installed numen (find_package(numen), numen::sim), that prefix's
/// share/numen (numen_installed_data_dir() below) when it holds scenes/default.toml; else the
/// source tree's sim/ this library was built from (the build tree's programs and tests). Its
/// scenes/ and data/ sit side by side there, so a scene's "../data/..." paths resolve in all.
std::filesystem::path shipped_data_dir();

/// The root of the shipped scenes and data for a module loaded from `module_dir` (the Python
/// module's directory): `module_dir/data_from_module` (an installed prefix's share/numen as seen
/// from the module's install directory, e.g. "../../../share/numen" from
/// lib/python3/dist-packages) when it holds scenes/default.toml, else shipped_data_dir().
std::filesystem::path shipped_data_dir_from(const std::filesystem::path& module_dir,
                                            const std::filesystem::path& data_from_module);

/// The viewer page directory (index.html, viewer.js, vendor/): `<shipped data dir>/viewer`
/// of an installed prefix when it holds index.html, else `build_tree_dir` (the build tree's
/// page, which the `numen` target passes).
std::filesystem::path shipped_viewer_dir(const std::filesystem::path& build_tree_dir);

}  // namespace numen::sim
