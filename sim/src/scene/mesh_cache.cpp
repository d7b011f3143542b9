/// @file mesh_cache.cpp
/// The cache file of a built mesh shape (see mesh_cache.hpp).

#include "numen/sim/scene/mesh_cache.hpp"

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

#include <unistd.h>

namespace numen::sim {
namespace {

constexpr char kMagic[8] = {'N', 'U', 'M', 'E', 'N', 'M', 'S', 'H'};
constexpr std::size_t kHeaderBytes = 8 + 4 + 8 + 8 + 8;

/// 64-bit FNV-1a over 8-byte words (then the tail bytes): fast enough for a 50 MB payload.
struct Hash {
  std::uint64_t h = 0xcbf29ce484222325ull;
  void bytes(const void* data, std::size_t n) noexcept {
    const auto* p = static_cast<const unsigned char*>(data);
    std::size_t i = 0;
    for (; i + 8 <= n; i += 8) {
      std::uint64_t w;
      std::memcpy(&w, p + i, 8);
      h = (h ^ w) * 0x100000001b3ull;
    }
    for (; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  }
  template <class T>
  void value(const T& v) noexcept {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes(&v, sizeof v);
  }
  /// A mesh's vertex count, vertices, triangle count and triangles.
  void mesh(const core::TriangleMesh& m) noexcept {
    value(static_cast<std::uint64_t>(m.vertices.size()));
    for (const core::Vec3& v : m.vertices)
      for (int k = 0; k < 3; ++k) value(v[k]);
    value(static_cast<std::uint64_t>(m.triangles.size()));
    bytes(m.triangles.data(), m.triangles.size() * sizeof(m.triangles[0]));
  }
};

/// Appends plain values and arrays to a byte string.
struct Writer {
  std::string out;
  template <class T>
  void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void vec3(const core::Vec3& v) {
    for (int k = 0; k < 3; ++k) value(v[k]);
  }
  template <class T>
  void array(const std::vector<T>& v) {
    value(static_cast<std::uint64_t>(v.size()));
    if constexpr (std::is_same_v<T, core::Vec3>) {
      for (const core::Vec3& x : v) vec3(x);
    } else {
      static_assert(std::is_trivially_copyable_v<T>);
      out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    }
  }
  void nodes(const std::vector<core::MeshBvhNode>& v) {
    value(static_cast<std::uint64_t>(v.size()));
    for (const core::MeshBvhNode& n : v) {
      vec3(n.lo);
      vec3(n.hi);
      value(n.index);
      value(n.count);
    }
  }
  void text(const std::string& t) {
    value(static_cast<std::uint64_t>(t.size()));
    out += t;
  }
};

/// Reads what Writer wrote; `ok` turns false at the first read past the end.
struct Reader {
  const char* p;
  const char* end;
  bool ok = true;
  template <class T>
  void value(T& v) {
    if (!ok || static_cast<std::size_t>(end - p) < sizeof v) {
      ok = false;
      return;
    }
    std::memcpy(&v, p, sizeof v);
    p += sizeof v;
  }
  void vec3(core::Vec3& v) {
    for (int k = 0; k < 3; ++k) value(v[k]);
  }
  template <class T>
  void array(std::vector<T>& v) {
    std::uint64_t n = 0;
    value(n);
    const std::size_t each = std::is_same_v<T, core::Vec3> ? 3 * sizeof(double) : sizeof(T);
    if (!ok || n > static_cast<std::size_t>(end - p) / each) {
      ok = false;
      return;
    }
    v.resize(static_cast<std::size_t>(n));
    if constexpr (std::is_same_v<T, core::Vec3>) {
      for (core::Vec3& x : v) vec3(x);
    } else {
      std::memcpy(v.data(), p, v.size() * sizeof(T));
      p += v.size() * sizeof(T);
    }
  }
  void nodes(std::vector<core::MeshBvhNode>& v) {
    constexpr std::size_t kNodeBytes = 6 * sizeof(double) + 2 * sizeof(std::int32_t);
    std::uint64_t n = 0;
    value(n);
    if (!ok || n > static_cast<std::size_t>(end - p) / kNodeBytes) {
      ok = false;
      return;
    }
    v.resize(static_cast<std::size_t>(n));
    for (core::MeshBvhNode& x : v) {
      vec3(x.lo);
      vec3(x.hi);
      value(x.index);
      value(x.count);
    }
  }
  void text(std::string& t) {
    std::uint64_t n = 0;
    value(n);
    if (!ok || n > static_cast<std::size_t>(end - p)) {
      ok = false;
      return;
    }
    t.assign(p, static_cast<std::size_t>(n));
    p += n;
  }
};

/// Writer's and Reader's walk over every field of a shape, in one order.
template <class IO, class Shape>
void fields(IO& io, Shape& s) {
  io.array(s.vertices);
  io.array(s.triangles);
  io.array(s.face_normals);
  io.array(s.triangle_edges);
  io.array(s.edge_normals);
  io.array(s.vertex_normals);
  io.nodes(s.nodes);
  io.array(s.grid_distance);
  io.value(s.grid_cells);
  io.vec3(s.grid_origin);
  io.value(s.grid_cell);
  io.vec3(s.aabb_min);
  io.vec3(s.aabb_max);
  io.value(s.tree_depth);
  io.value(s.band.width);
  io.value(s.band.cell);
  io.vec3(s.band.origin);
  io.value(s.band.cells);
  io.array(s.band.brick_slot);
  io.array(s.band.cell_begin);
  io.array(s.band.triangles);
  io.text(s.band.note);
}


/// "" when the arrays of `s` have the sizes and index ranges a built shape has, else what is off.
std::string check_shape(const core::MeshShape& s) {
  const std::size_t nv = s.vertices.size(), nt = s.triangles.size(), ne = s.edge_normals.size();
  if (nt == 0 || s.nodes.empty()) return "no triangle or no tree";
  if (s.face_normals.size() != nt || s.triangle_edges.size() != nt || s.vertex_normals.size() != nv)
    return "array sizes disagree";
  for (std::size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      const auto v = static_cast<std::size_t>(s.triangles[t][static_cast<std::size_t>(k)]);
      const auto e = static_cast<std::size_t>(s.triangle_edges[t][static_cast<std::size_t>(k)]);
      if (v >= nv || e >= ne) return "a vertex or edge index out of range";
    }
  for (std::size_t i = 0; i < s.nodes.size(); ++i) {
    const core::MeshBvhNode& n = s.nodes[i];
    const bool leaf_ok = n.count > 0 && n.index >= 0 &&
                         static_cast<std::size_t>(n.index) + static_cast<std::size_t>(n.count) <= nt;
    const bool inner_ok = n.count == 0 && static_cast<std::size_t>(n.index) > i + 1 &&
                          static_cast<std::size_t>(n.index) < s.nodes.size() && i + 1 < s.nodes.size();
    if (!leaf_ok && !inner_ok) return "a tree node out of range";
  }
  const std::size_t cells = static_cast<std::size_t>(s.grid_cells[0]) * s.grid_cells[1] * s.grid_cells[2];
  if (s.grid_cells[0] < 1 || s.grid_cells[1] < 1 || s.grid_cells[2] < 1 || s.grid_distance.size() != cells)
    return "grid sizes disagree";
  const core::MeshBand& b = s.band;
  if (b.width > 0.0) {
    constexpr std::size_t kCells = static_cast<std::size_t>(core::kMeshBrickCells) *
                                   core::kMeshBrickCells * core::kMeshBrickCells;
    for (int k = 0; k < 3; ++k)
      if (b.cells[static_cast<std::size_t>(k)] < core::kMeshBrickCells ||
          b.cells[static_cast<std::size_t>(k)] % core::kMeshBrickCells != 0)
        return "band cells out of range";
    const std::size_t bricks = static_cast<std::size_t>(b.cells[0] / core::kMeshBrickCells) *
                               static_cast<std::size_t>(b.cells[1] / core::kMeshBrickCells) *
                               static_cast<std::size_t>(b.cells[2] / core::kMeshBrickCells);
    if (b.brick_slot.size() != bricks || b.cell_begin.size() % (kCells + 1) != 0)
      return "band sizes disagree";
    const std::size_t slots = b.cell_begin.size() / (kCells + 1);
    for (const std::int32_t slot : b.brick_slot)
      if (slot < -1 || (slot >= 0 && static_cast<std::size_t>(slot) >= slots)) return "a band slot out of range";
    for (std::size_t i = 0; i < b.cell_begin.size(); ++i) {
      const bool first = i % (kCells + 1) == 0;
      if (b.cell_begin[i] > b.triangles.size() || (!first && b.cell_begin[i] < b.cell_begin[i - 1]))
        return "band offsets out of range";
    }
    for (const std::int32_t e : b.triangles)
      if (e < 0 || static_cast<std::size_t>(e >> 7) >= nt) return "a band triangle out of range";
  }
  return "";
}

/// Reads `path` into `out` when its key is `key`: "" then, else why not ("missing" when absent).
/// Reads cache file `path` into `data` and checks its header (`magic`, `version`, `key`, payload
/// size, checksum): "" with `r` at the payload, else why not ("missing", "stale (…)",
/// "damaged (…)"; `kind` names the cache, "mesh" or "net"; `stale` says why a key differs).
std::string open_cache(const std::filesystem::path& path, const char (&magic)[8], const char* kind,
                       std::uint32_t version, std::uint64_t key, const char* stale,
                       std::string& data, Reader& r) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return "missing";
  const std::streamoff bytes = in.tellg();
  if (bytes < 0) return "damaged (a read error)";
  data.assign(static_cast<std::size_t>(bytes), '\0');
  in.seekg(0);
  if (!in.read(data.data(), bytes)) return "damaged (a read error)";
  r = Reader{data.data(), data.data() + data.size()};
  char file_magic[8] = {};
  for (char& c : file_magic) r.value(c);
  std::uint32_t file_version = 0;
  std::uint64_t file_key = 0, size = 0, checksum = 0;
  r.value(file_version);
  r.value(file_key);
  r.value(size);
  r.value(checksum);
  if (!r.ok || std::memcmp(file_magic, magic, sizeof magic) != 0)
    return std::string("damaged (not a numen ") + kind + " cache)";
  if (file_version != version)
    return "stale (format version " + std::to_string(file_version) + ", this numen writes " +
           std::to_string(version) + ")";
  if (file_key != key) return std::string("stale (") + stale + ")";
  if (size != data.size() - kHeaderBytes)
    return "damaged (" + std::to_string(data.size() - kHeaderBytes) + " payload bytes, the header says " +
           std::to_string(size) + ")";
  Hash h;
  h.bytes(data.data() + kHeaderBytes, static_cast<std::size_t>(size));
  if (h.h != checksum) return "damaged (checksum mismatch)";
  return "";
}

std::string read_cache(const std::filesystem::path& path, std::uint64_t key, core::MeshShape& out) {
  std::string data;
  Reader r{nullptr, nullptr};
  if (std::string why = open_cache(path, kMagic, "mesh", kMeshCacheVersion, key,
                                   "built from other triangles or band settings", data, r);
      !why.empty())
    return why;
  core::MeshShape s;
  fields(r, s);
  if (!r.ok || r.p != r.end) return "damaged (the payload does not parse)";
  if (std::string bad = check_shape(s); !bad.empty()) return "damaged (" + bad + ")";
  out = std::move(s);
  return "";
}

/// Writes `payload` to cache file `path` after its header (`magic`, `version`, `key`, size,
/// checksum), through a temporary file renamed over it; "" or why it could not.
std::string write_cache_file(const std::filesystem::path& path, const char (&magic)[8],
                             std::uint32_t version, std::uint64_t key, const std::string& payload) {
  Hash h;
  h.bytes(payload.data(), payload.size());
  Writer w;
  for (char c : magic) w.value(c);
  w.value(version);
  w.value(key);
  w.value(static_cast<std::uint64_t>(payload.size()));
  w.value(h.h);
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  if (ec) return "cannot write " + path.string() + ": cannot make its folder (" + ec.message() + ")";
  const std::filesystem::path tmp = path.string() + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(w.out.data(), static_cast<std::streamsize>(w.out.size()));
    out.write(payload.data(), static_cast<std::streamsize>(payload.size()));
    out.close();
    if (!out) {
      std::filesystem::remove(tmp, ec);
      return "cannot write " + path.string() + " (" + std::strerror(errno) + ")";
    }
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    return "cannot write " + path.string() + " (" + ec.message() + ")";
  }
  return "";
}

std::string write_cache(const std::filesystem::path& path, std::uint64_t key, const core::MeshShape& s) {
  Writer payload;
  fields(payload, s);
  return write_cache_file(path, kMagic, kMeshCacheVersion, key, payload.out);
}

constexpr char kNetMagic[8] = {'N', 'U', 'M', 'E', 'N', 'N', 'E', 'T'};

std::string read_net_cache(const std::filesystem::path& path, std::uint64_t key,
                           core::TriangleMesh& out) {
  std::string data;
  Reader r{nullptr, nullptr};
  if (std::string why = open_cache(path, kNetMagic, "net", kNetCacheVersion, key,
                                   "simplified from another mesh, to another size or by another "
                                   "simplifier",
                                   data, r);
      !why.empty())
    return why;
  core::TriangleMesh net;
  r.array(net.vertices);
  r.array(net.triangles);
  if (!r.ok || r.p != r.end) return "damaged (the payload does not parse)";
  if (std::string bad = core::validate_mesh(net); !bad.empty()) return "damaged (" + bad + ")";
  out = std::move(net);
  return "";
}

}  // namespace

std::uint64_t mesh_cache_key(const core::TriangleMesh& mesh, const core::MeshShapeOptions& options) {
  Hash h;
  h.value(kMeshCacheVersion);
  h.mesh(mesh);
  h.value(options.band);
  h.value(options.cell_factor);
  h.value(static_cast<std::uint64_t>(options.max_band_bytes));
  h.value(core::kMeshLeafSize);
  h.value(core::kMeshGridCells);
  h.value(core::kMeshBrickCells);
  return h.h;
}

std::filesystem::path default_mesh_cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x != nullptr && *x != '\0')
    return std::filesystem::path(x) / "numen" / "meshes";
  if (const char* home = std::getenv("HOME"); home != nullptr && *home != '\0')
    return std::filesystem::path(home) / ".cache" / "numen" / "meshes";
  return {};
}

namespace {

/// "<stem>-<key, 16 hex digits><extension>".
std::string cache_file_name(const std::string& stem, std::uint64_t key, const char* extension) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(key));
  return stem + "-" + hex + extension;
}

}  // namespace

std::string mesh_cache_file_name(const std::string& stem, std::uint64_t key) {
  return cache_file_name(stem, key, ".nmshape");
}

namespace {

/// The cache protocol of both kinds: `read()` the file ("" when it held what is asked, else why
/// not), else `make()` it ("" or the error, returned) and `write()` it, the outcome saying
/// whether it was loaded or written and why not (`redo`: what was done instead, "rebuilt").
template <typename Read, typename Make, typename Write>
std::string through_cache(const std::filesystem::path& path, const char* redo, Read read, Make make,
                          Write write, MeshCacheOutcome& outcome) {
  outcome = MeshCacheOutcome{};
  const std::string why = read();
  if (why.empty()) {
    outcome.loaded = true;
    return "";
  }
  if (why != "missing") outcome.note = path.string() + ": " + why + ": " + redo;
  const std::string err = make();
  if (!err.empty()) return err;
  const std::string written = write();
  outcome.written = written.empty();
  if (!written.empty()) outcome.note += (outcome.note.empty() ? "" : "; ") + written;
  return "";
}

}  // namespace

std::string build_mesh_shape_cached(const core::TriangleMesh& mesh,
                                    const core::MeshShapeOptions& options,
                                    const std::filesystem::path& path, core::MeshShape& out,
                                    MeshCacheOutcome& outcome) {
  const std::uint64_t key = mesh_cache_key(mesh, options);
  return through_cache(
      path, "rebuilt", [&] { return read_cache(path, key, out); },
      [&] { return core::build_mesh_shape(mesh, out, options); },
      [&] { return write_cache(path, key, out); }, outcome);
}

std::uint64_t net_cache_key(const core::TriangleMesh& mesh, int nodes, std::uint64_t simplifier) {
  Hash h;
  h.value(kNetCacheVersion);
  h.mesh(mesh);
  h.value(nodes);
  h.value(simplifier);
  return h.h;
}

std::string net_cache_file_name(const std::string& stem, std::uint64_t key) {
  return cache_file_name(stem, key, ".nmnet");
}

std::string simplify_net_cached(const core::TriangleMesh& mesh, int nodes, std::uint64_t simplifier,
                                const std::filesystem::path& path,
                                const std::function<std::string(core::TriangleMesh&)>& simplify,
                                core::TriangleMesh& net, MeshCacheOutcome& outcome) {
  const std::uint64_t key = net_cache_key(mesh, nodes, simplifier);
  return through_cache(
      path, "simplified again", [&] { return read_net_cache(path, key, net); },
      [&] { return simplify(net); },
      [&] {
        Writer payload;
        payload.array(net.vertices);
        payload.array(net.triangles);
        return write_cache_file(path, kNetMagic, kNetCacheVersion, key, payload.out);
      },
      outcome);
}

}  // namespace numen::sim
