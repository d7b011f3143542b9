// Tests of the material net (core/include/numen/core/net_material.hpp; docs/tissue.md): the
// constants add_material_net() derives from the tissue and the tetrahedra — every tetrahedron
// edge a spring of E_net Σ V_t / L², masses ρ V_t / 4 per corner, ties κ V_i lumped as the masses,
// the contact law's E*, surface areas and normals and load patch — checked against
// the formulas on an octahedron with a centre node; a uniform dilatation stores the energy of a
// solid of the net's modulus and Poisson's ratio 1/4 on any mesh; bad materials and meshes are
// refused naming the scene key or the element, leaving the model as it was.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "net_states.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_forces.hpp"
#include "numen/core/net_material.hpp"
#include "numen/core/step.hpp"
#include "octahedron_net.hpp"

namespace core = numen::core;
using core::Vec3;

namespace {

/// The octahedron of tests/support/octahedron_net.hpp.
core::TetrahedralMesh octahedron(double r) { return numen::test::octahedron_volume(r); }

core::NetMaterial liver() {
  core::NetMaterial t;
  t.youngs_modulus = 10e3;
  t.poisson_ratio = 0.45;
  t.density = 1060.0;
  t.rayleigh_stiffness = 2e-3;
  t.support_length = 0.03;
  t.strain_stiffening = 1.0;
  return t;
}

/// A model with one anchored rigid component and the octahedron's material net.
core::Model octahedron_model(const core::NetMaterial& tissue, core::MaterialNetConstants* c,
                             std::string* err) {
  return numen::test::octahedron_material_model(tissue, c, err);
}

/// octahedron_model() of liver() with its materials, alone (no device): a model finalize_model()
/// takes; `err` says why add_material_net() refused it.
core::Model octahedron_organ(std::string* err) {
  core::MaterialNetConstants c;
  core::Model m = octahedron_model(liver(), &c, err);
  m.material_names = {"tissue"};
  m.material_pairs.assign(1, core::MaterialPair{2e4, 10.0, 0.0});
  m.initial_held_body = -1;  // the organ alone: no device
  return m;
}

}  // namespace

TEST(NetMaterial, EveryConstantFollowsFromTheMaterialAndTheTetrahedra) {
  const core::NetMaterial t = liver();
  core::MaterialNetConstants c;
  std::string err;
  core::Model m = octahedron_model(t, &c, &err);
  ASSERT_EQ(err, "");
  ASSERT_EQ(m.num_nets(), 1);
  const core::NetModel& net = m.nets[0];
  EXPECT_EQ(net.node_count, 7);
  EXPECT_EQ(net.face_count, 8);
  EXPECT_EQ(net.structural_count, 18);  // 12 octahedron edges + 6 spokes
  EXPECT_EQ(net.bending_count, 0);

  const double r = 0.01, volume = 4.0 / 3.0 * r * r * r;  // the octahedron's volume
  const double e_net = (15.0 / 16.0) * t.youngs_modulus / (1.0 - t.poisson_ratio * t.poisson_ratio);
  EXPECT_NEAR(c.volume, volume, 1e-15);
  EXPECT_NEAR(c.net_modulus, core::kNetAffineCorrection * e_net, 1e-9);
  EXPECT_NEAR(net.mass, t.density * volume, 1e-12);
  const double k_tie = c.net_modulus / (t.support_length * t.support_length) * volume / 7.0;
  EXPECT_NEAR(net.tie_stiffness, k_tie, 1e-9 * k_tie);
  EXPECT_NEAR(net.tie_damping, t.rayleigh_stiffness * k_tie, 1e-9 * k_tie);
  // The centre holds a quarter of every tetrahedron; a tip a quarter of its four.
  EXPECT_NEAR(m.node_mass[6], t.density * volume / 4.0, 1e-12);
  EXPECT_NEAR(m.node_mass[0], t.density * volume / 8.0, 1e-12);
  // The ties are lumped as the masses: node i's is κ V_i, κ V / N × tie_scale (mean 1).
  ASSERT_EQ(net.tie_scale.size(), 7u);
  const double kappa = c.net_modulus / (t.support_length * t.support_length);
  EXPECT_NEAR(core::tie_scale(net, 6) * net.tie_stiffness, kappa * volume / 4.0, 1e-9 * k_tie);
  EXPECT_NEAR(core::tie_scale(net, 0) * net.tie_stiffness, kappa * volume / 8.0, 1e-9 * k_tie);
  // The contact: E* = E / (1 − ν²), each surface node a third of its four faces' area (the
  // octahedron's faces are equilateral of side r√2), its normal outward, and the default patch
  // twice the edge of a 500-node net of the surface.
  EXPECT_NEAR(net.contact_modulus, t.youngs_modulus / (1.0 - t.poisson_ratio * t.poisson_ratio), 1e-9);
  EXPECT_EQ(net.contact_poisson_ratio, t.poisson_ratio);
  EXPECT_EQ(net.contact_stiffening, t.strain_stiffening);
  const double face = std::sqrt(3.0) / 4.0 * 2.0 * r * r;
  ASSERT_EQ(net.surface_node_area.size(), 6u);
  ASSERT_EQ(net.surface_node_normal.size(), 6u);
  for (int v = 0; v < 6; ++v) {
    EXPECT_NEAR(net.surface_node_area[static_cast<std::size_t>(v)], 4.0 * face / 3.0, 1e-15);
    EXPECT_NEAR(net.surface_node_normal[static_cast<std::size_t>(v)].dot(m.node_rest[static_cast<std::size_t>(v)]) / r,
                1.0, 1e-12);
  }
  EXPECT_NEAR(net.load_patch_radius, core::default_load_patch_radius(8.0 * face), 1e-15);
  EXPECT_NEAR(core::default_load_patch_radius(8.0 * face),
              3.0 * std::sqrt(2.0 * 8.0 * face / (std::sqrt(3.0) * 500.0)), 1e-15);
  EXPECT_NEAR(c.load_patch_radius, net.load_patch_radius, 0.0);
  EXPECT_NEAR(c.surface_mean_edge, r * std::sqrt(2.0), 1e-15);
  // A spoke is in the four tetrahedra of its tip (Σ V_t = V/2, L = r); an octahedron edge in two
  // (V/4, L = r√2).
  for (int e = net.spring_begin; e < net.spring_begin + net.structural_count; ++e) {
    const core::NetSpring& sp = m.net_springs[static_cast<std::size_t>(e)];
    const bool spoke = sp.node_b == 6;
    const double sum_v = spoke ? volume / 2.0 : volume / 4.0;
    const double length = spoke ? r : r * std::sqrt(2.0);
    EXPECT_NEAR(sp.rest_length, length, 1e-15);
    EXPECT_NEAR(sp.stiffness, c.net_modulus * sum_v / (length * length), 1e-9 * sp.stiffness);
    EXPECT_NEAR(sp.damping, t.rayleigh_stiffness * sp.stiffness, 1e-12 * sp.stiffness);
  }
  EXPECT_GT(c.explicit_step_limit, 0.0);
  EXPECT_LT(c.explicit_step_limit, 1.0);
}

// Under a uniform dilatation ε I every edge stretches by ε L, so the springs store
// ½ Σ k_e (ε L_e)² = ½ ε² E_net Σ_e Σ_{t∋e} V_t = 3 E_net ε² V, a solid's ½ K (3ε)² V with the
// bulk modulus K = E_net / (3 (1 − 2·¼)) of Poisson's ratio 1/4: on any tetrahedral mesh.
TEST(NetMaterial, AUniformDilatationStoresTheEnergyOfTheNetsSolid) {
  core::MaterialNetConstants c;
  std::string err;
  const core::Model m = octahedron_model(liver(), &c, &err);
  ASSERT_EQ(err, "");
  const double eps = 1e-3;
  double energy = 0.0;
  for (const core::NetSpring& sp : m.net_springs)
    energy += 0.5 * sp.stiffness * (eps * sp.rest_length) * (eps * sp.rest_length);
  const double bulk = c.net_modulus / (3.0 * (1.0 - 2.0 * 0.25));
  EXPECT_NEAR(energy, 0.5 * bulk * 9.0 * eps * eps * c.volume, 1e-9 * energy);
}

TEST(NetMaterial, ABadMaterialIsRefusedAtItsSceneKeyAndTheModelIsLeftAsItWas) {
  struct Case {
    void (*spoil)(core::NetMaterial&);
    const char* key;
  } cases[] = {
      {[](core::NetMaterial& t) { t.youngs_modulus = 0.0; }, "youngs_modulus_kpa"},
      {[](core::NetMaterial& t) { t.youngs_modulus = NAN; }, "youngs_modulus_kpa"},
      {[](core::NetMaterial& t) { t.poisson_ratio = 0.5; }, "poisson_ratio"},
      {[](core::NetMaterial& t) { t.poisson_ratio = -1.0; }, "poisson_ratio"},
      {[](core::NetMaterial& t) { t.density = 0.0; }, "density"},
      {[](core::NetMaterial& t) { t.rayleigh_stiffness = -1e-3; }, "rayleigh_stiffness"},
      {[](core::NetMaterial& t) { t.support_length = 0.0; }, "support_length"},
      {[](core::NetMaterial& t) { t.strain_stiffening = -0.1; }, "strain_stiffening"},
      {[](core::NetMaterial& t) { t.strain_stiffening = 4.1; }, "strain_stiffening"},
      {[](core::NetMaterial& t) { t.strain_stiffening = NAN; }, "strain_stiffening"},
  };
  for (const Case& k : cases) {
    core::NetMaterial t = liver();
    k.spoil(t);
    const char* key = "";
    EXPECT_NE(core::validate_material(t, &key), "");
    EXPECT_STREQ(key, k.key);
    std::string err;
    const core::Model m = octahedron_model(t, nullptr, &err);
    EXPECT_NE(err.find(std::string("net 'organ': ") + k.key), std::string::npos) << err;
    EXPECT_EQ(m.num_nets(), 0);
    EXPECT_EQ(m.num_nodes(), 0);
    EXPECT_TRUE(m.net_springs.empty());
  }
  EXPECT_EQ(core::validate_material(liver()), "");
}

TEST(NetMaterial, ABadTetrahedralMeshIsRefusedNamingTheElement) {
  core::Model m;
  core::BodyModel anchor;
  anchor.mass = 0.1;
  anchor.inertia_body = 1e-4 * core::Mat3::Identity();
  m.bodies = {anchor};
  core::MaterialNetSettings s;
  s.name = "organ";
  s.body = 0;
  s.tissue = liver();
  const auto refused = [&](const core::TetrahedralMesh& mesh, const std::string& what) {
    const std::string err = core::add_material_net(m, mesh, s);
    EXPECT_NE(err.find(what), std::string::npos) << err;
    EXPECT_EQ(m.num_nodes(), 0);
  };
  core::TetrahedralMesh mesh = octahedron(0.01);
  mesh.tetrahedra[3][2] = 7;
  refused(mesh, "tetrahedron 3 has node index 7 out of range");
  mesh = octahedron(0.01);
  mesh.tetrahedra[2][1] = mesh.tetrahedra[2][0];
  refused(mesh, "tetrahedron 2 repeats node");
  mesh = octahedron(0.01);
  mesh.interior[0] = Vec3(0.0, 0.0, 0.01);  // on the top tip: the cells at it are flat
  refused(mesh, "zero or non-finite volume");
  mesh = octahedron(0.01);
  mesh.interior.push_back(Vec3(0.001, 0.0, 0.0));  // node 7, in no tetrahedron
  refused(mesh, "node 7 is in no tetrahedron");
  mesh = octahedron(0.01);
  mesh.tetrahedra.clear();
  refused(mesh, "no tetrahedron");
  s.body = 3;
  refused(octahedron(0.01), "body index 3");
}

// finalize_model() checks what the tissue contact and the ties per node read in the period: a
// contact modulus needs a patch radius and a normal per surface area; ties per node need an
// anchored rigid component (the solve's tie sums of a moving one take every tie alike).
TEST(NetMaterial, FinalizeRefusesAnInconsistentTissueNet) {
  std::string err;
  const core::Model good = octahedron_organ(&err);
  ASSERT_EQ(err, "");
  {
    core::Model m = good;
    EXPECT_EQ(core::finalize_model(m), "");
  }
  {
    core::Model m = good;
    m.nets[0].surface_node_normal.clear();
    EXPECT_NE(core::finalize_model(m).find("one normal each"), std::string::npos);
  }
  {
    core::Model m = good;
    m.nets[0].load_patch_radius = 0.0;
    EXPECT_NE(core::finalize_model(m).find("load_patch_radius > 0"), std::string::npos);
  }
  {
    core::Model m = good;
    m.nets[0].contact_poisson_ratio = 0.5;
    EXPECT_NE(core::finalize_model(m).find("contact_poisson_ratio in (-1, 0.5)"), std::string::npos);
  }
  {
    core::Model m = good;
    m.nets[0].contact_stiffening = 5.0;
    EXPECT_NE(core::finalize_model(m).find("contact_stiffening in [0, 4]"), std::string::npos);
  }
  {
    core::Model m = good;
    m.bodies[0].anchored = false;
    EXPECT_NE(core::finalize_model(m).find("needs an anchored rigid component"), std::string::npos);
  }
  {
    core::Model m = good;
    m.nets[0].tie_scale.pop_back();
    EXPECT_NE(core::finalize_model(m).find("one entry per node"), std::string::npos);
  }
}

// The net keeps its tetrahedra (Model::net_tetrahedra), each ordered to a positive volume at rest,
// and measure_nets() counts those turned inside out (NetOutput::inverted_tetrahedra): none at
// rest; with the centre node moved 1.5 r up, past the apex, the four tetrahedra on the upper faces
// (their centre now beyond those faces' planes) and not the lower four; a flat one (the centre on
// an upper face's plane, at the apex) counts, as a non-finite node does. finalize_model() refuses
// a tetrahedron wound negative at rest or naming a node of no net of its own.
TEST(NetMaterial, MeasureCountsTheTetrahedraTurnedInsideOut) {
  std::string err;
  core::Model m = octahedron_organ(&err);
  ASSERT_EQ(err, "");
  ASSERT_EQ(core::finalize_model(m), "");
  ASSERT_EQ(m.nets[0].tetrahedron_count, 8);  // the centre and each of the 8 faces
  ASSERT_EQ(m.net_tetrahedra.size(), 8u);
  core::Data d = core::make_data(m);
  for (int i = 0; i < m.num_nodes(); ++i) d.nodes[static_cast<std::size_t>(i)].position = m.node_rest[static_cast<std::size_t>(i)];
  core::measure_nets(m, d);
  EXPECT_EQ(d.nets[0].inverted_tetrahedra, 0);
  // The centre node: the one at the origin (numen::test::octahedron_volume()).
  int centre = -1;
  for (int i = 0; i < m.num_nodes(); ++i)
    if (m.node_rest[static_cast<std::size_t>(i)].norm() < 1e-12) centre = i;
  ASSERT_GE(centre, 0);
  auto& x = d.nodes[static_cast<std::size_t>(centre)].position;
  x = Vec3(0.0, 0.0, 0.015);  // 1.5 r up: past the apex (0, 0, r)
  core::measure_nets(m, d);
  EXPECT_EQ(d.nets[0].inverted_tetrahedra, 4);
  x = Vec3(0.0, 0.0, 0.005);  // half way: inside
  core::measure_nets(m, d);
  EXPECT_EQ(d.nets[0].inverted_tetrahedra, 0);
  x = Vec3(0.0, 0.0, 0.01);  // on the apex: the four upper tetrahedra flat
  core::measure_nets(m, d);
  EXPECT_EQ(d.nets[0].inverted_tetrahedra, 4);
  x = Vec3(std::nan(""), 0.0, 0.0);  // not finite: every tetrahedron at the centre
  core::measure_nets(m, d);
  EXPECT_EQ(d.nets[0].inverted_tetrahedra, 8);
  {
    core::Model bad = m;
    std::swap(bad.net_tetrahedra[3][0], bad.net_tetrahedra[3][1]);
    EXPECT_NE(core::finalize_model(bad).find("tetrahedron 3 needs a positive volume at rest"), std::string::npos);
  }
  {
    core::Model bad = m;
    bad.net_tetrahedra[0][0] = m.num_nodes();
    EXPECT_NE(core::finalize_model(bad).find("tetrahedron 0 names a node outside the net"), std::string::npos);
  }
  {
    core::Model bad = m;
    bad.net_tetrahedra.pop_back();
    EXPECT_NE(core::finalize_model(bad).find("tetrahedron range beyond"), std::string::npos);
  }
  {
    core::Model bad = m;
    bad.nets[0].tetrahedron_begin = 1;
    EXPECT_NE(core::finalize_model(bad).find("tetrahedron range must follow the previous net's"), std::string::npos);
  }
  {
    core::Model bad = m;
    bad.net_tetrahedra.push_back(bad.net_tetrahedra[0]);  // one no net owns
    EXPECT_NE(core::finalize_model(bad).find("tetrahedron arrays hold entries no net owns"), std::string::npos);
  }
}

// The explicit step limit add_material_net() reports holds with the material's Rayleigh damping:
// symplectic Euler at 0.9 of it stays bounded with β = 0 and with β = 2 ms, whose limit is 4.8
// times below the undamped 2 / ω_max; at the undamped limit the damped net blows up (the
// stiffness-proportional damping, explicit in that integrator, sets the step) where the undamped
// one does not. (The Gershgorin bound on ω_max is conservative: the undamped octahedron holds to
// about twice its limit.)
TEST(NetMaterial, TheExplicitStepLimitHoldsWithTheRayleighDamping) {
  // Largest node displacement (m) over 3000 steps at `dt` (s), or the first above 1 m.
  const auto run = [](double beta, double dt, core::MaterialNetConstants* c) {
    core::NetMaterial t = liver();
    t.rayleigh_stiffness = beta;
    std::string err;
    core::Model m = octahedron_model(t, c, &err);
    EXPECT_EQ(err, "");
    m.material_names = {"tissue"};
    m.material_pairs.assign(1, core::MaterialPair{2e4, 10.0, 0.0});
    m.initial_held_body = -1;  // the organ alone
    m.gravity = Vec3::Zero();
    m.integrator = core::Integrator::kSymplecticEuler;
    m.dt = dt > 0.0 ? dt : 0.9 * c->explicit_step_limit;
    EXPECT_EQ(core::finalize_model(m), "");
    core::Data d = core::make_data(m);
    numen::test::perturb_nodes(d, 1e-4, 0.0);
    double largest = 0.0;
    for (int k = 0; k < 3000 && largest < 1.0; ++k) {
      core::step(m, d);
      for (std::size_t i = 0; i < d.nodes.size(); ++i)
        largest = std::max(largest, (d.nodes[i].position - m.node_rest[i]).norm());
    }
    return largest;
  };
  core::MaterialNetConstants undamped, damped;
  EXPECT_LT(run(0.0, 0.0, &undamped), 5e-4);
  EXPECT_LT(run(2e-3, 0.0, &damped), 5e-4);
  const double omega = 2.0 / undamped.explicit_step_limit, zeta = 0.5 * 2e-3 * omega;
  EXPECT_NEAR(damped.explicit_step_limit, 2.0 / omega * (std::sqrt(1.0 + zeta * zeta) - zeta), 1e-15);
  EXPECT_LT(4.0 * damped.explicit_step_limit, undamped.explicit_step_limit);
  EXPECT_LT(run(0.0, undamped.explicit_step_limit, &undamped), 5e-4);
  EXPECT_GE(run(2e-3, undamped.explicit_step_limit, &damped), 1.0);
}
