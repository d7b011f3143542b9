// Tests of sim/admittance_run and the shipped admittance scene: the hand goes 25 mm into the
// organ, the god-object and the device stop on its surface, the measured force is the hand's
// spring over the hand–device separation; scene keys and their errors.
#include "numen/sim/run/admittance_run.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "csv_lines.hpp"
#include "numen/platform/monotonic_clock.hpp"
#include "numen/sim/device/device_process.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_recording.hpp"
#include "numen/platform/state_frame.hpp"
#include "temp_dir.hpp"

namespace sim = numen::sim;

namespace {

const sim::Scene& admittance_scene() {
  static const sim::Scene s =
      sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/admittance.toml");
  return s;
}

/// The shipped admittance scene with `bus_keys` added to its [bus] table (after its latency),
/// written to and loaded from `dir`.
sim::Scene admittance_with_bus(const numen::test::TempDir& dir, const std::string& bus_keys) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/admittance.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string from = "latency = 0.0001";
  text.replace(text.find(from), from.size(), from + "\n" + bus_keys);
  const std::string path = (dir.path() / "variant.toml").string();
  std::ofstream(path) << text;
  return sim::load_scene(path);
}

}  // namespace

TEST(AdmittanceScene, LoadsTheSensorTheHandAndTheDrives) {
  const sim::Scene& s = admittance_scene();
  ASSERT_TRUE(s.admittance.has_value());
  EXPECT_EQ(s.model.coupling_mode, numen::core::CouplingMode::kAdmittance);
  EXPECT_EQ(s.admittance->config.sensor.effective_force_cob_id(), 0x1A0u);
  EXPECT_DOUBLE_EQ(s.admittance->config.sensor.force_scale, 0.001);
  EXPECT_DOUBLE_EQ(s.hand.stiffness, 200.0);
  EXPECT_DOUBLE_EQ(s.admittance->drive_lag_s, 0.002);
  EXPECT_EQ(s.admittance->config.rpdo_cob_ids.front(), 0x201u);
}

TEST(AdmittanceScene, GodObjectStaysOutsideWhileTheHandGoesThrough) {
  const sim::Scene& s = admittance_scene();
  sim::AdmittanceRunner r(s);
  const double k_hand = s.hand.stiffness;
  double hand_deepest = 0.0, tool_deepest = 0.0;
  // 2.7 s: the end of the hold, 25 mm inside.
  for (int k = 0; k < 2700; ++k) {
    r.period();
    hand_deepest = std::max(hand_deepest, r.hand_penetration());
    tool_deepest = std::max(tool_deepest, r.tool_penetration());
  }
  EXPECT_GT(hand_deepest, 0.024);  // the hand: 25 mm into the organ
  EXPECT_LT(tool_deepest, 0.001);  // the god-object: on the surface (k_c δ = F: ~0.25 mm)
  const numen::core::Vec3 x_dev = r.emulator().pose().position;
  const numen::core::Vec3 x_go = r.data().bodies[0].position;
  EXPECT_LT((x_dev - x_go).norm(), 1e-4);  // the device is where the god-object is
  EXPECT_NEAR(x_go.norm(), 0.045, 1e-3);   // on the organ's surface (r 40 mm + probe 5 mm)
  // Quasi-static contact: the measured force is k_hand × the hand–device separation.
  const double sep = (r.hand_pose().position - x_dev).norm();
  const double f = r.loop().last_report().feedback.force.norm();
  EXPECT_NEAR(f, k_hand * sep, 0.02 * k_hand * sep);
  EXPECT_GT(f, 4.0);
  // Force balance with the penalty contact: δ = F / k_c.
  EXPECT_NEAR(r.tool_penetration(), f / 2.0e4, 0.05 * f / 2.0e4);
  const sim::RunSummary sum = r.summary();
  EXPECT_TRUE(sum.admittance.enabled);
  EXPECT_EQ(sum.admittance.sensor_rejected_periods, 0);
  EXPECT_EQ(sum.admittance.hold_periods, 0);
  EXPECT_FALSE(sum.nan_detected);
}

TEST(AdmittanceScene, TheWholeRunComesBackOutAndReleases) {
  const sim::Scene& s = admittance_scene();
  sim::RunOptions o;
  const sim::RunSummary sum = sim::run_scene(s, o);  // dispatched to the admittance runner
  EXPECT_TRUE(sum.admittance.enabled);
  EXPECT_EQ(sum.steps, 4300);
  EXPECT_LT(sum.tool_penetration_max_mm, 1.0);
  EXPECT_GT(sum.target_penetration_max_mm, 24.0);
  EXPECT_GT(sum.admittance.measured_force_max_n, 4.0);
  EXPECT_LT(sum.admittance.measured_force_max_n, 8.0);
  EXPECT_LT(sum.admittance.final_measured_force_n, 0.1);  // back in free space, at rest
  EXPECT_EQ(sum.lifecycle, "active");
  EXPECT_NE(sim::format_summary(sum).find("admittance: measured force max"), std::string::npos);
  const nlohmann::json a = nlohmann::json::parse(sim::format_summary_json(sum)).at("admittance");
  EXPECT_EQ(a.at("measured_force_max_n"), sum.admittance.measured_force_max_n);
  EXPECT_EQ(a.at("csp_rpdos"), sum.admittance.csp_rpdos);
}

TEST(AdmittanceScene, PeriodsDoNotAllocate) {
  sim::AdmittanceRunner r(admittance_scene(), 3001);  // with a trace (--trace)
  r.period();
  numen::test::AllocationGuard guard;
  for (int k = 0; k < 3000; ++k) r.period();
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(r.trace().records().size(), 3001u);
}

TEST(AdmittanceScene, PeriodsDoNotAllocateWhileStreaming) {
  numen::test::TempDir dir;
  sim::AdmittanceRunner r(admittance_scene());
  // Every period published (rate above 1/dt), to a recording on the stream's own thread.
  r.stream_view((dir / "run.nmv").string(), {}, 1e6, true);
  r.period();
  numen::test::AllocationGuard guard;
  for (int k = 0; k < 3000; ++k) r.period();
  EXPECT_EQ(guard.count(), 0);
  r.finish();
  EXPECT_EQ(r.summary().view_record_frames, 3001);
}

// The state stream of an admittance run (docs/viewer.md, "Admittance runs"): the ghost is the
// hand, the wrench is the measured one, the axis field is zero, the scene says "admittance".
TEST(AdmittanceScene, RecordsTheHandAsGhostAndTheMeasuredWrench) {
  numen::test::TempDir dir;
  const sim::Scene& scene = admittance_scene();
  sim::RunOptions options;
  options.duration_s = 2.7;  // to the end of the hold, 25 mm inside
  options.record_view_path = (dir / "run.nmv").string();
  options.view_rate_hz = 1e6;  // every period
  const sim::RunSummary s = sim::run_scene(scene, options);
  EXPECT_EQ(s.exit_status, 0);
  EXPECT_EQ(s.view_record_frames, 2700);
  EXPECT_EQ(s.view_frames_dropped, 0);
  const sim::ViewRecordingReader reader(options.record_view_path);
  ASSERT_EQ(reader.size(), 2700u);
  EXPECT_EQ(nlohmann::json::parse(reader.scene_message())["device"]["protocol"], "admittance");
  // Replays the same run alongside: the last frame is its last period.
  sim::AdmittanceRunner r(scene);
  for (int k = 0; k < 2700; ++k) r.period();
  std::vector<std::byte> bytes;
  reader.frame(reader.size() - 1, bytes);
  numen::platform::StateFrameView v;
  ASSERT_TRUE(numen::platform::StateFrameDecoder::decode(bytes, v).ok());
  EXPECT_EQ(v.header().period, 2699u);
  const auto held = static_cast<std::uint32_t>(v.header().held_body);
  float ghost[7], wrench[6];
  ASSERT_TRUE(v.target_pose(held, ghost));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(ghost[i], r.hand_pose().position[i], 1e-6);
  EXPECT_GT(v.target_penetration(), 0.024f);  // the hand, 25 mm inside
  EXPECT_LT(v.tool_penetration(), 0.001f);    // the god-object on the surface
  v.feedback(wrench);
  const numen::core::Vec3 f(wrench[0], wrench[1], wrench[2]);
  EXPECT_NEAR(f.norm(), r.loop().last_report().feedback.force.norm(), 1e-3 * f.norm() + 1e-6);
  EXPECT_GT(f.norm(), 1.0);
  for (std::uint32_t a = 0; a < v.header().num_axes; ++a) EXPECT_EQ(v.axis_torque(a), 0.0f);
}

// `numen run --trace` of an admittance run: one row per period, the target is the hand, the
// feedback the measured wrench, the tool the god-object; no axis column (no torque is sent).
TEST(AdmittanceScene, TracesTheHandTheGodObjectAndTheMeasuredWrench) {
  numen::test::TempDir dir;
  const sim::Scene& scene = admittance_scene();
  sim::RunOptions options;
  options.duration_s = 2.7;  // to the end of the hold, 25 mm inside
  options.trace_path = (dir / "trace.csv").string();
  const sim::RunSummary s = sim::run_scene(scene, options);
  EXPECT_EQ(s.exit_status, 0);
  EXPECT_TRUE(s.warnings.empty());
  const std::vector<std::string> lines = numen::test::read_lines(options.trace_path);
  ASSERT_EQ(lines.size(), 2701u);  // header + one row per period
  const std::vector<std::string> header = numen::test::split_csv(lines.front());
  for (const std::string& h : header) EXPECT_NE(h.rfind("axis_torque_", 0), 0u) << h;
  auto col = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end()) throw std::runtime_error("no column " + name);
    return static_cast<std::size_t>(it - header.begin());
  };
  std::vector<std::vector<double>> rows;
  for (std::size_t l = 1; l < lines.size(); ++l) {
    std::vector<double> row;
    for (const std::string& f : numen::test::split_csv(lines[l])) row.push_back(std::stod(f));
    ASSERT_EQ(row.size(), header.size());
    rows.push_back(std::move(row));
  }
  ASSERT_EQ(rows.size(), 2700u);
  // Replays the same run alongside: the last row is its last period.
  sim::AdmittanceRunner r(scene);
  for (int k = 0; k < 2700; ++k) r.period();
  const std::vector<double>& last = rows.back();
  EXPECT_NEAR(last[col("time_s")], 2.7, 1e-9);
  EXPECT_EQ(last[col("sample_valid")], 1.0);
  EXPECT_NEAR(last[col("target_z")], r.hand_pose().position.z(), 1e-9);
  EXPECT_NEAR(last[col("tool_z")], r.data().bodies[0].position.z(), 1e-9);
  EXPECT_NEAR(last[col("tool_penetration_mm")], r.tool_penetration() * 1e3, 1e-6);
  EXPECT_GT(last[col("target_penetration_mm")], 24.0);  // the hand, 25 mm inside
  EXPECT_GE(last[col("tool_contacts")], 1.0);
  const numen::core::Vec3 f(last[col("feedback_fx")], last[col("feedback_fy")],
                            last[col("feedback_fz")]);
  EXPECT_NEAR(f.norm(), r.loop().last_report().feedback.force.norm(), 1e-6);
  EXPECT_GT(f.norm(), 4.0);
  // The deepest row is the run's deepest god-object contact.
  double deepest = 0.0;
  for (const auto& row : rows) deepest = std::max(deepest, row[col("tool_penetration_mm")]);
  EXPECT_NEAR(deepest, s.tool_penetration_max_mm, 1e-6);
}

// The emulated device lives on the scene's SimBus: another bus or a bus recording is refused
// before the run, naming the option (it used to run on the SimBus with a warning).
TEST(AdmittanceScene, RefusesAnotherBusAndABusRecording) {
  const sim::Scene& scene = admittance_scene();
  sim::RunOptions options;
  options.bus.spec = "log:/nonexistent.log";
  try {
    sim::run_scene(scene, options);
    ADD_FAILURE() << "--bus log: was accepted";
  } catch (const sim::InputError& e) {
    EXPECT_EQ(e.key(), "--bus");
    EXPECT_NE(std::string(e.what()).find("simulated bus only"), std::string::npos) << e.what();
  }
  options.bus.spec = "sim";
  options.bus.record_path = "/tmp/never-written.log";
  try {
    sim::run_scene(scene, options);
    ADD_FAILURE() << "--record was accepted";
  } catch (const sim::InputError& e) {
    EXPECT_EQ(e.key(), "--record");
  }
  options.bus.record_path.clear();
  options.trace_path = "/tmp/never-written.csv";
  options.duration_s = 1e7;  // 10^10 periods of trace
  try {
    sim::run_scene(scene, options);
    ADD_FAILURE() << "a trace over the budget was accepted";
  } catch (const sim::InputError& e) {
    EXPECT_EQ(e.key(), "--trace");
  }
}

// `--phase` applies to an admittance run: read before the sensor's answers arrive (50 µs after
// the SYNC, the bus latency is 100 µs) and the first period has no reading, the others read
// the previous period's; a phase not below dt is refused. A SIGUSR1 re-arm request is taken and
// reported (nothing latched: not accepted).
TEST(AdmittanceScene, TakesTheComputePhaseAndReArmRequests) {
  const sim::Scene& scene = admittance_scene();
  ASSERT_NEAR(scene.bus.latency_ns, 100'000, 1);
  sim::RunOptions options;
  options.duration_s = 0.5;
  const sim::RunSummary on_time = sim::run_scene(scene, options);
  EXPECT_EQ(on_time.admittance.sensor_rejected_periods, 0);
  options.compute_phase_s = 50e-6;
  std::atomic<bool> rearm{true};
  options.rearm = &rearm;
  const sim::RunSummary early = sim::run_scene(scene, options);
  EXPECT_EQ(early.admittance.sensor_rejected_periods, 1);
  EXPECT_EQ(early.exit_status, 6);  // samples rejected
  EXPECT_FALSE(rearm.load());
  EXPECT_EQ(early.rearm_requests, 1);
  EXPECT_EQ(early.rearm_first_period, 0);
  EXPECT_EQ(early.rearms_accepted, 0);  // nothing latched: kNotFaulted
  EXPECT_NE(sim::format_summary(early).find("re-arm: 1 request(s), 0 accepted"), std::string::npos);
  options.compute_phase_s = scene.model.dt;
  try {
    sim::run_scene(scene, options);
    ADD_FAILURE() << "a compute phase of one period was accepted";
  } catch (const sim::InputError& e) {
    EXPECT_EQ(e.key(), "--phase");
  }
}

// `numen device` emulates impedance instruments: an admittance scene is refused before a bus is
// opened (it used to emulate an encoder instrument in its place).
TEST(AdmittanceScene, TheDeviceProcessRefusesIt) {
  sim::DeviceOptions o;
  o.bus = "can:vcan0";
  try {
    (void)sim::run_device(admittance_scene(), o);
    ADD_FAILURE() << "numen device took an admittance scene";
  } catch (const sim::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("admittance device"), std::string::npos) << e.what();
  }
}

// Overruns (a paced run's late periods, stamped by each period's deadline and judged by the
// loop's statistics, so the next period's supervision sees them): overrun_limit of them in a
// row latch the safe state like the impedance stack's supervisor, an on-time period resets the
// streak, the summary names the cause and the verdict is a safety stop; a re-arm waits while
// the streak lasts and is taken after an on-time period. With a limit of 0 (offline runs,
// --overrun-limit 0) they are never latched.
TEST(AdmittanceScene, ConsecutiveOverrunsLatchTheSafeState) {
  const sim::Scene& s = admittance_scene();
  const auto late = [](sim::AdmittanceRunner& runner) {
    const std::int64_t now = numen::platform::monotonic_now_ns();
    runner.period(now - 100'000'000, now);  // 100 ms past its deadline
  };
  const auto on_time = [](sim::AdmittanceRunner& runner) {
    const std::int64_t now = numen::platform::monotonic_now_ns();
    runner.period(now + 100'000'000, now + 100'000'000);  // a deadline 100 ms ahead
  };
  sim::AdmittanceRunner counted(s, 0, 0);
  // The first 100 on time (an offline period is judged against its own wake-up: a period
  // slower than dt, as under a sanitizer on a loaded machine, would count), then 200 late.
  for (int k = 0; k < 300; ++k) k >= 100 ? late(counted) : on_time(counted);
  EXPECT_EQ(counted.loop().statistics().summary().overruns, 200);
  EXPECT_EQ(counted.summary().faults, 0);
  EXPECT_EQ(counted.loop().device().lifecycle(), numen::hal::LifecycleState::kActive);

  sim::AdmittanceRunner r(s, 0, 3);
  for (int k = 0; k < 100; ++k) on_time(r);
  ASSERT_EQ(r.loop().device().lifecycle(), numen::hal::LifecycleState::kActive);
  late(r);
  late(r);
  on_time(r);  // two in a row, then on time: no latch
  late(r);
  late(r);
  EXPECT_EQ(r.summary().faults, 0);
  EXPECT_EQ(r.loop().device().lifecycle(), numen::hal::LifecycleState::kActive);
  late(r);  // the third in a row, period 105: judged by period 106's supervision
  EXPECT_FALSE(r.loop().last_report().entered_safe_stop);
  on_time(r);
  EXPECT_TRUE(r.loop().last_report().entered_safe_stop);
  ASSERT_NE(r.loop().device().first_fault(), nullptr);
  EXPECT_EQ(r.loop().device().first_fault()->cause, numen::hal::FaultCause::kOverruns);
  EXPECT_EQ(r.loop().last_report().controlword, numen::hal::Controlword::kShutdown);
  for (int k = 0; k < 20; ++k) late(r);  // still late: the cause present
  EXPECT_EQ(r.loop().device().lifecycle(), numen::hal::LifecycleState::kFault);
  EXPECT_EQ(r.loop().rearm(), numen::platform::RearmResult::kAccepted);
  late(r);
  EXPECT_EQ(r.loop().device().lifecycle(), numen::hal::LifecycleState::kFault)
      << "the re-arm waits for an on-time period";
  for (int k = 0; k < 5; ++k) on_time(r);
  EXPECT_EQ(r.loop().device().lifecycle(), numen::hal::LifecycleState::kActive);
  const sim::RunSummary sum = r.summary();
  EXPECT_EQ(sum.faults, 1);
  EXPECT_EQ(sum.first_fault, "overruns");
  EXPECT_EQ(sum.first_fault_period, 106);
  EXPECT_NEAR(sum.first_fault_time_s, 0.106 + s.compute_phase_s, 1e-12);
  const sim::RunVerdict v = sim::run_verdict(sum);
  EXPECT_EQ(v.status, sim::ExitStatus::kSafetyStop);
}

// A sensor never heard (every frame lost) latches the safe state with its own cause, named in
// the summary and the verdict (they said an empty "first:").
TEST(AdmittanceScene, ASilentSensorIsNamedAsTheFirstFault) {
  numen::test::TempDir dir;
  const sim::Scene s = admittance_with_bus(dir, "drop_probability = 1.0");
  sim::RunOptions o;
  o.duration_s = 1.0;
  const sim::RunSummary sum = sim::run_scene(s, o);
  ASSERT_GT(sum.faults, 0);
  EXPECT_EQ(sum.first_fault, "force reading timeout");
  EXPECT_GE(sum.first_fault_period, 0);
  EXPECT_LE(sum.first_fault_period, 5);
  bool named = false;
  for (const std::string& reason : sim::run_verdict(sum).reasons)
    named = named || reason.find("latched, first: force reading timeout") != std::string::npos;
  EXPECT_TRUE(named);
}

TEST(AdmittanceScene, LostFramesAreRiddenThroughWithoutASafeStop) {
  // 2 % of the frames dropped both ways: a lost sensor TPDO leaves the other half and the
  // previous one fresh (max age 3 periods), a lost csp RPDO leaves the drive on its last
  // target; the contact is the same.
  numen::test::TempDir dir;
  const sim::Scene s = admittance_with_bus(dir, "drop_probability = 0.02\nseed = 3");
  sim::RunOptions o;
  const sim::RunSummary sum = sim::run_scene(s, o);
  EXPECT_GT(sum.bus_frames_dropped, 500);
  EXPECT_EQ(sum.faults, 0);
  EXPECT_EQ(sum.lifecycle, "active");
  EXPECT_LT(sum.tool_penetration_max_mm, 1.0);
  EXPECT_GT(sum.target_penetration_max_mm, 24.0);
  EXPECT_NEAR(sum.admittance.measured_force_max_n, 5.26, 0.3);
}

TEST(AdmittanceScene, KeysAreCheckedWithTheirPlace) {
  numen::test::TempDir dir;
  const std::string base = std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/admittance.toml";
  std::ifstream in(base);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto load_with = [&](std::string t) {
    const std::string path = (dir.path() / "a.toml").string();
    std::ofstream(path) << t;
    return sim::load_scene(path);
  };
  const auto replace = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    const auto at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return t.replace(at, from.size(), to);
  };
  // coupling admittance without [device.admittance], and the reverse.
  EXPECT_THROW(load_with(replace("[device.admittance]", "[device.feedback]")), sim::InputError);
  EXPECT_THROW(load_with(replace("coupling = \"admittance\"", "coupling = \"god-object\"")),
               sim::InputError);
  // `numen run --coupling` cannot change an admittance scene's coupling, nor make another
  // scene's admittance: the error names the option, not a line of the file.
  for (const auto& [file, override] :
       {std::pair{base, numen::core::CouplingMode::kDirect},
        std::pair{std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/construction.toml",  // no joints:
                  numen::core::CouplingMode::kAdmittance}}) {                     // any build
    sim::SceneOverrides o;
    o.coupling = override;
    try {
      sim::load_scene(file, o);
      ADD_FAILURE() << file << ": the coupling override was taken";
    } catch (const sim::InputError& e) {
      EXPECT_EQ(e.key(), "--coupling") << e.what();
    }
  }
  try {
    load_with(replace("force_scale = 0.001", "force_scale = 0.001\nbogus = 1"));
    ADD_FAILURE() << "no throw";
  } catch (const sim::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bogus"), std::string::npos) << e.what();
  }
  try {
    load_with(replace("node_id = 32", "node_id = 1"));  // force TPDO 0x181 = axis x's encoder
    ADD_FAILURE() << "no throw";
  } catch (const sim::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("force sensor"), std::string::npos) << e.what();
  }
}
