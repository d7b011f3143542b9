// Target velocity from encoders through the whole loop (platform/control_loop with a SimBus,
// an emulated pose tracker, hal::InstrumentDevice and core): the three rate estimators
// (DeviceConfig::velocity_estimator: the bare difference, the 50 Hz filter, FOAW) side by side
// on a 1 m target jump (with and without the axes' speed bound) and on a 2 Hz sine, at 1 and
// 10 kHz. Figures: docs/target_velocity.md.
//
// A pose tracker (minimal protocol) holds a rigid body with the default scene's held-body
// coupling (the tube: 50 g, k_t = 1000 N/m, damping ratio 0.85, implicit Euler). The rate held
// at 0 (max_speed 1e-9) gives the coupling spring's own response, which no target-velocity
// estimate can go below on the jump.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

#include "control_loop_fixtures.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace control_loop_target_velocity_test {  // named: the unity build shares a TU

using namespace numen::test::control_loop_fixtures;
using numen::hal::VelocityEstimator;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// One estimator setting of the tracker's device.
struct Setting {
  std::string name;
  VelocityEstimator estimator = VelocityEstimator::kFilter;
  bool bounded = true;               // the tracker's max_speed (5 m/s), else none
  double foaw_noise_counts = 0.5;    // FOAW's band, counts (1 µm each)
  bool zero = false;                 // the rate held at 0 (max_speed 1e-9)
};

/// Runs the loop for `duration_s` at `period_s` with the tracker's x encoder at x(t) (the other
/// axes still); `each(t, x, data)` is called after every period.
void run_tracker(const Setting& s, double period_s, double duration_s,
                 const std::function<double(double)>& x_of_t,
                 const std::function<void(double, double, const numen::core::Data&)>& each) {
  numen::hal::DeviceConfig c = numen::hal::make_default_pose_tracker_config(1);
  c.canopen.managed = false;
  c.control_period_s = period_s;
  c.jump_tolerance_counts = 2e6;  // 2 m at 1 µm per count: a 1 m jump passes the checks
  c.velocity_estimator = s.estimator;
  c.foaw_noise_counts = s.foaw_noise_counts;
  for (auto& a : c.axes) a.max_speed = s.zero ? 1e-9 : s.bounded ? a.max_speed : kInf;
  numen::core::Model m;
  m.dt = period_s;
  m.gravity = Vec3::Zero();
  m.material_names = {"default"};
  m.material_pairs = {numen::core::MaterialPair{}};
  numen::core::BodyModel b;
  b.name = "tube";
  b.mass = 0.05;
  b.inertia_body = 1e-5 * numen::core::Mat3::Identity();
  b.coupling.k_t = 1000.0;
  b.coupling.gamma_t = numen::core::damping_from_ratio(0.85, b.mass, b.coupling.k_t);
  b.coupling.k_r = 1.0;
  b.coupling.gamma_r = numen::core::damping_from_ratio(0.85, 1e-5, b.coupling.k_r);
  b.initial_pose.position = Vec3(x_of_t(0.0), 0.0, 0.0);
  m.bodies.push_back(b);
  m.initial_held_body = 0;
  const std::string err = numen::core::finalize_model(m);
  ASSERT_TRUE(err.empty()) << err;
  numen::core::Data data = numen::core::make_data(m);
  numen::hal::SimBusSettings bs;
  const auto period_ns = static_cast<std::int64_t>(std::llround(period_s * 1e9));
  bs.latency_ns = period_ns / 10;
  SimBus bus(bs);
  numen::hal::DeviceEmulator emulator(c);
  numen::hal::InstrumentDevice device(c);
  ControlLoop loop(m, data, bus.controller(), device);
  double q[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  const int end = static_cast<int>(std::llround(duration_s / period_s));
  for (int k = 0; k < end; ++k) {
    const std::int64_t t = k * period_ns;
    q[0] = x_of_t(static_cast<double>(t) * 1e-9);
    emulator.set_axis_values(q);
    bus.set_time_ns(t);
    loop.begin_period(t);
    bus.set_time_ns(t + bs.latency_ns);
    emulator.poll(bus.device());
    bus.set_time_ns(t + period_ns / 4);
    const PeriodReport& p = loop.end_period(t + period_ns / 4);
    ASSERT_TRUE(p.sample_valid) << s.name << " " << k;
    each(static_cast<double>(t) * 1e-9, q[0], data);
  }
  EXPECT_EQ(device.counters().rejected_jump, 0u) << s.name;
}

struct JumpResult {
  double peak_speed = 0.0;    // m/s, after the jump
  double overshoot_mm = 0.0;  // beyond the new target along x
};

/// The x encoder jumps from −0.5 m to +0.5 m at 50 ms; 0.5 s.
JumpResult jump_response(const Setting& s, double period_s) {
  JumpResult r;
  run_tracker(s, period_s, 0.5, [](double t) { return t < 0.05 - 1e-12 ? -0.5 : 0.5; },
              [&](double t, double, const numen::core::Data& d) {
                if (t < 0.05 - 1e-12) return;
                r.peak_speed = std::max(r.peak_speed, d.bodies[0].linear_velocity.norm());
                r.overshoot_mm = std::max(r.overshoot_mm, (d.bodies[0].position.x() - 0.5) * 1e3);
              });
  return r;
}

/// The x encoder moves 50 mm · sin(2π 2 t) for 3 s; the rms of the held body's x − the hand's
/// x over the last 2 s (whole periods), mm.
double sine_tracking_rms_mm(const Setting& s, double period_s) {
  constexpr double kA = 0.05, kW = 2.0 * numen::test::kPi * 2.0;
  double sum = 0.0;
  int n = 0;
  run_tracker(s, period_s, 3.0, [](double t) { return kA * std::sin(kW * t); },
              [&](double t, double x, const numen::core::Data& d) {
                if (t < 1.0 - 1e-12) return;
                const double e = d.bodies[0].position.x() - x;
                sum += e * e;
                ++n;
              });
  return n > 0 ? std::sqrt(sum / n) * 1e3 : 0.0;
}

const Setting kDifference{"difference", VelocityEstimator::kDifference};
const Setting kFilter{"filter 50 Hz", VelocityEstimator::kFilter};
const Setting kFoawHalf{"foaw d = 0.5 count", VelocityEstimator::kFoaw};
const Setting kFoawOne{"foaw d = 1 count", VelocityEstimator::kFoaw, true, 1.0};

// The bare difference without a bound is what numen did before RateEstimator: a 1 m jump is a
// 1000 (10 000) m/s target velocity. Every bounded estimator feeds the damper at most
// max_speed · Δt = 5 mm worth of motion: within 2 % / 0.3 mm of the spring's own response.
TEST(ControlLoopTargetVelocity, AOneMetreJumpNoLongerKicksTheTool) {
  for (const double period : {1e-3, 1e-4}) {
    const JumpResult spring = jump_response(Setting{"rate 0", VelocityEstimator::kFilter, true, 0.5, true}, period);
    std::printf("[   info   ] %g kHz, 1 m jump: the spring alone (rate 0): %.1f m/s %.2f mm\n",
                1e-3 / period, spring.peak_speed, spring.overshoot_mm);
    for (const Setting& s : {kDifference, kFilter, kFoawHalf, kFoawOne}) {
      Setting unbounded = s;
      unbounded.bounded = false;
      const JumpResult b = jump_response(s, period);
      const JumpResult u = jump_response(unbounded, period);
      std::printf("[   info   ] %g kHz, 1 m jump, %s: bounded %.1f m/s %.2f mm; no bound %.1f m/s "
                  "%.1f mm\n",
                  1e-3 / period, s.name.c_str(), b.peak_speed, b.overshoot_mm, u.peak_speed,
                  u.overshoot_mm);
      EXPECT_LT(b.peak_speed, 1.02 * spring.peak_speed) << s.name << " " << period;
      EXPECT_LT(b.overshoot_mm, spring.overshoot_mm + 0.3) << s.name << " " << period;
      if (s.estimator == VelocityEstimator::kDifference) {
        EXPECT_GT(u.peak_speed, 150.0) << period;
        EXPECT_GT(u.overshoot_mm, 100.0) << period;
        EXPECT_LT(b.peak_speed, u.peak_speed / 3.0) << period;
      }
    }
  }
}

// Free-space tracking of a 2 Hz, 50 mm sine: the coupling's damper is fed the estimate, so its
// lag costs tracking; the bare difference's noise at 1 µm per count is small.
TEST(ControlLoopTargetVelocity, TrackingA2HzSineWithEachEstimator) {
  for (const double period : {1e-3, 1e-4}) {
    const double zero =
        sine_tracking_rms_mm(Setting{"rate 0", VelocityEstimator::kFilter, true, 0.5, true}, period);
    const double diff = sine_tracking_rms_mm(kDifference, period);
    const double filt = sine_tracking_rms_mm(kFilter, period);
    const double half = sine_tracking_rms_mm(kFoawHalf, period);
    const double one = sine_tracking_rms_mm(kFoawOne, period);
    std::printf("[   info   ] %g kHz, 2 Hz 50 mm sine, tracking rms: difference %.4f mm, filter "
                "%.4f mm, foaw d = 0.5 count %.4f mm, d = 1 count %.4f mm; rate 0 %.4f mm\n",
                1e-3 / period, diff, filt, half, one, zero);
    EXPECT_LT(diff, filt) << period;
    EXPECT_LT(filt, zero) << period;
    EXPECT_LT(half, filt) << period;
    EXPECT_LT(one, filt) << period;
  }
}

}  // namespace control_loop_target_velocity_test
