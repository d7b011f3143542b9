// Tests of core/needle puncture (needle_puncture.hpp; docs/suturing.md, "The needle through
// tissue"): a 26 mm half-circle needle, held by the device as the god-object, driven along its own
// arc (turned about its circle's axis) through a flat 28 × 28 mm patch of tissue — it punctures at
// its threshold (the tissue giving way there within the step), slides along its arc inside, comes out at an exit point, lets go of the points
// that pass off its tail; no puncture from behind or at too steep an angle; no tunnelling at
// recorded speeds; no allocation; a model without a needle that punctures runs no needle stage.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_collision.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/needle_puncture.hpp"
#include "numen/core/step.hpp"
#include "numen/core/step_stages.hpp"
#include "needle_rig.hpp"
#include "sanitizer.hpp"
#include "scratch/data_scratch.hpp"

namespace {

namespace core = numen::core;

using numen::test::kPunctureDeg;
using numen::test::kPunctureThreshold;
using numen::test::puncture_drive;
using numen::test::puncture_rig;

/// What a drive through the patch saw.
struct PuncturePass {
  int puncture_step = -1, exit_step = -1, first_release_step = -1;
  double puncture_force = 0.0;      ///< NeedleState::puncture_tip_force (N).
  double contact_force = 0.0;       ///< NeedleState::puncture_contact_force (N).
  /// The tip's contacts' force along the needle after the puncture's step, as the step used them
  /// (N).
  double carried_at_puncture = 0.0;
  double largest_tip_force_before = 0.0;  ///< Largest tip_force before the puncture step (N).
  double max_deviation = 0.0;       ///< Largest deviation of a point from the arc (m).
  double entry_s_first = 0.0, entry_s_last = 0.0;  ///< The entry's arc parameter after it, and last.
  bool entry_s_decreasing = true;   ///< Never rose by more than 0.05 mm a step.
  std::int64_t tunnels = 0, tunnels_stopped = 0, punctures = 0, exits = 0, releases = 0;
  double lowest_tip_height = 1.0;   ///< The tip's lowest z before the puncture (m; the patch's top is z = 0).
  std::vector<double> feedback;     ///< |feedback force| per step (N).
  std::uint64_t allocations = 0;
  bool finite = true;
  core::Vec3 tip_end = core::Vec3::Zero();
};

PuncturePass run_puncture_pass(const core::Model& m, double omega, double turn, double seconds) {
  PuncturePass out;
  core::Data d = core::make_data(m);
  const int steps = static_cast<int>(std::lround(seconds / m.dt));
  out.feedback.reserve(static_cast<std::size_t>(steps));
  double entry_prev = 1.0;
  {
    numen::test::AllocationGuard guard;
    for (int s = 0; s < steps; ++s) {
      puncture_drive(m, d, s * m.dt, omega, turn);
      const core::Quat turned =
          d.bodies[static_cast<std::size_t>(m.needles[0].body)].orientation;  // at the start
      core::step(m, d);
      if (d.status & core::kNonFinite) {
        out.finite = false;
        break;
      }
      const core::NeedleState& st = d.needles[0];
      out.feedback.push_back(d.feedback_wrench.force.norm());
      if (st.event == core::PunctureEvent::kPuncture && out.puncture_step < 0) {
        out.puncture_step = s;
        out.puncture_force = st.puncture_tip_force;
        out.contact_force = st.puncture_contact_force;
        const core::NeedleModel& n = m.needles[0];
        const core::Vec3 t =
            turned * core::needle_tangent(n, n.length());  // as the step's test took it
        for (int c = 0; c < d.num_node_contacts; ++c) {
          const core::NodeContact& ct = d.node_contacts[static_cast<std::size_t>(c)];
          if (!ct.held && ct.body_b == n.body &&
              ct.sphere_b >= n.sphere_begin + n.sphere_count - 3 &&
              ct.sphere_b < n.sphere_begin + n.sphere_count)
            out.carried_at_puncture += ct.force.dot(t);
        }
      }
      if (out.puncture_step < 0) {
        out.largest_tip_force_before = std::max(out.largest_tip_force_before, st.tip_force);
        const core::BodyState& b = d.bodies[1];
        const core::Vec3 tip = b.position + b.orientation * core::needle_tip(m.needles[0]);
        out.lowest_tip_height = std::min(out.lowest_tip_height, tip.z());
      }
      if (st.event == core::PunctureEvent::kExit && out.exit_step < 0) out.exit_step = s;
      if (st.event == core::PunctureEvent::kRelease && out.first_release_step < 0) out.first_release_step = s;
      out.max_deviation = std::max(out.max_deviation, st.max_deviation);
      if (st.num_punctures > 0 && !st.punctures[0].exit && out.first_release_step < 0 && s > out.puncture_step + 1) {
        const double es = st.punctures[0].arc_parameter;
        if (out.entry_s_first == 0.0) out.entry_s_first = es;
        if (es > entry_prev + 5e-5) out.entry_s_decreasing = false;
        entry_prev = es;
        out.entry_s_last = es;
      }
    }
    out.allocations = guard.count();
  }
  const core::NeedleState& st = d.needles[0];
  out.tunnels = st.tunnels;
  out.tunnels_stopped = st.tunnels_stopped;
  out.punctures = st.punctures_made;
  out.exits = st.exits;
  out.releases = st.releases;
  const core::BodyState& b = d.bodies[1];
  out.tip_end = b.position + b.orientation * core::needle_tip(m.needles[0]);
  return out;
}

}  // namespace

TEST(NeedlePuncture, ThePassPuncturesAtTheThresholdSlidesAlongTheArcAndComesOut) {
  // Turned at 1 rad/s (the tip at 8.3 mm/s) through 230°: the tip meets the patch near β = −30°,
  // presses it until the force along its tangent reaches 1 N, punctures, goes round under the patch
  // and comes out near β = −150°; the tail passes the entry point after 180° from it.
  const core::Model m = puncture_rig();
  const PuncturePass p = run_puncture_pass(m, 1.0, 230 * kPunctureDeg, 4.5);
  std::printf(
      "pass at 8.3 mm/s: puncture at step %d, %.4f N along the needle (its contacts asked %.4f N; "
      "threshold %.2f N); exit at step %d; first release at step %d; largest deviation %.3f mm; "
      "entry s %.2f -> %.2f mm\n",
      p.puncture_step, p.puncture_force, p.contact_force, kPunctureThreshold, p.exit_step,
      p.first_release_step, p.max_deviation * 1e3, p.entry_s_first * 1e3, p.entry_s_last * 1e3);
  ASSERT_TRUE(p.finite);
  EXPECT_EQ(p.allocations, 0u) << "the needle in tissue allocated";
  ASSERT_EQ(p.punctures, 1);
  // The contacts reach the threshold within 10 % in the puncture's step, and the tissue gives way
  // at it: the needle meets F_p, no more.
  EXPECT_GE(p.contact_force, kPunctureThreshold);
  EXPECT_LT(p.contact_force, 1.1 * kPunctureThreshold) << "N: within 10 % of the threshold";
  EXPECT_DOUBLE_EQ(p.puncture_force, kPunctureThreshold);
  EXPECT_LT(p.largest_tip_force_before, kPunctureThreshold);
  EXPECT_GT(p.largest_tip_force_before, 0.5 * kPunctureThreshold) << "N: the tip pressed before it went in";
  EXPECT_EQ(p.tunnels, 0);
  ASSERT_EQ(p.exits, 1) << "the tip came out";
  EXPECT_GT(p.exit_step, p.puncture_step);
  EXPECT_TRUE(p.entry_s_decreasing) << "the entry slid along the arc towards the tail";
  EXPECT_LT(p.entry_s_last, p.entry_s_first - 0.01) << "m: the needle went 10 mm through the entry";
  EXPECT_LT(p.max_deviation, 1e-3) << "m: the tissue held the needle on its arc";
  EXPECT_GE(p.releases, 1) << "the entry let go once the tail passed it";
  EXPECT_GT(p.first_release_step, p.exit_step);
  // The hand's force (the device's feedback, Eq. 8): continuous but for the puncture's drop.
  double largest_jump = 0.0;
  for (std::size_t k = 1; k < p.feedback.size(); ++k) {
    const int s = static_cast<int>(k);
    if (s >= p.puncture_step - 1 && s <= p.puncture_step + 3) continue;
    largest_jump = std::max(largest_jump, std::abs(p.feedback[k] - p.feedback[k - 1]));
  }
  const auto at = static_cast<std::size_t>(p.puncture_step);
  std::printf("feedback around the puncture:");
  for (std::size_t k = at - 3; k < at + 8; ++k) std::printf(" %.4f", p.feedback[k]);
  std::printf(" N; largest step elsewhere %.4f N\n", largest_jump);
  EXPECT_LT(largest_jump, 0.15 * kPunctureThreshold) << "N in a step, away from the puncture";
  double lowest_after = p.feedback[at];
  for (std::size_t k = at; k < at + 4; ++k) lowest_after = std::min(lowest_after, p.feedback[k]);
  EXPECT_GT(p.feedback[at - 1] - lowest_after, 0.3 * kPunctureThreshold) << "N: the puncture's drop";
}

TEST(NeedlePuncture, ANeedlePuncturesAnOrganGivenByItsMaterial) {
  // ~7 s here; past the 300 s bound under ASan + UBSan (CI's sanitizer step).
  NUMEN_SKIP_UNDER_SANITIZER("two needle passes into a 1 125-node slab given by its material");
  // The pass above into a slab of tissue given by its material. The needle is sharp
  // (BodyModel::sharp): the organ meets it with the pair's penalty. With the two-scale law of a
  // blunt tool's sphere instead (net_tissue_contact.hpp), the 0.35 mm tip sinks two of its radii
  // into the slab at a few hundredths of a newton and would go through; the tip's sweep
  // (core::stop_needle_tunnels()) holds it at the surface instead, where it never punctures.
  core::Model blunt = numen::test::puncture_rig_material();
  ASSERT_TRUE(blunt.bodies[1].sharp);
  ASSERT_GT(blunt.nets[0].contact_modulus, 0.0);
  blunt.bodies[1].sharp = false;
  const PuncturePass b = run_puncture_pass(blunt, 1.0, 230 * kPunctureDeg, 1.6);
  std::printf("the needle as a blunt tool: punctures %lld, tunnels %lld (stopped %lld), largest force along it %.4f N\n",
              static_cast<long long>(b.punctures), static_cast<long long>(b.tunnels),
              static_cast<long long>(b.tunnels_stopped), b.largest_tip_force_before);
  EXPECT_EQ(b.punctures, 0);
  EXPECT_EQ(b.tunnels, 0);
  EXPECT_GE(b.tunnels_stopped, 1);
  EXPECT_LT(b.largest_tip_force_before, 0.2 * kPunctureThreshold);

  const core::Model m = numen::test::puncture_rig_material();
  const PuncturePass p = run_puncture_pass(m, 1.0, 230 * kPunctureDeg, 2.6);
  std::printf(
      "pass into the material slab: puncture at step %d, %.4f N along the needle (its contacts "
      "asked %.4f N; largest before %.4f N); exit at step %d; largest deviation %.3f mm; "
      "tunnels %lld\n",
      p.puncture_step, p.puncture_force, p.contact_force, p.largest_tip_force_before, p.exit_step,
      p.max_deviation * 1e3, static_cast<long long>(p.tunnels));
  ASSERT_TRUE(p.finite);
  EXPECT_EQ(p.allocations, 0u);
  EXPECT_EQ(p.tunnels, 0);
  ASSERT_EQ(p.punctures, 1);
  EXPECT_EQ(p.exits, 1);
  EXPECT_LT(p.max_deviation, 1e-3) << "m: the tissue held the needle on its arc";
  // Not within 10 % of the threshold here (docs/suturing.md, "The needle through tissue", "An
  // organ given by its material"): the soft slab dimples under the tip, which slides down the
  // dimple's side (the force along the needle falls from 0.75 N), until a triangle's face contact
  // appears in the crease 0.135 mm deep and the force jumps to 3.35 N in one step. The bound is
  // that figure's; on 1 mm cubes it punctures at 1.018 N (measured, too slow for a test).
  EXPECT_GE(p.contact_force, kPunctureThreshold);
  EXPECT_LT(p.contact_force, 4.0 * kPunctureThreshold);
  EXPECT_DOUBLE_EQ(p.puncture_force, kPunctureThreshold) << "the tissue gave way at the threshold";
}

TEST(NeedlePuncture, NoTunnellingAtRecordedSpeeds) {
  // Turned at 36 rad/s: the tip at 0.3 m/s (the fastest of the JIGSAWS recordings' tool tips),
  // 0.3 mm a step, under the wire's radius: it punctures, never crosses the patch without.
  const core::Model m = puncture_rig();
  const PuncturePass p = run_puncture_pass(m, 0.3 / m.needles[0].radius, 160 * kPunctureDeg, 0.25);
  std::printf("pass at 0.3 m/s: puncture at step %d, %.4f N; exit at step %d; tunnels %lld\n", p.puncture_step,
              p.puncture_force, p.exit_step, static_cast<long long>(p.tunnels));
  ASSERT_TRUE(p.finite);
  EXPECT_EQ(p.tunnels, 0);
  EXPECT_EQ(p.punctures, 1);
  EXPECT_EQ(p.exits, 1);
  // The force rises by newtons a step at that speed: the step's contacts ask several times the
  // threshold, and the tissue gives way at it within the step (find_punctures()): the contacts the
  // step used carry F_p along the needle, no more.
  const double f_p = m.needles[0].puncture_force;
  std::printf("  its contacts asked %.4f N; they carried %.4f N along the needle\n",
              p.contact_force, p.carried_at_puncture);
  EXPECT_GT(p.contact_force, 2.0 * f_p);
  EXPECT_DOUBLE_EQ(p.puncture_force, f_p);
  EXPECT_NEAR(p.carried_at_puncture, f_p, 1e-3 * f_p);
}

TEST(NeedlePuncture, ThePuncturesStepTakesTheExcessBackFromTheNodesAndTheNeedle) {
  // The 0.3 m/s pass up to the puncture's step, that step's stages as core::step() runs them up
  // to the forces, then find_punctures(): each tip contact scaled by a = F_p / F_tip, and the
  // nodes' forces and the needle's wrench, which the force stage gave the whole ask, changed by
  // exactly what the contacts gave back.
  const core::Model m = puncture_rig();
  const double omega = 0.3 / m.needles[0].radius, turn = 160 * kPunctureDeg;
  const int at = run_puncture_pass(m, omega, turn, 0.25).puncture_step;
  ASSERT_GT(at, 0);
  core::Data d = core::make_data(m);
  for (int s = 0; s < at; ++s) {
    puncture_drive(m, d, s * m.dt, omega, turn);
    core::step(m, d);
  }
  puncture_drive(m, d, at * m.dt, omega, turn);
  core::step_to_contacts(m, d);
  if (m.stage_plan & core::kStageContacts) core::detect_contacts(m, d);
  if (m.stage_plan & core::kStageNodeContacts) core::detect_node_contacts(m, d);
  if (m.stage_plan & core::kStageGrasp) core::update_grasps(m, d);
  core::tie_needles(m, d);
  core::compute_forces(m, d);
  const core::NeedleModel& n = m.needles[0];
  const auto body = static_cast<std::size_t>(n.body);
  const std::vector<core::Vec3> node_force = d.scratch->net.force;
  const core::Wrench wrench = d.body_wrench[body];
  const std::vector<core::NodeContact> asked(d.node_contacts.begin(),
                                             d.node_contacts.begin() + d.num_node_contacts);
  core::find_punctures(m, d);
  const core::NeedleState& st = d.needles[0];
  ASSERT_EQ(st.event, core::PunctureEvent::kPuncture);
  const double a = n.puncture_force / st.puncture_contact_force;
  ASSERT_LT(a, 0.5) << "the contacts asked more than twice the threshold";
  EXPECT_DOUBLE_EQ(st.tip_force, n.puncture_force);
  std::vector<core::Vec3> given_back(node_force.size(), core::Vec3::Zero());
  core::Vec3 on_needle = core::Vec3::Zero();
  int scaled = 0;
  for (std::size_t c = 0; c < asked.size(); ++c) {
    const core::NodeContact& was = asked[c];
    const core::NodeContact& now = d.node_contacts[c];
    const bool tip = !was.held && was.body_b == n.body &&
                     was.sphere_b >= n.sphere_begin + n.sphere_count - 3 &&
                     was.sphere_b < n.sphere_begin + n.sphere_count;
    if (!tip) {
      EXPECT_EQ(now.force, was.force) << c;
      continue;
    }
    ++scaled;
    EXPECT_LT((now.force - a * was.force).norm(), 1e-12) << c;
    EXPECT_NEAR(now.stiffness, a * was.stiffness, 1e-9 * was.stiffness) << c;
    given_back[static_cast<std::size_t>(was.node)] += was.force - now.force;
    on_needle += was.force - now.force;
  }
  EXPECT_GE(scaled, 1);
  for (std::size_t i = 0; i < node_force.size(); ++i)
    EXPECT_LT((d.scratch->net.force[i] - (node_force[i] - given_back[i])).norm(), 1e-12)
        << "node " << i;
  EXPECT_LT((d.body_wrench[body].force - (wrench.force + on_needle)).norm(), 1e-12);
}

TEST(NeedlePuncture, ATipDrivenThroughTheSurfaceWithoutAPunctureIsHeldAtIt) {
  // With contacts of 1 N/m (the tissue nearly not there) the penalty cannot stop the tip, and the
  // force along it never reaches the threshold: the tip's sweep (core::stop_needle_tunnels())
  // holds it at the patch, its centre never deeper than (1 − kTunnelStopDepth) r_w over the top
  // (z = 0) but for the patch's own give, no puncture, no tunnel.
  core::Model m = puncture_rig();
  for (core::MaterialPair& p : m.material_pairs) p = core::MaterialPair{1.0, 0.0, 0.0};
  ASSERT_EQ(core::finalize_model(m), "");
  const PuncturePass p = run_puncture_pass(m, 1.0, 200 * kPunctureDeg, 1.5);
  const double r_w = m.needles[0].wire_radius;
  std::printf("tip through a 1 N/m patch: punctures %lld, tunnels %lld, stopped %lld, lowest tip %.3f mm\n",
              static_cast<long long>(p.punctures), static_cast<long long>(p.tunnels),
              static_cast<long long>(p.tunnels_stopped), p.lowest_tip_height * 1e3);
  ASSERT_TRUE(p.finite);
  EXPECT_EQ(p.allocations, 0u);
  EXPECT_EQ(p.punctures, 0);
  EXPECT_EQ(p.tunnels, 0);
  EXPECT_GE(p.tunnels_stopped, 1);
  EXPECT_GT(p.lowest_tip_height, -r_w);
}

TEST(NeedlePuncture, ATipThatCrossedTheSurfaceWithoutAPunctureIsCountedAsATunnel) {
  // The sweep's own guard (tie_needles()), behind the stop above: the tip put 1 mm under the
  // patch's top from 1 mm over it between two steps, as no step of core::step() leaves it, is
  // one tunnel; put back over it, none more.
  const core::Model m = puncture_rig();
  core::Data d = core::make_data(m);
  core::BodyState& b = d.bodies[1];
  const core::Vec3 tip = b.position + b.orientation * core::needle_tip(m.needles[0]);
  const core::Vec3 over(0.0, 0.0, 0.001);
  b.position += over - tip;
  core::tie_needles(m, d);
  EXPECT_EQ(d.needles[0].tunnels, 0);
  b.position -= 2.0 * over;
  core::tie_needles(m, d);
  EXPECT_EQ(d.needles[0].tunnels, 1);
  b.position += 2.0 * over;
  core::tie_needles(m, d);
  EXPECT_EQ(d.needles[0].tunnels, 1);
}

TEST(NeedlePuncture, NoPunctureFromBehindOrAtTooSteepAnAngle) {
  // From behind: the same pass mirrored below the patch (C at z = −R/2), the tip going up into the
  // patch's underside: it never punctures (nor does the sheet push on it: its triangle contacts are
  // one-sided, so the tip passes its underside freely; an organ's closed surface has no underside).
  // Too steep: the tip meets the patch about 30° off its normal (the arc's crossing at β = −30° is
  // 60° from straight down, so the tangent there is 30° off the normal): pressed past the
  // threshold, it punctures with a 50° limit, not with a 20° one.
  const core::Model behind = puncture_rig(kPunctureThreshold, 60 * kPunctureDeg, true);
  const PuncturePass b = run_puncture_pass(behind, 1.0, 120 * kPunctureDeg, 2.0);
  std::printf("from behind: largest force along the needle %.3f N, punctures %lld\n", b.largest_tip_force_before,
              static_cast<long long>(b.punctures));
  ASSERT_TRUE(b.finite);
  EXPECT_EQ(b.punctures, 0) << "punctured from behind";
  const core::Model steep = puncture_rig(kPunctureThreshold, 20 * kPunctureDeg);
  const PuncturePass p = run_puncture_pass(steep, 1.0, 200 * kPunctureDeg, 1.5);
  ASSERT_TRUE(p.finite);
  EXPECT_EQ(p.punctures, 0) << "punctured 30° off the normal with a 20° limit";
  EXPECT_GT(p.largest_tip_force_before, kPunctureThreshold) << "N: pressed past the threshold all the same";
  const core::Model ok = puncture_rig(kPunctureThreshold, 50 * kPunctureDeg);
  EXPECT_EQ(run_puncture_pass(ok, 1.0, 200 * kPunctureDeg, 1.5).punctures, 1) << "the same pass with a 50° limit";
}

TEST(NeedlePuncture, AModelWithoutANeedleThatPuncturesRunsNoNeedleStage) {
  core::Model m = puncture_rig();
  EXPECT_NE(m.stage_plan & core::kStageNeedles, 0u);
  m.needles[0].puncture_force = std::numeric_limits<double>::quiet_NaN();
  ASSERT_EQ(core::finalize_model(m), "");
  EXPECT_EQ(m.stage_plan & core::kStageNeedles, 0u) << "a needle that never punctures";
  core::Data d = core::make_data(m);
  core::step(m, d);
  EXPECT_EQ(d.stages_run & core::kStageNeedles, 0u);
  EXPECT_EQ(d.num_node_needle_ties, 0);
}


TEST(NeedlePuncture, NearABoxsEdgeTheTopIsPuncturedAtTheThreshold) {
  // The suturing pad is a box: its top meets its sides at 90°. The needle's plane `edge` inside
  // the box's +y side (the wire's radius 0.35 mm), turned at 1 and 4 rad/s (8.3 and 33 mm/s at
  // the tip): from 1 mm (2.9 wire radii) on, the top is punctured within 10 % of the threshold
  // and the tip comes out through the bottom. Closer, the tip rides the box's corner node down and
  // slips off it (docs/suturing.md, "The pad's edge"): the puncture's force printed, not checked.
  // At every edge no tunnel: where the coupling spring throws the tip past the corner in one
  // step, the tip's sweep (core::stop_needle_tunnels()) holds it at the side. Under a sanitizer
  // (15 times slower) two edges: one the corner throws the tip past, one punctured at the threshold.
  const std::vector<double> edges = numen::test::under_sanitizer()
                                        ? std::vector<double>{0.0006, 0.001}
                                        : std::vector<double>{0.0004, 0.0006, 0.0008, 0.001, 0.0015, 0.003};
  for (const double edge : edges) {
    for (const double omega : {1.0, 4.0}) {
      const core::Model m = numen::test::puncture_rig_box(edge);
      const PuncturePass p = run_puncture_pass(m, omega, 200 * kPunctureDeg, 200 * kPunctureDeg / omega + 0.5);
      std::printf(
          "edge %.1f mm, %.0f rad/s: %lld punctures (%.3f N, its contacts asked %.3f N, largest "
          "before %.3f N), %lld exits, %lld tunnels, %lld stopped\n",
          edge * 1e3, omega, static_cast<long long>(p.punctures), p.puncture_force, p.contact_force,
          p.largest_tip_force_before, static_cast<long long>(p.exits),
          static_cast<long long>(p.tunnels), static_cast<long long>(p.tunnels_stopped));
      ASSERT_TRUE(p.finite);
      EXPECT_EQ(p.tunnels, 0) << edge << " " << omega;
      if (edge < 0.001) continue;
      EXPECT_EQ(p.punctures, 1) << edge << " " << omega;
      EXPECT_GE(p.contact_force, kPunctureThreshold) << edge << " " << omega;
      EXPECT_LT(p.contact_force, 1.1 * kPunctureThreshold) << edge << " " << omega;
      EXPECT_DOUBLE_EQ(p.puncture_force, kPunctureThreshold) << edge << " " << omega;
      EXPECT_EQ(p.exits, 1) << edge << " " << omega;
    }
  }
}
