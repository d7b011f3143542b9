/// @file mesh_cache.cpp
/// The cache file of a built mesh shape (see mesh_cache.hpp).

#include "numen/sim/scene/mesh_cache.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

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

constexpr char kNetMagic[8] = {'N', 'U', 'M', 'E', 'N', 'N', 'E', 'T'};

/// The cache kind whose magic the 8 bytes at `head` are ("mesh-shape", "net"), or nullptr.
const char* cache_kind_of(const char* head) {
  if (std::memcmp(head, kMagic, sizeof kMagic) == 0) return "mesh-shape";
  if (std::memcmp(head, kNetMagic, sizeof kNetMagic) == 0) return "net";
  return nullptr;
}

/// What a file of mode `mode` is, when it is not a regular file ("a directory", …), else "".
std::string not_a_regular_file(mode_t mode) {
  if (S_ISREG(mode)) return "";
  if (S_ISLNK(mode)) return "a symbolic link";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

/// A file descriptor closed when it goes out of scope.
struct Fd {
  int fd = -1;
  Fd() = default;
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

/// Moves all `n` bytes between `fd` and `buf` by `io` (::read or ::write), again after EINTR
/// and a short count: false at an error or an early end.
template <typename Byte, typename Io>
bool transfer_all(int fd, Byte* buf, std::size_t n, Io io) {
  while (n > 0) {
    const ssize_t done = io(fd, buf, n);
    if (done < 0 && errno == EINTR) continue;
    if (done <= 0) return false;
    buf += done;
    n -= static_cast<std::size_t>(done);
  }
  return true;
}

/// Reads `n` bytes of `fd` into `out`: false at a read error or an early end.
bool read_exactly(int fd, char* out, std::size_t n) { return transfer_all(fd, out, n, ::read); }

/// Writes the `n` bytes at `data` to `fd`: false at an error.
bool write_all(int fd, const char* data, std::size_t n) {
  return transfer_all(fd, data, n, ::write);
}

/// One cache file's kind: its magic, its name in messages ("mesh-shape", "net") and its format
/// version.
struct CacheKind {
  const char* magic;  ///< 8 bytes.
  const char* name;
  std::uint32_t version;
};

/// Looks at what cache path `path` names, following no link and opening nothing that could
/// block: "" when it may be `kind`'s cache, `exists` then saying whether a file of that kind is
/// there (its descriptor left open in `fd`, `bytes` its size) or nothing is (its folder exists);
/// else why `path` may be neither read nor written as that cache (a symbolic link, a directory,
/// a FIFO, a device node, a socket; a file that does not start with `kind`'s magic, which it
/// would overwrite; a folder that does not exist), naming `path`.
std::string inspect_cache_path(const std::filesystem::path& path, const CacheKind& kind, Fd& fd,
                               bool& exists, std::uint64_t& bytes) {
  exists = false;
  bytes = 0;
  const std::string name = path.string();
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) {
    if (errno != ENOENT) return name + ": cannot look at it (" + std::strerror(errno) + ")";
    const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : ".";
    struct stat ds {};
    if (::stat(dir.c_str(), &ds) != 0)
      return name + ": its folder " + dir.string() + " does not exist (" + std::strerror(errno) +
             "): numen makes no folder for a cache file; make it, or name a file in an existing "
             "folder";
    if (!S_ISDIR(ds.st_mode)) return name + ": " + dir.string() + " is not a folder";
    return "";
  }
  if (const std::string what = not_a_regular_file(st.st_mode); !what.empty())
    return name + " is " + what + ", not a cache file: a cache path must name a regular file or " +
           "nothing (numen neither follows, reads nor replaces anything else)";
  fd.fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd.fd < 0)
    return name + ": cannot read it (" + std::strerror(errno) +
           "), so numen cannot tell whether it is its cache: refusing to overwrite it";
  if (::fstat(fd.fd, &st) != 0 || !S_ISREG(st.st_mode))  // replaced since the lstat()
    return name + " is not a regular file: refusing to use it as a cache";
  char head[8] = {};
  const bool whole =
      st.st_size >= static_cast<off_t>(sizeof head) && read_exactly(fd.fd, head, sizeof head);
  const char* other = whole ? cache_kind_of(head) : nullptr;
  if (other == nullptr)
    return name + ": not a numen cache (it does not start with \"" + std::string(kind.magic, 8) +
           "\"); refusing to overwrite it: name a file of its own for the cache";
  if (std::memcmp(head, kind.magic, 8) != 0)
    return name + ": a numen " + other + " cache, not a " + kind.name +
           " cache; refusing to overwrite it: give each cache a file of its own";
  exists = true;
  bytes = static_cast<std::uint64_t>(st.st_size);
  return "";
}

/// Reads cache file `path` of `kind` and checks its header (version, `key`, payload size,
/// checksum): "" with `payload` filled, else why not ("missing", "stale (…)", "damaged (…)";
/// `stale` says why a key differs); or, in `refused`, why `path` cannot be this cache
/// (inspect_cache_path()).
std::string open_cache(const std::filesystem::path& path, const CacheKind& kind, std::uint64_t key,
                       const char* stale, std::string& payload, std::string& refused) {
  Fd fd;
  bool exists = false;
  std::uint64_t bytes = 0;
  refused = inspect_cache_path(path, kind, fd, exists, bytes);
  if (!refused.empty()) return refused;
  if (!exists) return "missing";
  char header[kHeaderBytes - 8];
  if (bytes < kHeaderBytes || !read_exactly(fd.fd, header, sizeof header))
    return "damaged (" + std::to_string(bytes) + " bytes, shorter than its header)";
  Reader r{header, header + sizeof header};
  std::uint32_t file_version = 0;
  std::uint64_t file_key = 0, size = 0, checksum = 0;
  r.value(file_version);
  r.value(file_key);
  r.value(size);
  r.value(checksum);
  if (file_version != kind.version)
    return "stale (format version " + std::to_string(file_version) + ", this numen writes " +
           std::to_string(kind.version) + ")";
  if (file_key != key) return std::string("stale (") + stale + ")";
  if (size != bytes - kHeaderBytes)
    return "damaged (" + std::to_string(bytes - kHeaderBytes) + " payload bytes, the header says " +
           std::to_string(size) + ")";
  payload.assign(static_cast<std::size_t>(size), '\0');
  if (!read_exactly(fd.fd, payload.data(), payload.size())) return "damaged (a read error)";
  Hash h;
  h.bytes(payload.data(), payload.size());
  if (h.h != checksum) return "damaged (checksum mismatch)";
  return "";
}

/// Parses a mesh-shape cache's payload into `out`: "" or why it is not the shape of `mesh`
/// ("damaged (…)").
std::string parse_shape(const std::string& payload, const core::TriangleMesh& mesh,
                        core::MeshShape& out) {
  Reader r{payload.data(), payload.data() + payload.size()};
  core::MeshShape s;
  fields(r, s);
  if (!r.ok || r.p != r.end) return "damaged (the payload does not parse)";
  if (std::string bad = check_shape(s); !bad.empty()) return "damaged (" + bad + ")";
  if (s.vertices != mesh.vertices)
    return "damaged (its key is this mesh's, its vertices another mesh's)";
  out = std::move(s);
  return "";
}

/// Writes `payload` to cache file `path` of `kind` after its header (magic, version, `key`,
/// size, checksum), through a temporary file in the same folder renamed over it, after looking
/// again at what `path` names (inspect_cache_path(): never over anything but a cache of `kind`);
/// "" or why it could not.
std::string write_cache_file(const std::filesystem::path& path, const CacheKind& kind,
                             std::uint64_t key, const std::string& payload) {
  Hash h;
  h.bytes(payload.data(), payload.size());
  Writer w;
  for (int k = 0; k < 8; ++k) w.value(kind.magic[k]);
  w.value(kind.version);
  w.value(key);
  w.value(static_cast<std::uint64_t>(payload.size()));
  w.value(h.h);
  std::string tmp = path.string() + ".XXXXXX";
  Fd out;
  out.fd = ::mkstemp(tmp.data());  // O_EXCL: never an existing file
  if (out.fd < 0) return "cannot write " + path.string() + " (" + std::strerror(errno) + ")";
  ::fchmod(out.fd, 0644);
  const bool ok = write_all(out.fd, w.out.data(), w.out.size()) &&
                  write_all(out.fd, payload.data(), payload.size());
  const int write_errno = errno;
  const bool closed = ::close(out.fd) == 0;
  out.fd = -1;
  std::string why;
  if (!ok || !closed) {
    why = "cannot write " + path.string() + " (" + std::strerror(ok ? errno : write_errno) + ")";
  } else {
    Fd look;
    bool exists = false;
    std::uint64_t bytes = 0;
    if (std::string refused = inspect_cache_path(path, kind, look, exists, bytes); !refused.empty())
      why = "not written: " + refused;
    else if (::rename(tmp.c_str(), path.c_str()) != 0)
      why = "cannot write " + path.string() + " (" + std::strerror(errno) + ")";
  }
  if (!why.empty()) ::unlink(tmp.c_str());
  return why;
}

constexpr CacheKind kShapeCache{kMagic, "mesh-shape", kMeshCacheVersion};
constexpr CacheKind kNetCache{kNetMagic, "net", kNetCacheVersion};

/// Parses a net cache's payload into `out`: "" or why it is not a net of `mesh` ("damaged
/// (…)"): not a valid, closed surface, fewer nodes than a tetrahedron's or as many as the mesh's
/// vertices, nodes farther outside the mesh's bounding box than its longest side.
std::string parse_net(const std::string& payload, const core::TriangleMesh& mesh,
                      core::TriangleMesh& out) {
  Reader r{payload.data(), payload.data() + payload.size()};
  core::TriangleMesh net;
  r.array(net.vertices);
  r.array(net.triangles);
  if (!r.ok || r.p != r.end) return "damaged (the payload does not parse)";
  if (std::string bad = core::validate_mesh(net); !bad.empty()) return "damaged (" + bad + ")";
  if (core::build_mesh_topology(net).boundary_edges > 0)
    return "damaged (its net has edges on one triangle only)";
  if (net.num_vertices() < 4 || net.num_vertices() >= mesh.num_vertices())
    return "damaged (its net has " + std::to_string(net.num_vertices()) + " nodes, the mesh " +
           std::to_string(mesh.num_vertices()) + " vertices)";
  core::Vec3 lo = mesh.vertices.front(), hi = lo;
  for (const core::Vec3& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double side = (hi - lo).maxCoeff();
  for (const core::Vec3& v : net.vertices)
    if (!((v - hi).maxCoeff() <= side && (lo - v).maxCoeff() <= side))
      return "damaged (its net lies off this mesh: a node more than the mesh's size outside its "
             "bounding box)";
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

/// The cache protocol of both kinds: read cache file `path` of `kind` (open_cache(), `stale`
/// saying why a key differs) and `parse()` its payload ("" when it held what is asked, else why
/// not), else `make()` it ("" or the error, returned) and `write()` it (its payload), the outcome
/// saying whether it was loaded or written and why not (`redo`: what was done instead,
/// "rebuilt"). A path that cannot be this cache is returned at once, nothing made
/// (MeshCacheOutcome::cache_refused).
template <typename Parse, typename Make, typename Payload>
std::string through_cache(const std::filesystem::path& path, const CacheKind& kind,
                          std::uint64_t key, const char* stale, const char* redo, Parse parse,
                          Make make, Payload payload, MeshCacheOutcome& outcome) {
  outcome = MeshCacheOutcome{};
  std::string bytes, refused;
  std::string why = open_cache(path, kind, key, stale, bytes, refused);
  if (!refused.empty()) {
    outcome.cache_refused = true;
    return refused;
  }
  if (why.empty()) why = parse(bytes);
  if (why.empty()) {
    outcome.loaded = true;
    return "";
  }
  if (why != "missing") outcome.note = path.string() + ": " + why + ": " + redo;
  const std::string err = make();
  if (!err.empty()) return err;
  const std::string written = write_cache_file(path, kind, key, payload());
  outcome.written = written.empty();
  if (!written.empty()) outcome.note += (outcome.note.empty() ? "" : "; ") + written;
  return "";
}

}  // namespace

std::string build_mesh_shape_cached(const core::TriangleMesh& mesh,
                                    const core::MeshShapeOptions& options,
                                    const std::filesystem::path& path, core::MeshShape& out,
                                    MeshCacheOutcome& outcome) {
  return through_cache(
      path, kShapeCache, mesh_cache_key(mesh, options),
      "built from other triangles or band settings", "rebuilt",
      [&](const std::string& bytes) { return parse_shape(bytes, mesh, out); },
      [&] { return core::build_mesh_shape(mesh, out, options); },
      [&] {
        Writer payload;
        fields(payload, out);
        return std::move(payload.out);
      },
      outcome);
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
  return through_cache(
      path, kNetCache, net_cache_key(mesh, nodes, simplifier),
      "simplified from another mesh, to another size or by another simplifier", "simplified again",
      [&](const std::string& bytes) { return parse_net(bytes, mesh, net); },
      [&] { return simplify(net); },
      [&] {
        Writer payload;
        payload.array(net.vertices);
        payload.array(net.triangles);
        return std::move(payload.out);
      },
      outcome);
}

std::optional<std::string> slow_net_simplification_hint(double wall_s, int nodes, bool cached) {
  if (cached || !(wall_s >= kSlowNetSimplifySeconds)) return std::nullopt;
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.1f", wall_s);
  return "simplified to " + std::to_string(nodes) + " nodes in " + seconds +
         " s (wall clock) at every load: `cache = true` (or a file path) keeps the net for the "
         "next load";
}

}  // namespace numen::sim
