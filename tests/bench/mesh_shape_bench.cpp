// Cost of the mesh obstacles' signed-distance query (core/mesh_shape.hpp, docs/meshes.md) against
// the triangle count, and of building the shape. Torus of R 4 cm, r 1.5 cm (core::make_torus) at
// 1k, 10k and 100k triangles (16×32, 50×100, 158×316 vertices).
// MeshContact: one query per contact — 4096 sphere centres outside the analytic surface, closer
// than the sphere radius 5 mm (uniform in the offset: penetrations 0–5 mm), reach 5 mm, cycled;
// the time per iteration is the cost of one sphere–mesh contact. Counters: triangles,
// tree_depth, hit_fraction (queries that found the contact; the rest are chord error).
// MeshContactSweep: the same offsets, the centres in the order a tool sweeping once around the
// torus's outer rim (v within ±9°) meets them: consecutive queries share cache lines.
// MeshContactInside: centres inside, 0–5 mm deep (a sphere sunk past its centre), where the
// tube's concavity leaves many triangles nearly as close as the nearest.
// MeshMiss: the same points moved 2 cm out along the torus normal (in the bounds box or beyond,
// no contact): the cost of a sphere that is near but not touching.
// MeshBuild: build_mesh_shape() (tree, normals, edges, the 32³-cell grid, the band); counter
// memory_MB (the whole shape) and band_MB.
// MeshCacheLoad: the same shape read from its cache file (sim::build_mesh_shape_cached(), written
// once before the loop in the temp folder: read, checksum, parse, index checks); counter file_MB.
// The second argument: 0 builds no band (the tree answers every query), 1 the narrow band of
// width 5 mm (the reach) and cells of the mean edge length; both in the same run. Counter
// band_triangles: triangles listed per non-empty band cell (mean).
//
//   ./build/tests/numen_bench --benchmark_filter='Mesh(Contact|Miss|Build|CacheLoad)' --benchmark_repetitions=3

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "numen/core/mesh.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/sim/scene/mesh_cache.hpp"

namespace {

namespace core = numen::core;
using core::Vec3;

constexpr double kMajor = 0.04, kMinor = 0.015, kReach = 0.005;

/// Sides around the tube for about `triangles` triangles (segments = 2 sides).
int sides_for(int triangles) {
  return static_cast<int>(std::lround(std::sqrt(triangles / 4.0)));
}

/// Options of the run: no band (`band` 0, the tree) or the band of width kReach.
core::MeshShapeOptions mesh_options(std::int64_t band) {
  core::MeshShapeOptions o;
  o.band = band != 0 ? kReach : 0.0;
  return o;
}

core::MeshShape torus_shape(int triangles, std::int64_t band) {
  const int sides = sides_for(triangles);
  core::MeshShape s;
  core::build_mesh_shape(core::make_torus(kMajor, kMinor, 2 * sides, sides), s, mesh_options(band));
  return s;
}

/// Mean triangles listed per non-empty band cell (0 without a band).
double band_triangles(const core::MeshShape& s) {
  constexpr std::size_t kCells = core::kMeshBrickCells * core::kMeshBrickCells * core::kMeshBrickCells;
  const auto& begin = s.band.cell_begin;
  std::size_t cells = 0;
  for (std::size_t slot = 0; slot < begin.size() / (kCells + 1); ++slot)
    for (std::size_t k = 0; k < kCells; ++k)
      if (begin[slot * (kCells + 1) + k + 1] > begin[slot * (kCells + 1) + k]) ++cells;
  return cells == 0 ? 0.0 : static_cast<double>(s.band.triangles.size()) / static_cast<double>(cells);
}

/// Points at a signed offset in [lo, hi] (m) from the analytic torus surface along its normal;
/// `sweep`: ordered along the torus (u increasing) as a tool would meet them, so that consecutive
/// queries touch neighbouring triangles; otherwise in random order over the whole surface.
std::vector<Vec3> torus_points(double lo, double hi, bool sweep) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * std::numbers::pi), offset(lo, hi);
  std::vector<Vec3> out(4096);
  for (std::size_t k = 0; k < out.size(); ++k) {
    Vec3& p = out[k];
    const double u = sweep ? 2.0 * std::numbers::pi * static_cast<double>(k) / out.size() : angle(rng);
    const double v = angle(rng) * (sweep ? 0.05 : 1.0);
    const double rho = kMinor + offset(rng);
    const double ring = kMajor + rho * std::cos(v);
    p = Vec3(ring * std::cos(u), ring * std::sin(u), rho * std::sin(v));
  }
  return out;
}

void run_queries(benchmark::State& state, double lo, double hi, bool sweep = false) {
  const core::MeshShape s = torus_shape(static_cast<int>(state.range(0)), state.range(1));
  const std::vector<Vec3> points = torus_points(lo, hi, sweep);
  std::size_t i = 0;
  int hits = 0;
  for (auto _ : state) {
    core::MeshDistance d;
    hits += core::mesh_signed_distance(s, points[i], kReach, d) ? 1 : 0;
    benchmark::DoNotOptimize(d);
    i = (i + 1) & (points.size() - 1);
  }
  state.counters["triangles"] = s.num_triangles();
  state.counters["tree_depth"] = s.tree_depth;
  state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(state.iterations());
  state.counters["band_triangles"] = band_triangles(s);
}

void MeshContact(benchmark::State& state) { run_queries(state, 0.0, kReach); }
void MeshContactInside(benchmark::State& state) { run_queries(state, -kReach, 0.0); }
void MeshContactSweep(benchmark::State& state) { run_queries(state, 0.0, kReach, true); }
void MeshMiss(benchmark::State& state) { run_queries(state, 0.02, 0.02); }

void MeshBuild(benchmark::State& state) {
  const int sides = sides_for(static_cast<int>(state.range(0)));
  const core::TriangleMesh mesh = core::make_torus(kMajor, kMinor, 2 * sides, sides);
  std::size_t bytes = 0, band_bytes = 0;
  for (auto _ : state) {
    core::MeshShape s;
    core::build_mesh_shape(mesh, s, mesh_options(state.range(1)));
    bytes = s.memory_bytes();
    band_bytes = core::mesh_band_bytes(s.band);
    benchmark::DoNotOptimize(s);
  }
  state.counters["triangles"] = mesh.num_triangles();
  state.counters["memory_MB"] = static_cast<double>(bytes) / 1e6;
  state.counters["band_MB"] = static_cast<double>(band_bytes) / 1e6;
}

void MeshCacheLoad(benchmark::State& state) {
  const int sides = sides_for(static_cast<int>(state.range(0)));
  const core::TriangleMesh mesh = core::make_torus(kMajor, kMinor, 2 * sides, sides);
  const core::MeshShapeOptions options = mesh_options(state.range(1));
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() /
      ("numen_bench_" + std::to_string(state.range(0)) + "_" + std::to_string(state.range(1)) + ".nmshape");
  core::MeshShape s;
  numen::sim::MeshCacheOutcome o;
  numen::sim::build_mesh_shape_cached(mesh, options, path, s, o);  // writes it
  if (!o.written) state.SkipWithError(("cache not written: " + o.note).c_str());
  bool loaded = true;
  for (auto _ : state) {
    core::MeshShape l;
    numen::sim::build_mesh_shape_cached(mesh, options, path, l, o);
    loaded = loaded && o.loaded;
    benchmark::DoNotOptimize(l);
  }
  if (!loaded) state.SkipWithError("the cache file was not used");
  state.counters["triangles"] = mesh.num_triangles();
  state.counters["file_MB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  std::error_code ec;
  std::filesystem::remove(path, ec);
}

/// Triangles {1k, 10k, 100k} × {tree, band}.
void sizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"triangles", "band"});
  for (std::int64_t band : {0, 1})
    for (std::int64_t n : {1000, 10000, 100000}) b->Args({n, band});
}

BENCHMARK(MeshContact)->Apply(sizes);
BENCHMARK(MeshContactSweep)->Apply(sizes);
BENCHMARK(MeshContactInside)->Apply(sizes);
BENCHMARK(MeshMiss)->Apply(sizes);
BENCHMARK(MeshBuild)->Apply(sizes)->Unit(benchmark::kMillisecond);
BENCHMARK(MeshCacheLoad)->Apply(sizes)->Unit(benchmark::kMillisecond);

}  // namespace
