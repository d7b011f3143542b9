// Tests of numen/hal/device/impedance_device.hpp, with the period's order it takes from
// hal::Device (device.hpp: SYNC with its counter, the protocol's frames read before the
// instrument's, read errors): the one gate and clamp of ImpedanceDevice::write() (no valid
// sample, shutdown, the implementation's per-axis permission, axes without a drive, a
// non-finite torque, ±max_torque and the RPDO's range, the per mille sent), the soft start (a
// linear ramp from the first open gate, 0 = unscaled), make_device()'s choice, and no
// allocation in a period of either implementation; the passivity controller in write().
#include "numen/hal/device/impedance_device.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/managed_device.hpp"
#include "numen/hal/device/minimal_device.hpp"
#include "numen/hal/device/safety_supervisor.hpp"
#include "numen/hal/transport/sim_bus.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"
#include "test_constants.hpp"
#include "instrument_fixtures.hpp"

namespace {

using namespace numen::hal;
using numen::test::kMs;
using numen::test::kQ0;

// A protocol whose permission per axis the test sets, taking frames on one COB-ID for itself
// and recording what it is asked to send.
class TestDevice final : public ImpedanceDevice {
 public:
  TestDevice(InstrumentDevice& instrument, Bus& bus) : ImpedanceDevice(instrument, bus) {
    allowed.fill(true);
  }
  DeviceSupervision supervise(std::int64_t, bool) noexcept override { return {}; }

  std::array<bool, kMaxAxes> allowed{};
  int non_finite_axis = -1;
  int sends = 0;
  int protocol_frames = 0;
  SentTorques last;

 private:
  bool take_frame(const CanFrame& f) noexcept override {
    if (f.id != 0x701) return false;
    ++protocol_frames;
    return true;
  }
  bool torque_allowed(int axis) const noexcept override {
    return allowed[static_cast<std::size_t>(axis)];
  }
  void on_non_finite_torque(int axis) noexcept override { non_finite_axis = axis; }
  IoStatus send(const SentTorques& t, std::int64_t) noexcept override {
    ++sends;
    last = t;
    return IoStatus::kOk;
  }
};

/// The default trocar instrument (1 ms period) with a soft start of `soft_start_s`.
DeviceConfig trocar_with_soft_start(double soft_start_s) {
  DeviceConfig c = make_default_trocar_config(1);
  c.soft_start_s = soft_start_s;
  return c;
}

struct ImpedanceRig {
  explicit ImpedanceRig(double soft_start_s = 0.0)
      : ImpedanceRig(trocar_with_soft_start(soft_start_s)) {}
  explicit ImpedanceRig(const DeviceConfig& c)
      : bus(SimBusSettings{}), instrument(c), dev(instrument, bus.controller()) {}

  // The encoders answer with kQ0 (plus `depth` m on the depth axis) at t, then the device
  // reads at t: the period's state.
  const DeviceState& answer_and_read(std::int64_t t, double depth = 0.0) {
    bus.set_time_ns(t);  // the bus stamps the frames it delivers
    for (int i = 0; i < instrument.num_axes(); ++i) {
      const AxisConfig& a = instrument.config().axes[static_cast<std::size_t>(i)];
      const double q = kQ0[i] + (i == TrocarKinematics::kDepth ? depth : 0.0);
      bus.device().write(encode_position_pdo(a.encoder_cob_id, value_to_counts(a, q), t));
    }
    return dev.read(t);
  }
  IoStatus write(std::vector<double> tau) {
    return dev.write(std::span<const double>(tau.data(), tau.size()), 0);
  }
  const AxisConfig& axis(int i) const { return instrument.config().axes[static_cast<std::size_t>(i)]; }

  SimBus bus;
  InstrumentDevice instrument;
  TestDevice dev;
};

TEST(ImpedanceDevice, BeginPeriodWritesSyncWithItsCounter1To240) {
  ImpedanceRig r;
  CanFrame f;
  for (int k = 1; k <= 241; ++k) {
    ASSERT_EQ(r.dev.begin_period(k * kMs), IoStatus::kOk);
    ASSERT_EQ(r.bus.device().read(f), IoStatus::kOk);
    ASSERT_TRUE(is_sync(f));
    ASSERT_EQ(f.len, 1);
    EXPECT_EQ(f.data[0], k <= 240 ? k : 1) << k;
  }
}

TEST(ImpedanceDevice, ReadGivesTheProtocolItsFramesFirstAndTheInstrumentTheRest) {
  ImpedanceRig r;
  CanFrame hb;
  encode_heartbeat(1, NmtState::kOperational, 0, hb);
  r.bus.device().write(hb);
  r.answer_and_read(0);
  EXPECT_EQ(r.dev.protocol_frames, 1);
  EXPECT_EQ(r.instrument.counters().frames_decoded, 5u);
  EXPECT_EQ(r.instrument.counters().frames_unknown_id, 0u);
  EXPECT_TRUE(r.dev.sample().valid);
  r.bus.set_state(BusState::kBusOff);
  EXPECT_TRUE(r.dev.read(kMs).read_error);
}

// read() returns the period's DeviceState: the checked sample as InstrumentDevice::sample()
// left it (values, rates, validity, per-axis faults and freshness), the links' poses, twists
// and Jacobians at its axis values, and the frames read; τ = Σ J_lᵀ w_l of the state's
// Jacobians is the instrument's own map. write(DeviceCommand) sends the torques as
// write(τ) does and reports what went out.
TEST(ImpedanceDevice, ReadReturnsTheCheckedSampleAndItsJacobiansAsTheState) {
  ImpedanceRig r;
  (void)r.answer_and_read(0);
  const DeviceState& s = r.answer_and_read(kMs, 1e-4);
  const DeviceSample& d = r.instrument.last_sample();
  EXPECT_EQ(s.frames_read, 5);
  EXPECT_EQ(s.input_frames, 5);
  EXPECT_FALSE(s.read_error);
  EXPECT_EQ(s.time_ns, kMs);
  EXPECT_TRUE(s.valid);
  EXPECT_TRUE(s.ready);
  EXPECT_EQ(s.faults, d.faults);
  ASSERT_EQ(s.num_axes, r.instrument.num_axes());
  ASSERT_EQ(s.num_links, r.instrument.num_links());
  for (int i = 0; i < s.num_axes; ++i) {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_EQ(s.q[i], d.q[i]);
    EXPECT_EQ(s.qdot[i], d.qdot[i]);
    EXPECT_EQ(s.axis_faults[k], d.axis_faults[k]);
    EXPECT_EQ(s.periods_since_accepted[k], 0u);
  }
  EXPECT_GT(s.qdot[TrocarKinematics::kDepth], 0.0);  // 0.1 mm in one period: the rate moved
  for (int l = 0; l < s.num_links; ++l) {
    const auto k = static_cast<std::size_t>(l);
    EXPECT_EQ(s.link_poses[k].position, d.link_poses[k].position);
    EXPECT_EQ(s.link_twists[k].linear, d.link_twists[k].linear);
    const Jacobian j = l == 0 ? r.instrument.kinematics().jacobian(d.q)
                              : r.instrument.kinematics().link_jacobian(l, d.q);
    EXPECT_EQ(s.link_jacobians[k], j) << "link " << l;
  }
  numen::core::Wrench w;
  w.force = numen::core::Vec3(1.0, -2.0, 3.0);
  w.torque = numen::core::Vec3(0.1, 0.2, -0.3);
  AxisVector by_instrument;
  AxisVector by_state;
  r.instrument.torques_for(std::span<const numen::core::Wrench>(&w, 1), by_instrument);
  torques_from_link_wrenches(std::span<const Jacobian>(s.link_jacobians.data(), 1),
                             std::span<const numen::core::Wrench>(&w, 1), by_state);
  EXPECT_EQ(by_state, by_instrument);
  const std::vector<double> tau{0.1, 0.0, -0.1, 0.0, 0.0};
  DeviceCommand c;
  c.torques = std::span<const double>(tau.data(), tau.size());
  const DeviceOutput& out = r.dev.write(c, kMs);
  EXPECT_EQ(out.status, IoStatus::kOk);
  EXPECT_FALSE(out.gated);
  EXPECT_TRUE(out.torque_commanded);
  EXPECT_EQ(out.ramp, 1.0);
  ASSERT_EQ(out.torque.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(out.torque[i], r.dev.sent_torques().torque[static_cast<int>(i)]);
  EXPECT_EQ(r.dev.sends, 1);
}

// The state holds the instrument's sample whole (DeviceState is a DeviceSample), and the face
// gives what was sent and the conditioning's figures without naming the kind (issue 68).
TEST(ImpedanceDevice, TheFaceHoldsTheSampleWholeAndGivesTheOutputAndItsConditioning) {
  ImpedanceRig r;
  (void)r.answer_and_read(0);
  const DeviceState& s = r.answer_and_read(kMs, 1e-4);
  const DeviceSample& d = r.instrument.last_sample();
  EXPECT_EQ(s.pose.position, d.pose.position);
  EXPECT_EQ(s.twist.linear, d.twist.linear);
  EXPECT_EQ(s.dq, d.dq);
  EXPECT_EQ(s.time_ns, d.time_ns);
  EXPECT_EQ(r.dev.input_frames(), 10u);  // 5 encoder TPDOs in each of the two reads
  const Device& face = r.dev;
  EXPECT_EQ(face.conditioning().torque, &r.dev.torque_counters());
  EXPECT_EQ(face.conditioning().passivity, &r.dev.passivity());
  EXPECT_EQ(face.conditioning().setpoints, nullptr);
  const std::vector<double> tau{0.1, 0.0, -0.1, 0.0, 0.0};
  DeviceCommand c;
  c.torques = std::span<const double>(tau.data(), tau.size());
  const DeviceOutput& out = r.dev.write(c, kMs);
  EXPECT_EQ(&face.output(), &out);
  ASSERT_EQ(face.output().torque.size(), 5u);
  EXPECT_EQ(face.output().torque[0], r.dev.sent_torques().torque[0]);
  EXPECT_EQ(face.conditioning().torque->writes, 1u);
}

TEST(ImpedanceDevice, WriteGatesEveryAxisWithoutAValidSampleOrAfterShutdown) {
  ImpedanceRig r;
  r.dev.read(0);  // no encoder frame: not valid
  ASSERT_FALSE(r.dev.sample().valid);
  r.write({0.1, 0.1, 0.1, 0.1, 0.1});
  EXPECT_TRUE(r.dev.sent_torques().gated);
  EXPECT_TRUE(r.dev.sent_torques().torque.isZero());
  EXPECT_FALSE(r.dev.sent_torques().any());
  EXPECT_EQ(r.dev.sends, 1);  // zeros are still sent
  r.answer_and_read(kMs);
  r.write({0.1, 0.1, 0.1, 0.1, 0.1});
  EXPECT_FALSE(r.dev.sent_torques().gated);
  EXPECT_TRUE(r.dev.sent_torques().any());
  r.dev.shutdown();
  r.answer_and_read(2 * kMs);
  r.write({0.1, 0.1, 0.1, 0.1, 0.1});
  EXPECT_TRUE(r.dev.sent_torques().gated);
  EXPECT_EQ(r.dev.torque_counters().gated_writes, 2u);
  EXPECT_EQ(r.dev.torque_counters().writes, 3u);
}

TEST(ImpedanceDevice, WriteGatesPerAxisOnThePermissionAndOnTheDrive) {
  ImpedanceRig r;
  r.answer_and_read(0);
  r.dev.allowed[TrocarKinematics::kPivotY] = false;
  r.write({0.01, 0.02, 0.03, 0.04, 0.05});
  const SentTorques& s = r.dev.sent_torques();
  for (int i = 0; i < 5; ++i) {
    const double asked = 0.01 * (i + 1);
    const bool on = r.axis(i).has_drive() && i != TrocarKinematics::kPivotY;
    EXPECT_EQ(s.torque[i], on ? asked : 0.0) << i;
    EXPECT_EQ(s.per_mille[static_cast<std::size_t>(i)], on ? torque_per_mille(r.axis(i), asked) : 0)
        << i;
  }
  EXPECT_FALSE(r.axis(TrocarKinematics::kRoll).has_drive());
  EXPECT_FALSE(s.gated);
  EXPECT_EQ(r.dev.last.per_mille, s.per_mille);  // the protocol encodes exactly this
}

TEST(ImpedanceDevice, WriteClampsOnceToMaxTorqueAndCountsPerAxis) {
  ImpedanceRig r;
  r.answer_and_read(0);
  const double big = 1e3;
  r.write({big, -big, 0.0, big, 0.0});
  const SentTorques& s = r.dev.sent_torques();
  int expected = 0;
  for (int i = 0; i < 5; ++i) {
    const AxisConfig& a = r.axis(i);
    if (!a.has_drive()) continue;
    const double want = i == 0 ? torque_limit(a) : i == 1 ? -torque_limit(a) : i == 3 ? torque_limit(a) : 0.0;
    EXPECT_EQ(s.torque[i], want) << i;
    EXPECT_LE(std::abs(s.torque[i]), a.max_torque) << i;
    // What the drive gets back from the RPDO is the clamped torque, to the per mille.
    EXPECT_NEAR(per_mille_to_torque(a, s.per_mille[static_cast<std::size_t>(i)]), s.torque[i],
                0.5e-3 * a.rated_torque + 1e-12)
        << i;
    if (want != 0.0) {
      ++expected;
      EXPECT_EQ(r.dev.torque_counters().axis_saturations[static_cast<std::size_t>(i)], 1u) << i;
    }
  }
  EXPECT_EQ(s.clamped, expected);
  EXPECT_EQ(r.dev.torque_counters().saturations, static_cast<std::uint64_t>(expected));
  EXPECT_GE(expected, 2);
}

TEST(ImpedanceDevice, TorqueLimitIsTheRpdoRangeWhenMaxTorqueIsBeyondIt) {
  AxisConfig a;
  a.rated_torque = 0.01;
  a.max_torque = 1.0;  // 100 000 per mille: beyond int16
  EXPECT_DOUBLE_EQ(torque_limit(a), 0.32767);
  EXPECT_EQ(torque_per_mille(a, torque_limit(a)), 32767);
  a.sign = -1;
  EXPECT_EQ(torque_per_mille(a, torque_limit(a)), -32767);
  EXPECT_EQ(torque_per_mille(a, std::numeric_limits<double>::quiet_NaN()), 0);
  a.max_torque = 0.2;
  EXPECT_EQ(torque_limit(a), 0.2);
}

TEST(ImpedanceDevice, NonFiniteTorqueOnAnAllowedAxisZeroesEveryAxisAndIsReported) {
  ImpedanceRig r;
  r.answer_and_read(0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  r.write({0.05, 0.05, nan, 0.05, 0.05});
  EXPECT_TRUE(r.dev.sent_torques().gated);
  EXPECT_TRUE(r.dev.sent_torques().torque.isZero());
  EXPECT_EQ(r.dev.non_finite_axis, 2);
  EXPECT_EQ(r.dev.torque_counters().non_finite, 1u);
  // On an axis that is gated anyway (no drive: roll) it is not looked at.
  r.dev.non_finite_axis = -1;
  r.write({0.05, 0.05, 0.05, nan, 0.05});
  EXPECT_FALSE(r.dev.sent_torques().gated);
  EXPECT_EQ(r.dev.non_finite_axis, -1);
  EXPECT_EQ(r.dev.sent_torques().torque[TrocarKinematics::kRoll], 0.0);
}

// ---- soft start (DeviceConfig::soft_start_s): r = min(1, k dt / T) from the first open gate

TEST(ImpedanceDevice, SoftStartRampsTheClampedTorquesInLinearlyFromTheFirstOpenGate) {
  ImpedanceRig r(0.01);    // T = 10 periods of 1 ms
  const double big = 1e3;  // clamped to max_torque on pivot_x
  const std::vector<double> tau = {big, -0.05, 0.2, 0.0, 0.0};
  // No valid sample yet: gated, the ramp has not begun (r = 0 until torque is enabled).
  r.dev.read(0);
  r.write(tau);
  EXPECT_TRUE(r.dev.sent_torques().gated);
  EXPECT_EQ(r.dev.sent_torques().ramp, 0.0);
  EXPECT_EQ(r.dev.torque_counters().soft_starts, 0u);
  std::array<double, 5> last{};
  for (int k = 1; k <= 14; ++k) {
    SCOPED_TRACE("write " + std::to_string(k) + " since the gate opened");
    r.answer_and_read(k * kMs);
    r.write(tau);
    const SentTorques& s = r.dev.sent_torques();
    const double ramp = std::min(1.0, k * 0.1);
    EXPECT_FALSE(s.gated);
    EXPECT_DOUBLE_EQ(s.ramp, ramp);
    for (int i = 0; i < 5; ++i) {
      const AxisConfig& a = r.axis(i);
      const double lim = torque_limit(a);
      const double full = a.has_drive() ? std::clamp(tau[static_cast<std::size_t>(i)], -lim, lim) : 0.0;
      EXPECT_EQ(s.torque[i], s.ramp * full) << i;  // the clamp first, then r
      EXPECT_EQ(s.per_mille[static_cast<std::size_t>(i)], torque_per_mille(a, s.ramp * full)) << i;
      // The slope: no axis rises by more than max_torque · dt / T in one period.
      EXPECT_LE(std::abs(s.torque[i] - last[static_cast<std::size_t>(i)]), 0.1 * lim + 1e-15) << i;
      last[static_cast<std::size_t>(i)] = s.torque[i];
    }
    EXPECT_EQ(s.clamped, 1);  // pivot_x: the clamp still counts what it clamped
  }
  EXPECT_EQ(r.dev.torque_counters().soft_starts, 1u);
  EXPECT_EQ(r.dev.torque_counters().ramped_writes, 9u);  // r = 0.1 … 0.9
}

TEST(ImpedanceDevice, SoftStartRunsOnThroughAGatedPeriodWithoutBeginningAgain) {
  ImpedanceRig r(0.005);  // 5 periods
  const std::vector<double> tau = {0.1, 0.1, 0.1, 0.0, 0.0};
  r.answer_and_read(0);
  r.write(tau);
  EXPECT_DOUBLE_EQ(r.dev.sent_torques().ramp, 0.2);
  r.answer_and_read(kMs);
  r.dev.allowed.fill(false);  // the protocol forbids torque for one period: every axis gated
  r.write(tau);
  r.dev.allowed.fill(true);
  EXPECT_TRUE(r.dev.sent_torques().gated);
  EXPECT_TRUE(r.dev.sent_torques().torque.isZero());
  // The ramp is a function of time since torque was enabled: a gated period counts.
  r.answer_and_read(2 * kMs);
  r.write(tau);
  EXPECT_DOUBLE_EQ(r.dev.sent_torques().ramp, 0.6);
  for (int k = 3; k < 8; ++k) {
    r.answer_and_read(k * kMs);
    r.write(tau);
  }
  EXPECT_EQ(r.dev.sent_torques().ramp, 1.0);
  EXPECT_EQ(r.dev.sent_torques().torque[0], 0.1);
  EXPECT_EQ(r.dev.torque_counters().soft_starts, 1u);
}

TEST(ImpedanceDevice, SoftStartOfZeroSendsTheClampedTorquesUnscaled) {
  ImpedanceRig r;  // soft_start_s = 0: the hal default
  ASSERT_EQ(r.instrument.config().soft_start_s, 0.0);
  const std::vector<double> tau = {1e3, -0.0123456789, 0.2, 0.0, 0.0};
  for (int k = 0; k < 5; ++k) {
    r.answer_and_read(k * kMs);
    r.write(tau);
    const SentTorques& s = r.dev.sent_torques();
    EXPECT_EQ(s.ramp, 1.0);
    for (int i = 0; i < 5; ++i) {
      const AxisConfig& a = r.axis(i);
      const double lim = torque_limit(a);
      const double want = a.has_drive() ? std::clamp(tau[static_cast<std::size_t>(i)], -lim, lim) : 0.0;
      EXPECT_EQ(s.torque[i], want) << i;  // bit for bit, from the first open period on
    }
  }
  EXPECT_EQ(r.dev.torque_counters().soft_starts, 0u);
  EXPECT_EQ(r.dev.torque_counters().ramped_writes, 0u);
}

TEST(ImpedanceDevice, MakeDeviceFollowsTheConfiguredProtocol) {
  SimBus bus(SimBusSettings{});
  DeviceConfig m = make_default_trocar_config(1);
  m.canopen.managed = false;
  InstrumentDevice minimal(m);
  const auto a = make_device(minimal, bus.controller(), 1'000'000);
  EXPECT_NE(dynamic_cast<MinimalDevice*>(a.get()), nullptr);
  EXPECT_FALSE(a->report().managed);  // no CANopen master, no supervisor
  EXPECT_EQ(a->report().lifecycle, LifecycleState::kUnconfigured);
  EXPECT_TRUE(a->notes().drive_states.empty());
  EXPECT_EQ(a->rearm(), RearmResult::kMinimalProtocol);
  EXPECT_EQ(a->activate(), LifecycleResult::kNotInactive);
  DeviceConfig c = make_default_trocar_config(1);
  c.canopen.managed = true;
  InstrumentDevice managed(c);
  const auto b = make_device(managed, bus.controller(), 1'000'000);
  ASSERT_NE(dynamic_cast<ManagedDevice*>(b.get()), nullptr);
  ASSERT_NE(dynamic_cast<ManagedDevice*>(b.get())->canopen(), nullptr);
  ASSERT_NE(dynamic_cast<ManagedDevice*>(b.get())->supervisor(), nullptr);
  EXPECT_TRUE(b->report().managed);
  EXPECT_EQ(b->report().lifecycle, LifecycleState::kInactive);
  EXPECT_EQ(b->notes().drive_states.size(), 3u);  // the trocar's three driven axes
  EXPECT_EQ(b->lifecycle(), LifecycleState::kInactive);  // configured at construction
  EXPECT_EQ(b->rearm(), RearmResult::kNotLatched);
  EXPECT_THROW(make_device(managed, bus.controller(), 0), std::invalid_argument);
}

// The passivity controller runs in write() after the gate and before the clamp: on the depth
// axis, moving at 20 mm/s under a torque that pushes along the motion (an active render), the
// controller adds damping from the first period E < 0, every write's E is the energy of what
// was sent (Σ −T τ_sent v, v the backward difference of the axis value), and it stays >= 0;
// the clamp still bounds the sent torque.
TEST(ImpedanceDevice, PassivityControllerDampsAnActiveRenderBeforeTheClamp) {
  DeviceConfig c = make_default_trocar_config(1);
  c.passivity.enabled = true;
  c.passivity.axis_mask = 1u << TrocarKinematics::kDepth;
  c.passivity.velocity_threshold = 1e-4;
  ImpedanceRig r(c);
  constexpr int kD = TrocarKinematics::kDepth;
  const double v = 0.02, lim = torque_limit(r.axis(kD));
  double energy = 0.0, q_prev = 0.0;
  for (int k = 0; k < 300; ++k) {
    SCOPED_TRACE("period " + std::to_string(k));
    r.answer_and_read(k * kMs, v * k * 1e-3);
    // Pushing along the motion; beyond the clamp for k >= 200.
    const double push = k < 200 ? 2.0 : 2.0 * lim;
    r.write({0.01, 0.0, push, 0.0, 0.0});
    const SentTorques& s = r.dev.sent_torques();
    // The controller's rate: the backward difference of the axis value (0 at the first sample).
    const double q = r.dev.sample().q[kD];
    const double rate = k == 0 ? 0.0 : (q - q_prev) / 1e-3;
    q_prev = q;
    energy -= 1e-3 * s.torque[kD] * rate;
    EXPECT_NEAR(r.dev.passivity().energy(kD), energy, 1e-12);
    EXPECT_GE(r.dev.passivity().energy(kD), -1e-12);
    EXPECT_LE(std::abs(s.torque[kD]), lim);
    EXPECT_EQ(s.torque[0], 0.01);  // pivot_x is outside the mask: untouched
    if (r.dev.passivity().damping(kD) > 0.0) {
      EXPECT_LT(s.torque[kD], std::min(push, lim));
    }
  }
  EXPECT_GT(r.dev.passivity().counters().acting_periods, 250u);
  EXPECT_GT(r.dev.passivity().counters().dissipated_j, 0.0);
  EXPECT_EQ(r.dev.passivity().counters().axis_acting_periods[0], 0u);
}

// Off (the default): write() has no controller.
TEST(ImpedanceDevice, PassivityControllerIsOffByDefault) {
  ImpedanceRig r;
  EXPECT_EQ(r.dev.passivity().num_axes(), 0);
  for (int k = 0; k < 10; ++k) {
    r.answer_and_read(k * kMs, 1e-4 * k);
    r.write({0.0, 0.0, 2.0, 0.0, 0.0});
    EXPECT_EQ(r.dev.sent_torques().torque[TrocarKinematics::kDepth], 2.0);
  }
}

// Both protocols against the device emulator: begin_period, read, supervise, write over 2000
// periods without one allocation; the managed stack reaches kActive and sends torque. A soft
// start of 0.5 s puts the ramp's periods under the counter.
TEST(ImpedanceDevice, PeriodsOfBothProtocolsNeverAllocate) {
  for (bool managed : {false, true}) {
    DeviceConfig c = make_default_trocar_config(1);
    c.canopen.managed = managed;
    c.soft_start_s = 0.5;
    c.passivity.enabled = true;  // the controller runs in every write
    c.passivity.axis_mask = 0b111;
    SimBusSettings bs;
    bs.latency_ns = 100'000;
    SimBus bus(bs);
    InstrumentDevice instrument(c);
    DeviceEmulator emulator(c);
    emulator.set_axis_values(std::vector<double>(kQ0, kQ0 + 5).data());
    const auto dev = make_device(instrument, bus.controller(), kMs);
    std::vector<double> tau = {0.02, -0.02, 0.5, 0.0, 0.01};
    int torque_periods = 0;
    std::int64_t allocations = 0;
    {
      numen::test::AllocationGuard guard;
      for (int k = 0; k < 2000; ++k) {
        const std::int64_t t = k * kMs;
        bus.set_time_ns(t);
        dev->begin_period(t);
        bus.set_time_ns(t + 200'000);
        emulator.poll(bus.device());
        emulator.tick(t + 200'000, bus.device());
        bus.set_time_ns(t + 400'000);
        dev->read(t + 400'000);
        dev->supervise(t + 400'000, false);
        dev->write(std::span<const double>(tau.data(), tau.size()), t + 400'000);
        torque_periods += dev->sent_torques().any() ? 1 : 0;
      }
      allocations = guard.count();
    }
    EXPECT_EQ(allocations, 0) << (managed ? "managed" : "minimal");
    EXPECT_GT(torque_periods, 1500) << (managed ? "managed" : "minimal");
    EXPECT_EQ(dev->torque_counters().soft_starts, 1u) << (managed ? "managed" : "minimal");
    EXPECT_EQ(dev->torque_counters().ramped_writes, 499u) << (managed ? "managed" : "minimal");
    if (managed) {
      EXPECT_EQ(dev->lifecycle(), LifecycleState::kActive);
    }
  }
}

}  // namespace
