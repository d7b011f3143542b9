// Tests of platform::DeviceRig: the loop's devices assembled in one place — impedance devices
// built for their protocol with their bindings, devices on one bus sharing it (one SYNC per
// bus), an admittance device built or borrowed — and a ControlLoop over a rig its caller owns
// running the same periods as one over a rig it builds itself.
#include "numen/platform/device_rig.hpp"

#include <gtest/gtest.h>

#include <numbers>
#include <stdexcept>
#include <vector>

#include "control_loop_fixtures.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/hal/device/admittance_device.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/platform/control_loop.hpp"

namespace device_rig_test {  // named: the unity build shares a TU with other test files

namespace core = numen::core;
namespace hal = numen::hal;
namespace platform = numen::platform;
namespace fx = numen::test::control_loop_fixtures;

/// The trocar instrument on nodes first_node .. +4 (minimal protocol), 1 kHz.
hal::DeviceConfig instrument_config(std::uint8_t first_node) {
  hal::DeviceConfig c = hal::make_default_trocar_config(first_node);
  c.canopen.managed = false;
  c.trocar.point = core::Vec3(0.0, 0.0, 0.2);
  c.trocar.orientation = core::Quat(Eigen::AngleAxisd(std::numbers::pi, core::Vec3::UnitX()));
  c.control_period_s = 1e-3;
  return c;
}

TEST(DeviceRig, AssemblesImpedanceDevicesWithTheirInstrumentsAndBindings) {
  hal::SimBus bus{fx::bus_settings()};
  hal::InstrumentDevice left(instrument_config(1)), right(instrument_config(11));
  std::vector<platform::LoopDevice> devices(2);
  devices[0].bus = &bus.controller();
  devices[0].instrument = &left;
  devices[1].bus = &bus.controller();
  devices[1].instrument = &right;
  devices[1].binding = platform::DeviceBinding{{platform::LinkBinding{0, 1, {}}}, {}};
  platform::DeviceRig rig(devices);
  EXPECT_EQ(rig.kind(), platform::DeviceKind::kImpedance);
  ASSERT_EQ(rig.size(), 2u);
  EXPECT_EQ(rig.instrument(0), &left);
  EXPECT_EQ(rig.instrument(1), &right);
  EXPECT_EQ(rig.binding(1).links.at(0).body, 1);
  EXPECT_EQ(rig.admittance(), nullptr);
  EXPECT_EQ(rig.period_ns(), 1'000'000);
  // Two devices on one bus: the first sends the period's SYNC, the second does not.
  bus.set_time_ns(0);
  (void)rig.device(0).begin_period(0);
  (void)rig.device(1).begin_period(0);
  EXPECT_EQ(bus.pending(hal::SimBus::Direction::kControllerToDevice), 1u);
  // The face reports the output before any write: its defaults.
  EXPECT_TRUE(rig.device(0).output().gated);
  EXPECT_TRUE(rig.device(0).output().torque.empty());
  // ... and the impedance kind's conditioning.
  EXPECT_NE(rig.device(0).conditioning().torque, nullptr);
  EXPECT_NE(rig.device(0).conditioning().passivity, nullptr);
}

TEST(DeviceRig, RefusesDevicesItCannotAssemble) {
  hal::SimBus bus{fx::bus_settings()};
  hal::InstrumentDevice a(instrument_config(1));
  hal::DeviceConfig slow = instrument_config(11);
  slow.control_period_s = 2e-3;
  hal::InstrumentDevice b(slow);
  EXPECT_THROW(platform::DeviceRig{std::span<const platform::LoopDevice>{}},
               std::invalid_argument);
  std::vector<platform::LoopDevice> no_bus(1);
  no_bus[0].instrument = &a;
  EXPECT_THROW(platform::DeviceRig{no_bus}, std::invalid_argument);
  std::vector<platform::LoopDevice> two_periods(2);
  two_periods[0].bus = two_periods[1].bus = &bus.controller();
  two_periods[0].instrument = &a;
  two_periods[1].instrument = &b;
  EXPECT_THROW(platform::DeviceRig{two_periods}, std::invalid_argument);
}

TEST(DeviceRig, BuildsOrBorrowsOneAdmittanceDevice) {
  hal::SimBus bus{fx::bus_settings()};
  hal::DeviceConfig tracker = hal::make_default_pose_tracker_config(1);
  tracker.control_period_s = 1e-3;
  platform::DeviceRig built(tracker, hal::make_admittance_config(tracker), bus.controller(),
                            hal::AxisVector::Zero(6), hal::AdmittanceSettings{});
  EXPECT_EQ(built.kind(), platform::DeviceKind::kAdmittance);
  EXPECT_EQ(built.size(), 1u);
  ASSERT_NE(built.admittance(), nullptr);
  EXPECT_EQ(&built.device(), static_cast<const hal::Device*>(built.admittance()));
  EXPECT_EQ(built.instrument(), nullptr);
  EXPECT_EQ(built.device().conditioning().torque, nullptr);  // it sends no torque
  EXPECT_NE(built.device().conditioning().setpoints, nullptr);
  hal::AdmittanceDevice own(tracker, hal::make_admittance_config(tracker), bus.controller());
  platform::DeviceRig borrowed(own);
  EXPECT_EQ(borrowed.admittance(), &own);
  EXPECT_EQ(&borrowed.device(), &own);
}

TEST(DeviceRig, ALoopOverTheCallersRigRunsAsALoopThatBuildsItsOwn) {
  const core::Model model = fx::small_model();
  const hal::DeviceConfig config = fx::trocar_config();
  struct Side {
    hal::SimBus bus{fx::bus_settings()};
    hal::InstrumentDevice instrument;
    hal::DeviceEmulator emulator;
    explicit Side(const hal::DeviceConfig& c) : instrument(c), emulator(c) {}
  };
  Side own(config), given(config);
  core::Data own_data = core::make_data(model), given_data = core::make_data(model);
  platform::ControlLoop built(model, own_data, own.bus.controller(), own.instrument);
  const platform::LoopDevice device{&given.bus.controller(), &given.instrument,
                                    platform::DeviceBinding::rigid(), {}};
  platform::DeviceRig rig(std::span<const platform::LoopDevice>(&device, 1));
  platform::ControlLoop over(model, given_data, rig);
  EXPECT_EQ(&over.rig(), &rig);
  EXPECT_EQ(&over.device(), &rig.device());
  for (std::int64_t k = 0; k < 50; ++k) {
    const std::int64_t t = k * fx::kMs;
    double q[5];
    for (int i = 0; i < 5; ++i) q[i] = fx::kQ[i] + 1e-3 * static_cast<double>(k);
    for (Side* s : {&own, &given}) {
      s->emulator.set_axis_values(q);
      s->bus.set_time_ns(t);
    }
    built.begin_period(t);
    over.begin_period(t);
    for (Side* s : {&own, &given}) {
      s->bus.set_time_ns(t + fx::kLatency);
      s->emulator.poll(s->bus.device());
      s->bus.set_time_ns(t + fx::kPhase);
    }
    const platform::PeriodReport& a = built.end_period(t + fx::kPhase);
    const platform::PeriodReport& b = over.end_period(t + fx::kPhase);
    ASSERT_EQ(a.sample_valid, b.sample_valid) << "period " << k;
    ASSERT_EQ(a.feedback.force, b.feedback.force) << "period " << k;
    ASSERT_EQ(own_data.bodies[0].position, given_data.bodies[0].position) << "period " << k;
  }
  EXPECT_TRUE(over.last_report().sample_valid);
}

}  // namespace device_rig_test
