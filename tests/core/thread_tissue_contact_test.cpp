// Tests of a thread lying on tissue (core/src/thread/thread_tissue_contact.cpp; thread.hpp
// "Couplings"; docs/suturing.md "The thread on tissue"): a heavy thread dropped on a patch of
// tissue comes to rest on its surface — on its fine surface where the net carries one — and the
// tissue carries exactly its weight through the contacts' springs on its nodes (the reaction is
// the contact's, reversed); nodes deep under the surface (a passage) are left alone; no
// allocation.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/core/step.hpp"
#include "numen/core/thread.hpp"
#include "organ_indentation.hpp"

namespace {

namespace core = numen::core;
namespace organ = numen::test::organ;

/// The puncture rig's flat patch (14 × 14 cells of 2 mm in z = 0, the shipped organ's
/// constants, body 0 its anchored core) and a free thread of 20 mm, 20 segments, 0.5 mm radius,
/// along x at height `z` over the patch's centre; gravity −z; the thread's `density`; the
/// contacts' viscous friction 0.5 N·s/m (the scenes' default).
core::Model patch_and_thread(double z, double density, double fine_height = -1.0) {
  core::Model m = organ::patch_rig_start();
  m.initial_held_body = -1;
  m.gravity = core::Vec3(0, 0, -9.81);
  for (core::MaterialPair& p : m.material_pairs) p.friction = 0.5;  // N·s/m, the scenes' default
  const core::TriangleMesh patch = organ::flat_patch(14, 0.002);
  EXPECT_EQ(core::add_net(m, patch, organ::organ_net_settings(patch, {})), "");
  if (fine_height >= 0.0) {
    // A fine surface `fine_height` over the patch (its drawn surface, docs/fine-surface.md): the
    // patch's own grid halved, each vertex on the net triangle under it.
    const core::TriangleMesh fine = organ::flat_patch(28, 0.001);
    std::vector<core::Vec3> vertices;
    std::vector<int> nearest;
    for (const core::Vec3& v : fine.vertices) {
      vertices.push_back(v + core::Vec3(0, 0, fine_height));
      int best = 0;
      double best_d = 1e9;
      for (int f = 0; f < static_cast<int>(patch.triangles.size()); ++f) {
        int feature = 0;
        const auto& tri = patch.triangles[static_cast<std::size_t>(f)];
        const double d = (v - core::detail::closest_on_triangle(v, patch.vertices[static_cast<std::size_t>(tri[0])],
                                                               patch.vertices[static_cast<std::size_t>(tri[1])],
                                                               patch.vertices[static_cast<std::size_t>(tri[2])], feature))
                             .norm();
        if (d < best_d - 1e-12) best_d = d, best = f;
      }
      nearest.push_back(best);
    }
    EXPECT_EQ(core::add_net_surface(m, 0, vertices, fine.triangles, nearest), "");
  }
  core::ThreadModel t;
  t.name = "suture";
  t.length = 0.02;
  t.segments = 20;
  t.radius = 5e-4;
  t.density = density;
  t.material = 0;  // steel against the tissue: 2e4 N/m, 10 N·s/m
  t.start = core::Vec3(-0.0095, 3e-4, z);
  t.direction = core::Vec3::UnitX();
  t.self_contact = false;
  m.threads.push_back(t);
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// The vertical force (N) the thread's contact springs put on the patch's nodes at the step's
/// start (Data::num_node_thread_ties entries, the last of the node contacts).
double thread_force_on_tissue_z(const core::Data& d) {
  const int end = d.num_node_contacts + d.num_node_grasp_springs + d.num_node_needle_ties +
                  d.num_node_thread_ties;
  double f = 0.0;
  for (int c = end - d.num_node_thread_ties; c < end; ++c) f += d.node_contacts[static_cast<std::size_t>(c)].force.z();
  return f;
}

TEST(ThreadTissueContact, AHeavyThreadComesToRestOnTheTissueWhichCarriesItsWeight) {
  const core::Model m = patch_and_thread(0.002, 1e6);
  core::Data d = core::make_data(m);
  const core::ThreadModel& t = m.threads[0];
  const double weight = t.density * M_PI * t.radius * t.radius * t.length * 9.81;
  numen::test::AllocationGuard guard;
  for (int s = 0; s < 1500; ++s) {
    core::step(m, d);
    ASSERT_FALSE(d.status & core::kNonFinite) << "step " << s;
  }
  EXPECT_EQ(guard.count(), 0u);
  const core::ThreadState& st = d.threads[0];
  double lowest = 1e9, fastest = 0.0;
  for (std::size_t i = 0; i < st.position.size(); ++i) {
    lowest = std::min(lowest, st.position[i].z());
    fastest = std::max(fastest, st.velocity[i].norm());
  }
  // The patch under the thread, dented by its weight (the centre node's depth).
  double dent = 0.0;
  for (const core::NodeState& n : d.nodes) dent = std::min(dent, n.position.z());
  const double carried = -thread_force_on_tissue_z(d);
  std::printf("[thread on tissue] weight %.4f N, carried by the tissue %.4f N through %d contacts; "
              "lowest node %.3f mm, patch dent %.3f mm, fastest node %.2e m/s\n",
              weight, carried, st.output.tissue_contacts, 1e3 * lowest, 1e3 * dent, fastest);
  EXPECT_GT(weight, 0.05);
  EXPECT_GE(st.output.tissue_contacts, 15);  // the nodes over the patch (not the free ends' few)
  EXPECT_EQ(st.output.contacts_dropped, 0);
  EXPECT_LT(fastest, 1e-3) << "at rest";
  // The tissue carries the weight (Newton's third law through the springs on its nodes).
  EXPECT_NEAR(carried, weight, 0.02 * weight);
  // Dented, and the thread on the dented surface: its centreline within one radius (and the
  // penalty's few µm) of the lowest patch node, never through.
  EXPECT_LT(dent, -1e-5);
  EXPECT_GT(lowest, dent + 0.5 * t.radius);
  EXPECT_LT(lowest, dent + 1.5 * t.radius);
}

TEST(ThreadTissueContact, OnAFineSurfaceTheThreadLiesOnItNotOnTheNetUnderIt) {
  // The test above with a fine surface 0.6 mm over the patch's net (an organ's drawn surface,
  // docs/fine-surface.md): the thread comes to rest on the fine surface, which the net's
  // triangles carry, and the tissue carries its weight through the nodes under it.
  constexpr double kFineHeight = 6e-4;
  const core::Model m = patch_and_thread(0.002 + kFineHeight, 1e6, kFineHeight);
  ASSERT_GT(m.nets[0].surface_face_count, 0);
  core::Data d = core::make_data(m);
  const core::ThreadModel& t = m.threads[0];
  const double weight = t.density * M_PI * t.radius * t.radius * t.length * 9.81;
  numen::test::AllocationGuard guard;
  double settled_lo = 1e9, settled_hi = -1e9;  // the lowest node's height over the last 0.5 s
  for (int s = 0; s < 1500; ++s) {
    core::step(m, d);
    ASSERT_FALSE(d.status & core::kNonFinite) << "step " << s;
    if (s < 1000) continue;
    double low = 1e9;
    for (const core::Vec3& x : d.threads[0].position) low = std::min(low, x.z());
    settled_lo = std::min(settled_lo, low);
    settled_hi = std::max(settled_hi, low);
  }
  EXPECT_EQ(guard.count(), 0u);
  const core::ThreadState& st = d.threads[0];
  double lowest = 1e9, fastest = 0.0;
  for (std::size_t i = 0; i < st.position.size(); ++i) {
    lowest = std::min(lowest, st.position[i].z());
    fastest = std::max(fastest, st.velocity[i].norm());
  }
  double dent = 0.0;
  for (const core::NodeState& n : d.nodes) dent = std::min(dent, n.position.z());
  const double carried = -thread_force_on_tissue_z(d);
  std::printf("[thread on a fine surface] weight %.4f N, carried %.4f N through %d contacts; lowest node %.3f mm, "
              "patch dent %.3f mm (the fine surface %.1f mm over it), fastest node %.2e m/s, the lowest node "
              "within %.1f um over the last 0.5 s\n",
              weight, carried, st.output.tissue_contacts, 1e3 * lowest, 1e3 * dent, 1e3 * kFineHeight, fastest,
              1e6 * (settled_hi - settled_lo));
  EXPECT_GE(st.output.tissue_contacts, 15);
  // At rest but for a jitter of a few micrometres (docs/suturing.md, "The thread on tissue": the
  // fine surface's offsets turn with the net's triangles, which the contact's point on the net
  // does not).
  EXPECT_LT(settled_hi - settled_lo, 2e-5) << "m";
  EXPECT_LT(fastest, 3e-3) << "m/s";
  EXPECT_NEAR(carried, weight, 0.02 * weight);
  EXPECT_LT(dent, -1e-5);
  // On the fine surface over the dent, not on the net: its centreline a radius over the fine
  // surface (the penalty's few µm aside).
  EXPECT_GT(lowest, dent + kFineHeight + 0.5 * t.radius);
  EXPECT_LT(lowest, dent + kFineHeight + 1.5 * t.radius);
}

TEST(ThreadTissueContact, AThreadDeepUnderTheSurfaceIsInAPassageNotOnIt) {
  // Started 3 mm under the patch (deeper than kThreadTissueContactReach): no contact, the thread
  // falls away under gravity, and the patch is left alone.
  const core::Model deep = patch_and_thread(-0.003, 1e6);
  core::Data d = core::make_data(deep);
  for (int s = 0; s < 50; ++s) {
    core::step(deep, d);
    EXPECT_EQ(d.threads[0].output.tissue_contacts, 0) << "step " << s;
    EXPECT_EQ(d.num_node_thread_ties, 0) << "step " << s;
  }
  EXPECT_LT(d.threads[0].position[10].z(), -0.003);
}

}  // namespace
