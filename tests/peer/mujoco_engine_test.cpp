// Tests of tests/peer/mujoco_engine: MuJoCo driven by the device inputs tracks the target in
// free space, the PD variant follows numen's own trajectory there, prescribed joints follow
// their prescription.
#include "mujoco_engine.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "numen/core/step.hpp"
#include "peer_metrics.hpp"
#include "peer_run.hpp"
#include "peer_scene.hpp"
#include "soft_constraint_mapping.hpp"

namespace peer = numen::peer;
namespace core = numen::core;

namespace {

// The wall scene's first 150 ms: the target starts at rest on the ball and moves at 0.2 m/s;
// the ball touches the wall at x = −10 mm, i.e. not before t = 0.2 s.
constexpr double kFreeSeconds = 0.15;

}  // namespace

TEST(MujocoEngine, BothDrivesTrackTheTargetInFreeSpaceWithinTheirBounds) {
  // The target jumps from rest to v = 0.2 m/s. PD (numen's springs, with the target twist): the
  // error e = x_t − x starts at e = 0, ė = v and obeys ë + 2ζω ė + ω² e = 0, so |e| never
  // exceeds v/ω, the undamped amplitude (k_t = 1000 N/m, m = 0.05 kg: ω = 141.4 rad/s,
  // v/ω = 1.41 mm). Mocap weld: MuJoCo's mocap body has no velocity, so the weld's damping B
  // acts on the tool's own velocity: ë + B ė + K e = B v, e → B v / K = 2ζ v / ω_w with
  // ω_w = √K = √(1 − d) ω (d = ½): a steady lag of 3.40 mm, approached with ζ = 0.85 (≤ 1 %
  // overshoot): bound 1.1 × that.
  const peer::PeerScene s = peer::make_wall_scene(kFreeSeconds);
  const double omega = std::sqrt(1000.0 / 0.05), v = 0.2, zeta = 0.85;
  const double omega_w = std::sqrt(1.0 - peer::kMinImpedance) * omega;
  const peer::PeerRow pd = peer::run_mujoco(s, peer::Drive::kPdForce);
  const peer::PeerRow weld = peer::run_mujoco(s, peer::Drive::kMocapWeld);
  for (const peer::PeerRow* r : {&pd, &weld}) {
    EXPECT_EQ(r->metrics.free_steps, r->steps) << r->variant;   // never touched the wall
    EXPECT_GT(r->metrics.tracking_max_mm, 0.05) << r->variant;  // it did lag: the error is measured
    EXPECT_EQ(r->divergences, 0) << r->variant;
  }
  EXPECT_LT(pd.metrics.tracking_max_mm, 1e3 * v / omega);
  EXPECT_LT(weld.metrics.tracking_max_mm, 1.1e3 * 2.0 * zeta * v / omega_w);
  EXPECT_GT(weld.metrics.tracking_max_mm, 0.9e3 * 2.0 * zeta * v / omega_w);  // the lag is there
  const peer::PeerRow n = peer::run_numen(s);
  EXPECT_LT(n.metrics.tracking_max_mm, 1e3 * v / omega);
}

TEST(MujocoEngine, ThePdDriveFollowsNumensFreeSpaceTrajectory) {
  // Same springs (core::coupling_wrench), same mass, no contact: MuJoCo's explicit Euler and
  // numen's linearly implicit Euler are both first order; their trajectories differ by O(ω h)
  // of the transient's amplitude v/ω, i.e. by about h v: bound 2 h v = 0.4 mm, against a
  // 30 mm displacement.
  const peer::PeerScene s = peer::make_wall_scene(kFreeSeconds);
  peer::MujocoEngine engine(s.model, peer::Drive::kPdForce, {0});
  core::Data d = core::make_data(s.model);
  std::vector<core::BodyState> states;
  double largest = 0.0;
  for (const peer::StepInput& in : s.inputs) {
    engine.apply(in);
    engine.step();
    engine.read_states(states);
    peer::apply_step_input(s.model, in, d);
    core::step(s.model, d);
    largest = std::max(largest, (states[0].position - d.bodies[0].position).norm());
  }
  EXPECT_GT((d.bodies[0].position - s.model.bodies[0].initial_pose.position).norm(), 0.025);
  EXPECT_LT(largest, 2.0 * 1e-3 * 0.2);
  EXPECT_LT((states[0].linear_velocity - d.bodies[0].linear_velocity).norm(), 0.02 * 0.2);
}

TEST(MujocoEngine, PrescribedJawsFollowTheRecordedJawAngle) {
  // The instrument: each jaw hinge is held by an equality at the recorded jaw angle (±½ jaw,
  // minus the starting coordinate); after 0.5 s MuJoCo's hinge coordinate is there within
  // 5 mrad (the equality is soft: time constant 2 Δt, critically damped, so it lags the
  // recorded motion by about 2 ms × the jaw's angular rate).
  const peer::PeerScene s = peer::load_recorded_scene("instrument", "sim/scenes/lattice.toml", 0.5);
  peer::MujocoEngine engine(s.model, peer::Drive::kMocapWeld, peer::held_bodies(s.inputs));
  for (const peer::StepInput& in : s.inputs) {
    engine.apply(in);
    engine.step();
  }
  const mjModel* m = engine.mj_model();
  int checked = 0;
  for (int j = 0; j < s.model.num_joints(); ++j) {
    if (!s.model.joints[static_cast<std::size_t>(j)].prescribed) continue;
    const std::string name =
        "j" + std::to_string(j) + "_" + s.model.joints[static_cast<std::size_t>(j)].name;
    const int jid = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    ASSERT_GE(jid, 0) << name;
    const double q = engine.mj_data()->qpos[m->jnt_qposadr[jid]];
    const core::JointPrescription& p =
        s.inputs.back().joint_prescribed[static_cast<std::size_t>(j)];
    EXPECT_NEAR(q, p.value - engine.translation().coordinate_offset[static_cast<std::size_t>(j)],
                5e-3)
        << name;
    ++checked;
  }
  EXPECT_EQ(checked, 2);
  EXPECT_EQ(engine.divergences(), 0);
}
