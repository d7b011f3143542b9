// Tests of a thread lying on tissue (core/src/thread/thread_tissue_contact.cpp; thread.hpp
// "Couplings"; docs/thread.md "The thread on tissue"): a heavy thread dropped on a patch of
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

/// What a heavy thread dropped on the patch came to after `steps` steps.
struct Settled {
  double weight = 0.0;    ///< The thread's weight (N).
  double carried = 0.0;   ///< The vertical force its contact springs put on the patch (N).
  double lowest = 1e9;    ///< Its lowest node's height (m).
  double fastest = 0.0;   ///< Its fastest node's speed (m/s).
  double dent = 0.0;      ///< The patch's lowest node's height (m).
  double wander = 0.0;    ///< How far its lowest node's height ranged over the last third (m).
  int contacts = 0;       ///< ThreadOutput::tissue_contacts.
  int dropped = 0;        ///< ThreadOutput::contacts_dropped.
  std::uint64_t allocations = 0;
};
Settled settle(const core::Model& m, int steps) {
  Settled out;
  core::Data d = core::make_data(m);
  const core::ThreadModel& t = m.threads[0];
  out.weight = t.density * M_PI * t.radius * t.radius * t.length * 9.81;
  double lo = 1e9, hi = -1e9;
  {
    numen::test::AllocationGuard guard;
    for (int s = 0; s < steps; ++s) {
      core::step(m, d);
      EXPECT_FALSE(d.status & core::kNonFinite) << "step " << s;
      if (3 * s < 2 * steps) continue;
      double low = 1e9;
      for (const core::Vec3& x : d.threads[0].position) low = std::min(low, x.z());
      lo = std::min(lo, low);
      hi = std::max(hi, low);
    }
    out.allocations = guard.count();
  }
  out.wander = hi - lo;
  const core::ThreadState& st = d.threads[0];
  for (std::size_t i = 0; i < st.position.size(); ++i) {
    out.lowest = std::min(out.lowest, st.position[i].z());
    out.fastest = std::max(out.fastest, st.velocity[i].norm());
  }
  for (const core::NodeState& n : d.nodes) out.dent = std::min(out.dent, n.position.z());
  out.carried = -thread_force_on_tissue_z(d);
  out.contacts = st.output.tissue_contacts;
  out.dropped = static_cast<int>(st.output.contacts_dropped);
  std::printf("[thread on tissue] weight %.4f N, carried by the tissue %.4f N through %d contacts; lowest node "
              "%.3f mm, patch dent %.3f mm, fastest node %.2e m/s, the lowest node within %.1f um over the "
              "last third\n",
              out.weight, out.carried, out.contacts, 1e3 * out.lowest, 1e3 * out.dent, out.fastest, 1e6 * out.wander);
  return out;
}

TEST(ThreadTissueContact, AHeavyThreadComesToRestOnTheTissueWhichCarriesItsWeight) {
  const core::Model m = patch_and_thread(0.002, 1e6);
  const double r = m.threads[0].radius;
  const Settled s = settle(m, 1500);
  EXPECT_EQ(s.allocations, 0u);
  EXPECT_GT(s.weight, 0.05);
  EXPECT_GE(s.contacts, 15);  // the nodes over the patch (not the free ends' few)
  EXPECT_EQ(s.dropped, 0);
  EXPECT_LT(s.fastest, 1e-3) << "at rest";
  // The tissue carries the weight (Newton's third law through the springs on its nodes).
  EXPECT_NEAR(s.carried, s.weight, 0.02 * s.weight);
  // Dented, and the thread on the dented surface: its centreline within one radius (and the
  // penalty's few µm) of the lowest patch node, never through.
  EXPECT_LT(s.dent, -1e-5);
  EXPECT_GT(s.lowest, s.dent + 0.5 * r);
  EXPECT_LT(s.lowest, s.dent + 1.5 * r);
}

TEST(ThreadTissueContact, OnAFineSurfaceTheThreadLiesOnItNotOnTheNetUnderIt) {
  // The test above with a fine surface 0.6 mm over the patch's net (an organ's drawn surface,
  // docs/fine-surface.md): the thread comes to rest on the fine surface, which the net's
  // triangles carry, and the tissue carries its weight through the nodes under it.
  constexpr double kFineHeight = 6e-4;
  const core::Model m = patch_and_thread(0.002 + kFineHeight, 1e6, kFineHeight);
  ASSERT_GT(m.nets[0].surface_face_count, 0);
  const double r = m.threads[0].radius;
  const Settled s = settle(m, 1500);
  EXPECT_EQ(s.allocations, 0u);
  EXPECT_GE(s.contacts, 15);
  EXPECT_EQ(s.dropped, 0);
  // At rest but for a jitter of a few micrometres (docs/thread.md, "The thread on tissue": the
  // fine surface's offsets turn with the net's triangles, which the contact's point on the net
  // does not).
  EXPECT_LT(s.wander, 2e-5) << "m";
  EXPECT_LT(s.fastest, 3e-3) << "m/s";
  EXPECT_NEAR(s.carried, s.weight, 0.02 * s.weight);
  EXPECT_LT(s.dent, -1e-5);
  // On the fine surface over the dent, not on the net: its centreline a radius over the fine
  // surface (the penalty's few µm aside).
  EXPECT_GT(s.lowest, s.dent + kFineHeight + 0.5 * r);
  EXPECT_LT(s.lowest, s.dent + kFineHeight + 1.5 * r);
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
