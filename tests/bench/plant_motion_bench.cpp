/// @file plant_motion_bench.cpp
/// What the closed loop's emulated device (sim/device/plant_motion.hpp) costs the emulator per
/// control period, against the replayed hand it replaces (sim/device/trajectory_motion.hpp):
///  - DeviceMotionAtSync/replay: TrajectoryMotion::at_sync (the trajectory's inverse
///    kinematics);
///  - DeviceMotionAtSync/plant/S: PlantMotion::at_sync of the shipped default scene's trainer
///    ([device.plant], [device.hand] defaults) with S sub-steps per period (the default 10, and
///    40): every sub-step the intent's inverse kinematics, the handle's forward kinematics and
///    Jacobian, the hand's wrench, the driven axes' closed-form steps.
/// One 1 ms period per iteration, with torques that change every period.
/// Run: ./build/tests/numen_bench --benchmark_filter=DeviceMotionAtSync

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include "numen/sim/device/plant_motion.hpp"
#include "numen/sim/device/trajectory_motion.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

constexpr std::int64_t kPeriodNs = 1'000'000;

const numen::sim::Scene& trainer() {
  static const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/lattice.toml");
  return scene;
}

void DeviceMotionAtSync(benchmark::State& state) {
  const numen::sim::Scene& scene = trainer();
  const int substeps = static_cast<int>(state.range(0));
  std::unique_ptr<numen::hal::DeviceMotion> motion;
  if (substeps == 0) {
    motion = std::make_unique<numen::sim::TrajectoryMotion>(scene.device, scene.trajectory);
  } else {
    numen::sim::DevicePlantSettings plant = *scene.plant;
    plant.substeps = substeps;
    motion = std::make_unique<numen::sim::PlantMotion>(scene.device, plant, scene.hand,
                                                       scene.trajectory);
  }
  numen::hal::DriveCommands commands;
  commands.torque = numen::hal::AxisVector::Zero(static_cast<int>(scene.device.axes.size()));
  const std::int64_t periods =
      static_cast<std::int64_t>(scene.trajectory.duration() / scene.model.dt) - 1;
  std::int64_t k = 0;
  for (auto _ : state) {
    commands.torque[2] = 0.5 * std::sin(0.01 * static_cast<double>(k));
    benchmark::DoNotOptimize(&motion->at_sync((k % periods) * kPeriodNs, commands));
    ++k;
  }
  state.SetLabel(substeps == 0 ? "replay" : "plant/" + std::to_string(substeps));
}
BENCHMARK(DeviceMotionAtSync)->Arg(0)->Arg(10)->Arg(40);

}  // namespace
