// Figures of organs given by their material (docs/tissue.md, "Measured"; issue 67's figures 1 and
// 2): label figures (tests/CMakeLists.txt: TissueFigures.*), left out of the README's test
// command. A 5 mm sphere pressed into a 60 × 60 × 30 mm block at three net sizes against Hertz and
// GetFEM's static reference (docs/figures/block_reference_neo_nu045.csv); the shipped organ's
// lobe and an ellipsoid of 10 242 vertices on nets of 500 to 10 000 nodes under a 2.5 mm sphere,
// against their finest net; the shipped organ given per spring and by its material. They print
// the tables docs/tissue.md quotes and check the bounds it states.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "build_features.hpp"
#include "numen/core/data.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/core/net_tissue_contact.hpp"
#include "numen/core/step.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_stability_cases.hpp"
#include "mesh/mesh_shape_query.hpp"
#include "organ_indentation.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace core = numen::core;
using core::Vec3;
using numen::test::TempDir;
namespace organ = numen::test::organ;

namespace {

/// The force (N) of `curve` at `depth` (m): the mean of the 5 samples centred on the one
/// nearest it (5 ms at 1 ms; centred, so that the curve's slope does not bias it).
double tissue_force_at(const std::vector<organ::IndentationSample>& curve, double depth) {
  std::size_t at = 0;
  for (std::size_t i = 0; i < curve.size(); ++i)
    if (std::abs(curve[i].depth - depth) < std::abs(curve[at].depth - depth)) at = i;
  const std::size_t lo = at >= 2 ? at - 2 : 0, hi = std::min(curve.size(), lo + 5);
  double f = 0.0;
  for (std::size_t i = lo; i < hi; ++i) f += curve[i].force;
  return f / static_cast<double>(hi - lo);
}

/// GetFEM's static reference F/E (mm²) by depth (mm) from a docs/figures/block_reference_*.csv.
std::map<double, double> tissue_block_reference(const std::string& name) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/docs/figures/" + name);
  std::map<double, double> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("law", 0) == 0) continue;
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string c; std::getline(s, c, ',');) cells.push_back(c);
    if (cells.size() >= 8) out[std::stod(cells[6])] = std::stod(cells[7]);
  }
  return out;
}

/// Hertz's F/E (mm²) of a 5 mm sphere at `depth_mm`, ν = 0.45.
double tissue_hertz_over_e(double depth_mm) {
  return 4.0 / 3.0 / (1.0 - 0.45 * 0.45) * std::sqrt(5.0) * std::pow(depth_mm, 1.5);
}

/// Distance along unit `dir` from `from` at which a sphere of `radius` first touches the fine
/// surface of net 0 of `m` at rest (scanned in 0.05 mm steps, then bisected; +∞ within 0.2 m).
double tissue_fine_touch(const core::Model& m, const Vec3& from, const Vec3& dir, double radius) {
  const core::Data d = core::make_data(m);
  const std::span<const core::NodeState> nodes(d.nodes.data(), d.nodes.size());
  std::vector<Vec3> x(m.net_surface_points.size());
  for (std::size_t p = 0; p < x.size(); ++p) x[p] = core::net_surface_position(m, nodes, static_cast<int>(p));
  const auto touches = [&](double s) {
    const Vec3 c = from + s * dir;
    for (const auto& t : m.net_surface_faces) {
      int feature = 0;
      const Vec3 q = core::detail::closest_on_triangle(c, x[static_cast<std::size_t>(t[0])],
                                                       x[static_cast<std::size_t>(t[1])],
                                                       x[static_cast<std::size_t>(t[2])], feature);
      if ((c - q).norm() < radius) return true;
    }
    return false;
  };
  return organ::first_true_along(touches);
}

/// Writes the shipped organ's lobe at geodesic frequency `f` (10 f² + 2 vertices) to `path`
/// (sim/data/make_organ_mesh.py; F = 10 is sim/data/organ_lobe.obj), or the 35 × 25 × 20 mm
/// ellipsoid (sim/data/make_fine_ellipsoid.py) with `ellipsoid`.
void tissue_write_mesh(int f, bool ellipsoid, const std::string& path) {
  const std::string cmd = "python3 " + std::string(NUMEN_SOURCE_DIR) + "/sim/data/" +
                          (ellipsoid ? "make_fine_ellipsoid.py " : "make_organ_mesh.py ") +
                          std::to_string(f) + " > '" + path + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
}

/// Figure 1 for one organ mesh: a 2.5 mm sphere at 20 mm/s along +z from `from`, 6 mm past the
/// fine surface's first touch, into the organ (E = 100 kPa, ν = 0.45, ρ = 1000, β = 1 ms,
/// ℓ = 20 mm, strain stiffening `b`) on nets of 500, 1 000, 2 500, 5 000 and 10 000 nodes carrying
/// the 10 242-vertex mesh, dt = 1 ms: each net's largest difference of the 5 ms means from the
/// finest's, over the finest's peak, and its largest period-to-period change. Checked: every net
/// within 5 % of the finest's peak (issue 67), and to 5.5 mm no net's largest period-to-period
/// change more than 10 % above the finest's (each net's largest change is its curve's steepest
/// slope over one period of 20 µm, about 0.5 N/mm at b = 0 and 0.9 N/mm at b = 1, and curves
/// within 5 % of each other's peak differ more in their slope; measured up to 1.3 % above,
/// docs/tissue.md; a jump of the touched point was 3 times it). Past 5.5 mm the sphere is 1.4–1.9 R deep in the fine surface and its
/// deepest face contact can slide off its triangle with no edge contact taken in its place: up
/// to 3 times the finest's change there, 0.06 N (printed; checked at 0.1 N; docs/tissue.md, "The
/// same feel at any net size").
void tissue_convergence(const char* label, bool ellipsoid, const Vec3& from, double b) {
  TempDir dir;
  const std::string obj = (dir.path() / "organ.obj").string();
  tissue_write_mesh(32, ellipsoid, obj);
  const int sizes[] = {500, 1000, 2500, 5000, 10000};
  std::vector<std::vector<organ::IndentationSample>> curves;
  std::vector<double> jumps, jumps_55;
  double touch = 0.0;
  for (const int nodes : sizes) {
    const std::string keys = "mesh = \"file\"\nfile = \"" + obj + "\"\nnodes = " + std::to_string(nodes) +
                             "\nyoungs_modulus_kpa = 100.0\npoisson_ratio = 0.45\ndensity = 1000.0\n"
                             "rayleigh_stiffness = 0.001\nsupport_length = 0.02\nstrain_stiffening = " +
                             std::to_string(b) + "\n";
    const numen::sim::Scene s =
        numen::sim::load_scene(dir.write("organ.toml", numen::test::indentation_bench_scene(keys, 0.0025, 1e-3)));
    if (curves.empty()) touch = tissue_fine_touch(s.model, from, Vec3::UnitZ(), 0.0025);
    ASSERT_TRUE(std::isfinite(touch));
    curves.push_back(organ::indentation_curve(s.model, from, Vec3::UnitZ(), 0.02, 0.006, 1, touch));
    double jump = 0.0, jump_at = 0.0, jump_55 = 0.0;
    for (std::size_t i = 1; i < curves.back().size(); ++i) {
      const double change = std::abs(curves.back()[i].force - curves.back()[i - 1].force);
      if (change > jump) jump = change, jump_at = curves.back()[i].depth;
      if (curves.back()[i].depth <= 0.0055) jump_55 = std::max(jump_55, change);
    }
    jumps.push_back(jump);
    jumps_55.push_back(jump_55);
    int inverted = 0;  // the most tetrahedra inside out at once, and from what depth
    double inverted_from = -1.0;
    for (const auto& sample : curves.back()) {
      inverted = std::max(inverted, sample.inverted_tetrahedra);
      if (sample.inverted_tetrahedra > 0 && inverted_from < 0.0) inverted_from = sample.depth;
    }
    std::printf("[tissue figure 1] %s, b %g, %d nodes (%d in all, patch %.2f mm): force at 1 / 2 / 4 / 6 mm "
                "%.3f / %.3f / %.3f / %.3f N, largest step-to-step change %.4f N (at %.2f mm), to 5.5 mm %.4f N; "
                "tetrahedra inside out at most %d of the %d watched",
                label, b, nodes, s.model.nets[0].node_count, 1e3 * s.model.nets[0].load_patch_radius,
                tissue_force_at(curves.back(), 0.001), tissue_force_at(curves.back(), 0.002),
                tissue_force_at(curves.back(), 0.004), tissue_force_at(curves.back(), 0.006), jump,
                1e3 * jump_at, jump_55, inverted, s.model.nets[0].tetrahedron_count);
    if (inverted > 0) std::printf(" (from %.2f mm)", 1e3 * inverted_from);
    std::printf("\n");
    // A guard, not the issue's: measured 0 at b = 0 and at most 12 of 1 694–115 382 at b = 1, past
    // 4.35 mm (docs/tissue.md, "Inversion").
    EXPECT_LE(inverted, b > 0.0 ? 20 : 0) << label << ", " << nodes << " nodes: tetrahedra inside out";
  }
  const auto finest = organ::block_means(curves.back(), 5);
  double peak = 0.0;
  for (const auto& m : finest) peak = std::max(peak, m.force);
  for (std::size_t k = 0; k + 1 < curves.size(); ++k) {
    const auto means = organ::block_means(curves[k], 5);
    double worst = 0.0, at = 0.0, worst_55 = 0.0;  // over the whole curve, and to 5.5 mm
    for (std::size_t i = 0; i < means.size() && i < finest.size(); ++i) {
      const double diff = std::abs(means[i].force - finest[i].force);
      if (diff > worst) worst = diff, at = means[i].depth;
      if (means[i].depth <= 0.0055) worst_55 = std::max(worst_55, diff);
    }
    std::printf("[tissue figure 1] %s, b %g, %d nodes: largest difference from 10 000 nodes %.4f N = %.1f %% "
                "of its peak %.3f N (at %.2f mm); to 5.5 mm %.1f %%\n",
                label, b, sizes[k], worst, 100.0 * worst / peak, peak, 1e3 * at, 100.0 * worst_55 / peak);
    std::printf("[tissue figure 1] %s, b %g, %d nodes: its largest period-to-period change %.4f N is %.3f "
                "times the finest's %.4f N; to 5.5 mm %.4f N, %.3f times\n", label, b, sizes[k], jumps[k],
                jumps[k] / jumps.back(), jumps.back(), jumps_55[k], jumps_55[k] / jumps_55.back());
    EXPECT_LE(worst, 0.05 * peak) << label << ", " << sizes[k] << " nodes";
    EXPECT_LE(jumps_55[k], 1.10 * jumps_55.back()) << label << ", " << sizes[k] << " nodes";
    EXPECT_LE(jumps[k], 0.1) << label << ", " << sizes[k] << " nodes";
  }
}

}  // namespace

// Figure 2: a rigid 5 mm sphere at 5 mm/s (quasi-static) into the top of a 60 × 60 × 30 mm block
// (E = 100 kPa, ν = 0.45, ℓ = 30 mm) on nets of 4, 2.86 and 2 mm surface edges: the force within
// 10 % of Hertz for δ ≤ 0.1 R = 0.5 mm, and against GetFEM's neo-Hookean cylinder block of radius
// and height 30 mm held at ℓ = 30 mm (docs/indentation-reference.md, "Block mode") within 10 % to
// δ = 3 mm (0.6 R), at every size.
/// Figure 2's block (see the tests below) with the strain stiffening `b`, pressed to `depth_max`
/// (mm): F/E against GetFEM's block `csv` within 10 % at every depth to `checked_to` (mm; printed
/// deeper), and against Hertz within 10 % to δ = 0.1 R, at the three net sizes.
static void block_against_reference(const char* csv, double b, double depth_max, double checked_to) {
  TempDir dir;
  const auto reference = tissue_block_reference(csv);
  ASSERT_FALSE(reference.empty()) << "docs/figures/" << csv << " is missing or has no row (a tracked file)";
  const Vec3 down(0, 0, -1);
  const Vec3 from(0.0, 0.0, 0.015 + 0.005 + 0.0005);  // 0.5 mm above the block's top face
  const double depths[] = {0.1, 0.2, 0.3, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0};
  for (const int subdivisions : {14, 20, 29}) {
    const std::string keys =
        "mesh = \"box\"\nhalf_extents = [0.03, 0.03, 0.015]\nsubdivisions = " +
        std::to_string(subdivisions) +
        "\nyoungs_modulus_kpa = 100.0\npoisson_ratio = 0.45\nrayleigh_stiffness = 0.001\n"
        "support_length = 0.03\nstrain_stiffening = " + std::to_string(b) + "\n";
    const numen::sim::Scene s =
        numen::sim::load_scene(dir.write("block.toml", numen::test::indentation_bench_scene(keys, 0.005, 1e-3)));
    const auto curve = organ::indentation_curve(s.model, from, down, 0.005, 1e-3 * depth_max, 1, 0.0005);
    const double edge = 60.0 / (subdivisions + 1);
    double worst_hertz = 0.0;
    for (const double d : depths) {
      if (d > depth_max + 1e-9) break;
      const double fe = tissue_force_at(curve, 1e-3 * d) / 100e3 * 1e6;  // F/E (mm²)
      const double hertz = tissue_hertz_over_e(d);
      const double ref = reference.at(d);
      std::printf("[tissue figure 2] b %g, edge %.2f mm (%d nodes, patch %.2f mm): delta %.1f mm: F/E %.4f mm2, "
                  "Hertz %.4f (%+.1f %%), GetFEM %.4f (%+.1f %%)\n",
                  b, edge, s.model.nets[0].node_count, 1e3 * s.model.nets[0].load_patch_radius, d, fe, hertz,
                  100.0 * (fe / hertz - 1.0), ref, 100.0 * (fe / ref - 1.0));
      if (d <= 0.5) worst_hertz = std::max(worst_hertz, std::abs(fe / hertz - 1.0));
      if (d <= checked_to + 1e-9) {
        EXPECT_LT(std::abs(fe / ref - 1.0), 0.10) << "edge " << edge << " mm, delta " << d;
      }
    }
    EXPECT_LT(worst_hertz, 0.10) << "edge " << edge << " mm";
  }
}

TEST(TissueFigures, ASphereIntoABlockIsHertzsAtThreeNetSizes) {
  NUMEN_REQUIRE_DEFORMABLE();
  block_against_reference("block_reference_neo_nu045.csv", 0.0, 3.0, 3.0);
}

// Figure 2 with the strain stiffening b = 1 (the shipped organ's), to δ = 5 mm (R): against
// GetFEM's block of the same stiffened law (docs/figures/block_reference_neo_b1_nu045.csv),
// checked to 5 mm. The finest net falls furthest below it with depth (−5.6 % at 4 mm, −6.8 % at
// 5 mm; the two coarser within 4.7 %), as it does at b = 0 (−4.4 % at 3 mm): docs/tissue.md.
TEST(TissueFigures, AStrainStiffenedBlockIsGetFemsAtThreeNetSizes) {
  NUMEN_REQUIRE_DEFORMABLE();
  block_against_reference("block_reference_neo_b1_nu045.csv", 1.0, 5.0, 5.0);
}


// Figure 1: the shipped organ's lobe (sim/data/make_organ_mesh.py at 10 242 vertices), the sphere
// into its convex lower face, as docs/organs.md's "Force against indentation"; with the shipped
// organ's strain stiffening (kShippedOrganMaterial, b = 1) and without it (a neo-Hookean solid).
TEST(TissueFigures, TheShippedOrgansLobeFeelsAlikeOnNetsOf500To10000Nodes) {
  NUMEN_REQUIRE_DEFORMABLE();
  tissue_convergence("lobe", false, Vec3(0.004, -0.003, -0.03),
                     numen::sim::stability::kShippedOrganMaterial.strain_stiffening);
  tissue_convergence("lobe", false, Vec3(0.004, -0.003, -0.03), 0.0);
}

// Figure 1: the 35 × 25 × 20 mm ellipsoid of 20 480 triangles (the issue's own organ), the
// sphere into its lower pole.
TEST(TissueFigures, AnEllipsoidFeelsAlikeOnNetsOf500To10000Nodes) {
  NUMEN_REQUIRE_DEFORMABLE();
  tissue_convergence("ellipsoid", true, Vec3(0.0, 0.0, -0.03),
                     numen::sim::stability::kShippedOrganMaterial.strain_stiffening);
  tissue_convergence("ellipsoid", true, Vec3(0.0, 0.0, -0.03), 0.0);
}


// Figure 5's case: the issue's own organ, the 35 × 25 × 20 mm ellipsoid of 327 680 triangles
// (163 842 vertices), on a 2 500-node net at 1 ms, the 2.5 mm sphere at 20 mm/s 6 mm into its
// lower pole. Per spring this net's 5 ms means reached 14.5 N and single steps 45 N (issue 67);
// with its material no period's force may differ from the last by more than 0.05 N, 2.5 times
// what the curve's steepest slope (about 1 N/mm) gives in one period of 0.02 mm.
TEST(TissueFigures, TheIssuesEllipsoidOn2500NodesNeverJumps) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const std::string obj = (dir.path() / "organ.obj").string();
  tissue_write_mesh(128, true, obj);
  const std::string keys = "mesh = \"file\"\nfile = \"" + obj + "\"\nnodes = 2500\n"
                           "youngs_modulus_kpa = 100.0\npoisson_ratio = 0.45\ndensity = 1000.0\n"
                           "rayleigh_stiffness = 0.001\nsupport_length = 0.02\n";
  const numen::sim::Scene s =
      numen::sim::load_scene(dir.write("organ.toml", numen::test::indentation_bench_scene(keys, 0.0025, 1e-3)));
  ASSERT_EQ(s.model.net_surface_points.size(), 163842u);
  const Vec3 from(0.0, 0.0, -0.03);
  const double touch = tissue_fine_touch(s.model, from, Vec3::UnitZ(), 0.0025);
  ASSERT_TRUE(std::isfinite(touch));
  const auto curve = organ::indentation_curve(s.model, from, Vec3::UnitZ(), 0.02, 0.006, 1, touch);
  double jump = 0.0, jump_at = 0.0, peak = 0.0;
  for (std::size_t i = 1; i < curve.size(); ++i) {
    peak = std::max(peak, curve[i].force);
    if (std::abs(curve[i].force - curve[i - 1].force) > jump)
      jump = std::abs(curve[i].force - curve[i - 1].force), jump_at = curve[i].depth;
  }
  std::printf("[tissue figure 5] ellipsoid of 327 680 triangles, 2 500 nodes: force at 2.2 / 3.8 / 5.4 mm "
              "%.3f / %.3f / %.3f N, peak %.3f N, largest period-to-period change %.4f N (at %.2f mm)\n",
              tissue_force_at(curve, 0.0022), tissue_force_at(curve, 0.0038), tissue_force_at(curve, 0.0054),
              peak, jump, 1e3 * jump_at);
  EXPECT_LE(jump, 0.05);
}

// The shipped organ keeps its feel with a material: sim/data/organ_lobe.obj given per spring (the
// constants sim/scenes/default.toml shipped before issue 67, the mesh as its own 1 002-node net) and
// by its material (kShippedOrganMaterial: E = 100 kPa, ν = 0.45, ρ = 1000 kg/m³, β = 1 ms, ℓ = 20
// mm, strain stiffening b = 1) on the shipped scene's 500-node net and on the mesh as its net, the
// 2.5 mm sphere at 20 mm/s into its convex face at five points (the first the fit's). At the first
// point the 500-node net's force is within 10 % of the per-spring organ's from 1 to 6 mm, the
// mesh net's from 1.5 mm; at every point both are within 16 % from 1 to 6 mm (the per-spring organ,
// a tied membrane, does not feel alike everywhere either: at the organ's middle, (0, 0), the
// material organ is up to 15 % stiffer at 2.5–3 mm; printed, docs/tissue.md). Below 1 mm the
// per-spring organ's penalty has taken up more force (printed from 0.5 mm). Without the stiffening
// (b = 0, a neo-Hookean solid) no E kept the first point within 10 % past 4 mm (measured with the
// load patch of two edges, docs/tissue.md).
TEST(TissueFigures, TheShippedOrganWithItsMaterialKeepsItsFeel) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const std::string file = "mesh = \"file\"\nfile = \"" + std::string(NUMEN_SOURCE_DIR) + "/sim/data/organ_lobe.obj\"\n";
  const numen::sim::stability::PerSpringOrgan& k = numen::sim::stability::kShippedPerSpringOrgan;
  char spring_keys[256];
  std::snprintf(spring_keys, sizeof spring_keys,
                "mass = %.17g\nstiffness = %.17g\ndamping = %.17g\nbending_stiffness = %.17g\n"
                "bending_damping = %.17g\ntie_stiffness = %.17g\ntie_damping = %.17g\n",
                k.mass, k.stiffness, k.damping, k.bending_stiffness, k.bending_damping, k.tie_stiffness,
                k.tie_damping);
  const std::string per_spring = file + spring_keys;
  const core::NetMaterial& m = numen::sim::stability::kShippedOrganMaterial;
  char material_keys[256];
  std::snprintf(material_keys, sizeof material_keys,
                "youngs_modulus_kpa = %.17g\npoisson_ratio = %.17g\ndensity = %.17g\nrayleigh_stiffness = %.17g\n"
                "support_length = %.17g\nstrain_stiffening = %.17g\n",
                1e-3 * m.youngs_modulus, m.poisson_ratio, m.density, m.rayleigh_stiffness, m.support_length,
                m.strain_stiffening);
  const std::string material = file + material_keys;
  std::vector<numen::sim::Scene> scenes;
  for (const std::string& keys : {per_spring, material + "nodes = 500\n", material})
    scenes.push_back(
        numen::sim::load_scene(dir.write("organ.toml", numen::test::indentation_bench_scene(keys, 0.0025, 1e-3))));
  const Vec3 up = Vec3::UnitZ();
  const double points[][2] = {{0.004, -0.003}, {0.0, 0.0}, {-0.006, 0.004}, {0.008, 0.003}, {-0.004, -0.006}};
  for (std::size_t p = 0; p < std::size(points); ++p) {
    const Vec3 from(points[p][0], points[p][1], -0.03);
    std::vector<std::vector<organ::IndentationSample>> curves;
    for (const numen::sim::Scene& s : scenes) {
      const double touch = organ::first_touch(s.model, from, up, 0.0025);
      ASSERT_TRUE(std::isfinite(touch)) << p;
      curves.push_back(organ::indentation_curve(s.model, from, up, 0.02, 0.006, 1, touch));
    }
    for (const double depth : {0.0005, 0.001, 0.0015, 0.002, 0.0025, 0.003, 0.004, 0.005, 0.006}) {
      const double spring = tissue_force_at(curves[0], depth), shipped = tissue_force_at(curves[1], depth),
                   mesh = tissue_force_at(curves[2], depth);
      std::printf("[tissue feel] point (%+.0f, %+.0f) mm, depth %.1f mm: per spring %.3f N, material on 500 "
                  "nodes %.3f N (%+.1f %%), on the mesh %.3f N (%+.1f %%)\n",
                  1e3 * from.x(), 1e3 * from.y(), 1e3 * depth, spring, shipped, 100.0 * (shipped / spring - 1.0),
                  mesh, 100.0 * (mesh / spring - 1.0));
      if (depth < 0.001 - 1e-9) continue;
      const double bound = p == 0 ? 0.10 : 0.16;  // the fit's point, the others
      EXPECT_NEAR(shipped, spring, bound * spring) << p << " " << depth;
      if (p > 0 || depth >= 0.0015 - 1e-9) {
        EXPECT_NEAR(mesh, spring, bound * spring) << p << " " << depth;
      }
    }
  }
}
