// Tests of sim/run: the shipped scenes run end to end through the simulated
// bus, the instrument, the controller's checks and core::step (SceneRunner),
// with the god-object staying on the surface while the hand goes through it
// (rigid, articulated and deformable tools: the nets deform on contact);
// period() never allocates; runs are bit-for-bit deterministic; corrupted and
// lost bus frames are rejected without harm.
#include "numen/sim/run.hpp"

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
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/jigsaws.hpp"
#include "numen/sim/run_verdict.hpp"
#include "numen/sim/scene.hpp"
#include "numen/sim/simulated_instrument.hpp"
#include "build_features.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "sanitizer.hpp"

namespace {

/// Why the whole-scene runs of the deformable scenes skip under a sanitizer (CI time, issue 17):
/// thousands of periods of a 162–642-node net take 1–3 min each under ASan; the net's code
/// paths run under the sanitizers in StepDeformable.* (10 000 steps each), and these tests run
/// in the default build.
constexpr const char* kDeformableRunTooSlow =
    "thousands of deformable-scene periods take minutes here; StepDeformable.* covers the net "
    "code under the sanitizer";

using numen::core::CouplingMode;
using numen::core::Vec3;
using numen::sim::RunSummary;
using numen::sim::Scene;
using numen::sim::SceneRunner;
using numen::sim::TraceRecord;

std::string construction_path() { return std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/construction.toml"; }

/// The shipped scenes, loaded once for the whole suite.
const Scene& default_scene() {
  static const Scene s = numen::sim::load_scene(numen::sim::default_scene_path());
  return s;
}
const Scene& construction_scene() {
  static const Scene s = numen::sim::load_scene(construction_path());
  return s;
}

std::int64_t periods_for(const Scene& s, double seconds) {
  return static_cast<std::int64_t>(std::llround(seconds / s.model.dt));
}

double wall_s(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }
bool same_bits(const Vec3& a, const Vec3& b) { return std::memcmp(a.data(), b.data(), sizeof(double) * 3) == 0; }
bool same_bits(const numen::core::Quat& a, const numen::core::Quat& b) {
  return std::memcmp(a.coeffs().data(), b.coeffs().data(), sizeof(double) * 4) == 0;
}

/// Every field of two trace records, bit for bit, except the wall-clock step time.
bool same_record(const TraceRecord& a, const TraceRecord& b) {
  bool same = same_bits(a.time_s, b.time_s) && a.attached_body == b.attached_body &&
              a.sample_valid == b.sample_valid && same_bits(a.target.position, b.target.position) &&
              same_bits(a.target.orientation, b.target.orientation) &&
              same_bits(a.tool.position, b.tool.position) &&
              same_bits(a.tool.orientation, b.tool.orientation) && a.contacts == b.contacts &&
              a.tool_contacts == b.tool_contacts &&
              same_bits(a.tool_penetration_mm, b.tool_penetration_mm) &&
              same_bits(a.target_penetration_mm, b.target_penetration_mm) &&
              same_bits(a.feedback.force, b.feedback.force) &&
              same_bits(a.feedback.torque, b.feedback.torque) && a.num_axes == b.num_axes &&
              a.solver_iterations == b.solver_iterations &&
              same_bits(a.solver_residual, b.solver_residual) &&
              a.node_contacts == b.node_contacts &&
              same_bits(a.net_penetration_mm, b.net_penetration_mm) &&
              same_bits(a.net_tie_stretch_mm, b.net_tie_stretch_mm) &&
              same_bits(a.net_strain_max, b.net_strain_max);
  for (std::size_t i = 0; i < a.axis_torque.size(); ++i) same = same && same_bits(a.axis_torque[i], b.axis_torque[i]);
  return same;
}

bool all_finite(const TraceRecord& r) {
  return r.target.position.allFinite() && r.target.orientation.coeffs().allFinite() &&
         r.tool.position.allFinite() && r.tool.orientation.coeffs().allFinite() &&
         r.feedback.force.allFinite() && r.feedback.torque.allFinite() &&
         std::isfinite(r.tool_penetration_mm) && std::isfinite(r.target_penetration_mm);
}

void print_summary(const char* what, const RunSummary& s, double wall) {
  std::printf(
      "[   info   ] %s: %lld steps in %.2f s wall; target pen %.2f mm, tool pen %.3f mm, "
      "free rms %.3f mm (max %.3f, %lld steps), feedback max %.2f N, rejected %lld, invalid %lld, "
      "corrupted %lld, dropped %lld, step median %.1f us\n",
      what, static_cast<long long>(s.steps), wall, s.target_penetration_max_mm, s.tool_penetration_max_mm,
      s.tracking_error_free_rms_mm, s.tracking_error_free_max_mm, static_cast<long long>(s.free_steps),
      s.feedback_force_max_n, static_cast<long long>(s.rejected_samples), static_cast<long long>(s.invalid_periods),
      static_cast<long long>(s.bus_frames_corrupted), static_cast<long long>(s.bus_frames_dropped),
      s.step_time_us.median);
}

// ---------------------------------------------------------------- default scene end to end

TEST(RunDefaultScene, GodObjectStaysOnTheSurfaceWhileTheHandGoesThrough) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = default_scene();
  const std::int64_t n = periods_for(scene, 15.0);
  SceneRunner runner(scene, static_cast<std::size_t>(n));
  const auto t0 = std::chrono::steady_clock::now();
  for (std::int64_t k = 0; k < n; ++k) runner.period();
  const double wall = wall_s(t0);
  const RunSummary s = runner.summary();
  print_summary("default 15 s", s, wall);

  EXPECT_EQ(runner.periods(), n);
  EXPECT_EQ(s.steps, n);
  EXPECT_NEAR(s.sim_time_s, 15.0, 1e-9);
  EXPECT_EQ(runner.data().step_count, n);
  EXPECT_EQ(s.scene, "default");
  EXPECT_EQ(s.coupling, "god-object");

  // The hand (the instrument placed at the device target) goes deep into the
  // organ and the tissue; the god-object stays on the surface.
  EXPECT_GE(s.target_penetration_max_mm, 10.0);
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
    ASSERT_EQ(r.attached_body, scene.model.initial_attached_body);
    ASSERT_EQ(r.num_axes, 5);
    deepest_target = std::max(deepest_target, r.target_penetration_mm);
  }
  EXPECT_DOUBLE_EQ(deepest_target, s.target_penetration_max_mm);
}

TEST(RunDefaultScene, StiffContactsOfOneTeraNewtonPerMetreStayFiniteAndOutside) {
  // Issue 17, defect 2: [contact_default] stiffness = 1e12 N/m. Without the contact time-constant
  // floor the tool was thrown away at 7–8 s (non-finite steps from then on, god-object
  // "penetration" of 7e8 mm, exit 0). With it, every contact acts with at most the stiffness the
  // 1 ms step resolves on its effective mass: on the jaws (the lightest: 1.66 g along a normal at
  // their tip) 5² · 1.66 g / (1 ms)² = 4.1e4 N/m, on the tube 2.6e5 N/m; both stiffer than the
  // shipped 2e4 N/m, under which the god-object stays within 2 mm of the surface
  // (GodObjectStaysOnTheSurfaceWhileTheHandGoesThrough), so it stays within 2 mm here too.
  NUMEN_REQUIRE_ARTICULATION();
  Scene scene = default_scene();
  for (numen::core::MaterialPair& p : scene.model.material_pairs) p.stiffness = 1e12;
  SceneRunner runner(scene);
  const std::int64_t n = periods_for(scene, 8.0);
  for (std::int64_t k = 0; k < n; ++k) runner.period();
  const RunSummary s = runner.summary();
  EXPECT_EQ(s.nonfinite_steps, 0);
  EXPECT_FALSE(s.nan_detected);
  EXPECT_GE(s.target_penetration_max_mm, 7.0) << "the hand must go into the organ";
  EXPECT_LE(s.tool_penetration_max_mm, 2.0);
  EXPECT_GT(s.contact_clamped_steps, 0) << "the floor acted and was counted";
  EXPECT_NE(numen::sim::format_summary(s).find("stiff contacts: stiffness clamped"), std::string::npos);
  EXPECT_LT(s.joint_drift_max_mm, 0.05);
}

// Issue 22: an EMCY reaches the summary with its node, time, code and name — a drive's by the
// CiA 402 table — (text and --json: the figure emcy_messages), and the trace's row of the period
// it came in, with its node and code (columns emcys, emcy_node, emcy_code).
TEST(RunDefaultScene, AnInjectedDriveFaultIsReportedByItsEmcyName) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = default_scene();
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

TEST(RunDefaultScene, NoJumpAtStart) {
  NUMEN_REQUIRE_ARTICULATION();
  // The instrument starts at the device's first target (the hand's pose at t = 0). The first
  // valid sample comes at period 49, after the NMT start-up and the nodes' configuration from
  // their DCFs; the god-object held its starting pose until then while the recorded hand went
  // on. At that sample target and god-object differ by no more than the hand moved during the
  // start-up (plus the encoder quantisation): no jump of the god-object's own.
  const Scene& scene = default_scene();
  SceneRunner runner(scene);
  runner.period();
  const auto held0 = static_cast<std::size_t>(runner.data().attached_body);
  const numen::core::Vec3 start = runner.data().bodies[held0].position;
  const numen::core::Quat start_q = runner.data().bodies[held0].orientation;
  EXPECT_FALSE(runner.device().last_sample().valid);
  for (int k = 1; k < 50; ++k) {
    runner.period();
    EXPECT_EQ(runner.device().last_sample().valid, k == 49) << "period " << k;
  }
  const auto& d = runner.data();
  ASSERT_TRUE(runner.device().last_sample().valid);
  const auto held = static_cast<std::size_t>(d.attached_body);
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
TEST(RunDefaultScene, SummaryFeedbackFiguresAreTheOnesTheDrivesReceive) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = default_scene();
  SceneRunner runner(scene);
  double sent_max = 0.0, received_max = 0.0, feedback_max = 0.0, core_gated_max = 0.0;
  std::array<std::int16_t, numen::hal::kMaxAxes> sent_before{};
  const auto n = static_cast<int>(scene.device.axes.size());
  for (std::int64_t k = 0; k < periods_for(scene, 3.0); ++k) {
    runner.period();
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

TEST(RunDefaultScene, RealtimeRunIsPacedToTheClock) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::sim::RunOptions opt;
  opt.duration_s = 0.1;
  opt.realtime = true;
  const RunSummary s = numen::sim::run_scene(default_scene(), opt);
  EXPECT_EQ(s.steps, 100);
  // 100 periods of 1 ms paced by clock_nanosleep take at least ~0.1 s.
  EXPECT_GE(s.wall_time_s, 0.09);
  std::printf("[   info   ] realtime 0.1 s: wall %.3f s, overruns %lld\n", s.wall_time_s,
              static_cast<long long>(s.realtime_overruns));
}

TEST(RunDefaultScene, RunSceneRunsTheRequestedDuration) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::sim::RunOptions opt;
  opt.duration_s = 0.5;
  const RunSummary s = numen::sim::run_scene(default_scene(), opt);
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
    const int expected = t_start < 5.7 - 1e-9 ? god_scene.model.initial_attached_body
                         : t_start < 7.2 - 1e-9 ? -1
                                                : loose_1;
    ASSERT_EQ(rec[i].attached_body, expected) << "period " << i << " (t = " << t_start << " s)";
  }
  EXPECT_EQ(god.data().attached_body, loose_1);
}

// ---------------------------------------------------------------- zero allocations

/// A state-stream consumer that only counts (stands in for a connected viewer).
class CountingViewSink final : public numen::platform::StateFrameSink {
 public:
  bool write_frame(std::span<const std::byte> frame) noexcept override {
    frames.fetch_add(1);
    bytes.fetch_add(frame.size());
    return true;
  }
  std::atomic<std::int64_t> frames{0}, bytes{0};
};

void expect_no_allocation(const Scene& scene, const char* name) {
  SceneRunner runner(scene, 10'000);  // construction allocates (trace storage too)
  // A viewer is connected: the state stream publishes every period (1 kHz, its worst case).
  CountingViewSink viewer;
  runner.stream_view("", {&viewer}, 1.0 / scene.model.dt, false);
  std::int64_t count = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 10'000; ++k) runner.period();
    count = guard.count();
  }
  EXPECT_EQ(count, 0) << name << ": heap allocations in 10,000 periods";
  EXPECT_EQ(runner.periods(), 10'000);
  EXPECT_EQ(runner.trace().records().size(), 10'000u);
  runner.finish();
  const RunSummary s = runner.summary();
  EXPECT_EQ(s.view_frames_published + s.view_frames_dropped, 10'000) << name;
  EXPECT_EQ(viewer.frames.load(), s.view_frames_published) << name;
  EXPECT_GT(s.contacts_max + s.node_contacts_max, 0)
      << name << ": the contact path was not exercised";
  if (scene.model.num_nets() > 0) {
    EXPECT_GT(s.node_contacts_max, 0) << name << ": the nets never touched anything";
  }
  EXPECT_FALSE(s.nan_detected);
}

// Issue 17, defect 4: direct coupling on the default scene reported "nan detected: YES" for its
// first two periods (before the first sample the trocar sleeve had no target and was
// over-constrained between the world and the imposed tube); the bound bodies now hold their
// starting poses until the device has a target.
TEST(RunDefaultScene, DirectCouplingHasNoNonFiniteStepBeforeTheFirstSample) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene scene = numen::sim::load_scene(numen::sim::default_scene_path(),
                                             numen::sim::SceneOverrides{CouplingMode::kDirect});
  SceneRunner runner(scene);
  for (int k = 0; k < 50; ++k) runner.period();
  const RunSummary s = runner.summary();
  EXPECT_GT(s.invalid_periods, 0);  // the premise: periods before the first sample
  EXPECT_EQ(s.nonfinite_steps, 0);
  EXPECT_FALSE(s.nan_detected);
}

TEST(RunAllocations, DefaultScenePeriodNeverAllocates) {
  NUMEN_REQUIRE_ARTICULATION();
  expect_no_allocation(default_scene(), "default");
}

TEST(RunAllocations, ConstructionScenePeriodNeverAllocates) {
  expect_no_allocation(construction_scene(), "construction");
}

const Scene& phantom_scene() {
  static const Scene s = numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/phantom.toml");
  return s;
}

TEST(RunAllocations, PhantomScenePeriodNeverAllocates) {
  NUMEN_REQUIRE_ARTICULATION();
  expect_no_allocation(phantom_scene(), "phantom");  // 6 s scene: the trajectory holds its end
}

const Scene& deformable_scene() {
  static const Scene s =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/deformable.toml");
  return s;
}
const Scene& endobag_scene() {
  static const Scene s =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/endobag.toml");
  return s;
}

TEST(RunAllocations, DeformableScenePeriodNeverAllocates) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  expect_no_allocation(deformable_scene(), "deformable");  // the post contact is at 2.7–3.2 s
}

TEST(RunAllocations, EndobagScenePeriodNeverAllocates) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  expect_no_allocation(endobag_scene(), "endobag");
}

const Scene& mouse_scene() {
  static const Scene s = numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/mouse.toml");
  return s;
}

TEST(RunAllocations, MouseScenePeriodNeverAllocates) {
  NUMEN_REQUIRE_EVDEV();  // the scene names its event codes
  expect_no_allocation(mouse_scene(), "mouse");  // 5 s scene: the trajectory holds its end
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

// ---------------------------------------------------------------- deformable scenes (paper §4.2)

/// Runs `scene` for `seconds` with a full trace; prints the summary.
RunSummary run_traced(SceneRunner& runner, const Scene& scene, double seconds, const char* name) {
  const std::int64_t n = periods_for(scene, seconds);
  const auto t0 = std::chrono::steady_clock::now();
  for (std::int64_t k = 0; k < n; ++k) runner.period();
  const double wall = wall_s(t0);
  const RunSummary s = runner.summary();
  print_summary(name, s, wall);
  std::printf(
      "[   info   ] %s: %d nodes, node contacts max %d, net penetration max %.3f mm, tie stretch "
      "max %.3f mm, "
      "strain max %.3f, node speed max %.3f m/s; solver iterations mean %.2f max %d, residual max "
      "%.2e, "
      "not converged %lld\n",
      name, s.num_nodes, s.node_contacts_max, s.net_penetration_max_mm, s.net_tie_stretch_max_mm,
      s.net_strain_max, s.net_node_speed_max_mps, s.solver_iterations_mean, s.solver_iterations_max,
      s.solver_residual_max, static_cast<long long>(s.solver_not_converged_steps));
  EXPECT_EQ(s.steps, n);
  EXPECT_FALSE(s.nan_detected) << name;
  EXPECT_EQ(s.nonfinite_steps, 0) << name;
  EXPECT_EQ(s.contact_overflow, 0) << name;
  EXPECT_EQ(s.rejected_samples, 0) << name;
  // The coupled implicit solve converges to the scene's tolerance every step.
  EXPECT_EQ(s.solver_not_converged_steps, 0) << name;
  EXPECT_LE(s.solver_residual_max, scene.model.solver.tolerance) << name;
  EXPECT_GT(s.solver_iterations_mean, 0.0) << name;
  EXPECT_LE(s.solver_iterations_mean, s.solver_iterations_max) << name;
  EXPECT_LE(s.solver_iterations_max, scene.model.solver.max_iterations) << name;
  const auto& records = runner.trace().records();
  EXPECT_EQ(records.size(), static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < records.size(); ++i) {
    const TraceRecord& r = records[i];
    EXPECT_TRUE(all_finite(r) && std::isfinite(r.net_strain_max) &&
                std::isfinite(r.net_tie_stretch_mm))
        << name << ": period " << i;
    if (!all_finite(r)) break;
  }
  for (const auto& node : runner.data().nodes)
    EXPECT_TRUE(node.position.allFinite() && node.velocity.allFinite());
  return s;
}

TEST(RunDeformable, ProbeDeformsThenSlidesAroundThePost) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  // Paper Fig. 8: the hand sweeps the probe through the post (2.7–3.2 s);
  // the net deforms on contact, the god-object is held outside and then
  // slides around the post, the hand going straight through it.
  const Scene& scene = deformable_scene();
  SceneRunner runner(scene, static_cast<std::size_t>(periods_for(scene, 10.0)));
  const RunSummary s = run_traced(runner, scene, 10.0, "deformable 10 s");
  EXPECT_EQ(s.num_nets, 1);
  EXPECT_EQ(s.num_nodes, 306);
  EXPECT_EQ(s.contacts_max, 0) << "the hidden core has no spheres";
  EXPECT_GT(s.node_contacts_max, 5);

  // The hand's probe goes deep into the post (node spheres of the rest shape
  // at the target: at most post radius + node radius ≈ 6.4 mm for a hollow
  // net on a 5 mm post); the net barely.
  EXPECT_GE(s.target_penetration_max_mm, 5.0);
  EXPECT_LE(s.tool_penetration_max_mm, 0.5);
  EXPECT_DOUBLE_EQ(s.tool_penetration_max_mm,
                   s.net_penetration_max_mm);  // the tool's only spheres are nodes
  EXPECT_GE(s.target_penetration_max_mm, 10.0 * s.net_penetration_max_mm);
  // The net deforms visibly: a few % to ~20 % strain, ties stretched by ~mm.
  EXPECT_GT(s.net_strain_max, 0.03);
  EXPECT_LT(s.net_strain_max, 0.3);
  EXPECT_GT(s.net_tie_stretch_max_mm, 0.5);
  EXPECT_LT(s.net_tie_stretch_max_mm, 3.0);
  EXPECT_GT(s.feedback_force_max_n, 1.0);
  EXPECT_LE(s.feedback_force_max_n, scene.model.feedback.max_force + 1e-9);

  // In the trace: strain > 0 whenever the net touches; the god-object is
  // held back by several mm while in contact, then free again, back on the
  // hand within a millimetre, once it has slid around the post.
  const auto& records = runner.trace().records();
  double contact_from = -1.0, contact_to = -1.0, lag_in_contact = 0.0, strain_in_contact = 0.0;
  double deepest_target = 0.0, tool_at_deepest_target = -1.0;
  for (const TraceRecord& r : records) {
    const double lag = (r.tool.position - r.target.position).norm();
    if (r.node_contacts > 0) {
      if (contact_from < 0.0) contact_from = r.time_s;
      contact_to = r.time_s;
      lag_in_contact = std::max(lag_in_contact, lag);
      strain_in_contact = std::max(strain_in_contact, r.net_strain_max);
      EXPECT_GT(r.net_strain_max, 0.0) << "t = " << r.time_s;
      EXPECT_GT(r.net_tie_stretch_mm, 0.0) << "t = " << r.time_s;
    }
    if (r.target_penetration_mm > deepest_target) {
      deepest_target = r.target_penetration_mm;
      tool_at_deepest_target = r.tool_penetration_mm;
    }
  }
  std::printf(
      "[   info   ] deformable: net in contact %.3f–%.3f s, god-object up to %.2f mm behind the "
      "hand, "
      "strain up to %.3f; at the hand's deepest (%.2f mm) the net is %.3f mm in\n",
      contact_from, contact_to, lag_in_contact * 1e3, strain_in_contact, deepest_target,
      tool_at_deepest_target);
  EXPECT_GT(contact_from, 2.5);
  EXPECT_LT(contact_to, 3.5);
  EXPECT_GT(lag_in_contact, 0.003);
  EXPECT_GT(strain_in_contact, 0.03);
  EXPECT_LT(tool_at_deepest_target, 0.5);
  // Slid around: free and back on the hand after the post.
  for (const TraceRecord& r : records) {
    if (r.time_s < contact_to + 0.3 || r.time_s > contact_to + 1.0) continue;
    EXPECT_EQ(r.node_contacts, 0) << "t = " << r.time_s;
    EXPECT_LT((r.tool.position - r.target.position).norm(), 1e-3) << "t = " << r.time_s;
  }
}

TEST(RunDeformable, EndobagSquashesOnTheOrganWhileTheHandGoesThrough) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = endobag_scene();
  SceneRunner runner(scene, static_cast<std::size_t>(periods_for(scene, 10.0)));
  const RunSummary s = run_traced(runner, scene, 10.0, "endobag 10 s");
  EXPECT_EQ(s.num_nets, 1);
  EXPECT_EQ(s.num_nodes, 162);
  EXPECT_EQ(s.num_joints, 5);
  // The hand (instrument and bag at the targets) goes deep into the organ;
  // the bag stays on it, squashed.
  EXPECT_GE(s.target_penetration_max_mm, 15.0);
  EXPECT_LE(s.tool_penetration_max_mm, 1.0);
  EXPECT_GE(s.target_penetration_max_mm, 10.0 * s.net_penetration_max_mm);
  EXPECT_GT(s.net_strain_max, 0.05);
  EXPECT_LT(s.net_strain_max, 0.5);
  EXPECT_GT(s.net_tie_stretch_max_mm, 1.0);
  EXPECT_LT(s.net_tie_stretch_max_mm, 8.0);
  // The jaws inside the bag never reach the organ; the joints hold.
  EXPECT_EQ(s.contacts_max, 0);
  EXPECT_LT(s.joint_drift_max_mm, 0.01);
  // The bag rides on the tube: its core stays 45 mm ahead of the tube's COM.
  const auto& d = runner.data();
  int tube = -1, core = -1;
  for (int b = 0; b < scene.model.num_bodies(); ++b) {
    if (scene.model.bodies[static_cast<std::size_t>(b)].name == "tube") tube = b;
    if (scene.model.bodies[static_cast<std::size_t>(b)].name == "bag_core") core = b;
  }
  ASSERT_GE(tube, 0);
  ASSERT_GE(core, 0);
  const auto& tb = d.bodies[static_cast<std::size_t>(tube)];
  const Vec3 mount = tb.position + tb.orientation * Vec3(0.0, 0.0, 0.045);
  EXPECT_LT((d.bodies[static_cast<std::size_t>(core)].position - mount).norm(), 1e-5);
}

TEST(RunDeformable, SummaryReportsTheNets) {
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  numen::sim::RunOptions opt;
  opt.duration_s = 0.2;
  const RunSummary s = numen::sim::run_scene(deformable_scene(), opt);
  const nlohmann::json json = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(json.at("num_nets"), 1);
  EXPECT_EQ(json.at("num_nodes"), 306);
  EXPECT_EQ(json.at("solver_not_converged_steps"), 0);
  EXPECT_EQ(json.at("net_strain_max"), s.net_strain_max);
  for (const char* key : {"node_contacts_max", "net_penetration_max_mm", "net_tie_stretch_max_mm",
                          "net_node_speed_max_mps", "solver_iterations_mean",
                          "solver_iterations_max", "solver_residual_max"})
    EXPECT_TRUE(json.at(key).is_number()) << key << " in " << json.dump();
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("deformable: 1 net(s), 306 nodes"), std::string::npos) << text;
  EXPECT_NE(text.find("solver iterations mean"), std::string::npos) << text;
  // A scene without nets says nothing about them.
  const RunSummary r = numen::sim::run_scene(default_scene(), opt);
  EXPECT_EQ(r.num_nodes, 0);
  EXPECT_EQ(numen::sim::format_summary(r).find("deformable:"), std::string::npos);
}

// ---------------------------------------------------------------- articulated scenes

TEST(RunArticulated, DefaultInstrumentStaysOutsideWhileTheJointsHold) {
  NUMEN_REQUIRE_ARTICULATION();
  // Paper Fig. 7: the articulated tool (sleeve, tube, jaws) stays on the
  // organ and tissue while the recorded tip goes through; the joints hold.
  SceneRunner runner(default_scene());
  for (int k = 0; k < 15'000; ++k) runner.period();
  const RunSummary s = runner.summary();
  EXPECT_EQ(s.num_joints, 4);
  EXPECT_GE(s.target_penetration_max_mm, 10.0);
  EXPECT_LE(s.tool_penetration_max_mm, 3.0);
  EXPECT_LT(s.joint_drift_max_mm, 0.01);
  EXPECT_LT(s.joint_angle_drift_max_mrad, 1.0);
  EXPECT_FALSE(s.nan_detected);
  // The sleeve stays on the trocar point: the spherical joint to the world.
  const auto& d = runner.data();
  EXPECT_LT((d.bodies[0].position - default_scene().device.trocar.point).norm(), 1e-5);
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
  EXPECT_GE(s.target_penetration_max_mm, 10.0) << "the hand goes through the desk";
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

// ---------------------------------------------------------------- determinism

void expect_deterministic(const Scene& scene, std::int64_t n, const char* name) {
  SceneRunner a(scene, static_cast<std::size_t>(n));
  SceneRunner b(scene, static_cast<std::size_t>(n));
  for (std::int64_t k = 0; k < n; ++k) {
    a.period();
    b.period();
  }
  const auto& ra = a.trace().records();
  const auto& rb = b.trace().records();
  ASSERT_EQ(ra.size(), static_cast<std::size_t>(n));
  ASSERT_EQ(rb.size(), ra.size());
  for (std::size_t i = 0; i < ra.size(); ++i) ASSERT_TRUE(same_record(ra[i], rb[i])) << name << ": record " << i;
  const numen::core::Data& da = a.data();
  const numen::core::Data& db = b.data();
  EXPECT_TRUE(same_bits(da.time, db.time));
  EXPECT_EQ(da.step_count, db.step_count);
  ASSERT_EQ(da.bodies.size(), db.bodies.size());
  for (std::size_t i = 0; i < da.bodies.size(); ++i) {
    EXPECT_TRUE(same_bits(da.bodies[i].position, db.bodies[i].position)) << name << ": body " << i;
    EXPECT_TRUE(same_bits(da.bodies[i].orientation, db.bodies[i].orientation)) << name << ": body " << i;
    EXPECT_TRUE(same_bits(da.bodies[i].linear_velocity, db.bodies[i].linear_velocity)) << name << ": body " << i;
    EXPECT_TRUE(same_bits(da.bodies[i].angular_velocity, db.bodies[i].angular_velocity)) << name << ": body " << i;
  }
  ASSERT_EQ(da.nodes.size(), db.nodes.size());
  for (std::size_t i = 0; i < da.nodes.size(); ++i) {
    EXPECT_TRUE(same_bits(da.nodes[i].position, db.nodes[i].position)) << name << ": node " << i;
    EXPECT_TRUE(same_bits(da.nodes[i].velocity, db.nodes[i].velocity)) << name << ": node " << i;
  }
  EXPECT_TRUE(same_bits(da.feedback_wrench.force, db.feedback_wrench.force));
  EXPECT_TRUE(same_bits(da.target.position, db.target.position));
  // Something happened: the bodies moved and there were contacts.
  EXPECT_GT(a.summary().contacts_max + a.summary().node_contacts_max, 0) << name;
  bool moved = false;
  for (std::size_t i = 0; i < da.bodies.size(); ++i)
    moved = moved || (da.bodies[i].position - scene.model.bodies[i].initial_pose.position).norm() > 1e-3;
  EXPECT_TRUE(moved) << name;
}

TEST(RunDeterminism, DefaultSceneTwoRunnersAreBitIdentical) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "bit-identity is not what a sanitizer checks; 12 s of the scene twice take 31 s under"
      " ASan+UBSan with coverage (RunDefaultScene.* runs it there)");
  NUMEN_REQUIRE_ARTICULATION();
  expect_deterministic(default_scene(), periods_for(default_scene(), 12.0), "default");
}

TEST(RunDeterminism, ConstructionSceneTwoRunnersAreBitIdentical) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "bit-identity is not what a sanitizer checks; 9 s of the scene twice take 37 s under "
      "ASan+UBSan with coverage (RunConstructionScene.* runs it there)");
  expect_deterministic(construction_scene(), periods_for(construction_scene(), 9.0), "construction");
}

TEST(RunDeterminism, DeformableSceneTwoRunnersAreBitIdentical) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  expect_deterministic(deformable_scene(), periods_for(deformable_scene(), 10.0), "deformable");
}

TEST(RunDeterminism, EndobagSceneTwoRunnersAreBitIdentical) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  expect_deterministic(endobag_scene(), periods_for(endobag_scene(), 10.0), "endobag");
}

// ---------------------------------------------------------------- bad bus frames

TEST(RunBadBus, CorruptedAndLostFramesAreRejectedWithoutHarm) {
  NUMEN_REQUIRE_ARTICULATION();
  Scene scene = default_scene();  // a copy
  scene.bus.corruption_probability = 0.05;
  scene.bus.drop_probability = 0.02;
  scene.bus.seed = 20240611;
  // The nodes come configured: on a bus that flips payload bits a configuration write can land
  // altered, and the read-back then refuses the start-up, as it must (DcfConfiguration tests).
  for (numen::hal::CanopenAxisConfig& x : scene.device.canopen.axes) x.dcf = nullptr;
  const std::int64_t n = periods_for(scene, 12.0);
  SceneRunner runner(scene, static_cast<std::size_t>(n));
  const auto t0 = std::chrono::steady_clock::now();
  for (std::int64_t k = 0; k < n; ++k) runner.period();
  const RunSummary s = runner.summary();
  print_summary("default 12 s, bad bus", s, wall_s(t0));

  EXPECT_GT(s.bus_frames_corrupted, 0);
  EXPECT_GT(s.bus_frames_dropped, 0);
  EXPECT_GT(s.rejected_samples, 0);
  EXPECT_GT(s.invalid_periods, 0);
  EXPECT_FALSE(s.nan_detected);
  EXPECT_EQ(s.nonfinite_steps, 0);
  // The god-object is still held on the surface while the hand goes in.
  EXPECT_GE(s.target_penetration_max_mm, 10.0);
  EXPECT_LE(s.tool_penetration_max_mm, 4.0);
  EXPECT_LE(s.feedback_force_max_n, scene.model.feedback.max_force + 1e-9);
  EXPECT_LT(s.tracking_error_free_rms_mm, 2.0);
  for (const TraceRecord& r : runner.trace().records()) ASSERT_TRUE(all_finite(r)) << "t = " << r.time_s;
  // The managed stack treats an implausible encoder value (a corrupted frame past the jump or
  // range check) as a fault: the safe state latches, with the cause and the period, and no
  // torque is commanded from then on (nobody re-arms in this run).
  std::printf("[   info   ] bad bus: start-up %s, lifecycle %s, %lld safe stop(s), first %s (id %d) "
              "at %.3f s, period %lld; %lld fault records\n",
              s.startup.c_str(), s.lifecycle.c_str(), static_cast<long long>(s.faults),
              s.first_fault.c_str(), s.first_fault_id, s.first_fault_time_s,
              static_cast<long long>(s.first_fault_period), static_cast<long long>(s.fault_records));
  EXPECT_EQ(s.faults, 1);
  EXPECT_FALSE(s.first_fault.empty());
  EXPECT_EQ(s.lifecycle, "fault");
  std::int64_t torque_after_fault = 0;
  for (const TraceRecord& r : runner.trace().records()) {
    if (r.time_s * 1e3 <= static_cast<double>(s.first_fault_period) + 0.5) continue;
    for (double tau : r.axis_torque) torque_after_fault += tau != 0.0 ? 1 : 0;
  }
  EXPECT_EQ(torque_after_fault, 0);
  // Positions stay near the recorded workspace (no wild jump from a bad frame).
  const Vec3 p = runner.data().bodies[static_cast<std::size_t>(runner.data().attached_body)].position;
  EXPECT_TRUE(p.allFinite());
  EXPECT_LT((p - runner.data().target.position).norm(), 0.05);
}

}  // namespace

// --record and --bus log: (run_options.hpp BusChoice): a recorded run replayed from
// its own candump log drives the controller to the same result, bit for bit.
TEST(RunBusLog, RecordedRunReplaysBitIdentically) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = default_scene();
  const numen::test::TempDir dir;
  const std::string log = (dir / "run.log").string();
  constexpr int kPeriods = 2000;
  std::vector<Vec3> recorded, replayed;
  std::int64_t frames_recorded = 0;
  {
    numen::sim::BusChoice bus;
    bus.record_path = log;
    SceneRunner runner(scene, 0, bus);
    for (int k = 0; k < kPeriods; ++k) {
      runner.period();
      recorded.push_back(runner.data().bodies[static_cast<std::size_t>(std::max(0, runner.data().attached_body))].position);
    }
    const RunSummary s = runner.summary();
    EXPECT_EQ(s.bus_record_dropped, 0);
    frames_recorded = s.bus_frames_recorded;
    EXPECT_GT(frames_recorded, 3 * kPeriods);  // SYNC + encoder frames + torques
  }  // the writer flushes and closes the log here
  numen::sim::BusChoice bus;
  bus.spec = "log:" + log;
  SceneRunner runner(scene, 0, bus);
  for (int k = 0; k < kPeriods; ++k) {
    runner.period();
    replayed.push_back(runner.data().bodies[static_cast<std::size_t>(std::max(0, runner.data().attached_body))].position);
  }
  const RunSummary s = runner.summary();
  EXPECT_GT(s.bus_frames_replayed, kPeriods);
  EXPECT_EQ(s.invalid_periods, 49);  // the start-up periods, as in the recorded run
  // The replayed heartbeats, SDO responses and drive TPDOs take the controller through the
  // same start-up, its configuration included.
  EXPECT_EQ(s.periods_to_active, 50);
  EXPECT_EQ(s.lifecycle, "active");
  ASSERT_EQ(recorded.size(), replayed.size());
  for (int k = 0; k < kPeriods; ++k) {
    ASSERT_EQ(recorded[static_cast<std::size_t>(k)], replayed[static_cast<std::size_t>(k)]) << "period " << k;
  }
  // The god-object moved: the comparison means something.
  EXPECT_GT((recorded.back() - recorded.front()).norm(), 1e-3);
}

namespace {

/// `log` with, after the `nth` received line of COB-ID 0x181 (1-based), `extra` lines at its time.
std::string with_lines_after(const std::string& log, int nth, const std::vector<std::string>& extra) {
  std::istringstream in(log);
  std::string out, line;
  int seen = 0;
  while (std::getline(in, line)) {
    out += line + "\n";
    if (line.find(" 181#") == std::string::npos || line.back() != 'R' || ++seen != nth) continue;
    const std::string stamp = line.substr(0, line.find(' '));
    for (const std::string& e : extra) out += stamp + " sim0 " + e + " R\n";
  }
  return out;
}

/// The log of a 600-period recorded run of the default scene.
std::string recorded_log(const numen::test::TempDir& dir) {
  const std::string path = (dir / "run.log").string();
  {
    numen::sim::BusChoice bus;
    bus.record_path = path;
    SceneRunner runner(default_scene(), 0, bus);
    for (int k = 0; k < 600; ++k) runner.period();
  }
  return numen::test::read_file(path);
}

RunSummary replay(const numen::test::TempDir& dir, const std::string& name, const std::string& log) {
  numen::sim::BusChoice bus;
  bus.spec = "log:" + dir.write(name, log);
  SceneRunner runner(default_scene(), 0, bus);
  for (int k = 0; k < 600; ++k) runner.period();
  return runner.summary();
}

}  // namespace

// A remote request (181#R) and a 29-bit frame numbered like an encoder's COB-ID
// (00000181#...) in a replayed log were filtered out unseen: frames_rejected 0,
// frames_unknown_id 0, though docs/inputs.md says they are rejected / counted. They now reach
// the controller and are counted (remote: rejected; 29-bit: unknown id).
TEST(RunBusLog, RemoteAndExtendedFramesOnAnEncoderIdAreCounted) {
  NUMEN_REQUIRE_ARTICULATION();
  const numen::test::TempDir dir;
  const std::string log = recorded_log(dir);
  const RunSummary clean = replay(dir, "clean.log", log);
  EXPECT_EQ(clean.frames_rejected, 0);
  EXPECT_EQ(clean.frames_unknown_id, 0);
  const RunSummary s = replay(
      dir, "odd.log",
      with_lines_after(with_lines_after(log, 300, {"181#R", "00000181#01020304"}), 400,
                       {"181#R4", "00000181#R", "00000182#0506"}));
  EXPECT_EQ(s.encoder_frames_remote, 2);
  EXPECT_EQ(s.frames_rejected, 2);
  EXPECT_EQ(s.frames_unknown_id, 3);
  EXPECT_GT(s.rejected_samples + s.invalid_periods, clean.rejected_samples + clean.invalid_periods)
      << "a remote request rejects its axis's sample for the period";
  const numen::sim::RunVerdict v = numen::sim::run_verdict(s);
  EXPECT_EQ(v.status, numen::sim::ExitStatus::kSamplesRejected);
  EXPECT_NE(std::find(v.reasons.begin(), v.reasons.end(),
                      "samples rejected: 2 encoder frames rejected (CAN FD 0, remote 2, wrong "
                      "length 0): encoder TPDOs are classic CAN data frames of their mapped length"),
            v.reasons.end());
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("frames rejected 2 (encoder frames: CAN FD 0, remote 2, wrong length 0), "
                      "unknown id 3"),
            std::string::npos)
      << text;
}

// Every encoder frame sent as CAN FD (181##0...): the verdict named "drive stuck" (or nothing
// about the frames); it counts the FD frames and names them.
TEST(RunBusLog, EncoderFramesSentAsCanFdAreCountedAndNamed) {
  NUMEN_REQUIRE_ARTICULATION();
  const numen::test::TempDir dir;
  std::string log = recorded_log(dir);
  std::int64_t encoder_lines = 0;
  for (std::size_t at = log.find(" sim0 18"); at != std::string::npos;
       at = log.find(" sim0 18", at + 1)) {
    const std::size_t hash = log.find('#', at);
    if (log.compare(log.find('\n', at) - 1, 1, "R") != 0) continue;  // received only
    log.replace(hash, 1, "##0");
    ++encoder_lines;
  }
  ASSERT_GT(encoder_lines, 1000);
  const RunSummary s = replay(dir, "fd.log", log);
  EXPECT_GT(s.encoder_frames_fd, 1000);
  EXPECT_LE(s.encoder_frames_fd, encoder_lines);
  EXPECT_EQ(s.encoder_frames_remote + s.encoder_frames_wrong_length, 0);
  const numen::sim::RunVerdict v = numen::sim::run_verdict(s);
  const std::string named = "samples rejected: " + std::to_string(s.encoder_frames_fd) +
                            " encoder frames rejected (CAN FD " +
                            std::to_string(s.encoder_frames_fd) + ", remote 0, wrong length 0)";
  bool found = false;
  for (const std::string& r : v.reasons) found = found || r.rfind(named, 0) == 0;
  EXPECT_TRUE(found) << ::testing::PrintToString(v.reasons);
}

// The same frames on the simulated bus reach the controller and are counted.
TEST(RunBadBus, RemoteExtendedAndFdFramesOnTheSimBusAreCounted) {
  NUMEN_REQUIRE_ARTICULATION();
  SceneRunner runner(default_scene(), 0);
  for (int k = 0; k < 300; ++k) runner.period();
  numen::hal::CanFrame remote;
  remote.id = 0x181;
  remote.flags = numen::hal::CanFlag::kRemote;
  numen::hal::CanFrame extended;
  extended.id = 0x181;
  extended.flags = numen::hal::CanFlag::kExtendedId;
  extended.len = 4;
  numen::hal::CanFrame fd;
  fd.id = 0x182;
  fd.flags = numen::hal::CanFlag::kFd;
  fd.len = 4;
  for (const numen::hal::CanFrame& f : {remote, extended, fd})
    ASSERT_EQ(runner.bus().device().write(f), numen::hal::IoStatus::kOk);
  for (int k = 0; k < 5; ++k) runner.period();
  const RunSummary s = runner.summary();
  EXPECT_EQ(s.encoder_frames_remote, 1);
  EXPECT_EQ(s.encoder_frames_fd, 1);
  EXPECT_EQ(s.frames_rejected, 2);
  EXPECT_EQ(s.frames_unknown_id, 1);
}

// recorder_settings(): a paced run never waits for its recorder's disk; an offline run has no
// deadline and waits, so its log is complete on a starved machine (the replay above needs
// every frame).
TEST(RunBusLog, PacedRecorderDropsOfflineRecorderWaits) {
  EXPECT_EQ(numen::sim::recorder_settings(true).full_queue, numen::hal::FullQueuePolicy::kDrop);
  EXPECT_EQ(numen::sim::recorder_settings(false).full_queue, numen::hal::FullQueuePolicy::kWait);
}

TEST(RunBusLog, BadBusSpecAndBadLogAreClearErrors) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = default_scene();
  numen::sim::BusChoice bus;
  bus.spec = "can0";
  EXPECT_THROW(SceneRunner(scene, 0, bus), std::invalid_argument);
  const numen::test::TempDir dir;
  const std::string log =
      dir.write("bad.log", "(0.000000) sim0 181#00000000 R\n(0.001000) sim0 18Z#00 R\n");
  bus.spec = "log:" + log;
  try {
    SceneRunner runner(scene, 0, bus);
    FAIL() << "a bad log line must be refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.log:2:"), std::string::npos) << e.what();
  }
}

// RunOptions::rt (run_options.hpp): the real-time setup is applied on the running
// thread and reported step by step; a step that fails (a CPU that does not
// exist) is reported without stopping the run, unless strict. Run in its own
// thread so the test runner's scheduling and affinity are left alone.
TEST(RunRealtimeSetup, StepsAreReportedAndAFailureDoesNotStopTheRun) {
  NUMEN_REQUIRE_ARTICULATION();
  RunSummary s;
  std::thread t([&] {
    numen::sim::RunOptions opt;
    opt.duration_s = 0.05;
    opt.rt.cpu_affinity = {4095};  // no such CPU here
    s = numen::sim::run_scene(default_scene(), opt);
  });
  t.join();
  EXPECT_EQ(s.steps, 50);
  ASSERT_FALSE(s.realtime_setup.empty());
  bool affinity_failed = false;
  for (const std::string& line : s.realtime_setup)
    affinity_failed = affinity_failed || (line.find("affinity") != std::string::npos &&
                                          line.find("FAILED") != std::string::npos);
  EXPECT_TRUE(affinity_failed);
  const nlohmann::json setup =
      nlohmann::json::parse(numen::sim::format_summary_json(s)).at("realtime_setup");
  ASSERT_EQ(setup.size(), s.realtime_setup.size());
  EXPECT_EQ(setup.at(0), s.realtime_setup[0]);

  bool threw = false;
  std::thread strict([&] {
    numen::sim::RunOptions opt;
    opt.duration_s = 0.05;
    opt.rt.cpu_affinity = {4095};
    opt.rt.strict = true;
    try {
      numen::sim::run_scene(default_scene(), opt);
    } catch (const std::runtime_error&) {
      threw = true;
    }
  });
  strict.join();
  EXPECT_TRUE(threw);
}

TEST(RunRealtimeSetup, NothingRequestedReportsNothing) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::sim::RunOptions opt;
  opt.duration_s = 0.01;
  EXPECT_TRUE(numen::sim::run_scene(default_scene(), opt).realtime_setup.empty());
}

TEST(RunOverrunPolicy, PacedRunsLatchAfterTheLimitAndZeroOnlyCounts) {
  NUMEN_REQUIRE_ARTICULATION();
  const auto paced = numen::sim::control_loop_settings(true, 5);
  EXPECT_TRUE(paced.supervise_overruns);
  EXPECT_EQ(paced.overrun_limit, 5u);
  const auto count_only = numen::sim::control_loop_settings(true, 0);
  EXPECT_FALSE(count_only.supervise_overruns);
  EXPECT_GE(count_only.overrun_limit, 1u);  // a valid setting even when unused
  // A run as fast as possible has no deadlines, whatever the limit.
  EXPECT_FALSE(numen::sim::control_loop_settings(false, 3).supervise_overruns);
  // The policy in effect is reported in the summary.
  numen::sim::RunOptions opt;
  opt.duration_s = 0.01;
  opt.realtime = true;
  opt.overrun_limit = 0;
  const RunSummary s = numen::sim::run_scene(default_scene(), opt);
  EXPECT_EQ(s.overrun_limit, 0u);
  EXPECT_NE(numen::sim::format_summary(s).find("overrun policy: count only"), std::string::npos);
  // The minimal protocol has no supervisor to latch: its run reports count only, whatever the
  // limit asked (it used to print "latch after 3").
  Scene minimal = default_scene();
  minimal.device.canopen.managed = false;
  opt.overrun_limit = 3;
  const RunSummary m = numen::sim::run_scene(minimal, opt);
  EXPECT_FALSE(m.managed);
  EXPECT_EQ(m.overrun_limit, 0u);
  EXPECT_NE(numen::sim::format_summary(m).find("overrun policy: count only"), std::string::npos);
  const RunSummary managed = numen::sim::run_scene(default_scene(), opt);
  EXPECT_EQ(managed.overrun_limit, 3u);
  // Unpaced: no deadlines, nothing latches, whatever the limit (its JSON said 3).
  opt.realtime = false;
  EXPECT_EQ(numen::sim::run_scene(default_scene(), opt).overrun_limit, 0u);
}

TEST(RunRearm, ARequestIsTakenOnceBeforeThePeriodAndReported) {
  NUMEN_REQUIRE_ARTICULATION();
  std::atomic<bool> rearm{true};
  numen::sim::RunOptions opt;
  opt.duration_s = 0.02;
  opt.rearm = &rearm;
  const RunSummary s = numen::sim::run_scene(default_scene(), opt);
  EXPECT_FALSE(rearm.load());
  EXPECT_EQ(s.rearm_requests, 1);
  EXPECT_EQ(s.rearm_first_period, 0);
  EXPECT_EQ(s.rearms_accepted, 0);  // nothing latched at period 0: ControlLoop says kNotLatched
  EXPECT_NE(numen::sim::format_summary(s).find("re-arm: 1 request(s), 0 accepted"), std::string::npos);
}

// ---------------------------------------------------------------- recorded trials (issue 17)
// Every shipped JIGSAWS scene must accept every recorded trial: the axis limits are the
// instrument's, not one excerpt's. The full trials live outside the repository:
// $NUMEN_JIGSAWS_DIR, else ../shared/data/jigsaws beside the clone (CI; /work/shared/data/jigsaws
// in development). Without them these tests run the shipped excerpt only and say so.

namespace fs = std::filesystem;

/// The recordings to run: the shipped excerpt, then every *.txt of the trials folder.
std::vector<fs::path> recorded_trials(std::string* note) {
  std::vector<fs::path> out = {numen::sim::jigsaws_excerpt_path()};
  const char* env = std::getenv("NUMEN_JIGSAWS_DIR");
  const fs::path dir = env != nullptr && *env != '\0'
                           ? fs::path(env)
                           : fs::path(NUMEN_SOURCE_DIR) / ".." / "shared" / "data" / "jigsaws";
  std::vector<fs::path> trials;
  std::error_code ec;
  if (fs::is_directory(dir, ec))
    for (const auto& e : fs::directory_iterator(dir, ec))
      if (e.path().extension() == ".txt") trials.push_back(e.path());
  std::sort(trials.begin(), trials.end());
  *note = trials.empty() ? "no JIGSAWS trials in " + dir.string() +
                               " (set NUMEN_JIGSAWS_DIR): the shipped excerpt only"
                         : std::to_string(trials.size()) + " trials from " + dir.string();
  out.insert(out.end(), trials.begin(), trials.end());
  return out;
}

/// The shipped scenes driven by a JIGSAWS recording (those that accept a trial).
std::vector<fs::path> jigsaws_scenes() {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(fs::path(NUMEN_SOURCE_DIR) / "sim" / "scenes")) {
    if (!e.is_regular_file() || e.path().extension() != ".toml") continue;  // devices/: the DCFs
    std::ifstream in(e.path());
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (text.find("source = \"jigsaws\"") != std::string::npos) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// The text of the shipped scene `scene` reading `trial` instead of its excerpt, with `extra`
/// lines added to its [trajectory] (the last table of each of these scenes) and `trocar`
/// replacing its approach placement when not empty.
std::string scene_on_trial(const fs::path& scene, const fs::path& trial, const std::string& extra,
                           const std::string& trocar = "") {
  std::ifstream in(scene);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string file_line = "file = \"../data/jigsaws_suturing_b002_excerpt.txt\"";
  const auto at = text.find(file_line);
  EXPECT_NE(at, std::string::npos) << "test bug: " << scene << " does not read the excerpt";
  if (at != std::string::npos)
    text.replace(at, file_line.size(), "file = \"" + fs::absolute(trial).string() + "\"\n" + extra);
  text = numen::test::with_absolute_dcf_paths(text, fs::absolute(scene).parent_path().string());
  if (!trocar.empty()) {
    const std::string approach = "placement = \"approach\"";
    const auto p = text.find(approach);
    EXPECT_NE(p, std::string::npos) << "test bug: " << scene << " has no approach placement";
    if (p != std::string::npos) text.replace(p, approach.size(), trocar);
    const auto standoff = text.find("standoff = ", p);
    if (standoff != std::string::npos) text.insert(standoff, "# ");
  }
  return text;
}

/// The samples where one axis leaves its range (or exceeds its max_speed).
struct AxisViolation {
  std::string axis;
  bool speed = false;         ///< max_speed (else [min, max]).
  double first_time_s = 0.0;  ///< First such sample (s).
  double worst = 0.0;         ///< Farthest value (range) or highest speed.
  std::int64_t samples = 0;   ///< Number of such samples.
};

/// Records one bad sample of `axis` in `out` (one entry per axis and kind).
void note_violation(std::vector<AxisViolation>& out, const std::string& axis, bool speed,
                    double t, double value, double limit) {
  auto it = std::find_if(out.begin(), out.end(),
                         [&](const AxisViolation& v) { return v.axis == axis && v.speed == speed; });
  if (it == out.end()) it = out.insert(out.end(), AxisViolation{axis, speed, t, value, 0});
  if (std::abs(value - limit) > std::abs(it->worst - limit)) it->worst = value;
  ++it->samples;
}

/// Walks the whole trajectory of `s` at dt and returns where the instrument's axes (inverse
/// kinematics of each target) leave [min, max] or move faster than max_speed; `closest` gets
/// the time at which an axis comes closest to a limit (relative to its range).
std::vector<AxisViolation> axis_violations(const Scene& s, double* closest) {
  const auto kin = numen::hal::make_kinematics(s.device);
  std::vector<AxisViolation> out;
  numen::hal::AxisVector last;
  double best = -1.0;
  const auto n = static_cast<std::int64_t>(std::floor(s.trajectory.duration() / s.model.dt));
  for (std::int64_t k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) * s.model.dt;
    const numen::hal::AxisVector q = numen::sim::instrument_axes(s.device, *kin, s.trajectory.at(t));
    for (std::size_t i = 0; i < s.device.axes.size(); ++i) {
      const numen::hal::AxisConfig& a = s.device.axes[i];
      const double v = q[static_cast<Eigen::Index>(i)];
      if (!a.wraps) {
        if (v < a.min) note_violation(out, a.name, false, t, v, a.min);
        if (v > a.max) note_violation(out, a.name, false, t, v, a.max);
        const double margin = std::min(v - a.min, a.max - v) / (a.max - a.min);
        if (best < 0.0 || 0.5 - margin > best) {
          best = 0.5 - margin;
          *closest = t;
        }
      }
      if (k > 0) {
        double d = v - last[static_cast<Eigen::Index>(i)];
        if (a.wraps) d = std::remainder(d, 2.0 * std::numbers::pi);
        const double speed = std::abs(d) / s.model.dt;
        if (speed > a.max_speed) note_violation(out, a.name, true, t, speed, a.max_speed);
      }
    }
    last = q;
  }
  return out;
}

TEST(RunRecordedTrials, EveryAxisOfEveryTrialStaysInItsRangeInEveryJigsawsScene) {
  NUMEN_REQUIRE_ARTICULATION();
  std::string note;
  const std::vector<fs::path> trials = recorded_trials(&note);
  std::printf("[   info   ] %s\n", note.c_str());
  const std::vector<fs::path> scenes = jigsaws_scenes();
  ASSERT_GE(scenes.size(), 3u) << "default, deformable and endobag read JIGSAWS recordings";
  numen::test::TempDir dir;
  for (const fs::path& scene_path : scenes) {
    if (!numen::core::kWithDeformable && scene_path.stem() != "default") continue;
    for (const fs::path& trial : trials) {
      SCOPED_TRACE(scene_path.stem().string() + " on " + trial.filename().string());
      const Scene s = numen::sim::load_scene(
          dir.write(scene_path.stem().string() + "_full.toml", scene_on_trial(scene_path, trial, "")));
      double closest = 0.0;
      const std::vector<AxisViolation> bad = axis_violations(s, &closest);
      for (const AxisViolation& v : bad)
        ADD_FAILURE() << v.axis << ": " << v.samples << " samples beyond its "
                      << (v.speed ? "max_speed" : "[min, max]") << " from " << v.first_time_s
                      << " s on, up to " << v.worst << (v.speed ? " per s" : "");
    }
  }
}

TEST(RunRecordedTrials, EveryTrialRunsThroughEveryJigsawsSceneWithoutASafetyStop) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_ARTICULATION();
  std::string note;
  const std::vector<fs::path> trials = recorded_trials(&note);
  std::printf("[   info   ] %s\n", note.c_str());
  numen::test::TempDir dir;
  // Bounded: 3 s of each trial, around the instant where an axis comes closest to its limit
  // (the whole trial sets the trocar, as in a run of the whole trial).
  constexpr double kWindow = 3.0;
  for (const fs::path& scene_path : jigsaws_scenes()) {
    if (!numen::core::kWithDeformable && scene_path.stem() != "default") continue;
    for (const fs::path& trial : trials) {
      const std::string name = scene_path.stem().string() + " on " + trial.filename().string();
      SCOPED_TRACE(name);
      const Scene full = numen::sim::load_scene(
          dir.write("full.toml", scene_on_trial(scene_path, trial, "")));
      double closest = 0.0;
      (void)axis_violations(full, &closest);
      const double start = std::clamp(closest - kWindow / 2, 0.0,
                                       std::max(0.0, full.trajectory.duration() - kWindow));
      const numen::core::Vec3& p = full.device.trocar.point;
      const numen::core::Quat& q = full.device.trocar.orientation;
      char trocar[256];
      std::snprintf(trocar, sizeof trocar,
                    "point = [%.17g, %.17g, %.17g]\norientation = [%.17g, %.17g, %.17g, %.17g]",
                    p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z());
      char window[128];
      std::snprintf(window, sizeof window, "start_time = %.17g\nend_time = %.17g", start,
                    start + kWindow);
      const Scene s = numen::sim::load_scene(
          dir.write("window.toml", scene_on_trial(scene_path, trial, window, trocar)));
      numen::sim::RunOptions opt;
      const auto t0 = std::chrono::steady_clock::now();
      const RunSummary r = numen::sim::run_scene(s, opt);
      print_summary(name.c_str(), r, wall_s(t0));
      std::printf("[   info   ]   window %.2f-%.2f s; lifecycle %s, safe stops %lld, first fault "
                  "'%s'; divergence '%s' %s %.4g (limit %.4g), speed %.3g energy %.3g of limits\n",
                  start, start + kWindow, r.lifecycle.c_str(), static_cast<long long>(r.faults),
                  r.first_fault.c_str(), r.divergence.cause.c_str(), r.divergence.subject.c_str(),
                  r.divergence.value, r.divergence.limit, r.divergence.speed_ratio_max,
                  r.divergence.energy_ratio_max);
      EXPECT_GT(r.steps, 0);
      EXPECT_EQ(r.faults, 0) << "safe stop: " << r.first_fault << " (id " << r.first_fault_id
                             << ", value " << r.first_fault_value << ") at " << r.first_fault_time_s << " s";
      EXPECT_EQ(r.rejected_samples, 0);
      EXPECT_EQ(r.values_out_of_range, 0);
      EXPECT_EQ(r.values_jump, 0);
      EXPECT_FALSE(r.nan_detected);
      EXPECT_FALSE(r.divergence.latched) << r.divergence.cause;
      EXPECT_EQ(r.lifecycle, "active");
    }
  }
}

// ---------------------------------------------------------------- soft start (docs/safety.md)

/// `text` with `soft_start = <seconds>` as the first key of its [device] table.
std::string with_soft_start(std::string text, double seconds) {
  const auto at = text.find("\n[device]\n");
  EXPECT_NE(at, std::string::npos) << "test bug: no [device] table";
  if (at != std::string::npos) text.insert(at + 10, "soft_start = " + std::to_string(seconds) + "\n");
  return text;
}

// The two held-out JIGSAWS trials (not the excerpt's Suturing_B002) start with the tool inside
// an obstacle of the default scene (warned: "the tool started inside ..."): the hand is inside,
// the god-object is pushed out, so the coupling force is large from the first torque period.
// Without a soft start the feedback jumps from 0 to it in one period (8 N, max_force, on
// Needle_Passing). With one (T = 0.1 s) it rises along the ramp. The two runs see the same hand
// and step the same god-object (the simulated hand does not feel the torques), so the ramped
// feedback is exactly r_k times the unramped one, and every period-to-period change is at most
// the ramp's slope max_force dt / T plus what the unramped feedback itself changed, scaled by
// the previous r: |F_k - F_{k-1}| <= (dt / T) max_force + r_{k-1} |F^_k - F^_{k-1}|.
TEST(RunSoftStart, TheHeldOutTrialsStartingInsideAnObstacleRampTheFeedbackInInsteadOfJumping) {
  NUMEN_REQUIRE_ARTICULATION();
  std::string note;
  std::vector<fs::path> trials;
  for (const fs::path& t : recorded_trials(&note))
    if (t.filename() == "Knot_Tying_B001.txt" || t.filename() == "Needle_Passing_B001.txt")
      trials.push_back(t);
  if (trials.size() != 2) GTEST_SKIP() << "the held-out JIGSAWS trials are not here: " << note;
  constexpr double kT = 0.1;
  const fs::path scene_path = fs::path(NUMEN_SOURCE_DIR) / "sim" / "scenes" / "default.toml";
  numen::test::TempDir dir;
  for (const fs::path& trial : trials) {
    SCOPED_TRACE(trial.filename().string());
    const std::string text = scene_on_trial(scene_path, trial, "");
    const Scene off_scene = numen::sim::load_scene(dir.write("off.toml", with_soft_start(text, 0.0)));
    const Scene on_scene = numen::sim::load_scene(dir.write("on.toml", with_soft_start(text, kT)));
    ASSERT_EQ(off_scene.device.soft_start_s, 0.0);
    ASSERT_EQ(on_scene.device.soft_start_s, kT);
    const double dt = on_scene.model.dt;
    const double max_force = on_scene.model.feedback.max_force;
    const double slope = max_force * dt / kT;  // N per period from the ramp
    const std::int64_t n = periods_for(on_scene, 0.3);
    SceneRunner off(off_scene, static_cast<std::size_t>(n));
    SceneRunner on(on_scene, static_cast<std::size_t>(n));
    numen::core::Vec3 off_last = numen::core::Vec3::Zero(), on_last = numen::core::Vec3::Zero();
    double ramp_last = 0.0, off_first = 0.0, on_first = 0.0, off_jump_after_first = 0.0;
    std::int64_t first = -1, ramp_periods = 0;
    for (std::int64_t k = 0; k < n; ++k) {
      off.period();
      on.period();
      const numen::platform::PeriodReport& a = off.last_report();
      const numen::platform::PeriodReport& b = on.last_report();
      const numen::core::Vec3 fa = a.feedback.force, fb = b.feedback.force;
      EXPECT_EQ(a.soft_start_ramp, 1.0) << "period " << k;  // soft_start = 0: today's behaviour
      const bool open = !on.loop().impedance().sent_torques().gated;
      ASSERT_EQ(open, !off.loop().impedance().sent_torques().gated) << "period " << k;
      if (first < 0 && open) {  // torque enabled: the ramp begins
        first = k;
        off_first = fa.norm();
        on_first = fb.norm();
      }
      if (first >= 0) {
        // r_k = min(1, (k - first + 1) dt / T): the ramp begins at the first open gate.
        const double r = std::min(1.0, static_cast<double>(k - first + 1) * dt / kT);
        EXPECT_NEAR(b.soft_start_ramp, r, 1e-12) << "period " << k;
        EXPECT_NEAR((fb - b.soft_start_ramp * fa).norm(), 0.0, 1e-9) << "period " << k;
        EXPECT_LE((fb - on_last).norm(), slope + ramp_last * (fa - off_last).norm() + 1e-9)
            << "period " << k;
        if (k > first) off_jump_after_first = std::max(off_jump_after_first, (fa - off_last).norm());
        if (b.soft_start_ramp < 1.0) ++ramp_periods;
      }
      off_last = fa;
      on_last = fb;
      ramp_last = first >= 0 ? b.soft_start_ramp : 0.0;
    }
    const RunSummary so = off.summary(), sn = on.summary();
    std::printf("[   info   ] %s: start-up %lld steps from %.2f mm; first torque period %lld: "
                "feedback %.3f N without a soft start, %.4f N with %.1f s; jump max %.3f N -> %.4f N "
                "(ramp slope %.3f N, unramped jumps after the first period up to %.4f N)\n",
                trial.filename().string().c_str(), static_cast<long long>(sn.startup_steps),
                sn.startup_tool_penetration_mm, static_cast<long long>(first), off_first, on_first,
                kT, so.feedback_force_jump_max_n, sn.feedback_force_jump_max_n, slope,
                off_jump_after_first);
    ASSERT_GE(first, 0) << "no feedback at all";
    EXPECT_GT(sn.startup_steps, 0) << "the trial no longer starts inside an obstacle";
    // Without the ramp: the kick, from 0 to most of max_force in one period.
    EXPECT_GT(off_first, 0.5 * max_force);
    EXPECT_EQ(so.feedback_force_jump_max_n, off_first);
    EXPECT_EQ(so.soft_start_ramps, 0);
    // With it: one ramp step in the first period, and no jump above the slope plus the
    // unramped feedback's own largest change after its first period.
    EXPECT_LE(on_first, slope + 1e-9);
    EXPECT_LE(sn.feedback_force_jump_max_n, slope + off_jump_after_first + 1e-9);
    EXPECT_LT(sn.feedback_force_jump_max_n, 0.1 * so.feedback_force_jump_max_n);
    EXPECT_EQ(ramp_periods, std::llround(kT / dt) - 1);
    EXPECT_EQ(sn.soft_start_s, kT);
    EXPECT_EQ(sn.soft_start_ramps, 1);
    EXPECT_NE(numen::sim::format_summary(sn).find("soft start: feedback ramped in over 100.000 ms, 1 ramp(s)"),
              std::string::npos);
    EXPECT_NE(numen::sim::format_summary(so).find("soft start: off"), std::string::npos);
  }
}

// ---------------------------------------------------------------- summary figures (issue 17)

/// numen::test::kMiniScene (a ball held by a pose tracker over a floor at z = -0.1 m) with the
/// scripted trajectory `path` (the lines after source = "scripted").
std::string ball_over_floor(const std::string& path) {
  const std::string& mini = numen::test::kMiniScene;
  return mini.substr(0, mini.find("[trajectory]")) + "[trajectory]\nsource = \"scripted\"\n" + path;
}

TEST(RunSummaryFigures, AToolSpawnedInsideAnObstacleIsAStartUpReportedApartWithAWarning) {
  numen::test::TempDir dir;
  // The hand starts 15 mm inside the floor (ball bottom at -0.115 m) and rises out of it.
  const Scene scene = numen::sim::load_scene(dir.write("inside.toml", ball_over_floor(R"(
start = { position = [0.0, 0.0, -0.105] }
[[trajectory.segment]]
type = "line"
to = [0.0, 0.0, 0.0]
duration = 0.5
[[trajectory.segment]]
type = "hold"
duration = 0.2
)")));
  const RunSummary s = numen::sim::run_scene(scene, {});
  print_summary("start inside", s, 0.0);
  std::printf("[   info   ] start-up %lld steps from %.2f mm\n",
              static_cast<long long>(s.startup_steps), s.startup_tool_penetration_mm);
  EXPECT_NEAR(s.startup_tool_penetration_mm, 15.0, 0.5);
  EXPECT_GT(s.startup_steps, 0);
  EXPECT_LT(s.startup_steps, 200);  // pushed out within 0.2 s
  // After the start-up the god-object rests on the floor while the hand rises through it.
  EXPECT_LT(s.tool_penetration_max_mm, 1.0);
  EXPECT_GT(s.target_penetration_max_mm, 14.0);  // the hand's own depth is unchanged
  bool warned = false;
  for (const std::string& w : s.warnings)
    warned = warned || (w.find("the tool started inside obstacle 'floor', 15.") != std::string::npos &&
                        w.find("start-up") != std::string::npos);
  EXPECT_TRUE(warned) << "a warning names the obstacle and the depth";
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("after a start-up of " + std::to_string(s.startup_steps) + " steps"),
            std::string::npos)
      << text;
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j.at("startup_steps").get<std::int64_t>(), s.startup_steps);
  EXPECT_EQ(j.at("startup_tool_penetration_mm").get<double>(), s.startup_tool_penetration_mm);
  EXPECT_EQ(j.at("tool_penetration_max_mm").get<double>(), s.tool_penetration_max_mm);
  EXPECT_EQ(j.at("warnings").size(), s.warnings.size());

  // Starting free: no start-up, no warning.
  const Scene free_scene = numen::sim::load_scene(dir.write("free.toml", ball_over_floor(R"(
start = { position = [0.0, 0.0, 0.0] }
[[trajectory.segment]]
type = "hold"
duration = 0.05
)")));
  const RunSummary f = numen::sim::run_scene(free_scene, {});
  EXPECT_EQ(f.startup_steps, 0);
  EXPECT_EQ(f.startup_tool_penetration_mm, 0.0);
  EXPECT_TRUE(f.warnings.empty());
  EXPECT_EQ(numen::sim::format_summary(f).find("after a start-up"), std::string::npos);
}

TEST(RunSummaryFigures, FreeSpaceTrackingCountsOnlyStepsWhereNeitherToolNorHandTouches) {
  numen::test::TempDir dir;
  // The hand holds still in free space, then plunges 15 mm into the floor at 2.5 m/s: the
  // god-object, lagging on its spring, touches nothing for some steps while the hand is
  // already inside.
  const Scene scene = numen::sim::load_scene(dir.write("plunge.toml", ball_over_floor(R"(
start = { position = [0.0, 0.0, -0.08] }
[[trajectory.segment]]
type = "hold"
duration = 0.2
[[trajectory.segment]]
type = "line"
to = [0.0, 0.0, -0.105]
duration = 0.01
[[trajectory.segment]]
type = "hold"
duration = 0.29
)")));
  SceneRunner runner(scene, static_cast<std::size_t>(periods_for(scene, 0.5)));
  std::int64_t tool_free_hand_inside = 0;
  double error_hand_inside_mm = 0.0;  // the largest |x_tool - x_target| of those steps
  for (std::int64_t k = 0; k < periods_for(scene, 0.5); ++k) {
    runner.period();
    const TraceRecord& r = runner.trace().records().back();
    if (r.tool_contacts == 0 && r.target_penetration_mm > 0.0) {
      ++tool_free_hand_inside;
      error_hand_inside_mm =
          std::max(error_hand_inside_mm, (r.tool.position - r.target.position).norm() * 1e3);
    }
  }
  const RunSummary s = runner.summary();
  print_summary("plunge into the floor", s, 0.0);
  std::printf("[   info   ] steps with the tool free and the hand inside: %lld, error up to %.2f mm\n",
              static_cast<long long>(tool_free_hand_inside), error_hand_inside_mm);
  ASSERT_GT(error_hand_inside_mm, 12.0) << "test bug: the scenario has no such step";
  EXPECT_EQ(s.rejected_samples, 0);
  // In free space the hand holds, then moves 10 mm (ball bottom from 10 mm above the floor to
  // the floor): the error cannot exceed those 10 mm. The steps after, tool still free and hand
  // inside, are not free space.
  EXPECT_LT(s.tracking_error_free_max_mm, 10.0);
  EXPECT_LE(s.free_steps, periods_for(scene, 0.2) + 5);
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("tracking error in free space (tool and hand out of contact)"),
            std::string::npos)
      << text;
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j.at("tracking_error_free_max_mm").get<double>(), s.tracking_error_free_max_mm);
  EXPECT_EQ(j.at("free_steps").get<std::int64_t>(), s.free_steps);
}

TEST(RunSummaryFigures, JsonCarriesEveryFigureOfTheTextSummary) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::sim::RunOptions opt;
  opt.duration_s = 0.02;
  const RunSummary s = numen::sim::run_scene(default_scene(), opt);
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  // Figures of the text summary that the JSON used to leave out.
  EXPECT_EQ(j.at("trocar_note").get<std::string>(), s.trocar_note);
  EXPECT_EQ(j.at("overrun_limit").get<std::uint32_t>(), s.overrun_limit);
  EXPECT_EQ(j.at("rearm_requests").get<std::int64_t>(), s.rearm_requests);
  EXPECT_EQ(j.at("rearms_accepted").get<std::int64_t>(), s.rearms_accepted);
  EXPECT_EQ(j.at("rearm_first_period").get<std::int64_t>(), s.rearm_first_period);
  for (const char* key : {"startup_steps", "startup_tool_penetration_mm", "free_steps",
                          "tracking_error_free_rms_mm", "tracking_error_free_max_mm"})
    EXPECT_TRUE(j.contains(key)) << key;
}
