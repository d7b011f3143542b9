// Tests of sim/run: the shipped scenes run end to end through the simulated
// bus, the instrument, the controller's checks and core::step (SceneRunner),
// with the god-object staying on the surface while the hand goes through it
// (rigid and articulated tools, the mouse scene's clutch). Deformable scenes:
// run_deformable_test.cpp; allocations, determinism, bus frames, run options, recorded
// trials and summary figures: run_*_test.cpp by name.
#include "numen/sim/run/run.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <atomic>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "child_process.hpp"
#include "lattice_scene.hpp"
#include "run_scenes.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/input/jigsaws.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "build_features.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "sanitizer.hpp"

namespace {

using namespace numen::test::run_scenes;

TEST(RunLatticeScene, GodObjectStaysOnTheSurfaceWhileTheHandGoesThrough) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = lattice_scene();
  const std::int64_t n = periods_for(scene, 15.0);
  SceneRunner runner(scene, static_cast<std::size_t>(n));
  const auto t0 = std::chrono::steady_clock::now();
  for (std::int64_t k = 0; k < n; ++k) runner.period();
  const double wall = wall_s(t0);
  const RunSummary s = runner.summary();
  print_summary("lattice 15 s", s, wall);

  EXPECT_EQ(runner.periods(), n);
  EXPECT_EQ(s.steps, n);
  EXPECT_NEAR(s.sim_time_s, 15.0, 1e-9);
  EXPECT_EQ(runner.data().step_count, n);
  EXPECT_EQ(s.scene, "lattice");
  EXPECT_EQ(s.coupling, "god-object");

  // The hand (the instrument placed at the device target) goes deep into the
  // organ and the tissue; the god-object stays on the surface.
  EXPECT_GE(s.hand_penetration_max_mm, 10.0);
  EXPECT_LE(s.tool_penetration_max_mm, 2.0);
  EXPECT_GT(s.contacts_max, 0);
  EXPECT_EQ(s.contact_overflow, 0);

  EXPECT_FALSE(s.nan_detected);
  EXPECT_EQ(s.nonfinite_steps, 0);
  EXPECT_EQ(s.rejected_samples, 0);
  // The managed CANopen start-up: period 0 (reset communication, boot-ups), periods 1–47 (every
  // node configured from its DCF over SDO, one transfer per node and period: the drive nodes'
  // 47) and period 48 (start remote node) have no encoder TPDO yet, so their samples are not
  // valid; every later one is.
  EXPECT_EQ(s.invalid_periods, 49);
  EXPECT_EQ(s.configured_nodes, 5);
  EXPECT_EQ(s.bus_frames_corrupted, 0);
  EXPECT_EQ(s.bus_frames_dropped, 0);
  // Lifecycle: operational and active at period 50 (the first node heartbeats after the start,
  // on their 10 ms grid), torque from period 54 (CiA 402 shutdown → switch on → enable
  // operation), no fault.
  EXPECT_TRUE(s.managed);
  EXPECT_EQ(s.startup, "operational");
  EXPECT_EQ(s.periods_to_operational, 50);
  EXPECT_EQ(s.periods_to_active, 50);
  EXPECT_GE(s.periods_to_torque, 54);
  EXPECT_EQ(s.lifecycle, "active");
  EXPECT_EQ(s.faults, 0);
  EXPECT_EQ(s.fault_records, 0);
  EXPECT_EQ(s.first_fault, "");
  EXPECT_EQ(s.emcys, 0);
  EXPECT_EQ(s.heartbeat_losses, 0);
  ASSERT_EQ(s.drive_states.size(), 3u);
  EXPECT_EQ(s.drive_states[0], "pivot_x: operation enabled");
  EXPECT_EQ(s.drive_states[2], "depth: operation enabled");

  // Free space: the god-object follows the hand closely.
  EXPECT_GT(s.free_steps, n / 10);
  EXPECT_LT(s.tracking_error_free_rms_mm, 1.0);

  // Feedback: bounded by the scene's saturation, and really used while the
  // god-object is held back by the organ (spring stretched by ≥ 8 mm × 300 N/m).
  EXPECT_LE(s.feedback_force_max_n, scene.model.feedback.max_force + 1e-9);
  EXPECT_LE(s.feedback_torque_max_nm, scene.model.feedback.max_torque + 1e-9);
  EXPECT_GT(s.feedback_force_max_n, 1.0);
  EXPECT_GT(s.axis_torque_max, 0.0);

  // Trace: one record per period, finite, feedback saturated record by record,
  // and the tool never far below the surface while the target is deep.
  const auto& records = runner.trace().records();
  ASSERT_EQ(records.size(), static_cast<std::size_t>(n));
  EXPECT_EQ(runner.trace().dropped(), 0u);
  double deepest_target = 0.0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const TraceRecord& r = records[i];
    ASSERT_TRUE(all_finite(r)) << "period " << i;
    ASSERT_LE(r.feedback.force.norm(), scene.model.feedback.max_force + 1e-9) << "period " << i;
    ASSERT_NEAR(r.time_s, static_cast<double>(i + 1) * scene.model.dt, 1e-9);
    ASSERT_EQ(r.held_body, scene.model.initial_held_body);
    ASSERT_EQ(r.num_axes, 5);
    deepest_target = std::max(deepest_target, r.target_penetration_mm);
  }
  EXPECT_DOUBLE_EQ(deepest_target, s.target_penetration_max_mm);
}

TEST(RunLatticeScene, StiffContactsOfOneTeraNewtonPerMetreStayFiniteAndOutside) {
  // Issue 17, defect 2: [contact_default] stiffness = 1e12 N/m. Without the contact time-constant
  // floor the tool was thrown away at 7–8 s (non-finite steps from then on, god-object
  // "penetration" of 7e8 mm, exit 0). With it, every contact acts with at most the stiffness the
  // 1 ms step resolves on its effective mass: on the jaws (the lightest: 1.66 g along a normal at
  // their tip) 5² · 1.66 g / (1 ms)² = 4.1e4 N/m, on the tube 2.6e5 N/m; both stiffer than the
  // shipped 2e4 N/m, under which the god-object stays within 2 mm of the surface
  // (GodObjectStaysOnTheSurfaceWhileTheHandGoesThrough), so it stays within 2 mm here too.
  NUMEN_REQUIRE_ARTICULATION();
  Scene scene = lattice_scene();
  for (numen::core::MaterialPair& p : scene.model.material_pairs) p.stiffness = 1e12;
  SceneRunner runner(scene);
  const std::int64_t n = periods_for(scene, 8.0);
  for (std::int64_t k = 0; k < n; ++k) runner.period();
  const RunSummary s = runner.summary();
  EXPECT_EQ(s.nonfinite_steps, 0);
  EXPECT_FALSE(s.nan_detected);
  EXPECT_GE(s.hand_penetration_max_mm, 7.0) << "the hand must go into the organ";
  EXPECT_LE(s.tool_penetration_max_mm, 2.0);
  EXPECT_GT(s.contact_clamped_steps, 0) << "the floor acted and was counted";
  EXPECT_NE(numen::sim::format_summary(s).find("stiff contacts: stiffness clamped"), std::string::npos);
  EXPECT_LT(s.joint_drift_max_mm, 0.05);
}

// Issue 22: an EMCY reaches the summary with its node, time, code and name — a drive's by the
// CiA 402 table — (text and --json: the figure emcy_messages), and the trace's row of the period
// it came in, with its node and code (columns emcys, emcy_node, emcy_code).
TEST(RunLatticeScene, AnInjectedDriveFaultIsReportedByItsEmcyName) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = lattice_scene();
  SceneRunner runner(scene, 500);
  for (int k = 0; k < 500; ++k) {
    if (k == 300) {
      ASSERT_TRUE(runner.instrument().emulator().inject_drive_fault(2, 0x4310));
    }
    runner.period();
  }
  const RunSummary s = runner.summary();
  EXPECT_GE(s.emcy_faults, 1);
  ASSERT_FALSE(s.emcy_messages.empty());
  const std::string& m = s.emcy_messages.front();
  EXPECT_EQ(m.rfind("node 3 at 0.30", 0), 0u) << m;  // depth's drive, node 3, at period 300
  EXPECT_NE(m.find("0x4310 "), std::string::npos) << m;
  EXPECT_NE(m.find("0x4310 drive temperature too high (register"), std::string::npos) << m;
  EXPECT_NE(numen::sim::format_summary(s).find("  EMCY: " + m), std::string::npos);
  EXPECT_NE(numen::sim::format_summary_json(s).find("emcy_messages"), std::string::npos);
  // The trace: the EMCY in exactly one row, within the bus latency after the injection.
  const std::vector<numen::sim::TraceRecord>& rows = runner.trace().records();
  ASSERT_EQ(rows.size(), 500u);
  int emcy_rows = 0;
  int emcys = 0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    emcys += rows[k].emcys;
    if (rows[k].emcys == 0) {
      EXPECT_EQ(rows[k].emcy_node, 0) << "period " << k;
      EXPECT_EQ(rows[k].emcy_code, 0) << "period " << k;
      continue;
    }
    ++emcy_rows;
    EXPECT_GE(k, 300u);
    EXPECT_LE(k, 302u);
    EXPECT_EQ(rows[k].emcy_node, 3);
    EXPECT_EQ(rows[k].emcy_code, 0x4310);
  }
  EXPECT_EQ(emcy_rows, 1);
  EXPECT_EQ(emcys, s.emcys);
}

TEST(RunLatticeScene, NoJumpAtStart) {
  NUMEN_REQUIRE_ARTICULATION();
  // The instrument starts at the device's first target (the hand's pose at t = 0). The first
  // valid sample comes at period 49, after the NMT start-up and the nodes' configuration from
  // their DCFs; the god-object held its starting pose until then while the recorded hand went
  // on. At that sample target and god-object differ by no more than the hand moved during the
  // start-up (plus the encoder quantisation): no jump of the god-object's own.
  const Scene& scene = lattice_scene();
  SceneRunner runner(scene);
  runner.period();
  const auto held0 = static_cast<std::size_t>(runner.data().held_body);
  const numen::core::Vec3 start = runner.data().bodies[held0].position;
  const numen::core::Quat start_q = runner.data().bodies[held0].orientation;
  EXPECT_FALSE(runner.device().last_sample().valid);
  for (int k = 1; k < 50; ++k) {
    runner.period();
    EXPECT_EQ(runner.device().last_sample().valid, k == 49) << "period " << k;
  }
  const auto& d = runner.data();
  ASSERT_TRUE(runner.device().last_sample().valid);
  const auto held = static_cast<std::size_t>(d.held_body);
  const double gap = (d.bodies[held].position - d.target.position).norm();
  const double tilt = d.bodies[held].orientation.angularDistance(d.target.orientation);
  const double hand = (d.target.position - start).norm();
  const double hand_tilt = d.target.orientation.angularDistance(start_q);
  std::printf("[   info   ] first valid period: |tool - target| = %.4f mm, %.4f mrad (hand moved %.4f mm, "
              "%.4f mrad since t = 0), feedback %.4f N\n", gap * 1e3, tilt * 1e3, hand * 1e3, hand_tilt * 1e3,
              d.feedback_wrench.force.norm());
  EXPECT_LT(gap, hand + 0.1e-3);
  EXPECT_LT(tilt, hand_tilt + 1e-3);
}

// The summary's feedback figures are what the drives were sent — after hal::ImpedanceDevice::write()'s
// gate and clamp — and what the simulated drives applied, not the core's composite wrench.
TEST(RunLatticeScene, SummaryFeedbackFiguresAreTheOnesTheDrivesReceive) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = lattice_scene();
  SceneRunner runner(scene);
  double sent_max = 0.0, received_max = 0.0, feedback_max = 0.0, core_gated_max = 0.0;
  std::array<std::int16_t, numen::hal::kMaxAxes> sent_before{};
  const auto n = static_cast<int>(scene.device.axes.size());
  for (std::int64_t k = 0; k < periods_for(scene, 3.0); ++k) {
    runner.period();
    // The RPDOs' per mille are the impedance device's wire encoding, not on the face.
    const numen::hal::SentTorques& sent = runner.loop().impedance().sent_torques();
    const numen::platform::PeriodReport& r = runner.last_report();
    // The simulated drives applied, at this period's SYNC, the RPDOs of the period before.
    for (int a = 0; a < n; ++a) {
      const auto i = static_cast<std::size_t>(a);
      ASSERT_EQ(runner.instrument().last_torques()[a],
                numen::hal::per_mille_to_torque(scene.device.axes[i], sent_before[i]))
          << "period " << k << " axis " << a;
      received_max = std::max(received_max, std::abs(runner.instrument().last_torques()[a]));
    }
    sent_before = sent.per_mille;
    sent_max = std::max(sent_max, sent.torque.cwiseAbs().maxCoeff());
    feedback_max = std::max(feedback_max, r.feedback.force.norm());
    if (!r.torque_commanded)
      core_gated_max = std::max(core_gated_max, runner.data().feedback_wrench.force.norm());
  }
  const numen::sim::RunSummary s = runner.summary();
  EXPECT_EQ(s.axis_torque_max, sent_max);
  EXPECT_EQ(s.feedback_force_max_n, feedback_max);
  EXPECT_GT(sent_max, 0.0);
  double rated_max = 0.0;
  for (const numen::hal::AxisConfig& a : scene.device.axes) rated_max = std::max(rated_max, a.rated_torque);
  EXPECT_NEAR(received_max, sent_max, 0.5e-3 * rated_max + 1e-12);  // the RPDO's per mille
  std::printf("[   info   ] sent |tau| max %.4f, received %.4f; feedback %.3f N; core's while gated %.3f N\n",
              sent_max, received_max, feedback_max, core_gated_max);
}

TEST(RunLatticeScene, RealtimeRunIsPacedToTheClock) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::sim::RunOptions opt;
  opt.duration_s = 0.1;
  opt.realtime = true;
  const RunSummary s = numen::sim::run_scene(lattice_scene(), opt);
  EXPECT_EQ(s.steps, 100);
  // 100 periods of 1 ms paced by clock_nanosleep take at least ~0.1 s.
  EXPECT_GE(s.wall_time_s, 0.09);
  std::printf("[   info   ] realtime 0.1 s: wall %.3f s, overruns %lld\n", s.wall_time_s,
              static_cast<long long>(s.realtime_overruns));
}

TEST(RunLatticeScene, RunSceneRunsTheRequestedDuration) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::sim::RunOptions opt;
  opt.duration_s = 0.5;
  const RunSummary s = numen::sim::run_scene(lattice_scene(), opt);
  EXPECT_EQ(s.steps, 500);
  EXPECT_NEAR(s.sim_time_s, 0.5, 1e-12);
  EXPECT_GT(s.wall_time_s, 0.0);
  EXPECT_EQ(s.realtime_overruns, 0);
  EXPECT_FALSE(s.nan_detected);
  // JSON summary: one object that parses, with the summary's values.
  const std::string json = numen::sim::format_summary_json(s);
  ASSERT_TRUE(nlohmann::json::accept(json)) << json;
  const nlohmann::json j = nlohmann::json::parse(json);
  EXPECT_EQ(j.at("steps"), 500);
  EXPECT_EQ(j.at("dt_s"), s.dt_s);  // round-trips exactly
  EXPECT_EQ(j.at("scene"), s.scene);
  EXPECT_EQ(j.at("nan_detected"), false);
  EXPECT_EQ(j.at("loop").at("step_ns").at("count"), s.loop.step.count);
  EXPECT_EQ(j.at("step_time_us").at("median"), s.step_time_us.median);
  EXPECT_EQ(json.substr(0, 10), "{\"scene\":\"") << "keys keep their order";
  EXPECT_NE(numen::sim::format_summary(s).find("500 steps"), std::string::npos);
}

// ---------------------------------------------------------------- construction scene

TEST(RunConstructionScene, DirectCouplingPenetratesTenTimesMoreThanTheGodObject) {
  const Scene& god_scene = construction_scene();
  const Scene direct_scene = numen::sim::load_scene(construction_path(), numen::sim::SceneOverrides{CouplingMode::kDirect});
  ASSERT_EQ(direct_scene.model.coupling_mode, CouplingMode::kDirect);
  const std::int64_t n = periods_for(god_scene, god_scene.duration_s);

  SceneRunner god(god_scene, static_cast<std::size_t>(n));
  SceneRunner direct(direct_scene);
  const auto t0 = std::chrono::steady_clock::now();
  for (std::int64_t k = 0; k < n; ++k) {
    god.period();
    direct.period();
  }
  const double wall = wall_s(t0);
  const RunSummary g = god.summary();
  const RunSummary d = direct.summary();
  print_summary("construction god-object", g, wall / 2);
  print_summary("construction direct", d, wall / 2);
  std::printf("[   info   ] construction: fastest free block %.3f m/s (god-object) vs %.3f m/s (direct)\n",
              g.free_body_speed_max_mps, d.free_body_speed_max_mps);

  EXPECT_EQ(g.coupling, "god-object");
  EXPECT_EQ(d.coupling, "direct");
  // The same hand: the target goes ~20 mm into the board in both runs.
  EXPECT_GE(g.target_penetration_max_mm, 10.0);
  EXPECT_GE(d.target_penetration_max_mm, 10.0);
  // Imposed at the hand, the block goes into the board; the god-object does not.
  EXPECT_GE(d.tool_penetration_max_mm, 10.0);
  EXPECT_GT(g.tool_penetration_max_mm, 0.0) << "the held block never touched anything";
  EXPECT_GE(d.tool_penetration_max_mm, 10.0 * g.tool_penetration_max_mm);
  EXPECT_FALSE(g.nan_detected);
  EXPECT_FALSE(d.nan_detected);
  EXPECT_EQ(g.rejected_samples, 0);
  EXPECT_EQ(d.rejected_samples, 0);
  // Direct coupling sends no feedback (paper Fig. 5: no god-object).
  EXPECT_EQ(d.feedback_force_max_n, 0.0);

  // Paper Fig. 5/6: the held block carried through tower A pushes its middle
  // block away with the god-object too, but only the imposed (direct) block
  // throws blocks about with penalty forces. The block dropped at 5.7 s falls
  // from 0.16 m (√(2 g h) ≈ 1.7 m/s) in both runs.
  int tower_a2 = -1;
  for (int b = 0; b < god_scene.model.num_bodies(); ++b)
    if (god_scene.model.bodies[static_cast<std::size_t>(b)].name == "tower_a2") tower_a2 = b;
  ASSERT_GE(tower_a2, 0);
  const Vec3 a2_0 = god_scene.model.bodies[static_cast<std::size_t>(tower_a2)].initial_pose.position;
  const double pushed_god = (god.data().bodies[static_cast<std::size_t>(tower_a2)].position - a2_0).norm();
  const double pushed_direct = (direct.data().bodies[static_cast<std::size_t>(tower_a2)].position - a2_0).norm();
  std::printf("[   info   ] construction: tower_a2 moved %.1f mm (god-object), %.1f mm (direct)\n",
              pushed_god * 1e3, pushed_direct * 1e3);
  EXPECT_GT(pushed_god, 0.01) << "the god-object did not push the tower";
  EXPECT_GT(d.free_body_speed_max_mps, 2.0 * g.free_body_speed_max_mps) << "direct coupling threw nothing about";

  // Tool switching: held until 5.7 s, nothing until 7.2 s, then loose_1.
  const auto& rec = god.trace().records();
  ASSERT_EQ(rec.size(), static_cast<std::size_t>(n));
  int loose_1 = -1;
  for (int b = 0; b < god_scene.model.num_bodies(); ++b)
    if (god_scene.model.bodies[static_cast<std::size_t>(b)].name == "loose_1") loose_1 = b;
  ASSERT_GE(loose_1, 0);
  for (std::size_t i = 0; i < rec.size(); ++i) {
    const double t_start = static_cast<double>(i) * god_scene.model.dt;  // period i starts at i·dt
    const int expected = t_start < 5.7 - 1e-9 ? god_scene.model.initial_held_body
                         : t_start < 7.2 - 1e-9 ? -1
                                                : loose_1;
    ASSERT_EQ(rec[i].held_body, expected) << "period " << i << " (t = " << t_start << " s)";
  }
  EXPECT_EQ(god.data().held_body, loose_1);
}

// Issue 17, defect 4: direct coupling on the default scene reported "nan detected: YES" for its
// first two periods (before the first sample the trocar sleeve had no target and was
// over-constrained between the world and the imposed tube); the bound bodies now hold their
// starting poses until the device has a target.
TEST(RunLatticeScene, DirectCouplingHasNoNonFiniteStepBeforeTheFirstSample) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene scene = numen::sim::load_scene(numen::test::lattice_scene_path(),
                                             numen::sim::SceneOverrides{CouplingMode::kDirect});
  SceneRunner runner(scene);
  for (int k = 0; k < 50; ++k) runner.period();
  const RunSummary s = runner.summary();
  EXPECT_GT(s.invalid_periods, 0);  // the premise: periods before the first sample
  EXPECT_EQ(s.nonfinite_steps, 0);
  EXPECT_FALSE(s.nan_detected);
}

// ---------------------------------------------------------------- the mouse scene (paper's mouse device)

/// Target position (m) at time t (s) in the trace of a run of the mouse scene.
Vec3 target_at(const std::vector<TraceRecord>& records, double dt, double t) {
  return records[static_cast<std::size_t>(std::llround(t / dt))].target.position;
}

// The shipped recording (sim/scenes/mouse.toml's phases): the tool moves only while the left
// button is held, stays while the mouse is moved back with the button up (indexing), follows
// the mouse closely in free motion, and pushes the loose block along the board.
TEST(RunMouseScene, TheToolFollowsTheMouseOnlyWhileTheClutchIsHeld) {
  NUMEN_REQUIRE_EVDEV();  // the scene names its event codes
  const Scene& scene = mouse_scene();
  const std::int64_t n = periods_for(scene, scene.duration_s);
  SceneRunner runner(scene, n);
  for (std::int64_t k = 0; k < n; ++k) runner.period();
  const RunSummary s = runner.summary();
  const auto& rec = runner.trace().records();
  const double dt = scene.model.dt;
  const Vec3 start(-0.08, 0.0, 0.03);
  // 0–0.3 s: the mouse moves, button up: the target stays at the start.
  // (The trace's target is the device's measured pose: encoders of 1 µm.)
  EXPECT_LT((target_at(rec, dt, 0.29) - start).norm(), 2e-6);
  // 0.3–1.3 s: held: +x 49.6 mm (124 reports of 4 counts), wheel down 5 detents: -10 mm.
  const Vec3 held = target_at(rec, dt, 1.32);
  EXPECT_NEAR(held.x(), -0.08 + 0.0496, 2e-6);
  EXPECT_NEAR(held.z(), 0.02, 2e-6);
  // 1.3–1.8 s: button up, the mouse goes back -x: the target does not move.
  EXPECT_LT((target_at(rec, dt, 1.79) - held).norm(), 2e-6);
  // 1.8–3.0 s: held again: +x 60 mm.
  EXPECT_NEAR(target_at(rec, dt, 3.05).x() - held.x(), 0.06, 0.002);
  // Free motion (before the block): the held block follows the target within 3 mm.
  for (const double t : {0.8, 1.2, 1.6}) {
    const auto& r = rec[static_cast<std::size_t>(std::llround(t / dt))];
    EXPECT_LT((r.tool.position - r.target.position).norm(), 0.003) << t << " s";
  }
  // The loose block (body 1) was pushed along +x, and stayed on the board.
  const Vec3 loose = runner.data().bodies[1].position;
  EXPECT_GT(loose.x(), 0.02) << "the held block pushed the loose one";
  EXPECT_NEAR(loose.z(), 0.02, 0.003);
  EXPECT_GT(s.contacts_max, 0);
  EXPECT_FALSE(s.nan_detected);
  EXPECT_EQ(s.rejected_samples, 0);
}

// ---------------------------------------------------------------- articulated scenes

TEST(RunArticulated, DefaultInstrumentStaysOutsideWhileTheJointsHold) {
  NUMEN_REQUIRE_ARTICULATION();
  // Paper Fig. 7: the articulated tool (sleeve, tube, jaws) stays on the
  // organ and tissue while the recorded tip goes through; the joints hold.
  SceneRunner runner(lattice_scene());
  for (int k = 0; k < 15'000; ++k) runner.period();
  const RunSummary s = runner.summary();
  EXPECT_EQ(s.num_joints, 4);
  EXPECT_GE(s.hand_penetration_max_mm, 10.0);
  EXPECT_LE(s.tool_penetration_max_mm, 3.0);
  EXPECT_LT(s.joint_drift_max_mm, 0.01);
  EXPECT_LT(s.joint_angle_drift_max_mrad, 1.0);
  EXPECT_FALSE(s.nan_detected);
  // The sleeve stays on the trocar point: the spherical joint to the world.
  const auto& d = runner.data();
  EXPECT_LT((d.bodies[0].position - lattice_scene().device.trocar.point).norm(), 1e-5);
  // The jaws follow the jaw encoder: each hinge at ±jaw/2 within a few mrad.
  const double jaw = runner.device().last_sample().q(4);
  EXPECT_NEAR(d.joints[2].coordinate, 0.5 * jaw, 5e-3);
  EXPECT_NEAR(d.joints[3].coordinate, -0.5 * jaw, 5e-3);
}

TEST(RunArticulated, PhantomArmStopsOnTheDeskAndItsMotorsGetJointTorques) {
  NUMEN_REQUIRE_ARTICULATION();
  SceneRunner runner(phantom_scene(), 6000);
  for (int k = 0; k < 6000; ++k) runner.period();
  const RunSummary s = runner.summary();
  EXPECT_GE(s.hand_penetration_max_mm, 10.0) << "the hand goes through the desk";
  EXPECT_LE(s.tool_penetration_max_mm, 3.0) << "the arm stays on it";
  EXPECT_LT(s.joint_drift_max_mm, 0.05);
  EXPECT_FALSE(s.nan_detected);
  // Torques reach the three motors (turret, shoulder, elbow) only.
  double arm = 0.0, gimbal = 0.0;
  for (const TraceRecord& r : runner.trace().records()) {
    ASSERT_EQ(r.num_axes, 6);
    for (int a = 0; a < 3; ++a) arm = std::max(arm, std::abs(r.axis_torque[static_cast<std::size_t>(a)]));
    for (int a = 3; a < 6; ++a) gimbal = std::max(gimbal, std::abs(r.axis_torque[static_cast<std::size_t>(a)]));
  }
  EXPECT_GT(arm, 0.1);
  EXPECT_EQ(gimbal, 0.0);
}

}  // namespace

// ---------------------------------------------------------------- several devices

TEST(RunDevices, EachDeviceDrivesItsBodyOnTheSharedBusAndIsSummarized) {
  // kTwoDeviceScene: "left" holds left_tool on a line to (0.01, 0, 0), "right" drives right_tool
  // through its link on a line from (0, 0.05, 0) to (0, 0.06, 0), both on the one simulated
  // bus (nodes 1–6 and 7–12, managed stack). Each body ends near its own device's path's end.
  numen::test::TempDir dir;
  const Scene scene = numen::sim::load_scene(dir.write("two.toml", numen::test::kTwoDeviceScene));
  SceneRunner runner(scene, 1000);
  for (int k = 0; k < 750; ++k) runner.period();
  runner.finish();
  EXPECT_EQ(runner.loop().num_devices(), 2u);
  const numen::core::Data& d = runner.data();
  EXPECT_NEAR((d.bodies[0].position - Vec3(0.01, 0.0, 0.0)).norm(), 0.0, 2e-3);
  EXPECT_NEAR((d.bodies[1].position - Vec3(0.0, 0.06, 0.0)).norm(), 0.0, 2e-3);
  const RunSummary s = runner.summary();
  ASSERT_EQ(s.devices.size(), 2u);
  EXPECT_EQ(s.devices[0].name, "left");
  EXPECT_EQ(s.devices[1].name, "right");
  for (const numen::sim::DeviceRunSummary& dev : s.devices) {
    EXPECT_LT(dev.invalid_periods, 100) << dev.name << ": its samples reached the loop";
    EXPECT_EQ(dev.rejected_samples, 0) << dev.name;
    EXPECT_EQ(dev.faults, 0) << dev.name;
    EXPECT_EQ(dev.lifecycle, "active") << dev.name;
  }
  EXPECT_EQ(s.devices[0].invalid_periods, s.invalid_periods);  // device 0's are the summary's
  // The JSON's devices array and the text's line per device.
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  ASSERT_EQ(j.at("devices").size(), 2u);
  EXPECT_EQ(j.at("devices")[1].at("name"), "right");
  EXPECT_EQ(j.at("devices")[1].at("invalid_periods").get<std::int64_t>(), s.devices[1].invalid_periods);
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("  device left: feedback force max"), std::string::npos) << text;
  EXPECT_NE(text.find("  device right: feedback force max"), std::string::npos) << text;
  // One device's scene has no devices array (its summary keys are unchanged).
  const Scene one = numen::sim::load_scene(dir.write("mini.toml", numen::test::kMiniScene));
  SceneRunner single(one, 10);
  for (int k = 0; k < 10; ++k) single.period();
  single.finish();
  const nlohmann::json j1 = nlohmann::json::parse(numen::sim::format_summary_json(single.summary()));
  EXPECT_FALSE(j1.contains("devices"));
  EXPECT_FALSE(j1.contains("device_lines"));
}

// Issue 66: a device after the first that only prescribes a joint (no body's link) was given
// the rigid binding by the control loop — the held body, the first device's — and the run
// failed with "devices 0 and 1 both drive the held body". Its binding drives its joint only.
TEST(RunDevices, ADeviceThatOnlyPrescribesAJointRuns) {
  NUMEN_REQUIRE_ARTICULATION();  // a prescribed joint
  numen::test::TempDir dir;
  const std::string text =
      numen::test::replace(numen::test::kTwoDeviceScene, "link = \"tool\"\ndevice = \"right\"\n",
                           "") +
      R"(
[[joint]]
name = "slide"
type = "prismatic"
parent = "world"
parent_frame = { position = [0.0, 0.05, 0.0] }
child = "right_tool"
prescribed = { axis = "y", scale = 1.0, offset = -0.05, device = "right" }
)";
  const Scene scene = numen::sim::load_scene(dir.write("slide.toml", text));
  ASSERT_TRUE(scene.extra_devices.at(0).binding.links.empty());
  ASSERT_EQ(scene.extra_devices.at(0).binding.prescriptions.size(), 1u);
  SceneRunner runner(scene, 100);
  for (int k = 0; k < 100; ++k) runner.period();
  runner.finish();
  EXPECT_EQ(runner.loop().num_devices(), 2u);
  EXPECT_TRUE(std::isfinite(runner.data().bodies[1].position.y()));
}

TEST(RunDevices, ASceneOfSeveralDevicesRunsOnTheSimulatedBusOnly) {
  numen::test::TempDir dir;
  const Scene scene = numen::sim::load_scene(dir.write("two.toml", numen::test::kTwoDeviceScene));
  numen::sim::BusChoice log;
  log.spec = "log:" + dir.write("empty.log", "");
  try {
    SceneRunner runner(scene, 0, log);
    FAIL() << "a log bus was accepted for two devices";
  } catch (const numen::sim::InputError& e) {
    EXPECT_EQ(e.key(), "--bus");
    EXPECT_NE(e.message().find("has 2 devices"), std::string::npos) << e.what();
  }
}
