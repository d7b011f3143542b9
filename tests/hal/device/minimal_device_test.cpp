// Tests of numen/hal/device/minimal_device.hpp: the minimal protocol's sending half of hal::Device —
// InstrumentDevice::torques_for() (τ = Σ_l J_lᵀ w_l) then ImpedanceDevice::write(): one torque RPDO per
// driven axis, the gate (not ready, non-finite, no drive) and the per-axis clamp, bus failures,
// no allocation; on the trocar and on a phantom arm with drives on three of its six axes.
#include "numen/hal/device/minimal_device.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>

#include "alloc_counter.hpp"
#include "instrument_fixtures.hpp"
#include "kinematics_check.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/phantom_kinematics.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"
#include "test_constants.hpp"

namespace {

using namespace numen::hal;
using numen::core::Vec3;
using numen::core::Wrench;
using TK = TrocarKinematics;
using numen::test::feed;
using numen::test::kP0;
using numen::test::kQ0;
using numen::test::phantom_config;
using numen::test::some_link_wrenches;
using numen::test::trocar_config;
using numen::test::kMs;

// A MinimalDevice on `bus`'s controller port around `inst`: map (torques_for), then write().
class Sender {
 public:
  Sender(InstrumentDevice& inst, SimBus& bus) : inst_(&inst), dev_(inst, bus.controller()) {}
  IoStatus command_links(std::span<const Wrench> w, std::int64_t now_ns) {
    AxisVector tau;
    inst_->torques_for(w, tau);
    return dev_.write(std::span<const double>(tau.data(), static_cast<std::size_t>(tau.size())),
                      now_ns);
  }
  IoStatus command(const Wrench& w, std::int64_t now_ns) {
    return command_links(std::span<const Wrench>(&w, 1), now_ns);
  }
  IoStatus command_zero(std::int64_t now_ns) {
    const AxisVector zero = AxisVector::Zero(inst_->num_axes());
    return dev_.write(std::span<const double>(zero.data(), static_cast<std::size_t>(zero.size())),
                      now_ns);
  }
  const AxisVector& last_torques() const { return dev_.sent_torques().torque; }
  const std::array<std::int16_t, kMaxAxes>& last_torque_per_mille() const {
    return dev_.sent_torques().per_mille;
  }
  std::uint64_t saturations() const { return dev_.torque_counters().saturations; }
  MinimalDevice& device() { return dev_; }

 private:
  InstrumentDevice* inst_;
  MinimalDevice dev_;
};




TEST(MinimalDevice, CommandSendsJTransposeWrenchOnDrivenAxes) {
  DeviceConfig c = trocar_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  Sender tx(dev, bus);
  feed(dev, kQ0, 0);
  const DeviceSample s = dev.sample(0);
  Wrench w;
  w.force = Vec3(0.5, -0.3, 1.0);
  w.torque = Vec3(0.01, 0.02, -0.01);
  ASSERT_EQ(tx.command(w, 7), IoStatus::kOk);
  const AxisVector tau = torques_from_wrench(dev.kinematics().jacobian(s.q), w);
  CanFrame f;
  int frames = 0;
  while (bus.device().read(f) == IoStatus::kOk) {
    ++frames;
    bool found = false;
    for (int i = 0; i < 5; ++i) {
      const AxisConfig& a = c.axes[static_cast<std::size_t>(i)];
      if (!a.has_drive() || a.drive_cob_id != f.id) continue;
      found = true;
      std::int16_t pm = 0;
      ASSERT_EQ(decode_torque_pdo(f, a.drive_cob_id, pm), DecodeStatus::kOk);
      EXPECT_NEAR(per_mille_to_torque(a, pm), tau[i], 0.5e-3 * a.rated_torque + 1e-12) << i;
      EXPECT_DOUBLE_EQ(tx.last_torques()[i], tau[i]);
    }
    EXPECT_TRUE(found) << f.id;
  }
  EXPECT_EQ(frames, 3);  // pivot_x, pivot_y, depth
  EXPECT_EQ(tx.last_torques()[TK::kRoll], 0.0);
  EXPECT_EQ(tx.saturations(), 0u);
}

TEST(MinimalDevice, CommandSaturatesPerAxis) {
  InstrumentDevice dev(trocar_config());
  SimBus bus(SimBusSettings{});
  Sender tx(dev, bus);
  feed(dev, kQ0, 0);
  dev.sample(0);
  Wrench w;
  w.force = Vec3(100, 100, 100);
  tx.command(w, 0);
  EXPECT_GT(tx.saturations(), 0u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_LE(std::abs(tx.last_torques()[i]),
              dev.config().axes[static_cast<std::size_t>(i)].max_torque + 1e-12);
  }
}

TEST(MinimalDevice, ZeroTorqueBeforeReadyForNonFiniteWrenchAndOnCommandZero) {
  InstrumentDevice dev(trocar_config());
  SimBus bus(SimBusSettings{});
  Sender tx(dev, bus);
  Wrench w;
  w.force = Vec3(1, 1, 1);
  dev.sample(0);
  EXPECT_EQ(tx.command(w, 0), IoStatus::kOk);  // not ready
  EXPECT_EQ(tx.last_torques().norm(), 0.0);
  feed(dev, kQ0, 0);
  dev.sample(0);
  tx.command(w, 0);
  EXPECT_GT(tx.last_torques().norm(), 0.0);
  w.force.x() = std::nan("");
  tx.command(w, 0);
  EXPECT_EQ(tx.last_torques().norm(), 0.0);
  EXPECT_EQ(dev.counters().non_finite_wrenches, 1u);
  w.force.x() = 1.0;
  tx.command(w, 0);
  tx.command_zero(0);
  EXPECT_EQ(tx.last_torques().norm(), 0.0);
  // The last three frames on the bus are zeros.
  CanFrame f;
  std::int16_t last_pm[3] = {1, 1, 1};
  int n = 0;
  while (bus.device().read(f) == IoStatus::kOk) {
    std::int16_t pm = 0;
    decode_torque_pdo(f, f.id, pm);
    last_pm[n++ % 3] = pm;
  }
  EXPECT_EQ(n, 15);
  for (std::int16_t pm : last_pm) EXPECT_EQ(pm, 0);
}

TEST(MinimalDevice, CommandReportsBusFailures) {
  InstrumentDevice dev(trocar_config());
  SimBusSettings st;
  st.capacity = 2;
  SimBus bus(st);
  Sender tx(dev, bus);
  EXPECT_EQ(tx.command_zero(0), IoStatus::kWouldBlock);  // 3 drives, room for 2
  bus.set_state(BusState::kBusOff);
  EXPECT_EQ(tx.command_zero(0), IoStatus::kError);
}

using PK = PhantomKinematics;
using numen::core::Pose;
using numen::core::Quat;



// Reads every frame waiting on the device side; returns how many, and the per mille of each
// drive COB-ID 0x200 + node seen (indexed by axis).
int drain(SimBus& bus, const DeviceConfig& c, std::array<std::int16_t, kMaxAxes>& per_mille,
          std::array<int, kMaxAxes>& frames_per_axis) {
  per_mille = {};
  frames_per_axis = {};
  CanFrame f;
  int n = 0;
  while (bus.device().read(f) == IoStatus::kOk) {
    ++n;
    for (std::size_t i = 0; i < c.axes.size(); ++i) {
      const AxisConfig& a = c.axes[i];
      if (!a.has_drive() || a.drive_cob_id != f.id) continue;
      std::int16_t pm = 0;
      EXPECT_EQ(decode_torque_pdo(f, a.drive_cob_id, pm), DecodeStatus::kOk);
      per_mille[i] = pm;
      ++frames_per_axis[i];
    }
  }
  return n;
}


TEST(MinimalDevice, CommandLinksDrivesOnlyTheMotorisedAxes) {
  const DeviceConfig c = phantom_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  Sender tx(dev, bus);
  feed(dev, kP0, 0);
  const DeviceSample s = dev.sample(0);
  ASSERT_TRUE(s.valid);
  const auto w = some_link_wrenches(0.1);
  ASSERT_EQ(tx.command_links(w, 3), IoStatus::kOk);
  const AxisVector tau = numen::test::link_torques(dev.kinematics(), s.q, w);
  std::array<std::int16_t, kMaxAxes> pm{};
  std::array<int, kMaxAxes> frames{};
  EXPECT_EQ(drain(bus, c, pm, frames), 3);  // turret, shoulder, elbow
  for (int i = 0; i < 6; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (i < 3) {
      ASSERT_TRUE(c.axes[k].has_drive());
      EXPECT_EQ(frames[k], 1) << i;
      ASSERT_LT(std::abs(tau[i]), c.axes[k].max_torque) << i;  // not saturated
      EXPECT_NEAR(tx.last_torques()[i], tau[i], 1e-15) << i;
      EXPECT_NEAR(per_mille_to_torque(c.axes[k], pm[k]), tau[i], 0.5e-3 * c.axes[k].rated_torque)
          << i;
      EXPECT_EQ(tx.last_torque_per_mille()[k], pm[k]);
    } else {
      EXPECT_FALSE(c.axes[k].has_drive());
      EXPECT_EQ(frames[k], 0);
      EXPECT_GT(std::abs(tau[i]), 1e-4) << i;  // the gimbal would feel it, but has no motor
      EXPECT_EQ(tx.last_torques()[i], 0.0);
    }
  }
  EXPECT_EQ(tx.saturations(), 0u);
  EXPECT_EQ(dev.counters().commands, 1u);
}

TEST(MinimalDevice, CommandLinksSaturatesPerAxis) {
  const DeviceConfig c = phantom_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  Sender tx(dev, bus);
  feed(dev, kP0, 0);
  const DeviceSample s = dev.sample(0);
  const auto w = some_link_wrenches(40.0);
  tx.command_links(w, 0);
  const AxisVector tau = numen::test::link_torques(dev.kinematics(), s.q, w);
  std::uint64_t expected_saturations = 0;
  for (int i = 0; i < 3; ++i) {
    const AxisConfig& a = c.axes[static_cast<std::size_t>(i)];
    const double clamped = std::clamp(tau[i], -a.max_torque, a.max_torque);
    if (clamped != tau[i]) ++expected_saturations;
    EXPECT_DOUBLE_EQ(tx.last_torques()[i], clamped) << i;
    EXPECT_LE(std::abs(tx.last_torques()[i]), a.max_torque);
  }
  EXPECT_GE(expected_saturations, 2u);  // the check is not vacuous
  EXPECT_EQ(tx.saturations(), expected_saturations);
}

TEST(MinimalDevice, CommandEqualsCommandLinksOfOneWrench) {
  for (const DeviceConfig& c : {phantom_config(), trocar_config()}) {
    InstrumentDevice a(c);
    InstrumentDevice b(c);
    SimBus bus_a(SimBusSettings{});
    SimBus bus_b(SimBusSettings{});
    Sender tx_a(a, bus_a);
    Sender tx_b(b, bus_b);
    const double* q0 = c.kind == DeviceKind::kPhantom ? kP0 : kQ0;
    feed(a, q0, 0);
    feed(b, q0, 0);
    a.sample(0);
    b.sample(0);
    Wrench w;
    w.force = Vec3(0.7, -0.2, 0.4);
    w.torque = Vec3(0.01, -0.03, 0.02);
    tx_a.command(w, 5);
    const std::array<Wrench, 1> one{w};
    tx_b.command_links(one, 5);
    EXPECT_EQ(tx_a.last_torques(), tx_b.last_torques());
    EXPECT_EQ(tx_a.last_torque_per_mille(), tx_b.last_torque_per_mille());
    EXPECT_GT(tx_a.last_torques().norm(), 0.0);
    // Missing entries are zero wrenches.
    const std::array<Wrench, 3> padded{w, Wrench{}, Wrench{}};
    tx_b.command_links(padded, 5);
    EXPECT_EQ(tx_a.last_torques(), tx_b.last_torques());
    // And the frames on the bus are the same.
    CanFrame fa, fb;
    int n = 0;
    while (bus_a.device().read(fa) == IoStatus::kOk) {
      ASSERT_EQ(bus_b.device().read(fb), IoStatus::kOk);
      EXPECT_EQ(fa.id, fb.id);
      EXPECT_EQ(fa.data, fb.data);
      ++n;
    }
    EXPECT_EQ(n, 3);
  }
}

TEST(MinimalDevice, NonFiniteLinkWrenchSendsZeros) {
  const DeviceConfig c = phantom_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  Sender tx(dev, bus);
  feed(dev, kP0, 0);
  dev.sample(0);
  auto w = some_link_wrenches(0.5);
  tx.command_links(w, 0);
  EXPECT_GT(tx.last_torques().norm(), 0.0);
  w[PK::kLinkForearm].torque.y() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(tx.command_links(w, 0), IoStatus::kOk);
  EXPECT_EQ(tx.last_torques().norm(), 0.0);
  EXPECT_EQ(dev.counters().non_finite_wrenches, 1u);
  EXPECT_EQ(tx.device().torque_counters().non_finite, 1u) << "zeroed by write()'s trip, once";
  std::array<std::int16_t, kMaxAxes> pm{};
  std::array<int, kMaxAxes> frames{};
  EXPECT_EQ(drain(bus, c, pm, frames), 6);  // two commands, three drives
  for (int i = 0; i < 3; ++i) EXPECT_EQ(pm[static_cast<std::size_t>(i)], 0) << i;
  // Not ready (after reset): zeros too, whatever the wrench.
  dev.reset();
  w = some_link_wrenches(0.5);
  tx.command_links(w, 0);
  EXPECT_EQ(tx.last_torques().norm(), 0.0);
}

TEST(MinimalDevice, ExtraLinkWrenchesAreIgnoredAndCounted) {
  InstrumentDevice dev(phantom_config());
  SimBus bus(SimBusSettings{});
  Sender tx(dev, bus);
  feed(dev, kP0, 0);
  dev.sample(0);
  const auto w = some_link_wrenches(0.3);
  tx.command_links(w, 0);
  const AxisVector five = tx.last_torques();
  std::array<Wrench, 7> seven{};
  std::copy(w.begin(), w.end(), seven.begin());
  seven[5].force = Vec3(100, 100, 100);
  seven[6].force.x() = std::nan("");  // beyond the links: not even checked
  tx.command_links(seven, 0);
  EXPECT_EQ(tx.last_torques(), five);
  EXPECT_EQ(dev.counters().extra_link_wrenches, 1u);
  EXPECT_EQ(dev.counters().non_finite_wrenches, 0u);
}

TEST(MinimalDevice, SampleAndCommandLinksDoNotAllocate) {
  const DeviceConfig c = phantom_config();
  InstrumentDevice dev(c);
  SimBus bus(SimBusSettings{});
  Sender tx(dev, bus);
  std::array<Wrench, PK::kNumLinks> w{};
  double q[6];
  std::copy(kP0, kP0 + 6, q);
  feed(dev, q, 0);
  dev.sample(0);
  int valid = 0;
  std::int64_t allocations = 0;
  {
    numen::test::AllocationGuard guard;
    CanFrame f;
    for (int k = 1; k <= 1000; ++k) {
      q[0] = kP0[0] + 0.2 * std::sin(0.01 * k);
      q[4] = kP0[4] + 0.3 * std::sin(0.02 * k);
      for (int i = 0; i < 6; ++i) {
        const AxisConfig& a = c.axes[static_cast<std::size_t>(i)];
        dev.on_frame(encode_position_pdo(a.encoder_cob_id, value_to_counts(a, q[i]), k * kMs));
      }
      const DeviceSample s = dev.sample(k * kMs);
      valid += s.valid ? 1 : 0;
      for (int l = 0; l < PK::kNumLinks; ++l) {
        w[static_cast<std::size_t>(l)].force = Vec3(0.1 * l, -0.2, 0.3 * std::sin(0.01 * k));
      }
      tx.command_links(w, k * kMs);
      while (bus.device().read(f) == IoStatus::kOk) {
      }
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(valid, 1000);
  EXPECT_EQ(dev.counters().commands, 1000u);
}

}  // namespace
