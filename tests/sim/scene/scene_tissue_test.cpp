// Tests of organs given by their material (docs/tissue.md; core/net_material.hpp): the
// [[deformable]] keys youngs_modulus_kpa, poisson_ratio, density, rayleigh_stiffness and
// support_length through a scene file, the force against indentation they give at several net
// sizes, the located errors of a bad material, and the default recording's grasp of such an
// organ.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "numen/core/features.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/step.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"
#include "organ_indentation.hpp"
#include "scene_text.hpp"
#include "mesh_text.hpp"
#include "scene/net_tetrahedralize.hpp"
#include "temp_dir.hpp"

namespace {

using numen::core::Vec3;
using numen::sim::load_scene;
using numen::sim::Scene;
using numen::test::TempDir;
namespace organ = numen::test::organ;

/// The indentation bench of scene_text.hpp with the organ's [[deformable]] keys `deformable`.
std::string bench_scene(const std::string& deformable, double tool_radius, double dt) {
  return numen::test::indentation_bench_scene(deformable, tool_radius, dt);
}

/// The shipped organ's mesh, by its path.
std::string shipped_organ_file() { return std::string(NUMEN_SOURCE_DIR) + "/sim/data/organ_lobe.obj"; }

/// The force (N) of `curve` at `depth` (m): the 5-sample mean nearest it.
double force_at(const std::vector<organ::IndentationSample>& curve, double depth) {
  const auto means = organ::block_means(curve, 5);
  double best = 1e9, f = 0.0;
  for (const auto& s : means)
    if (std::abs(s.depth - depth) < best) best = std::abs(s.depth - depth), f = s.force;
  return f;
}

}  // namespace


namespace {

/// The shipped organ given by a material: youngs_modulus_kpa = 100, ν = 0.45, ρ = 1000,
/// β = 1 ms, ℓ = 20 mm, and `extra` keys.
std::string organ_keys(const std::string& extra = "") {
  return "mesh = \"file\"\nfile = \"" + shipped_organ_file() + "\"\n" +
         "youngs_modulus_kpa = 100.0\npoisson_ratio = 0.45\ndensity = 1000.0\n"
         "rayleigh_stiffness = 0.001\nsupport_length = 0.02\n" + extra;
}

/// The first of `s`'s load warnings that contains `text` ("" when none does).
std::string warning_containing(const Scene& s, const std::string& text) {
  for (const std::string& w : s.warnings)
    if (w.find(text) != std::string::npos) return w;
  return std::string();
}

/// Volume (m³) enclosed by the closed, outward-wound surface of net 0 of `s` at rest.
double enclosed_volume(const Scene& s) {
  const auto& m = s.model;
  double v = 0.0;
  for (const auto& t : s.net_triangles[0])
    v += m.node_rest[static_cast<std::size_t>(t[0])].dot(
        m.node_rest[static_cast<std::size_t>(t[1])].cross(m.node_rest[static_cast<std::size_t>(t[2])]));
  return std::abs(v) / 6.0;
}

}  // namespace

// The constants follow from the material and the geometry, not from the net: the same organ at
// 1002 (its own mesh), 500 and 250 surface nodes has one modulus, its mass ρ V and its ties'
// total stiffness κ V within the tetrahedralisation's few per cent of the enclosed volume.
TEST(SceneTissue, TheSameOrganAtThreeNetSizesIsTheSameSolid) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const double e_net = (15.0 / 16.0) * 100e3 / (1.0 - 0.45 * 0.45);
  double volume_1002 = 0.0;
  for (const int nodes : {1002, 500, 250}) {
    const Scene s = load_scene(dir.write(
        "bench.toml", bench_scene(organ_keys(nodes < 1002 ? "nodes = " + std::to_string(nodes) + "\n" : ""),
                                  0.0025, 1e-3)));
    ASSERT_EQ(s.net_loads.size(), 1u);
    const numen::sim::NetLoad& load = s.net_loads[0];
    const numen::core::NetModel& net = s.model.nets[0];
    ASSERT_TRUE(load.material);
    EXPECT_EQ(net.node_count - load.interior_nodes, nodes);
    EXPECT_GT(load.interior_nodes, 0);
    EXPECT_GT(load.tetrahedra, net.node_count);
    EXPECT_EQ(net.bending_count, 0);
    const auto& c = load.material_constants;
    EXPECT_NEAR(c.net_modulus, numen::core::kNetAffineCorrection * e_net, 1e-9 * e_net);
    const double enclosed = enclosed_volume(s);
    if (nodes == 1002) volume_1002 = enclosed;
    EXPECT_NEAR(c.volume, enclosed, 0.03 * enclosed) << nodes << " nodes";
    EXPECT_NEAR(c.volume, volume_1002, 0.05 * volume_1002) << nodes << " nodes";
    EXPECT_NEAR(net.mass, 1000.0 * c.volume, 1e-9);
    const double kappa = c.net_modulus / (0.02 * 0.02);
    EXPECT_NEAR(net.tie_stiffness * net.node_count, kappa * c.volume, 1e-9 * kappa * c.volume);
    EXPECT_NEAR(net.tie_damping, 0.001 * net.tie_stiffness, 1e-12);
    std::printf("[tissue] %d surface + %d interior nodes, %d tetrahedra, %.3f cm3 (enclosed %.3f), "
                "springs %.3g..%.3g N/m, tie %.3g N/m, explicit step limit %.3g s\n",
                nodes, load.interior_nodes, load.tetrahedra, 1e6 * c.volume, 1e6 * enclosed,
                c.spring_stiffness_min, c.spring_stiffness_max, c.tie_stiffness, c.explicit_step_limit);
  }
}

// The material sets the force: a 5 mm sphere pressed 1 mm into a block at 5 mm/s (quasi-static)
// pushes back twice as hard on a tissue of twice the Young's modulus (the springs, ties and their
// damping scale with E; the masses and the contacts' penalty do not, whence the tolerance), and
// the force rises with depth.
TEST(SceneTissue, TwiceTheYoungsModulusPushesBackTwiceAsHard) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const Vec3 down(0, 0, -1);
  const Vec3 from(0.0, 0.0, 0.01 + 0.0055);  // 0.5 mm above the block's top face
  std::vector<double> at_1mm;
  for (const double e_kpa : {100.0, 200.0}) {
    const std::string keys = "mesh = \"box\"\nhalf_extents = [0.02, 0.02, 0.01]\nsubdivisions = 13\n"
                             "youngs_modulus_kpa = " + std::to_string(e_kpa) +
                             "\npoisson_ratio = 0.45\nrayleigh_stiffness = 0.001\nsupport_length = 0.02\n";
    const Scene s = load_scene(dir.write("block.toml", bench_scene(keys, 0.005, 1e-3)));
    const auto curve = organ::indentation_curve(s.model, from, down, 0.005, 0.001, 1, 0.0005);
    const auto means = organ::block_means(curve, 10);
    for (std::size_t i = 1; i < means.size(); ++i) {
      if (means[i - 1].depth > 0.0) {
        EXPECT_GT(means[i].force, means[i - 1].force) << means[i].depth;
      }
    }
    at_1mm.push_back(force_at(curve, 0.001));
    // Printed for docs/tissue.md: F/E (mm²) against Hertz's 4/3 · 1/(1 − ν²) · √R · δ^1.5.
    for (const double depth : {0.0005, 0.001}) {
      const double hertz = 4.0 / 3.0 / (1.0 - 0.45 * 0.45) * std::sqrt(5.0) * std::pow(1e3 * depth, 1.5);
      const double fe = force_at(curve, depth) / (1e3 * e_kpa) * 1e6;
      std::printf("[tissue] block, E %.0f kPa, delta %.1f mm: F/E %.3f mm2, Hertz %.3f mm2\n", e_kpa,
                  1e3 * depth, fe, hertz);
      // The contact's two scales: Hertz's half-space within 10 % (docs/tissue.md, "The contact").
      EXPECT_NEAR(fe, hertz, 0.10 * hertz) << e_kpa << " kPa, " << depth << " m";
    }
  }
  EXPECT_GT(at_1mm[0], 0.05);
  EXPECT_NEAR(at_1mm[1] / at_1mm[0], 2.0, 0.04) << at_1mm[0] << " N, " << at_1mm[1] << " N";
}

TEST(SceneTissueErrors, ABadMaterialIsALocatedErrorAtItsKey) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const std::string good = bench_scene(organ_keys(), 0.0025, 1e-3);
  struct Case {
    std::string from, to, key, phrase;
  } cases[] = {
      {"youngs_modulus_kpa = 100.0", "youngs_modulus_kpa = 0.0", "youngs_modulus_kpa", "finite and > 0"},
      {"youngs_modulus_kpa = 100.0", "youngs_modulus_kpa = -5.0", "youngs_modulus_kpa", "finite and > 0"},
      {"poisson_ratio = 0.45", "poisson_ratio = 0.5", "poisson_ratio", "in (-1, 0.5)"},
      {"poisson_ratio = 0.45", "poisson_ratio = -1.0", "poisson_ratio", "in (-1, 0.5)"},
      {"density = 1000.0", "density = 0.0", "density", "> 0 kg/m^3"},
      {"rayleigh_stiffness = 0.001", "rayleigh_stiffness = -0.001", "rayleigh_stiffness", ">= 0 s"},
      {"support_length = 0.02", "support_length = 0.0", "support_length", "> 0 m"},
      {"support_length = 0.02", "support_length = 0.02\nload_patch_radius = 0.0", "load_patch_radius", "0"},
      {"support_length = 0.02", "support_length = 0.02\nload_patch_radius = -0.01", "load_patch_radius", "-0.01"},
      {"support_length = 0.02", "support_length = 0.02\nstrain_stiffening = -0.5", "strain_stiffening", "in [0, 4]"},
      {"support_length = 0.02", "support_length = 0.02\nstrain_stiffening = 4.5", "strain_stiffening", "in [0, 4]"},
      // A per-spring key beside the material: what replaces it is named.
      {"support_length = 0.02", "support_length = 0.02\ntie_stiffness = 100.0", "tie_stiffness",
       "derives its masses, springs and ties from youngs_modulus_kpa"},
      {"support_length = 0.02", "support_length = 0.02\nmass = 0.07", "mass", "remove mass"},
      // A material key without youngs_modulus_kpa.
      {"youngs_modulus_kpa = 100.0\n", "mass = 0.07\nstiffness = 200.0\ntie_stiffness = 100.0\n", "poisson_ratio",
       "set youngs_modulus_kpa as well"},
  };
  for (const Case& k : cases) {
    const std::string text = numen::test::replace(good, k.from, k.to);
    const numen::sim::InputError e = numen::test::load_error(dir, text);
    EXPECT_EQ(e.key(), "deformable[0]." + k.key) << e.what();
    EXPECT_NE(e.message().find(k.phrase), std::string::npos) << e.what();
    // The offending line: the replacement's line that sets the key (else, a required key's
    // absence, the table's).
    const auto at = k.to.find(k.key + " = ");
    const std::string needle = at == std::string::npos ? "" : k.to.substr(at, k.to.find('\n', at) - at);
    if (!needle.empty()) {
      EXPECT_EQ(e.line(), numen::test::line_of(text, needle)) << e.what();
    }
  }
  // Required keys.
  const numen::sim::InputError missing =
      numen::test::load_error(dir, numen::test::replace(good, "support_length = 0.02\n", ""));
  EXPECT_EQ(missing.key(), "deformable[0].support_length") << missing.what();
}

// The shipped organ given by a material at three net sizes, a 2.5 mm sphere at 20 mm/s into its
// convex face (the figure of docs/organs.md "Force against indentation"): the force rises with
// depth to 3 mm at every size (at least 1.5 times the 1 mm force at 2 mm, 1.8 times at 3 mm: a
// solid's force under a sphere rises at least linearly), and the 500- and 250-node nets' are the
// 1 002-node net's within 10 % (the load patch: docs/tissue.md, "The contact"; measured within
// 1.6 %, the 250-node net coarser than the 500 the patch is made for). Printed: the force at 1, 2
// and 3 mm (docs/tissue.md quotes them).
TEST(SceneTissue, TheShippedOrganWithAMaterialPushesBackHarderTheDeeper) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const Vec3 up(0, 0, 1);
  const Vec3 from(0.004, -0.003, -0.03);
  double touch = 0.0;
  std::vector<double> at_1002;
  for (const int nodes : {1002, 500, 250}) {
    const Scene s = load_scene(dir.write(
        "bench.toml", bench_scene(organ_keys(nodes < 1002 ? "nodes = " + std::to_string(nodes) + "\n" : ""),
                                  0.0025, 1e-3)));
    if (nodes == 1002) touch = organ::first_touch(s.model, from, up, 0.0025);  // the fine surface's
    const auto curve = organ::indentation_curve(s.model, from, up, 0.02, 0.003, 1, touch);
    const double f1 = force_at(curve, 0.001), f2 = force_at(curve, 0.002), f3 = force_at(curve, 0.003);
    EXPECT_GT(f1, 0.2) << nodes;
    EXPECT_GT(f2, 1.5 * f1) << nodes;
    EXPECT_GT(f3, 1.8 * f1) << nodes;
    if (nodes == 1002) at_1002 = {f1, f2, f3};
    if (nodes < 1002) {
      const double f[] = {f1, f2, f3};
      for (std::size_t k = 0; k < 3; ++k) {
        EXPECT_NEAR(f[k], at_1002[k], 0.10 * at_1002[k]) << k + 1 << " mm";
      }
    }
    std::printf("[tissue] %d surface nodes (%d in all): force at 1 / 2 / 3 mm %.3f / %.3f / %.3f N\n", nodes,
                s.model.nets[0].node_count, force_at(curve, 0.001), force_at(curve, 0.002), force_at(curve, 0.003));
  }
}

// An open surface cannot be tetrahedralised: a located error at the key that made the net, naming
// the mesh file (here the mesh is its own net: nodes = its vertex count).
TEST(SceneTissueErrors, AnOpenSurfaceIsALocatedErrorNamingTheMesh) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  dir.write("open.obj", numen::test::fine_ellipsoid_obj(2, 1));
  const std::string keys = "mesh = \"file\"\nfile = \"open.obj\"\nunits = \"mm\"\nnodes = 162\n"
                           "youngs_modulus_kpa = 10.0\npoisson_ratio = 0.45\nsupport_length = 0.02\n";
  const numen::sim::InputError e = numen::test::load_error(dir, bench_scene(keys, 0.0025, 1e-3));
  EXPECT_EQ(e.key(), "deformable[0].file") << e.what();
  EXPECT_NE(e.message().find("open.obj: the organ's volume cannot be tetrahedralised"), std::string::npos)
      << e.what();
  EXPECT_NE(e.message().find("not closed"), std::string::npos) << e.what();
}

// A material too stiff for the symplectic Euler integrator at the scene's dt: a warning at load
// with the largest stable step; none with implicit Euler.
TEST(SceneTissue, AStepAboveTheSymplecticEulerLimitIsWarnedWithTheLimit) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const std::string keys = "mesh = \"icosphere\"\nradius = 0.02\nsubdivisions = 2\n"
                           "youngs_modulus_kpa = 10.0\npoisson_ratio = 0.45\nsupport_length = 0.02\n";
  const std::string implicit = bench_scene(keys, 0.0025, 1e-3);
  const Scene quiet = load_scene(dir.write("a.toml", implicit));
  const auto warned = [](const Scene& s) {
    for (const std::string& w : s.warnings)
      if (w.find("symplectic Euler integrator") != std::string::npos) return w;
    return std::string();
  };
  EXPECT_EQ(warned(quiet), "");
  const Scene explicit_step = load_scene(dir.write(
      "b.toml", numen::test::replace(implicit, "integrator = \"implicit-euler\"", "integrator = \"symplectic-euler\"")));
  const std::string w = warned(explicit_step);
  ASSERT_NE(w, "");
  const double limit = explicit_step.net_loads[0].material_constants.explicit_step_limit;
  EXPECT_LT(limit, 1e-3);
  EXPECT_NE(w.find("needs a step of at most"), std::string::npos) << w;
  EXPECT_NE(w.find("youngs_modulus_kpa"), std::string::npos) << w;
}

// A material on a deformable whose rigid component moves (not an organ) is refused at the key.
TEST(SceneTissueErrors, AMaterialNeedsAnAnchoredRigidComponent) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const std::string text =
      numen::test::replace(bench_scene(organ_keys(), 0.0025, 1e-3), "anchored = true\n", "");
  const numen::sim::InputError e = numen::test::load_error(dir, text);
  EXPECT_EQ(e.key(), "deformable[0].youngs_modulus_kpa") << e.what();
  EXPECT_NE(e.message().find("must be anchored = true"), std::string::npos) << e.what();
}

// The step of an organ given by its material allocates nothing: the shipped organ's material net
// (1 338 nodes) pressed 3 mm by the 2.5 mm sphere, 300 steps under the allocation guard.
TEST(SceneTissue, StepsPressingAMaterialOrganDoNotAllocate) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const Scene s = load_scene(dir.write("bench.toml", bench_scene(organ_keys(), 0.0025, 1e-3)));
  const numen::core::Model& m = s.model;
  numen::core::Data d = numen::core::make_data(m);
  const Vec3 up(0, 0, 1), from(0.004, -0.003, -0.03);
  const double touch = organ::first_touch(m, from, up, 0.0025);
  const auto at = [&](int k) {  // to 3 mm past the touch at 20 mm/s, then held
    d.target.position = from + std::min(0.02 * k * m.dt, touch + 0.003) * up;
    d.target_twist.linear.setZero();
    numen::core::step(m, d);
  };
  at(0);  // warm-up outside the guard
  std::int64_t count = -1;
  int contacts = 0;
  {
    numen::test::AllocationGuard guard;
    for (int k = 1; k <= 1000; ++k) {
      at(k);
      ASSERT_EQ(d.status, numen::core::kStepOk) << k;
      contacts = std::max(contacts, d.num_node_contacts);
    }
    count = guard.count();
  }
  EXPECT_EQ(count, 0);
  EXPECT_GE(contacts, 3) << "the sphere must press on the organ";
}

// A material organ in multirate (docs/tissue.md, "Multirate"): the shipped organ given its
// material (1 338 nodes), the 2.5 mm god-object's target moved from its start to 5 mm past its
// touch of the convex face in 0.4 s and held to 0.8 s, single-rate at 10 kHz and multirate with
// the organ in a 1 kHz scene loop and the god-object at 10 kHz on its tissue plane (the load
// patch's plane, the law linearised at each sample in series with the patch's compliance). Both
// hold the god-object on the dented organ: the feedback (at rest and its largest on the way in)
// and the god-object's depth within 3 % (measured: 0.475 / 0.475 N and 0.504 / 0.504 N, 3.418 /
// 3.418 mm); the device loop's periods do not allocate. A scene with a material organ and
// [multirate] loads (it was refused).
TEST(SceneTissue, TheMultirateDeviceLoopFeelsAMaterialOrganAsTheSingleRateStepDoes) {
  NUMEN_REQUIRE_DEFORMABLE();
  const numen::core::TriangleMesh surface = organ::shipped_organ_mesh();
  numen::core::TetrahedralMesh volume;
  ASSERT_EQ(numen::sim::tetrahedralize_net(
                surface, numen::sim::kInteriorSpacingEdges * numen::sim::mean_edge_length(surface), volume),
            "");
  numen::core::NetMaterial tissue;
  tissue.youngs_modulus = 100e3;
  tissue.poisson_ratio = 0.45;
  tissue.density = 1000.0;
  tissue.rayleigh_stiffness = 1e-3;
  tissue.support_length = 0.02;
  const double dt = 1e-4, radius = 0.0025;
  const Vec3 from(0.004, -0.003, -0.03), dir = Vec3::UnitZ();
  const numen::core::Model m = organ::tissue_model(volume, tissue, dt, numen::core::CouplingMode::kGodObject,
                                                   radius, from);
  const double touch = organ::first_touch(m, from, dir, radius);
  ASSERT_TRUE(std::isfinite(touch));
  numen::core::Data single = numen::core::make_data(m);
  numen::core::MultirateGodObject mr(m, 1, {10, 0.002, {}});
  const auto target = [&](int k) {
    return Vec3(from + (touch + 0.005) * std::min(1.0, k * dt / 0.4) * dir);
  };
  const int periods = 8000;
  double peak_single = 0.0, peak_mr = 0.0;  // the largest feedback on the way in
  for (int k = 0; k < periods - 500; ++k) {
    single.target.position = target(k);
    mr.device_data().target.position = target(k);
    numen::core::step(m, single);
    mr.step();
    ASSERT_EQ(single.status, numen::core::kStepOk) << k;
    ASSERT_EQ(mr.device_data().status, numen::core::kStepOk) << k;
    peak_single = std::max(peak_single, single.feedback_wrench.force.dot(-dir));
    peak_mr = std::max(peak_mr, mr.device_data().feedback_wrench.force.dot(-dir));
  }
  std::int64_t count = 0;
  {
    numen::test::AllocationGuard guard;
    for (int k = periods - 500; k < periods; ++k) {
      mr.device_data().target.position = target(k);
      mr.step();
    }
    count = guard.count();
  }
  for (int k = periods - 500; k < periods; ++k) {
    single.target.position = target(k);
    numen::core::step(m, single);
  }
  const double f_single = single.feedback_wrench.force.dot(-dir);
  const double f_mr = mr.device_data().feedback_wrench.force.dot(-dir);
  const double z_single = (single.bodies[1].position - from).dot(dir) - touch;
  const double z_mr = (mr.device_data().bodies[0].position - from).dot(dir) - touch;
  std::printf("[tissue multirate] god-object past the touch: single-rate %.3f mm, multirate %.3f mm; "
              "feedback %.3f / %.3f N (largest on the way in %.3f / %.3f N); planes max %ld\n",
              1e3 * z_single, 1e3 * z_mr, f_single, f_mr, peak_single, peak_mr,
              static_cast<long>(mr.counters().planes_max));
  EXPECT_EQ(count, 0);
  EXPECT_GT(f_single, 0.4);
  EXPECT_NEAR(peak_mr, peak_single, 0.03 * peak_single);
  EXPECT_NEAR(f_mr, f_single, 0.03 * f_single);
  EXPECT_NEAR(z_mr, z_single, 0.03 * z_single);
  EXPECT_GE(mr.counters().planes_max, 1);
  // And the default scene (its organ given by its material) with [multirate] loads (its
  // instrument has joints).
  if (!numen::core::kWithArticulation) return;
  TempDir temp;
  std::string text = numen::test::shipped_scene_text("default.toml");
  for (auto at = text.find("\"../data/"); at != std::string::npos; at = text.find("\"../data/", at + 1))
    text.replace(at + 1, 2, std::string(NUMEN_SOURCE_DIR) + "/sim");
  text += "\n[multirate]\nscene_dt = 0.001\nmargin = 0.005\n";
  const Scene loaded = load_scene(temp.write("multirate.toml", text));
  ASSERT_TRUE(loaded.multirate.has_value());
  EXPECT_TRUE(loaded.net_loads[0].material);
}

// A Poisson's ratio below the contact law's table (its rows span 0.2 to 0.49) is warned at its
// key: the half-space under a tool's sphere takes the first row.
TEST(SceneTissue, APoissonsRatioBelowTheContactLawsTableIsWarned) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const auto warned = [](const Scene& s) { return warning_containing(s, "neo-Hookean half-space"); };
  const auto keys = [](const std::string& nu) {
    return "mesh = \"file\"\nfile = \"" + shipped_organ_file() + "\"\nnodes = 500\n" +
           "youngs_modulus_kpa = 100.0\npoisson_ratio = " + nu +
           "\nsupport_length = 0.02\n";
  };
  EXPECT_EQ(warned(load_scene(dir.write("a.toml", bench_scene(keys("0.2"), 0.0025, 1e-3)))), "");
  EXPECT_EQ(warned(load_scene(dir.write("b.toml", bench_scene(keys("0.499"), 0.0025, 1e-3)))), "");
  const Scene low = load_scene(dir.write("c.toml", bench_scene(keys("0.1"), 0.0025, 1e-3)));
  const std::string w = warned(low);
  ASSERT_NE(w, "");
  EXPECT_NE(w.find("deformable[0].poisson_ratio"), std::string::npos) << w;
  EXPECT_NE(w.find("0.2 to 0.49"), std::string::npos) << w;
  EXPECT_DOUBLE_EQ(low.model.nets[0].contact_poisson_ratio, 0.1);
}

// A net coarser than its load patch is made for is warned at load (its mean edge above 0.6 ρ):
// the shipped organ at 100 nodes, not at 500 (the default patch's design size), and not when
// load_patch_radius is given large enough; the warning names the key that set ρ.
TEST(SceneTissue, ANetCoarserThanItsLoadPatchIsWarned) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const auto warned = [](const Scene& s) { return warning_containing(s, "load patch radius"); };
  const Scene at_500 = load_scene(dir.write("a.toml", bench_scene(organ_keys("nodes = 500\n"), 0.0025, 1e-3)));
  EXPECT_EQ(warned(at_500), "");
  const Scene at_100 = load_scene(dir.write("b.toml", bench_scene(organ_keys("nodes = 100\n"), 0.0025, 1e-3)));
  const std::string w = warned(at_100);
  ASSERT_NE(w, "");
  EXPECT_NE(w.find("deformable[0].youngs_modulus_kpa"), std::string::npos) << w;
  EXPECT_NE(w.find("resolves the patch poorly"), std::string::npos) << w;
  EXPECT_GT(at_100.net_loads[0].material_constants.surface_mean_edge,
            0.6 * at_100.net_loads[0].material_constants.load_patch_radius);
  const Scene given = load_scene(
      dir.write("c.toml", bench_scene(organ_keys("nodes = 100\nload_patch_radius = 0.025\n"), 0.0025, 1e-3)));
  EXPECT_EQ(warned(given), "");
  EXPECT_DOUBLE_EQ(given.model.nets[0].load_patch_radius, 0.025);
}

// Grasping of tissue is kept (issue 67, "Keep what the organ has"): the default scene's recording
// with a grasper on its jaws, its organ given by its material (E = 100 kPa, ν = 0.45, a 500-node
// net), grasps the organ where the per-spring organ it shipped before was grasped (at 6.968 s and
// 7.824 s, released at 7.026 s and 8.913 s), holds it with a pull and lets it go, and the run
// stays clean (docs/grasping.md, "On the shipped recording").
TEST(SceneTissue, TheDefaultRecordingGraspsAnOrganGivenByItsMaterial) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  std::string text = numen::test::shipped_scene_text_anywhere("default.toml");
  text += "\n[[grasp]]\nname = \"grasper\"\njaws = [\"jaw_1\", \"jaw_2\"]\n";
  const Scene scene = load_scene(dir.write("grasp.toml", text));
  ASSERT_EQ(scene.net_loads.size(), 1u);
  ASSERT_TRUE(scene.net_loads[0].material);
  numen::sim::RunOptions opt;
  opt.duration_s = 9.5;
  const numen::sim::RunSummary s = numen::sim::run_scene(scene, opt);
  for (const std::string& e : s.grasp_events) std::printf("[   info   ] %s\n", e.c_str());
  EXPECT_FALSE(s.nan_detected);
  EXPECT_EQ(s.exit_status, 0);
  EXPECT_EQ(s.grasps_started, 2);
  EXPECT_EQ(s.grasps_released, 2);
  EXPECT_EQ(s.grasps_slipped, 0);
  EXPECT_EQ(s.net_inverted_tetrahedra_max, 0) << "the grasp turned tetrahedra inside out";
  ASSERT_EQ(s.grasp_events.size(), 4u);
  const double times[] = {6.968, 7.026, 7.824, 8.913};  // the per-spring organ's
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_NE(s.grasp_events[i].find(i % 2 == 0 ? " grasp grasper: organ (" : " release grasper: organ ("),
              std::string::npos) << s.grasp_events[i];
    EXPECT_NEAR(std::stod(s.grasp_events[i]), times[i], 0.1) << s.grasp_events[i];
  }
  // Each release says the pull it held: more than nothing.
  for (const std::size_t i : {std::size_t{1}, std::size_t{3}}) {
    const std::size_t at = s.grasp_events[i].find("pull ");
    ASSERT_NE(at, std::string::npos) << s.grasp_events[i];
    EXPECT_GT(std::stod(s.grasp_events[i].substr(at + 5)), 0.1) << s.grasp_events[i];
  }
}

// A net that turns tetrahedra inside out says so (core::NetOutput::inverted_tetrahedra;
// docs/tissue.md, "Inversion"): the default recording on the shipped organ with a load patch of
// 2 mm (ρ = 13.5 mm as shipped) turns up to 2 of its 1 694 watched tetrahedra inside out at once
// in 10.5 s (3 over the whole 30 s), the first at 9.85 s — the summary's figure, the time, the
// organ, and a warning that names it; as shipped, over the same 10.5 s, none and no warning. The
// run's exit status is the same (a warning, not a failure).
TEST(SceneTissue, ANetThatTurnsTetrahedraInsideOutIsWarned) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  const std::string shipped = numen::test::shipped_scene_text_anywhere("default.toml");
  const std::string key = "strain_stiffening = 1.0";
  const std::size_t at = shipped.find(key);
  ASSERT_NE(at, std::string::npos) << "default.toml's organ no longer has its strain_stiffening";
  std::string small = shipped;
  small.insert(at, "load_patch_radius = 0.002\n");
  numen::sim::RunOptions opt;
  opt.duration_s = 10.5;
  const Scene patched = load_scene(dir.write("small_patch.toml", small));
  ASSERT_NEAR(patched.model.nets[0].load_patch_radius, 0.002, 1e-12);
  const numen::sim::RunSummary s = numen::sim::run_scene(patched, opt);
  EXPECT_FALSE(s.nan_detected);
  EXPECT_EQ(s.exit_status, 0);
  EXPECT_GE(s.net_inverted_tetrahedra_max, 1);
  EXPECT_GT(s.net_first_inversion_s, 5.0);
  EXPECT_LT(s.net_first_inversion_s, 10.5);
  EXPECT_EQ(s.net_first_inversion_net, "organ");
  std::string warned;
  for (const std::string& w : s.warnings)
    if (w.find("turned tetrahedra inside out") != std::string::npos) warned = w;
  EXPECT_NE(warned.find("organ 'organ'"), std::string::npos) << warned;
  EXPECT_NE(warned.find("up to " + std::to_string(s.net_inverted_tetrahedra_max) + " at once"), std::string::npos)
      << warned;
  std::printf("[   info   ] load patch 2 mm: %s\n", warned.c_str());
  const numen::sim::RunSummary as_shipped = numen::sim::run_scene(load_scene(dir.write("default.toml", shipped)), opt);
  EXPECT_EQ(as_shipped.exit_status, 0);
  EXPECT_EQ(as_shipped.net_inverted_tetrahedra_max, 0);
  EXPECT_LT(as_shipped.net_first_inversion_s, 0.0);
  for (const std::string& w : as_shipped.warnings)
    EXPECT_EQ(w.find("inside out"), std::string::npos) << w;
}
