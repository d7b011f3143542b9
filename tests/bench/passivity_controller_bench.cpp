/// @file passivity_controller_bench.cpp
/// What the time-domain passivity controller (hal/device/passivity_controller.hpp) costs the
/// loop per period: apply() and sent() of the default trocar's three driven axes (pivot_x,
/// pivot_y, depth), as ImpedanceDevice::write() runs them.
///  - PassivityControllerPeriod/active: a render that produces energy every period (τ along
///    the motion), so the damper acts on every axis (the costlier branch);
///  - PassivityControllerPeriod/passive: a spring being compressed (observer only).
/// Run: ./build/tests/numen_bench --benchmark_filter=PassivityController

#include <benchmark/benchmark.h>

#include <array>
#include <cmath>

#include "numen/hal/device/passivity_controller.hpp"

namespace {

void PassivityControllerPeriod(benchmark::State& state) {
  const bool active = state.range(0) != 0;
  numen::hal::PassivityController pc(5, 1e-3, 0b111);
  std::array<double, 1000> phase{};
  for (std::size_t k = 0; k < phase.size(); ++k) phase[k] = std::sin(2e-3 * static_cast<double>(k));
  std::array<double, 5> tau{};
  std::array<double, 5> rate{};
  std::size_t k = 0;
  for (auto _ : state) {
    const double s = phase[k % phase.size()];
    for (std::size_t i = 0; i < 3; ++i) {
      rate[i] = 0.05 + 0.01 * s;                      // moving into +x on every axis
      tau[i] = active ? 0.5 + 0.1 * s : -0.5 - 0.1 * s;  // along (active) or against the motion
    }
    benchmark::DoNotOptimize(pc.apply(tau, rate));
    pc.sent(tau);
    benchmark::DoNotOptimize(tau.data());
    ++k;
  }
  state.SetLabel(active ? "active" : "passive");
}
BENCHMARK(PassivityControllerPeriod)->Arg(1)->Arg(0);

}  // namespace
