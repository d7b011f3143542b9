// Tests of numen/platform/period_stages.hpp and period_data.hpp, in the manner of core's
// StepStages: the two stage lists run every stage once, in order; PeriodData's writer table
// lists each field once; and, period after period of a running loop of either kind, each
// stage writes only the PeriodData fields whose writer it is (bytes compared field by field
// before and after each stage), while every stage is seen to write some field of its own.
#include "numen/platform/period_stages.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "control_loop_fixtures.hpp"
#include "fixed_motion.hpp"
#include "numen/hal/device/bus_filters.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/emulation/admittance_emulator.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/transport/bus_share.hpp"
#include "numen/platform/control_loop.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace period_stages_test {  // named: the unity build shares a TU with other test files

namespace core = numen::core;
namespace hal = numen::hal;
namespace platform = numen::platform;
using platform::PeriodStage;

constexpr std::uint16_t stage_bit(PeriodStage s) { return static_cast<std::uint16_t>(s); }

/// Checks each stage against the writer table: the bytes of every field before and after it,
/// per record (a loop of several devices shows each device's record after each stage).
class WriterCheck final : public platform::PeriodObserver {
 public:
  explicit WriterCheck(const platform::PeriodData& p) { snapshot(p, before_[&p]); }
  /// Also watches `p` (another device's record).
  void watch(const platform::PeriodData& p) { snapshot(p, before_[&p]); }

  /// The begin stage (begin_period(), outside end_period()).
  void after_begin(const platform::PeriodData& p) { compare(PeriodStage::kBegin, "begin", p); }
  void after_stage(const platform::PeriodStageEntry& stage,
                   const platform::PeriodData& p) noexcept override {
    compare(stage.stage, stage.name, p);
    order_.push_back(stage.stage);
  }

  std::vector<std::string> violations;   ///< "stage wrote field" (must stay empty).
  std::uint16_t stages_that_wrote = 0;   ///< Stages seen writing a field of their own.
  std::vector<PeriodStage> order_;       ///< The stages end_period() ran, in order.

 private:
  static void snapshot(const platform::PeriodData& p, std::vector<unsigned char>& out) {
    out.assign(sizeof p, 0);
    std::memcpy(out.data(), static_cast<const void*>(&p), sizeof p);
  }
  void compare(PeriodStage s, const char* name, const platform::PeriodData& p) {
    std::vector<unsigned char> now;
    snapshot(p, now);
    std::vector<unsigned char>& before = before_.at(&p);
    for (const platform::PeriodField& f : platform::period_data_fields()) {
      if (f.writers == 0) continue;  // the whole report: its fields are listed one by one
      if (std::memcmp(before.data() + f.offset, now.data() + f.offset, f.size) == 0) continue;
      if ((f.writers & stage_bit(s)) == 0)
        violations.push_back(std::string(name) + " wrote " + f.name);
      else
        stages_that_wrote |= stage_bit(s);
    }
    before = std::move(now);
  }
  std::map<const platform::PeriodData*, std::vector<unsigned char>> before_;
};

void expect_stage_list(std::span<const platform::PeriodStageEntry> list) {
  ASSERT_EQ(list.size(), 7u);
  const PeriodStage order[] = {PeriodStage::kRead, PeriodStage::kSupervise, PeriodStage::kBind,
                               PeriodStage::kStep, PeriodStage::kMap,       PeriodStage::kSend,
                               PeriodStage::kFinish};
  std::set<std::string> names;
  for (std::size_t i = 0; i < list.size(); ++i) {
    EXPECT_EQ(list[i].stage, order[i]) << list[i].name;
    EXPECT_NE(list[i].run, nullptr);
    EXPECT_TRUE(names.insert(list[i].name).second) << list[i].name;
  }
}

TEST(PeriodStages, EachListRunsEveryStageOnceInPeriodOrder) {
  expect_stage_list(platform::impedance_period_stages());
  expect_stage_list(platform::admittance_period_stages());
  // The kind's own stages differ, the shared ones are the same functions.
  const auto imp = platform::impedance_period_stages();
  const auto adm = platform::admittance_period_stages();
  EXPECT_NE(imp[2].run, adm[2].run);  // bind
  EXPECT_NE(imp[4].run, adm[4].run);  // map
  for (std::size_t i : {0u, 1u, 3u, 5u, 6u}) EXPECT_EQ(imp[i].run, adm[i].run) << imp[i].name;
}

TEST(PeriodStages, WriterTableListsEachFieldOnceWithOneWriter) {
  std::set<std::string> names;
  std::set<std::size_t> offsets;
  for (const platform::PeriodField& f : platform::period_data_fields()) {
    EXPECT_TRUE(names.insert(f.name).second) << f.name;
    EXPECT_GT(f.size, 0u) << f.name;
    EXPECT_LE(f.offset + f.size, sizeof(platform::PeriodData)) << f.name;
    if (f.writers == 0) {
      EXPECT_EQ(std::string(f.name), "report");  // the only entry without a writer of its own
      continue;
    }
    EXPECT_TRUE(offsets.insert(f.offset).second) << f.name;
    const int bits = __builtin_popcount(f.writers);
    // One writer each; PeriodData::wrench is bind's (admittance) or map's (impedance).
    EXPECT_EQ(bits, std::string(f.name) == "wrench" ? 2 : 1) << f.name;
    EXPECT_EQ(f.writers & ~0xFFu, 0u) << f.name;
  }
  EXPECT_EQ(names.size(), 38u);
}

using namespace numen::test::control_loop_fixtures;

TEST(PeriodStages, EachStageOfAnImpedancePeriodWritesOnlyItsFields) {
  numen::hal::DeviceConfig config = trocar_config();
  config.soft_start_s = 0.01;  // the send stage's r below 1 at first
  SimBus bus{bus_settings()};
  numen::hal::DeviceEmulator emulator{config};
  numen::hal::InstrumentDevice device{config};
  const core::Model model = small_model();
  core::Data data = core::make_data(model);
  platform::ControlLoop loop{model, data, bus.controller(), device};
  WriterCheck check(loop.period_data());
  double q[5] = {kQ[0], kQ[1], kQ[2], kQ[3], kQ[4]};
  for (std::int64_t k = 0; k < 60; ++k) {
    q[3] = kQ[3] + 0.01 * std::sin(0.2 * static_cast<double>(k));  // the depth moves
    emulator.set_axis_values(q);
    const std::int64_t t = k * kMs;
    bus.set_time_ns(t);
    // Every 10th period stamped with a deadline 10 ms past: LoopStatistics finds it overran.
    const std::int64_t now = platform::monotonic_now_ns();
    if (k % 10 == 5)
      loop.begin_period(t, now - 10'000'000, now);
    else
      loop.begin_period(t, now + 10'000'000, now + 10'000'000);
    check.after_begin(loop.period_data());
    bus.set_time_ns(t + kLatency);
    emulator.poll(bus.device());
    bus.set_time_ns(t + kPhase);
    check.order_.clear();
    loop.end_period(t + kPhase, &check);
    ASSERT_EQ(check.order_.size(), 7u);
    bus.set_time_ns(t + kPhase + kLatency);
    emulator.poll(bus.device());
  }
  for (const std::string& v : check.violations) ADD_FAILURE() << v;
  EXPECT_TRUE(loop.last_report().torque_commanded);  // the period ran through to the drives
  // Every stage was seen to write its own fields (the comparison is not blind) — but the
  // minimal protocol's supervision, which has nothing to supervise (the admittance test below
  // sees that stage write).
  for (PeriodStage s : {PeriodStage::kBegin, PeriodStage::kRead, PeriodStage::kBind,
                        PeriodStage::kStep, PeriodStage::kMap, PeriodStage::kSend,
                        PeriodStage::kFinish})
    EXPECT_NE(check.stages_that_wrote & stage_bit(s), 0) << platform::to_string(s);
}

TEST(PeriodStages, EachStageOfAnAdmittancePeriodWritesOnlyItsFields) {
  const core::Model model = probe_model();
  core::Data data = core::make_data(model);
  hal::DeviceConfig tracker = hal::make_default_pose_tracker_config(1);
  tracker.control_period_s = 1e-3;
  hal::SimBus bus{hal::SimBusSettings{}};
  hal::AdmittanceEmulator emulator(tracker, hal::make_admittance_config(tracker));
  numen::test::FixedMotion motion(6);
  emulator.set_motion(&motion);
  emulator.set_axis_values(hal::AxisVector::Zero(6));
  hal::AdmittanceDevice device(tracker, hal::make_admittance_config(tracker), bus.controller(),
                               hal::AxisVector::Zero(6));
  platform::ControlLoop loop(model, data, device);
  WriterCheck check(loop.period_data());
  for (std::int64_t k = 0; k < 60; ++k) {
    motion.state.handle_wrench.force = core::Vec3(0.5 * std::sin(0.1 * static_cast<double>(k)), 0.2, 0.0);
    const std::int64_t t = k * 1'000'000;
    bus.set_time_ns(t);
    loop.begin_period(t);
    check.after_begin(loop.period_data());
    bus.set_time_ns(t + 100'000);
    emulator.poll(bus.device());
    bus.set_time_ns(t + 300'000);
    check.order_.clear();
    loop.end_period(t + 300'000, &check);
    ASSERT_EQ(check.order_.size(), 7u);
  }
  for (const std::string& v : check.violations) ADD_FAILURE() << v;
  EXPECT_TRUE(loop.last_report().driven);
  for (PeriodStage s : {PeriodStage::kBegin, PeriodStage::kRead, PeriodStage::kSupervise,
                        PeriodStage::kBind, PeriodStage::kStep, PeriodStage::kMap,
                        PeriodStage::kSend, PeriodStage::kFinish})
    EXPECT_NE(check.stages_that_wrote & stage_bit(s), 0) << platform::to_string(s);
}

TEST(PeriodStages, EachStageOfATwoDevicePeriodWritesOnlyItsFieldsInEachDevicesRecord) {
  // Two minimal-protocol trocars on one bus (the loop shares it), one body each: every stage
  // runs over both records, the step once (device 1 takes device 0's stamps: the step stage's
  // own fields), and neither record is written outside its writer table.
  numen::hal::DeviceConfig c0 = trocar_config();
  numen::hal::DeviceConfig c1 = numen::hal::make_default_trocar_config(11);
  c1.canopen.managed = false;
  c1.control_period_s = c0.control_period_s;
  SimBus bus{bus_settings()};
  numen::hal::BusShare device_side(bus.device());
  numen::hal::Bus& port0 = device_side.add_port(numen::hal::device_filters(c0));
  numen::hal::Bus& port1 = device_side.add_port(numen::hal::device_filters(c1));
  numen::hal::DeviceEmulator e0{c0}, e1{c1};
  numen::hal::InstrumentDevice i0{c0}, i1{c1};
  core::Model model = small_model();
  model.bodies.push_back(model.bodies[0]);
  ASSERT_EQ(core::finalize_model(model), "");
  core::Data data = core::make_data(model);
  std::vector<platform::LoopDevice> devices(2);
  devices[0].bus = &bus.controller();
  devices[0].instrument = &i0;
  devices[0].binding = platform::DeviceBinding{{platform::LinkBinding{0, 0, {}}}, {}};
  devices[1].bus = &bus.controller();
  devices[1].instrument = &i1;
  devices[1].binding = platform::DeviceBinding{{platform::LinkBinding{0, 1, {}}}, {}};
  platform::ControlLoop loop(model, data, devices);
  WriterCheck check(loop.period_data(0));
  check.watch(loop.period_data(1));
  e0.set_axis_values(kQ);
  e1.set_axis_values(kQ);
  for (std::int64_t k = 0; k < 60; ++k) {
    const std::int64_t t = k * kMs;
    bus.set_time_ns(t);
    loop.begin_period(t);
    check.after_begin(loop.period_data(0));
    check.after_begin(loop.period_data(1));
    bus.set_time_ns(t + kLatency);
    e0.poll(port0);
    e1.poll(port1);
    bus.set_time_ns(t + kPhase);
    check.order_.clear();
    loop.end_period(t + kPhase, &check);
    ASSERT_EQ(check.order_.size(), 14u);  // 7 stages × 2 devices, stage by stage
    EXPECT_EQ(check.order_[6], PeriodStage::kStep);
    EXPECT_EQ(check.order_[7], PeriodStage::kStep);
    bus.set_time_ns(t + kPhase + kLatency);
    e0.poll(port0);
    e1.poll(port1);
  }
  for (const std::string& v : check.violations) ADD_FAILURE() << v;
  EXPECT_TRUE(loop.last_report(0).torque_commanded);
  EXPECT_TRUE(loop.last_report(1).torque_commanded);
  EXPECT_EQ(loop.last_report(1).step_ns, loop.last_report(0).step_ns);  // one step
  EXPECT_EQ(loop.step_time().count(), 60);
}

}  // namespace period_stages_test
