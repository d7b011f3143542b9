/// @file mesh_shape_band.cpp
/// The narrow band of a MeshShape (mesh_shape.hpp, MeshBand; docs/meshes.md): which triangles
/// each cell near the surface lists, so that a query within the band tests a bounded number of
/// triangles whatever the triangle count. Built at load; the query is band_nearest()
/// (mesh/mesh_shape_query.hpp).
///
/// Every feature f (face, edge, vertex) is rasterised into the cells that meet its region R_f
/// (the points whose closest point on the surface can lie on f) within distance B of f. R_f is an
/// intersection of half-spaces n·x ≤ d; a cell is kept unless it lies wholly outside one of them
/// (conservative: a kept cell may miss R_f near its corners, a dropped one never meets it). Rows
/// of cells along x are clipped analytically, then the distance test runs per cell.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "mesh/mesh_shape_query.hpp"
#include "numen/core/mesh_shape.hpp"

namespace numen::core {
namespace {

using detail::closest_on_triangle;

constexpr int kB = kMeshBrickCells;
constexpr int kBrick = kB * kB * kB;
constexpr int kTriangleBits = 24;  // a key is (cell << 24) | triangle; an entry t << 7 | q

/// n·x ≤ d, n unit; `r` = half the cell side × |n|₁ (n·x's drop from a cell centre to its
/// lowest corner).
struct HalfSpace {
  Vec3 n = Vec3::Zero();
  double d = 0.0;
  double r = 0.0;
};

/// Bounds (offsets from the apex, lo ≤ 0 ≤ hi) of {w in the cone spanned by `rays` : |w| ≤ len}.
/// The cone lies in the circular cone around the rays' mean μ of half-angle α, the largest angle
/// from μ to a ray (convex, it holds their conic hull); α > 60° or no mean: the ball's bounds.
void cone_bounds(const std::vector<Vec3>& rays, double len, Vec3& lo, Vec3& hi) {
  lo = Vec3::Zero();
  hi = Vec3::Zero();
  if (rays.empty()) return;
  bool parallel = true;
  for (const Vec3& r : rays) parallel = parallel && r.cross(rays[0]).norm() < 1e-9;
  if (parallel) {
    for (const Vec3& r : rays) {
      lo = lo.cwiseMin(len * r);
      hi = hi.cwiseMax(len * r);
    }
    return;
  }
  Vec3 mu = Vec3::Zero();
  for (const Vec3& r : rays) mu += r;
  double alpha = 0.0;
  if (mu.norm() > 1e-9) {
    mu.normalize();
    for (const Vec3& r : rays) alpha = std::max(alpha, std::acos(std::clamp(mu.dot(r), -1.0, 1.0)));
  }
  if (mu.norm() <= 1e-9 || alpha > std::numbers::pi / 3.0) {
    lo = Vec3::Constant(-len);
    hi = Vec3::Constant(len);
    return;
  }
  constexpr double kRight = std::numbers::pi / 2.0;
  for (int k = 0; k < 3; ++k) {
    const double beta = std::acos(std::clamp(mu[k], -1.0, 1.0));  // angle from +e_k to μ
    const double up = beta <= alpha ? len : (beta - alpha < kRight ? len * std::cos(beta - alpha) : 0.0);
    const double beta_neg = std::numbers::pi - beta;  // from −e_k
    const double down = beta_neg <= alpha ? len
                        : (beta_neg - alpha < kRight ? len * std::cos(beta_neg - alpha) : 0.0);
    hi[k] = std::max(up, 0.0);
    lo[k] = std::min(-down, 0.0);
  }
}

/// Distance from c to the segment [a, b].
double segment_distance(const Vec3& c, const Vec3& a, const Vec3& b) noexcept {
  const Vec3 ab = b - a;
  const double t = std::clamp((c - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (c - (a + t * ab)).norm();
}

/// Collects (cell, triangle) keys of the cells that meet a feature's region within the band.
class Rasterizer {
 public:
  Rasterizer(const MeshBand& band, double slack, std::size_t max_keys, std::vector<std::uint64_t>& keys)
      : b_(band), h_(band.cell), half_(0.5 * band.cell),
        reach_(band.width + 0.5 * std::sqrt(3.0) * band.cell + slack), slack_(slack),
        max_keys_(max_keys), keys_(keys) {}

  bool full() const noexcept { return full_; }

  /// The cells meeting [lo, hi] that no half-space of `hs` excludes and whose centre c has
  /// dist(c) ≤ B + ρ (dist(c) − ρ bounds the feature's distance to the cell from below).
  template <class Dist>
  void add(const Vec3& lo, const Vec3& hi, std::vector<HalfSpace>& hs, const Dist& dist,
           std::int32_t triangle) {
    if (full_) return;
    int i0[3], i1[3];
    for (int k = 0; k < 3; ++k) {
      const double a = std::floor((lo[k] - slack_ - b_.origin[k]) / h_);
      const double z = std::floor((hi[k] + slack_ - b_.origin[k]) / h_);
      i0[k] = static_cast<int>(std::max(a, 0.0));
      i1[k] = static_cast<int>(std::min(z, static_cast<double>(b_.cells[static_cast<std::size_t>(k)] - 1)));
      if (i0[k] > i1[k]) return;
    }
    for (HalfSpace& s : hs) s.r = half_ * s.n.cwiseAbs().sum();
    for (int z = i0[2]; z <= i1[2]; ++z)
      for (int y = i0[1]; y <= i1[1]; ++y) {
        // The row's cells x in [x0, x1] that every half-space admits: n·c0 + n_x h x − r ≤ d.
        const Vec3 c0 = b_.origin + h_ * Vec3(0.5, y + 0.5, z + 0.5);
        double x0 = i0[0], x1 = i1[0];
        for (const HalfSpace& s : hs) {
          const double room = s.d + slack_ + s.r - s.n.dot(c0);
          const double nx = s.n.x() * h_;
          if (std::abs(nx) < 1e-300) {
            if (room < 0.0) x1 = x0 - 1.0;
          } else if (nx > 0.0) {
            x1 = std::min(x1, std::floor(room / nx));
          } else {
            x0 = std::max(x0, std::ceil(room / nx));
          }
          if (x0 > x1) break;
        }
        if (x0 > x1) continue;
        for (int x = static_cast<int>(x0); x <= static_cast<int>(x1); ++x) {
          const Vec3 c = c0 + Vec3(h_ * x, 0.0, 0.0);
          if (dist(c) > reach_) continue;
          if (keys_.size() >= max_keys_) {
            full_ = true;
            return;
          }
          keys_.push_back((cell_id(x, y, z) << kTriangleBits) | static_cast<std::uint64_t>(triangle));
        }
      }
  }

 private:
  std::uint64_t cell_id(int x, int y, int z) const noexcept {
    const std::uint64_t nbx = static_cast<std::uint64_t>(b_.cells[0] / kB);
    const std::uint64_t nby = static_cast<std::uint64_t>(b_.cells[1] / kB);
    const std::uint64_t brick = static_cast<std::uint64_t>(x / kB) +
                                nbx * (static_cast<std::uint64_t>(y / kB) +
                                       nby * static_cast<std::uint64_t>(z / kB));
    return brick * kBrick + static_cast<std::uint64_t>(x % kB + kB * (y % kB + kB * (z % kB)));
  }

  const MeshBand& b_;
  double h_, half_, reach_, slack_;
  std::size_t max_keys_;
  std::vector<std::uint64_t>& keys_;
  bool full_ = false;
};

/// n·(x − at) ≤ 0 for a unit n.
HalfSpace below(const Vec3& n, const Vec3& at) { return HalfSpace{n, n.dot(at), 0.0}; }

/// Rasterises every face, edge and vertex region of `s` (band geometry set) into `keys`.
/// false when the keys would pass `max_keys`.
bool rasterize(const MeshShape& s, const MeshBand& band, double slack, std::size_t max_keys,
               std::vector<std::uint64_t>& keys) {
  Rasterizer raster(band, slack, max_keys, keys);
  const double B = band.width;
  const auto& V = s.vertices;
  const auto vtx = [&](int t, int k) -> const Vec3& {
    return V[static_cast<std::size_t>(s.triangles[static_cast<std::size_t>(t)][static_cast<std::size_t>(k)])];
  };
  const auto inward = [&](int t, int k) {  // in t's plane, ⊥ side k, into t
    return Vec3(s.face_normals[static_cast<std::size_t>(t)].cross(vtx(t, (k + 1) % 3) - vtx(t, k)).normalized());
  };
  std::vector<HalfSpace> hs;
  std::vector<Vec3> rays;
  const auto no_distance = [](const Vec3&) { return 0.0; };

  // Faces: the prism over the triangle (three sides) cut by the slab |n·(x − a)| ≤ B.
  for (int t = 0; t < s.num_triangles(); ++t) {
    const Vec3& n = s.face_normals[static_cast<std::size_t>(t)];
    hs.clear();
    Vec3 lo = Vec3::Constant(detail::kInf), hi = Vec3::Constant(-detail::kInf);
    for (int k = 0; k < 3; ++k) {
      hs.push_back(below(-inward(t, k), vtx(t, k)));
      lo = lo.cwiseMin(vtx(t, k) - B * n.cwiseAbs()).cwiseMin(vtx(t, k) + B * n.cwiseAbs());
      hi = hi.cwiseMax(vtx(t, k) - B * n.cwiseAbs()).cwiseMax(vtx(t, k) + B * n.cwiseAbs());
    }
    hs.push_back(HalfSpace{n, n.dot(vtx(t, 0)) + B, 0.0});
    hs.push_back(HalfSpace{-n, -n.dot(vtx(t, 0)) + B, 0.0});
    raster.add(lo, hi, hs, no_distance, t);
  }

  // Edges: between the end caps, on the outer side of both triangles' edge lines.
  std::vector<std::array<int, 2>> edge_side(s.edge_normals.size(), {-1, -1});  // 3t + k
  for (int t = 0; t < s.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) {
      auto& e = edge_side[static_cast<std::size_t>(s.triangle_edges[static_cast<std::size_t>(t)][static_cast<std::size_t>(k)])];
      e[e[0] < 0 ? 0 : 1] = 3 * t + k;
    }
  for (const auto& e : edge_side) {
    if (e[0] < 0 || e[1] < 0) continue;
    const int t0 = e[0] / 3, k0 = e[0] % 3, t1 = e[1] / 3, k1 = e[1] % 3;
    const Vec3& a = vtx(t0, k0);
    const Vec3& b = vtx(t0, (k0 + 1) % 3);
    const Vec3 u = (b - a).normalized();
    const Vec3 m0 = inward(t0, k0), m1 = inward(t1, k1);
    const Vec3& n0 = s.face_normals[static_cast<std::size_t>(t0)];
    const Vec3& n1 = s.face_normals[static_cast<std::size_t>(t1)];
    hs.clear();
    hs.push_back(below(-u, a));
    hs.push_back(below(u, b));
    hs.push_back(below(m0, a));
    hs.push_back(below(m1, a));
    rays.clear();
    if (n0.dot(n1) > 1.0 - 1e-12) {
      rays = {n0, -n0};  // flat: the plane through the edge ⊥ the faces
    } else if (std::abs(n0.dot(m1)) > 1e-9 && std::abs(n1.dot(m0)) > 1e-9) {
      rays = {n0.dot(m1) <= 0.0 ? n0 : Vec3(-n0), n1.dot(m0) <= 0.0 ? n1 : Vec3(-n1)};
    } else {
      rays = {Vec3::UnitX(), -Vec3::UnitX(), Vec3::UnitY(), -Vec3::UnitY()};  // a fold: the ball
    }
    Vec3 clo, chi;
    cone_bounds(rays, B, clo, chi);
    const Vec3 lo = a.cwiseMin(b) + clo, hi = a.cwiseMax(b) + chi;
    raster.add(lo, hi, hs, [&](const Vec3& c) { return segment_distance(c, a, b); }, t0);
  }

  // Vertices: (x − v)·(w − v) ≤ 0 for every neighbour w; the cone's rays are the feasible
  // normals of pairs of those planes.
  std::vector<std::vector<int>> neighbours(V.size());
  std::vector<int> vertex_triangle(V.size(), -1);
  for (int t = 0; t < s.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int v = s.triangles[static_cast<std::size_t>(t)][static_cast<std::size_t>(k)];
      neighbours[static_cast<std::size_t>(v)].push_back(s.triangles[static_cast<std::size_t>(t)][static_cast<std::size_t>((k + 1) % 3)]);
      if (vertex_triangle[static_cast<std::size_t>(v)] < 0) vertex_triangle[static_cast<std::size_t>(v)] = t;
    }
  std::vector<Vec3> dirs;
  for (std::size_t v = 0; v < V.size(); ++v) {
    if (vertex_triangle[v] < 0) continue;
    dirs.clear();
    hs.clear();
    auto& ring = neighbours[v];  // each neighbour twice (two triangles an edge)
    std::sort(ring.begin(), ring.end());
    ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
    for (int w : ring) {
      dirs.push_back((V[static_cast<std::size_t>(w)] - V[v]).normalized());
      hs.push_back(below(dirs.back(), V[v]));
    }
    rays.clear();
    for (std::size_t i = 0; i < dirs.size(); ++i)
      for (std::size_t j = i + 1; j < dirs.size(); ++j) {
        const Vec3 c = dirs[i].cross(dirs[j]);
        if (c.norm() < 1e-12) continue;
        for (const Vec3& r : {Vec3(c.normalized()), Vec3(-c.normalized())}) {
          bool feasible = true;
          for (const Vec3& d : dirs) feasible = feasible && r.dot(d) <= 1e-9;
          if (feasible) rays.push_back(r);
        }
      }
    Vec3 clo, chi;
    cone_bounds(rays, B, clo, chi);
    const Vec3& at = V[v];
    raster.add(at + clo, at + chi, hs, [&](const Vec3& c) { return (c - at).norm(); },
               vertex_triangle[v]);
  }
  return !raster.full();
}

}  // namespace

std::size_t mesh_band_bytes(const MeshBand& b) noexcept {
  return b.brick_slot.capacity() * sizeof(std::int32_t) +
         b.cell_begin.capacity() * sizeof(std::uint32_t) +
         b.triangles.capacity() * sizeof(std::int32_t);
}

namespace {

/// Whole megabytes, or three digits and an exponent beyond 10^9 MB: a mesh far smaller than its
/// band (a 1e-30 scale) estimates 10^90 bytes, which a long long cannot hold.
std::string megabytes(double bytes) {
  char text[32];
  const double m = bytes / 1048576.0;
  std::snprintf(text, sizeof text, m < 1e9 ? "%.0f MB" : "%.3g MB", m);
  return std::string(text);
}

/// The band's grid over `s` (width, cell h = cell_factor × mean edge, origin, cells in whole
/// bricks), or the reason it is refused (over the byte cap, too many cells or bricks).
struct BandGrid {
  std::string refused;           ///< Non-empty: no band, why.
  std::uint64_t total_bricks = 0;
  std::uint64_t total_cells = 0;
  double rho = 0.0;    ///< The cell's half diagonal √3 h / 2 (m).
  double slack = 0.0;  ///< Rounding slack of the region tests (m).
};

/// Sets b's width, cell, cells and origin for `s`; the grid's sizes in the result.
BandGrid plan_band_grid(const MeshShape& s, const MeshShapeOptions& options, MeshBand& b) {
  BandGrid g;
  double edges = 0.0, area = 0.0;
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    const auto& tri = s.triangles[t];
    const Vec3& a = s.vertices[static_cast<std::size_t>(tri[0])];
    const Vec3& p = s.vertices[static_cast<std::size_t>(tri[1])];
    const Vec3& c = s.vertices[static_cast<std::size_t>(tri[2])];
    edges += (p - a).norm() + (c - p).norm() + (a - c).norm();
    area += 0.5 * (p - a).cross(c - a).norm();
  }
  const double B = options.band;
  const double h = std::max(options.cell_factor, 1e-3) * edges / (3.0 * static_cast<double>(s.triangles.size()));
  g.rho = 0.5 * std::sqrt(3.0) * h;
  // Estimate first (cells of the band of area·2(B + ρ), about 16 keys each, 12 bytes a key
  // while built): refuse a band clearly over the cap before rasterising it.
  const double estimate = area * 2.0 * (B + g.rho) / (h * h * h) * 16.0 * 12.0;
  const std::size_t cap = options.max_band_bytes;
  if (!(estimate <= static_cast<double>(cap))) {  // NaN too
    g.refused = "it would take about " + megabytes(estimate) + ", over the cap of " +
                megabytes(static_cast<double>(cap));
    return g;
  }
  b.width = B;
  b.cell = h;
  const Vec3 lo = s.aabb_min - Vec3::Constant(B + h);
  const Vec3 ext = s.aabb_max + Vec3::Constant(B + h) - lo;
  std::uint64_t total_bricks = 1;
  for (int k = 0; k < 3; ++k) {
    const double cells = std::ceil(ext[k] / h / kB) * kB;
    if (cells > double{1 << 20}) {
      g.refused = "more than 2^20 cells along an axis";
      return g;
    }
    b.cells[static_cast<std::size_t>(k)] = static_cast<int>(cells);
    total_bricks *= static_cast<std::uint64_t>(cells) / kB;
  }
  if (total_bricks > (std::uint64_t{1} << 28)) {
    g.refused = "more than 2^28 bricks";
    return g;
  }
  g.total_bricks = total_bricks;
  g.total_cells = total_bricks * kBrick;
  if (g.total_cells * sizeof(std::uint32_t) > cap) {
    g.refused = "its grid of " + std::to_string(g.total_cells) + " cells is over the cap of " +
                megabytes(static_cast<double>(cap));
    return g;
  }
  b.origin = lo;
  g.slack = 1e-9 * (ext.norm() + B);
  return g;
}

/// Per listed cell (`start`, `by_cell`: the rasterised triangles grouped by cell), the listed
/// triangles' distances to its centre; keeps those within min(B, d_min + ρ) + ρ (no point of
/// the cell within B has its closest point farther), quantised, into b's bricks.
void fill_band_cells(const MeshShape& s, const BandGrid& g, const std::vector<std::uint32_t>& start,
                     std::vector<std::int32_t>& by_cell, MeshBand& b) {
  const double B = b.width, h = b.cell, rho = g.rho;
  b.brick_slot.assign(static_cast<std::size_t>(g.total_bricks), -1);
  const std::uint64_t nbx = static_cast<std::uint64_t>(b.cells[0] / kB);
  const std::uint64_t nby = static_cast<std::uint64_t>(b.cells[1] / kB);
  const double unit = (B + 2.0 * rho) / 127.0;
  std::vector<std::pair<double, std::int32_t>> list;
  std::int64_t open_brick = -1;
  std::size_t base = 0;
  int filled = 0;
  const auto close_brick = [&]() {
    if (open_brick < 0) return;
    for (int k = filled; k <= kBrick; ++k)
      b.cell_begin[base + static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(b.triangles.size());
  };
  for (std::uint64_t cell = 0; cell < g.total_cells; ++cell) {
    if (start[cell] == start[cell + 1]) continue;
    const std::uint64_t brick = cell / kBrick;
    const int local = static_cast<int>(cell % kBrick);
    const int x = static_cast<int>((brick % nbx) * kB) + local % kB;
    const int y = static_cast<int>(((brick / nbx) % nby) * kB) + (local / kB) % kB;
    const int z = static_cast<int>((brick / (nbx * nby)) * kB) + local / (kB * kB);
    const Vec3 c = b.origin + h * Vec3(x + 0.5, y + 0.5, z + 0.5);
    auto* first = by_cell.data() + start[cell];
    auto* last = by_cell.data() + start[cell + 1];
    std::sort(first, last);
    last = std::unique(first, last);
    list.clear();
    double d_min = detail::kInf;
    for (auto* it = first; it != last; ++it) {
      const auto& tri = s.triangles[static_cast<std::size_t>(*it)];
      int feature = 0;
      const double d = (c - closest_on_triangle(c, s.vertices[static_cast<std::size_t>(tri[0])],
                                                s.vertices[static_cast<std::size_t>(tri[1])],
                                                s.vertices[static_cast<std::size_t>(tri[2])], feature))
                           .norm();
      list.emplace_back(d, *it);
      d_min = std::min(d_min, d);
    }
    const double keep = std::min(B, d_min + rho) + rho + g.slack;
    std::sort(list.begin(), list.end());
    while (!list.empty() && list.back().first > keep) list.pop_back();
    if (list.empty()) continue;
    if (static_cast<std::int64_t>(brick) != open_brick) {
      close_brick();
      open_brick = static_cast<std::int64_t>(brick);
      b.brick_slot[static_cast<std::size_t>(brick)] =
          static_cast<std::int32_t>(b.cell_begin.size() / (kBrick + 1));
      base = b.cell_begin.size();
      b.cell_begin.resize(base + kBrick + 1);
      filled = 0;
    }
    for (int k = filled; k <= local; ++k)
      b.cell_begin[base + static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(b.triangles.size());
    for (const auto& [d, t] : list) {
      const int q = std::clamp(static_cast<int>(std::floor(d / unit)), 0, 127);
      b.triangles.push_back(static_cast<std::int32_t>((t << 7) | q));
    }
    filled = local + 1;
  }
  close_brick();
}

}  // namespace

void build_mesh_band(MeshShape& s, const MeshShapeOptions& options) {
  MeshBand& b = s.band;
  b = MeshBand{};
  if (!(options.band > 0.0) || s.triangles.empty()) return;
  const auto refuse = [&](const std::string& why) {
    b = MeshBand{};
    b.note = "no narrow band (" + why + "): every query searches the tree";
  };
  if (s.triangles.size() >= (std::size_t{1} << kTriangleBits)) {
    refuse("more than 2^24 triangles");
    return;
  }
  const BandGrid g = plan_band_grid(s, options, b);
  if (!g.refused.empty()) {
    refuse(g.refused);
    return;
  }
  // (cell, triangle) keys, then the triangles grouped by cell (a counting sort: 8 + 4 bytes a
  // key and 4 a cell while built, all under the cap).
  const std::size_t cap = options.max_band_bytes;
  std::vector<std::uint64_t> keys;
  const std::size_t max_keys = (cap - g.total_cells * sizeof(std::uint32_t)) / 12;
  if (!rasterize(s, b, g.slack, max_keys, keys)) {
    refuse("more than " + megabytes(static_cast<double>(cap)) + " while built");
    return;
  }
  std::vector<std::uint32_t> start(static_cast<std::size_t>(g.total_cells) + 1, 0);
  for (const std::uint64_t k : keys) ++start[static_cast<std::size_t>(k >> kTriangleBits) + 1];
  for (std::size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  std::vector<std::int32_t> by_cell(keys.size());
  {
    std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
    for (const std::uint64_t k : keys)
      by_cell[next[static_cast<std::size_t>(k >> kTriangleBits)]++] =
          static_cast<std::int32_t>(k & ((std::uint64_t{1} << kTriangleBits) - 1));
  }
  std::vector<std::uint64_t>().swap(keys);
  fill_band_cells(s, g, start, by_cell, b);
  b.cell_begin.shrink_to_fit();
  b.triangles.shrink_to_fit();
}

}  // namespace numen::core
