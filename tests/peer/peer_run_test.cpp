// Tests of tests/peer/peer_run (and the recording it replays, and the table): both engines step
// every scene, the figures are finite, numen's replay is the run of `numen run`.
#include "peer_run.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <sstream>

#include "numen/core/step.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "peer_table.hpp"

namespace peer = numen::peer;
namespace core = numen::core;

TEST(PeerRun, BothEnginesStepEveryScene) {
  const std::vector<peer::PeerScene> scenes = peer::comparison_scenes(0.3);
  ASSERT_EQ(scenes.size(), 3u);
  const std::vector<peer::PeerRow> rows = peer::run_comparison(scenes);
  ASSERT_EQ(rows.size(), 9u);
  for (const peer::PeerRow& r : rows) {
    SCOPED_TRACE(r.scene + " " + r.engine + " " + r.variant);
    EXPECT_EQ(r.steps, 300);
    EXPECT_GT(r.step_median_us, 0.0);
    EXPECT_GE(r.step_p99_us, r.step_median_us);
    EXPECT_TRUE(std::isfinite(r.metrics.penetration_max_mm));
    EXPECT_TRUE(std::isfinite(r.metrics.tracking_rms_mm));
    EXPECT_LE(r.metrics.tracking_rms_mm, r.metrics.tracking_max_mm);
    // The held block starts on the board (in contact) and lifts only after 0.5 s.
    if (r.scene != "construction") {
      EXPECT_GT(r.metrics.free_steps, 0);
    }
    EXPECT_GT(r.ratio_numen_over_this, 0.0);
  }
  // numen and the mocap weld stay finite on every scene (the explicit PD may not: see
  // docs/peer.md).
  for (const peer::PeerRow& r : rows) {
    if (r.variant != to_string(peer::Drive::kPdForce)) {
      EXPECT_EQ(r.divergences, 0) << r.scene << " " << r.variant;
    }
  }
  const std::string csv = peer::format_csv(rows);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 10);
  EXPECT_EQ(csv.rfind("scene,engine,variant,steps,step_median_us", 0), 0u);
  EXPECT_NE(peer::format_table(rows).find("| wall | mujoco / mocap weld |"), std::string::npos);
}

TEST(PeerRun, NumensReplayIsTheRunOfTheSceneRunnerBitForBit) {
  // The recording holds every input core::step reads: replaying it on a fresh Data reproduces
  // the SceneRunner's bodies exactly (construction: 3 s through the tower, the instrument: 1 s).
  for (const char* file : {"sim/scenes/construction.toml", "sim/scenes/lattice.toml"}) {
    const numen::sim::Scene scene =
        numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/" + file);
    const int steps = file[11] == 'c' ? 3000 : 1000;
    auto runner = std::make_unique<numen::sim::SceneRunner>(scene);
    core::Data d = core::make_data(scene.model);
    for (int k = 0; k < steps; ++k) {
      runner->period();
      const core::Data& r = runner->data();
      peer::StepInput in{r.held_body, r.target, r.target_twist, r.body_targets, r.joint_prescribed};
      peer::apply_step_input(scene.model, in, d);
      core::step(scene.model, d);
    }
    for (std::size_t b = 0; b < d.bodies.size(); ++b) {
      EXPECT_EQ(std::memcmp(d.bodies[b].position.data(), runner->data().bodies[b].position.data(),
                            3 * sizeof(double)),
                0)
          << file << " body " << b;
      EXPECT_EQ(
          std::memcmp(d.bodies[b].orientation.coeffs().data(),
                      runner->data().bodies[b].orientation.coeffs().data(), 4 * sizeof(double)),
          0)
          << file << " body " << b;
    }
  }
}

TEST(PeerRun, PercentilesAreNearestRank) {
  std::vector<std::int64_t> ns;
  for (int i = 1; i <= 1000; ++i) ns.push_back(1000 * i);  // 1 µs … 1000 µs, shuffled below
  std::reverse(ns.begin(), ns.end());
  double med = 0.0, p99 = 0.0;
  peer::percentiles_us(ns, med, p99);
  EXPECT_DOUBLE_EQ(med, 500.0);
  EXPECT_DOUBLE_EQ(p99, 990.0);
}

TEST(PeerRun, HeldBodiesAreTheDistinctOnesHeld) {
  peer::InputRecording rec(5);
  rec[0].held_body = 3;
  rec[1].held_body = -1;
  rec[2].held_body = 0;
  rec[3].held_body = 3;
  rec[4].held_body = -1;
  EXPECT_EQ(peer::held_bodies(rec), (std::vector<int>{0, 3}));
}
