#pragma once
/// @file mesh_cache.hpp
/// A cache file of a built core::MeshShape (docs/meshes.md, "Build cache"), and of a net
/// simplified from a mesh file (at the end; docs/organs.md): the narrow band of a
/// large mesh takes seconds to build (about 2 s at 100k triangles), its file a fraction of that
/// to read. The file holds the whole shape (tree, normals, edges, grid, band) after a header:
///
///   "NUMENMSH" (8 bytes), format version (u32), key (u64), payload size (u64),
///   payload checksum (u64), payload
///
/// in the host's byte order (a file from another byte order reads as stale). The key is a 64-bit
/// FNV-1a hash of the format version, the mesh's vertices and triangles as built (after units,
/// scale and winding), the build options (band width, cell factor, memory cap) and the shape's
/// compile-time constants (leaf size, grid and brick cells): any change of what the build would
/// produce changes it. The checksum (the same hash of the payload) finds a damaged file; the
/// payload is then checked for sizes and index ranges before it is trusted. A cache path is
/// only ever read or replaced when it names a regular file that starts with its kind's magic, or
/// nothing in a folder that exists (docs/meshes.md, "Build cache"). Load time only.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "numen/core/mesh.hpp"
#include "numen/core/mesh_shape.hpp"

namespace numen::sim {

/// Version of the cache file format (part of the key: a file of another version is stale).
inline constexpr std::uint32_t kMeshCacheVersion = 1;

/// The key of the shape core::build_mesh_shape(mesh, ·, options) builds (see the file's comment).
std::uint64_t mesh_cache_key(const core::TriangleMesh& mesh, const core::MeshShapeOptions& options);

/// The default cache folder: $XDG_CACHE_HOME/numen/meshes, else $HOME/.cache/numen/meshes; empty
/// when neither variable is set.
std::filesystem::path default_mesh_cache_dir();

/// The file name of a mesh's cache in a cache folder: "<stem>-<key, 16 hex digits>.nmshape"
/// (`stem`: the mesh file's name without its extension).
std::string mesh_cache_file_name(const std::string& stem, std::uint64_t key);

/// What build_mesh_shape_cached() did.
struct MeshCacheOutcome {
  bool loaded = false;   ///< The shape came from the file (else it was built).
  bool written = false;  ///< The file was (re)written with the built shape.
  /// "" or why the file was not used or not written: "stale (…)", "damaged (…)", "cannot write
  /// …" — the caller's warning. A missing file is no warning (the first load writes it).
  std::string note;
  /// The returned error is the cache path's, not the build's: it names something that is not
  /// this kind of numen cache file and is never read or replaced — a symbolic link, a directory,
  /// a FIFO, a device node, a socket, a file that does not start with the cache's magic (or
  /// starts with the other kind's), one that cannot be read, a folder that does not exist.
  /// Nothing was built; the caller's error at its `cache` key.
  bool cache_refused = false;
};

/// Fills `out` with the shape of `mesh` built with `options`: read from `path` when the file is
/// there with the right key and checksum and a consistent payload (the vertices `mesh`'s), else
/// built (core::build_mesh_shape()) and written to `path` (through a temporary file in its folder
/// renamed over it; no folder is made). `path` must name nothing or a numen mesh-shape cache
/// (a regular file starting with "NUMENMSH"): anything else is returned as the error at once,
/// nothing read, built or written (`outcome.cache_refused`; lstat() first and an open with
/// O_NOFOLLOW | O_NONBLOCK, so a FIFO or a device never blocks the load). A cache file that is
/// stale, damaged or cannot be written is not an error: the shape is built, and `outcome.note`
/// says why. Returns that refusal or build_mesh_shape()'s error ("" on success; then nothing is
/// written). Load time only.
std::string build_mesh_shape_cached(const core::TriangleMesh& mesh,
                                    const core::MeshShapeOptions& options,
                                    const std::filesystem::path& path, core::MeshShape& out,
                                    MeshCacheOutcome& outcome);

/// Version of the simplified net's cache file format ("NUMENNET", the same header; part of the
/// key).
inline constexpr std::uint32_t kNetCacheVersion = 1;

/// The key of the net simplified from `mesh` (as placed: after units, scale and placement) to
/// `nodes` nodes by simplifier `simplifier` (its library's version, net_simplify.hpp): a 64-bit
/// FNV-1a hash of the format version, the mesh's vertices and triangles, `nodes` and `simplifier`.
std::uint64_t net_cache_key(const core::TriangleMesh& mesh, int nodes, std::uint64_t simplifier);

/// The file name of a simplified net's cache in a cache folder: "<stem>-<key, 16 hex
/// digits>.nmnet".
std::string net_cache_file_name(const std::string& stem, std::uint64_t key);

/// Fills `net` with the net simplified from `mesh` to `nodes` nodes (docs/organs.md, "A fine
/// surface on a coarser net"): read from cache file `path` when it is there with the right key
/// (net_cache_key()) and checksum and a closed, valid mesh (core::validate_mesh()) of 4 to fewer
/// than `mesh`'s vertices within `mesh`'s size of its bounding box as payload (the net's
/// vertices, m, and triangles), else made by `simplify` (which fills its argument, "" or an
/// error) and written to `path` as build_mesh_shape_cached() writes (a temporary file renamed
/// over it). `path` must name nothing or a numen net cache ("NUMENNET"): anything else is
/// refused as build_mesh_shape_cached() refuses it (`outcome.cache_refused`, nothing simplified).
/// A stale or damaged file, or one that cannot be written, is not an error: `outcome.note` says
/// why. Returns the refusal or `simplify`'s error ("" on success; then nothing is written). Load
/// time only.
std::string simplify_net_cached(const core::TriangleMesh& mesh, int nodes, std::uint64_t simplifier,
                                const std::filesystem::path& path,
                                const std::function<std::string(core::TriangleMesh&)>& simplify,
                                core::TriangleMesh& net, MeshCacheOutcome& outcome);

/// A net simplification of at least this wall-clock time (s) without a cache file gets a hint to
/// set one (docs/organs.md, "Load time, and the cache file").
inline constexpr double kSlowNetSimplifySeconds = 2.0;

/// The load warning of a net simplified to `nodes` nodes in `wall_s` seconds of wall clock with
/// no cache file (`cached` false): "simplified to N nodes in X s (wall clock) at every load:
/// `cache = true` (or a file path) keeps the net for the next load" when `wall_s` ≥
/// kSlowNetSimplifySeconds, else nothing.
std::optional<std::string> slow_net_simplification_hint(double wall_s, int nodes, bool cached);

}  // namespace numen::sim
