// The multirate god-object's device step with a needle (issue 69; docs/multirate-suturing.md,
// "A needle in the device loop"): the puncture rig of tests/support/needle_rig.hpp — a 26 mm
// half-circle needle weighted to 20 g, held by the device and turned along its arc through a
// 28 × 28 mm patch of tissue (the shipped organ's constants per spring) — with the needle in the
// device loop at 10 kHz and the patch in the scene loop at 1 kHz, beside the single-rate step of
// the whole at 10 kHz, alternated period by period (same machine state). One iteration is one
// 10 kHz period; the run is one pass, 45 000 periods (4.5 s): the approach, the tip pressing,
// the puncture, the slide on the puncture ties, the exit. Counters:
//   device_p50_us, device_p99_us   periods without a scene step: what the device loop costs
//   tied_p50_us                    those of them holding the needle on its puncture ties
//                                  (Data::num_sliding_ties > 0 in the device loop)
//   scene_p50_us                   periods with a scene step: scene step + device step
//   single_p50_us                  the single-rate core::step of the same period
//   device_vs_single               device_p50 / single_p50
//   punctures, exits               what the multirate pass made (1 and 1: it went through)
//
//   ./build/tests/numen_bench --benchmark_filter=multirate_needle
//
// The rig's helpers record a bad model as a GoogleTest failure (they are the tests' own); the
// benchmark refuses to run on one.

#include <benchmark/benchmark.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/step.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/monotonic_clock.hpp"
#include "needle_rig.hpp"

namespace {

void multirate_needle(benchmark::State& state) {
  namespace core = numen::core;
  const int ratio = static_cast<int>(state.range(0));
  const core::Model model = numen::test::weighted_puncture_rig(0.02, 1e-4);
  if (::testing::UnitTest::GetInstance()->ad_hoc_test_result().Failed())
    throw std::runtime_error("multirate_needle: the puncture rig's model was refused (printed above)");
  core::Data single_data = core::make_data(model);
  core::MultirateSettings settings;
  settings.ratio = ratio;
  settings.margin = 5e-4;  // as MultirateNeedle's: ≥ 8.3 mm/s × 1 ms, and the wire's radius
  core::MultirateGodObject mr(model, 1, settings);
  numen::platform::LatencyHistogram device, tied, scene_periods, single;
  constexpr double kOmega = 1.0;  // rad/s: the tip at 8.3 mm/s (MultirateNeedle's pass)
  constexpr double kTurn = 230 * numen::test::kPunctureDeg;
  std::int64_t k = 0;
  for (auto _ : state) {
    const double t = static_cast<double>(k) * model.dt;
    numen::test::puncture_drive(model, single_data, t, kOmega, kTurn);
    std::int64_t t0 = numen::platform::monotonic_now_ns();
    core::step(model, single_data);
    single.record(numen::platform::monotonic_now_ns() - t0);
    numen::test::puncture_drive(model, mr.device_data(), t, kOmega, kTurn);
    t0 = numen::platform::monotonic_now_ns();
    mr.step();
    const std::int64_t dt_ns = numen::platform::monotonic_now_ns() - t0;
    state.SetIterationTime(static_cast<double>(dt_ns) * 1e-9);
    if (k % ratio == 0) {
      scene_periods.record(dt_ns);
    } else {
      device.record(dt_ns);
      if (mr.device_data().num_sliding_ties > 0) tied.record(dt_ns);
    }
    ++k;
  }
  core::Data view = core::make_data(model);
  mr.view(view);
  const double single_p50 = static_cast<double>(single.quantile(0.5)) * 1e-3;
  const double device_p50 = static_cast<double>(device.quantile(0.5)) * 1e-3;
  state.counters["nodes"] = model.num_nodes();
  state.counters["device_p50_us"] = device_p50;
  state.counters["device_p99_us"] = static_cast<double>(device.quantile(0.99)) * 1e-3;
  state.counters["tied_p50_us"] = static_cast<double>(tied.quantile(0.5)) * 1e-3;
  state.counters["tied_periods"] = static_cast<double>(tied.count());
  state.counters["scene_p50_us"] = static_cast<double>(scene_periods.quantile(0.5)) * 1e-3;
  state.counters["single_p50_us"] = single_p50;
  state.counters["device_vs_single"] = single_p50 > 0.0 ? device_p50 / single_p50 : 0.0;
  state.counters["punctures"] = static_cast<double>(view.needles[0].punctures_made);
  state.counters["exits"] = static_cast<double>(view.needles[0].exits);
}

}  // namespace

BENCHMARK(multirate_needle)->Arg(10)->UseManualTime()->Iterations(45000);
