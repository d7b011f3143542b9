/// @file state_frame_bench.cpp
/// What the state stream (platform/state_stream.hpp, docs/viewer.md) costs the loop, and the
/// choice of the frame encoding:
///  - StateFramePublish/<scene>: StateStream::publish() (the loop's whole cost: encode into a
///    pool buffer + queue the index), timed alone; between iterations (untimed) the consumer
///    thread hands the frame to a sink that does nothing. The default scene and the
///    deformable ball of 642 and 2562 nodes (subdivisions 3, 4).
///  - StateFrameEncode{Binary,Json}/<subdivisions>: one frame of the deformable ball encoded as
///    the binary frame and, for comparison, as the JSON a text encoding would need (the same
///    values, nlohmann::json); counters: bytes per frame, and bandwidth at 60 Hz.
/// Run: ./build/tests/numen_bench --benchmark_filter=StateFrame

#include <benchmark/benchmark.h>

#include <chrono>
#include <limits>
#include <thread>
#include <nlohmann/json.hpp>
#include <vector>

#include "deformable_ball.hpp"
#include "lattice_scene.hpp"
#include "numen/core/step.hpp"
#include "numen/platform/state_stream.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_scene.hpp"

namespace {

class NullSink final : public numen::platform::StateFrameSink {
 public:
  bool write_frame(std::span<const std::byte>) noexcept override { return true; }
};

/// A model and its data after `warm_up` steps, with contacts.
struct BallState {
  numen::core::Model model;
  numen::core::Data data;
  explicit BallState(int subdivisions)
      : model(numen::test::make_deformable_ball(subdivisions)), data(numen::core::make_data(model)) {
    numen::test::run_deformable_ball(model, data, 0, numen::test::kBallWarmUpSteps);
  }
  numen::platform::StateFrameLayout layout() const {
    return {static_cast<std::uint32_t>(model.num_bodies()), static_cast<std::uint32_t>(model.num_nodes()),
            0, static_cast<std::uint32_t>(numen::core::kMaxContacts + numen::core::kMaxNodeContacts)};
  }
};

void publish_loop(benchmark::State& state, const numen::core::Data& data,
                  const numen::platform::StateFrameLayout& layout) {
  NullSink sink;
  numen::platform::StateStream stream(
      layout, {&sink},
      numen::platform::StateStreamSettings{std::numeric_limits<double>::infinity(), 64, 20'000});  // the consumer polls every 20 µs: iterations stay short
  stream.start();
  const numen::platform::PeriodReport report;
  const std::vector<double> torques(layout.num_axes, 0.1);
  std::uint64_t k = 0;
  for (auto _ : state) {
    // Timed: the loop's side alone. Untimed: wait until the consumer has the frame, so that
    // every iteration finds a free buffer (as at 60 Hz) and none measures the drop path.
    const auto t0 = std::chrono::steady_clock::now();
    const bool queued = stream.publish(data, report, torques, {k++, 0.001, 0.002});
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(queued);
    state.SetIterationTime(std::chrono::duration<double>(t1 - t0).count());
    while (stream.counters().delivered < stream.counters().published) std::this_thread::yield();
  }
  stream.stop();
  const auto c = stream.counters();
  state.counters["bytes_per_frame"] =
      c.delivered > 0 ? static_cast<double>(c.bytes) / static_cast<double>(c.delivered) : 0.0;
  state.counters["dropped_share"] = static_cast<double>(c.dropped) / static_cast<double>(c.periods);
}

void StateFramePublishDefaultScene(benchmark::State& state) {
  const numen::sim::Scene scene = numen::sim::load_scene(numen::test::lattice_scene_path());
  numen::sim::SceneRunner runner(scene);
  for (int k = 0; k < 3000; ++k) runner.period();  // the tool is in contact by now
  publish_loop(state, runner.data(), numen::sim::view_frame_layout(scene));
}

void StateFramePublishBall(benchmark::State& state) {
  const BallState ball(static_cast<int>(state.range(0)));
  publish_loop(state, ball.data, ball.layout());
  state.counters["nodes"] = ball.model.num_nodes();
}

void StateFrameEncodeBinary(benchmark::State& state) {
  const BallState ball(static_cast<int>(state.range(0)));
  const auto layout = ball.layout();
  std::vector<std::byte> out(layout.max_frame_bytes());
  const numen::platform::PeriodReport report;
  std::size_t bytes = 0;
  for (auto _ : state) {
    bytes = numen::platform::encode_state_frame(layout, ball.data, report, {}, {}, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["bytes_per_frame"] = static_cast<double>(bytes);
  state.counters["MB_per_s_at_60Hz"] = static_cast<double>(bytes) * 60.0 / 1e6;
  state.counters["nodes"] = ball.model.num_nodes();
}

/// The same values as JSON (what a text frame would carry): shortest round-trip doubles.
void StateFrameEncodeJson(benchmark::State& state) {
  const BallState ball(static_cast<int>(state.range(0)));
  const numen::core::Data& d = ball.data;
  std::size_t bytes = 0;
  for (auto _ : state) {
    nlohmann::json j;
    j["period"] = d.step_count;
    j["time"] = d.time;
    auto& bodies = j["bodies"] = nlohmann::json::array();
    for (const auto& b : d.bodies)
      bodies.push_back({b.position.x(), b.position.y(), b.position.z(), b.orientation.x(),
                        b.orientation.y(), b.orientation.z(), b.orientation.w()});
    auto& nodes = j["nodes"] = nlohmann::json::array();
    for (const auto& n : d.nodes) {
      nodes.push_back(n.position.x());
      nodes.push_back(n.position.y());
      nodes.push_back(n.position.z());
    }
    auto& contacts = j["contacts"] = nlohmann::json::array();
    for (int c = 0; c < d.num_node_contacts; ++c) {
      const auto& k = d.node_contacts[static_cast<std::size_t>(c)];
      contacts.push_back({k.position.x(), k.position.y(), k.position.z(), k.normal.x(), k.normal.y(),
                          k.normal.z(), k.depth, k.force.x(), k.force.y(), k.force.z()});
    }
    const std::string text = j.dump();
    bytes = text.size();
    benchmark::DoNotOptimize(text.data());
  }
  state.counters["bytes_per_frame"] = static_cast<double>(bytes);
  state.counters["MB_per_s_at_60Hz"] = static_cast<double>(bytes) * 60.0 / 1e6;
  state.counters["nodes"] = ball.model.num_nodes();
}

}  // namespace

BENCHMARK(StateFramePublishDefaultScene)->UseManualTime()->Iterations(20000)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(StateFramePublishBall)->Arg(3)->Arg(4)->UseManualTime()->Iterations(20000)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(StateFrameEncodeBinary)->Arg(3)->Arg(4)->MinTime(0.3);
BENCHMARK(StateFrameEncodeJson)->Arg(3)->Arg(4)->MinTime(0.3);
