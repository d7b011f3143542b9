/// @file rate_estimator_bench.cpp
/// What the encoder velocity filter (hal/device/rate_estimator.hpp) costs the loop, against the
/// bare backward difference it replaced (the same class with f_c = +∞, no bound: one division):
///  - RateEstimatorUpdate/{filtered,bare}: one axis, one accepted value per iteration (a 2 Hz
///    sine at 1 kHz, quantised to the default trocar's 14-bit pivot).
///  - InstrumentDeviceSample/{filtered,bare}: InstrumentDevice::sample() of the default trocar
///    (5 axes: decode, checks, rates, forward kinematics and link Jacobians), one period per
///    iteration with fresh TPDOs fed untimed; bare = velocity cutoff +∞ (α = 1, no exp).
///  - FoawEstimatorUpdate/{sine,still}: FOAW (foaw_estimator.hpp, window up to 32, band a half
///    count) on the same sine, and on a still axis (every window accepted: the longest search).
/// Run: ./build/tests/numen_bench --benchmark_filter='RateEstimator|Foaw|InstrumentDeviceSample'

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/foaw_estimator.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/rate_estimator.hpp"

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::int64_t kMs = 1'000'000;

double pivot_value(std::int64_t k) {
  const double q = 2.0 * std::numbers::pi / 16384.0;
  return q * std::round(0.3 * std::sin(2.0 * std::numbers::pi * 2.0 * 1e-3 * k) / q);
}

void RateEstimatorUpdate(benchmark::State& state) {
  const bool filtered = state.range(0) != 0;
  numen::hal::RateEstimator r = filtered
                                    ? numen::hal::RateEstimator(
                                          numen::hal::kDefaultVelocityCutoffHz, 10.0, false)
                                    : numen::hal::RateEstimator();
  double values[1000];
  for (std::int64_t k = 0; k < 1000; ++k) values[k] = pivot_value(k);
  std::int64_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(r.update(values[k % 1000], k * kMs));
    ++k;
  }
  state.SetLabel(filtered ? "filtered" : "bare");
}
BENCHMARK(RateEstimatorUpdate)->Arg(1)->Arg(0);

void FoawEstimatorUpdate(benchmark::State& state) {
  const bool sine = state.range(0) != 0;
  const double q = 2.0 * std::numbers::pi / 16384.0;
  numen::hal::FoawEstimator r(numen::hal::kFoawMaxWindow, 0.5 * q, 10.0, false);
  double values[1000];
  for (std::int64_t k = 0; k < 1000; ++k) values[k] = sine ? pivot_value(k) : 0.25;
  std::int64_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(r.update(values[k % 1000], k * kMs));
    ++k;
  }
  state.SetLabel(sine ? "sine" : "still");
}
BENCHMARK(FoawEstimatorUpdate)->Arg(1)->Arg(0);

void InstrumentDeviceSample(benchmark::State& state) {
  const bool filtered = state.range(0) != 0;
  numen::hal::DeviceConfig c = numen::hal::make_default_trocar_config(1);
  if (!filtered) c.velocity_cutoff_hz = kInf;  // same checks (max_speed), α = 1
  numen::hal::InstrumentDevice dev(c);
  const double q0[5] = {0.1, -0.2, 0.1, 0.5, 0.3};
  std::int64_t k = 0;
  for (auto _ : state) {
    state.PauseTiming();
    for (int i = 0; i < 5; ++i) {
      const auto& a = c.axes[static_cast<std::size_t>(i)];
      const double v = q0[i] + 1e-3 * std::sin(1e-2 * static_cast<double>(k + i));
      dev.on_frame(numen::hal::encode_position_pdo(a.encoder_cob_id,
                                                   numen::hal::value_to_counts(a, v), k * kMs));
    }
    state.ResumeTiming();
    benchmark::DoNotOptimize(dev.sample(k * kMs));
    ++k;
  }
  state.SetLabel(filtered ? "filtered" : "bare");
}
BENCHMARK(InstrumentDeviceSample)->Arg(1)->Arg(0);

}  // namespace
