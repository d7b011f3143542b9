// view_replay_series(): the replay's plot series read from every frame of a recording.

#include "numen/sim/view/view_series.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "build_features.hpp"
#include "numen/platform/state_frame.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_recording.hpp"
#include "numen/sim/view/view_server.hpp"
#include "lattice_scene.hpp"
#include "temp_dir.hpp"

namespace {

using numen::sim::ViewRecordingReader;

/// A recording's frames as a ViewFrameSource (as `numen view` serves them).
class ReaderSource final : public numen::sim::ViewFrameSource {
 public:
  explicit ReaderSource(const ViewRecordingReader& r) : r_(r) {}
  std::size_t frame_count() const override { return r_.size(); }
  std::int64_t frame_time_ns(std::size_t i) const override { return r_.time_ns(i); }
  void read_frame(std::size_t i, std::vector<std::byte>& out) override { r_.frame(i, out); }

 private:
  const ViewRecordingReader& r_;
};

/// |feedback force| (N) of frame i.
double force_of(const ViewRecordingReader& r, std::size_t i) {
  std::vector<std::byte> bytes;
  r.frame(i, bytes);
  numen::platform::StateFrameView v;
  EXPECT_TRUE(numen::platform::StateFrameDecoder::decode(bytes, v).ok());
  float f[6];
  v.feedback(f);
  return std::hypot(static_cast<double>(f[0]), static_cast<double>(f[1]), static_cast<double>(f[2]));
}

class ViewSeries : public ::testing::Test {
 protected:
  void SetUp() override {
    NUMEN_REQUIRE_ARTICULATION();
    numen::sim::RunOptions options;
    options.duration_s = 0.5;  // 30 frames at 60 Hz
    options.record_view_path = (dir_ / "run.nmv").string();
    numen::sim::run_scene(numen::sim::load_scene(numen::test::lattice_scene_path()), options);
    reader_ = std::make_unique<ViewRecordingReader>(options.record_view_path);
  }
  numen::test::TempDir dir_;
  std::unique_ptr<ViewRecordingReader> reader_;
};

TEST_F(ViewSeries, UndecimatedHasOnePointPerFrame) {
  ReaderSource source(*reader_);
  const auto j = nlohmann::json::parse(numen::sim::view_replay_series(source));
  ASSERT_EQ(reader_->size(), 30u);
  EXPECT_EQ(j["frames"], 30);
  EXPECT_EQ(j["stride"], 1);
  for (const char* k : {"frame", "t", "tool_mm", "hand_mm", "intent_mm", "force_n", "step_us", "contacts",
                        "lifecycle", "step_status"})
    EXPECT_EQ(j[k].size(), 30u) << k;
  for (std::size_t i = 0; i < 30; ++i) {
    EXPECT_EQ(j["frame"][i], i);
    EXPECT_NEAR(j["t"][i].get<double>(), static_cast<double>(reader_->time_ns(i)) * 1e-9, 1e-6);
    EXPECT_NEAR(j["force_n"][i].get<double>(), force_of(*reader_, i), 1e-5);
  }
  // The start-up's lifecycle changes are events, each where the lifecycle changed.
  ASSERT_GE(j["event_count"].get<int>(), 1);
  for (const auto& e : j["events"]) {
    const std::size_t k = e["frame"];
    ASSERT_GT(k, 0u);
    EXPECT_TRUE(j["lifecycle"][k] != j["lifecycle"][k - 1] || j["step_status"][k] != j["step_status"][k - 1]);
  }
}

TEST_F(ViewSeries, DecimatedKeepsEachWindowsPeakAndTheLastFrame) {
  ReaderSource source(*reader_);
  const auto j = nlohmann::json::parse(numen::sim::view_replay_series(source, 7));
  EXPECT_EQ(j["stride"], 5);  // ceil(30 / 7)
  const std::vector<std::size_t> expected = {0, 5, 10, 15, 20, 25, 29};
  ASSERT_EQ(j["frame"].get<std::vector<std::size_t>>(), expected);
  ASSERT_EQ(j["force_n"].size(), expected.size());
  for (std::size_t p = 0; p < expected.size(); ++p) {
    double peak = 0.0;
    for (std::size_t k = expected[p]; k < std::min<std::size_t>(30, expected[p] + 5); ++k)
      peak = std::max(peak, force_of(*reader_, k));
    EXPECT_NEAR(j["force_n"][p].get<double>(), peak, 1e-5) << "point " << p;
  }
}

}  // namespace
