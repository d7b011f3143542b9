// The multirate god-object's device step on the benchmark ball (tests/support/deformable_ball.hpp:
// an icosphere net of 642 or 2562 nodes on a hidden rigid core, circling on a floor; docs/
// multirate.md, "Deformable god-objects"): the net in the scene loop at 100 Hz, the core in the
// device loop at 1 kHz against the node planes, beside the single-rate step of the whole. Each
// iteration is one 1 kHz period; counters as in multirate_bench.cpp:
//   device_p50_us, device_p99_us   periods without a scene step: what the device loop costs
//   scene_p50_us                   periods with one: scene step + device step
//   single_p50_us                  the single-rate core::step of the same period
//   device_vs_single               device_p50 / single_p50
//
//   ./build/tests/numen_bench --benchmark_filter=multirate_ball

#include <benchmark/benchmark.h>

#include <cstdint>

#include "deformable_ball.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/step.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace {

/// The device step is the core's 6×6 step against the node planes, whatever the net's size.
void multirate_ball(benchmark::State& state) {
  const int subdivisions = static_cast<int>(state.range(0));
  const int ratio = static_cast<int>(state.range(1));
  const numen::core::Model model = numen::test::make_deformable_ball(subdivisions);
  numen::core::Data single_data = numen::core::make_data(model);
  numen::core::MultirateGodObject mr(model, 0, {ratio, 0.002, {}});
  numen::platform::LatencyHistogram device, scene_periods, single;
  std::int64_t k = 0;
  for (auto _ : state) {
    numen::test::set_deformable_ball_target(model, single_data, k);
    std::int64_t t0 = numen::platform::monotonic_now_ns();
    numen::core::step(model, single_data);
    single.record(numen::platform::monotonic_now_ns() - t0);
    numen::test::set_deformable_ball_target(model, mr.device_data(), k);
    t0 = numen::platform::monotonic_now_ns();
    mr.step();
    const std::int64_t t = numen::platform::monotonic_now_ns() - t0;
    state.SetIterationTime(static_cast<double>(t) * 1e-9);
    (k % ratio == 0 ? scene_periods : device).record(t);
    ++k;
  }
  const double single_p50 = static_cast<double>(single.quantile(0.5)) * 1e-3;
  state.counters["nodes"] = model.num_nodes();
  state.counters["device_p50_us"] = static_cast<double>(device.quantile(0.5)) * 1e-3;
  state.counters["device_p99_us"] = static_cast<double>(device.quantile(0.99)) * 1e-3;
  state.counters["scene_p50_us"] = static_cast<double>(scene_periods.quantile(0.5)) * 1e-3;
  state.counters["single_p50_us"] = single_p50;
  state.counters["device_vs_single"] =
      single_p50 > 0.0 ? static_cast<double>(device.quantile(0.5)) * 1e-3 / single_p50 : 0.0;
  state.counters["planes_max"] = static_cast<double>(mr.counters().planes_max);
}

}  // namespace

BENCHMARK(multirate_ball)->Args({3, 10})->Args({4, 10})->UseManualTime()->Iterations(2000);
