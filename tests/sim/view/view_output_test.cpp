// Tests of sim/view_output: the run's state stream as both runners use it (its figures in the
// summary, the recording first among the sinks) and the pacing of a watched offline run.
#include "numen/sim/view/view_output.hpp"

#include <gtest/gtest.h>

#include "numen/platform/monotonic_clock.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/view/view_scene.hpp"
#include "temp_dir.hpp"

namespace {

namespace sim = numen::sim;

/// Counts the frames it is given.
class CountingSink final : public numen::platform::StateFrameSink {
 public:
  bool write_frame(std::span<const std::byte>) noexcept override { return ++frames, true; }
  int frames = 0;
};

TEST(ViewOutput, FeedsTheRecordingAndTheSinksAndSummarizesBoth) {
  numen::test::TempDir dir;
  const sim::Scene scene = sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/admittance.toml");
  CountingSink sink;
  const std::string path = (dir / "run.nmv").string();
  sim::ViewOutput out(scene, path, {&sink}, 60.0, true);
  numen::core::Data data = numen::core::make_data(scene.model);
  numen::platform::PeriodReport report;
  const std::vector<double> axes(scene.device.axes.size(), 0.0);
  for (int k = 0; k < 100; ++k) {  // 0.1 s at 1 kHz: 6 frames at 60 Hz (0, 16.7, ..., 83.3 ms)
    data.time = k * scene.model.dt;
    out.publish(data, report, axes, {static_cast<std::uint64_t>(k), 0.0, 0.0});
  }
  out.finish();
  out.finish();  // idempotent
  sim::RunSummary s;
  out.summarize(s);
  EXPECT_TRUE(s.view_streamed);
  EXPECT_TRUE(s.view_recorded);
  EXPECT_EQ(s.view_frames_published, 6);
  EXPECT_EQ(s.view_frames_decimated, 94);
  EXPECT_EQ(s.view_frames_delivered, 6);
  EXPECT_EQ(s.view_record_frames, 6);
  EXPECT_EQ(sink.frames, 6);
  EXPECT_EQ(sim::ViewRecordingReader(path).size(), 6u);
}

TEST(ViewPacer, NeverLetsAPeriodStartBeforeItsTimeAtTheSpeedAsked) {
  // Lower bounds only (a wait never returns early); how late it may be is the machine's.
  const std::int64_t t0 = numen::platform::monotonic_now_ns();
  sim::ViewPacer pacer(0.004, 2.0, t0);  // 4 ms periods at twice real time: 2 ms each
  for (int k = 0; k < 5; ++k) pacer.wait();
  EXPECT_GE(numen::platform::monotonic_now_ns() - t0, 10'000'000);
}

TEST(ViewPacer, ASpeedOfZeroDoesNotPace) {
  // A wall0 an hour ahead: a pacer that paced would sleep an hour before its first period.
  const std::int64_t t0 = numen::platform::monotonic_now_ns();
  sim::ViewPacer pacer(0.001, 0.0, t0 + 3'600'000'000'000);
  for (int k = 0; k < 1000; ++k) pacer.wait();
  EXPECT_LT(numen::platform::monotonic_now_ns() - t0, 60'000'000'000);
}

}  // namespace
