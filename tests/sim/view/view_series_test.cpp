// view_replay_series(): the replay's plot series read from every frame of a recording.

#include "numen/sim/view/view_series.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "build_features.hpp"
#include "numen/core/data.hpp"
#include "numen/platform/state_frame.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_recording.hpp"
#include "numen/sim/view/view_server.hpp"
#include "lattice_scene.hpp"
#include "temp_dir.hpp"

namespace {

using numen::sim::ViewRecordingReader;

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
  numen::sim::ViewRecordingSource source(*reader_);
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
  numen::sim::ViewRecordingSource source(*reader_);
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

/// Frames encoded here, one Data per frame (no run): a ViewFrameSource of known graspers.
class EncodedFrames final : public numen::sim::ViewFrameSource {
 public:
  std::size_t frame_count() const override { return frames_.size(); }
  std::int64_t frame_time_ns(std::size_t i) const override { return static_cast<std::int64_t>(i) * 16'000'000; }
  void read_frame(std::size_t i, std::vector<std::byte>& out) override { out = frames_.at(i); }
  /// Appends the frame of `data` (one body, graspers as data.grasps) at period i.
  void add(const numen::core::Data& data) {
    numen::platform::StateFrameLayout layout{1, 0, 0, 0, static_cast<std::uint32_t>(data.grasps.size())};
    std::vector<std::byte> f(layout.max_frame_bytes());
    numen::platform::StateFrameFigures figures;
    figures.period = frames_.size();
    f.resize(numen::platform::encode_state_frame(layout, data, {}, {}, figures, f));
    ASSERT_FALSE(f.empty());
    frames_.push_back(std::move(f));
  }

 private:
  std::vector<std::vector<std::byte>> frames_;
};

// Grasp events come from the graspers' counts, at the frame where they grew, in the order they
// happened, with what was held: a grasp and its release between two frames are both listed.
TEST(ViewSeriesGrasps, EventsAreWhereAGraspersCountsGrew) {
  numen::core::Data d;
  d.bodies.resize(1);
  d.grasps.resize(2);
  d.time = 0.0;
  EncodedFrames frames;
  frames.add(d);                          // frame 0: nothing held
  d.grasps[1].body = 0;                   // frame 1: grasper 1 grasps body 0
  d.grasps[1].grasps = 1;
  frames.add(d);
  frames.add(d);                          // frame 2: no change
  d.grasps[1].body = -1;                  // frame 3: it slips out; grasper 0 grasps tissue of
  d.grasps[1].slips = 1;                  // net 0 and lets go again before the frame
  d.grasps[0].grasps = 1;
  d.grasps[0].releases = 1;
  frames.add(d);
  d.grasps[0].net = 0;                    // frame 4: grasper 0 grasps net 0 again
  d.grasps[0].grasps = 2;
  frames.add(d);
  d.grasps[0].net = -1;                   // frame 5: and releases it
  d.grasps[0].releases = 2;
  frames.add(d);
  d.grasps[1].thread = 0;                 // frame 6: grasper 1 takes thread 0 (3 nodes)
  d.grasps[1].num_thread_nodes = 3;
  d.grasps[1].grasps = 2;
  frames.add(d);
  d.grasps[1].thread = -1;                // frame 7: and lets it go
  d.grasps[1].releases = 1;
  frames.add(d);
  const auto j = nlohmann::json::parse(numen::sim::view_replay_series(frames));
  ASSERT_EQ(j["grasp_event_count"], 8) << j["grasp_events"].dump();
  const auto& e = j["grasp_events"];
  auto is = [&](std::size_t i, std::size_t frame, int grasper, const char* kind, int body, int net,
                int thread = -1) {
    EXPECT_EQ(e[i]["frame"], frame) << i;
    EXPECT_EQ(e[i]["grasper"], grasper) << i;
    EXPECT_EQ(e[i]["event"], kind) << i;
    EXPECT_EQ(e[i]["body"], body) << i;
    EXPECT_EQ(e[i]["net"], net) << i;
    EXPECT_EQ(e[i]["thread"], thread) << i;
  };
  is(0, 1, 1, "grasp", 0, -1);
  is(1, 3, 0, "grasp", -1, -1);   // grasped and let go between frames 2 and 3: what, unknown
  is(2, 3, 0, "release", -1, -1);
  is(3, 3, 1, "slip", 0, -1);     // what the previous frame held
  is(4, 4, 0, "grasp", -1, 0);
  is(5, 5, 0, "release", -1, 0);
  is(6, 6, 1, "grasp", -1, -1, 0);    // a thread
  is(7, 7, 1, "release", -1, -1, 0);  // what the previous frame held
}

}  // namespace
