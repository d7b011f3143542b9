// Tests of sim/run: a period of every shipped scene never allocates (SceneRunner, with a
// connected state-stream consumer).
#include "numen/sim/run/run.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <atomic>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "child_process.hpp"
#include "run_scenes.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/input/jigsaws.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_scene.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "build_features.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "sanitizer.hpp"

namespace {

using namespace numen::test::run_scenes;

// ---------------------------------------------------------------- zero allocations

/// A state-stream consumer that only counts (stands in for a connected viewer).
class CountingViewSink final : public numen::platform::StateFrameSink {
 public:
  bool write_frame(std::span<const std::byte> frame) noexcept override {
    frames.fetch_add(1);
    bytes.fetch_add(frame.size());
    if (static_cast<std::int64_t>(frame.size()) < smallest.load()) smallest.store(static_cast<std::int64_t>(frame.size()));
    return true;
  }
  std::atomic<std::int64_t> frames{0}, bytes{0};
  std::atomic<std::int64_t> smallest{std::numeric_limits<std::int64_t>::max()};  // one writer: the stream's thread
};

/// Returns the run's summary (the callers may check what the 10,000 periods exercised); the
/// viewer's smallest frame (bytes) in `*smallest_frame` when given.
RunSummary expect_no_allocation(const Scene& scene, const char* name,
                                std::int64_t* smallest_frame = nullptr, int periods = 10'000) {
  SceneRunner runner(scene, periods);  // construction allocates (trace storage too)
  // A viewer is connected: the state stream publishes every period (1 kHz, its worst case).
  CountingViewSink viewer;
  runner.stream_view("", {&viewer}, 1.0 / scene.model.dt, false);
  std::int64_t count = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < periods; ++k) runner.period();
    count = guard.count();
  }
  EXPECT_EQ(count, 0) << name << ": heap allocations in " << periods << " periods";
  EXPECT_EQ(runner.periods(), periods);
  EXPECT_EQ(runner.trace().records().size(), static_cast<std::size_t>(periods));
  runner.finish();
  const RunSummary s = runner.summary();
  EXPECT_EQ(s.view_frames_published + s.view_frames_dropped, periods) << name;
  EXPECT_EQ(viewer.frames.load(), s.view_frames_published) << name;
  if (smallest_frame != nullptr) *smallest_frame = viewer.smallest.load();
  EXPECT_GT(s.contacts_max + s.node_contacts_max, 0)
      << name << ": the contact path was not exercised";
  if (scene.model.num_nets() > 0) {
    EXPECT_GT(s.node_contacts_max, 0) << name << ": the nets never touched anything";
  }
  EXPECT_FALSE(s.nan_detected);
  return s;
}

TEST(RunAllocations, LatticeScenePeriodNeverAllocates) {
  NUMEN_REQUIRE_ARTICULATION();
  expect_no_allocation(lattice_scene(), "lattice");
}

TEST(RunAllocations, ConstructionScenePeriodNeverAllocates) {
  expect_no_allocation(construction_scene(), "construction");
}

TEST(RunAllocations, PhantomScenePeriodNeverAllocates) {
  NUMEN_REQUIRE_ARTICULATION();
  expect_no_allocation(phantom_scene(), "phantom");  // 6 s scene: the trajectory holds its end
}

TEST(RunAllocations, DeformableScenePeriodNeverAllocates) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  expect_no_allocation(deformable_scene(), "deformable");  // the post contact is at 2.7–3.2 s
}

TEST(RunAllocations, EndobagScenePeriodNeverAllocates) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  expect_no_allocation(endobag_scene(), "endobag");
}

TEST(RunAllocations, OrganScenePeriodNeverAllocates) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  expect_no_allocation(organ_scene(), "default (organ)");  // the hand goes into the organ from 3 s
}

// The default scene whose organ turns tetrahedra inside out (a load patch of 2 mm, as
// SceneTissue.ANetThatTurnsTetrahedraInsideOutIsWarned: the first at 9.85 s): counting them and
// noting the first, in the periods, allocates nothing (the organ's name, longer than a string's
// small buffer here, is taken in summary()).
TEST(RunAllocations, OrganSceneTurningTetrahedraInsideOutNeverAllocates) {
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  std::string text = numen::test::shipped_scene_text_anywhere("default.toml");
  const std::size_t at = text.find("strain_stiffening = 1.0");
  ASSERT_NE(at, std::string::npos);
  text.insert(at, "load_patch_radius = 0.002\n");
  // A name past the strings' small-buffer size, so that a copy of it in a period would allocate.
  const std::string organ = "name = \"organ\"\nbody = \"organ_core\"";
  const std::size_t named = text.find(organ);
  ASSERT_NE(named, std::string::npos);
  text.replace(named, organ.size(), "name = \"organ_given_by_its_material\"\nbody = \"organ_core\"");
  const Scene scene = numen::sim::load_scene(dir.write("small_patch.toml", text));
  const RunSummary s = expect_no_allocation(scene, "default, a 2 mm load patch", nullptr, 10'500);
  EXPECT_GE(s.net_inverted_tetrahedra_max, 1) << "no inversion: the periods did not take that path";
  EXPECT_EQ(s.net_first_inversion_net, "organ_given_by_its_material");
}

TEST(RunAllocations, MeshObstacleScenePeriodNeverAllocates) {
  expect_no_allocation(mesh_scene(), "mesh");  // the probe presses the mesh lobe at 1–2.7 s
}

TEST(RunAllocations, BimanualScenePeriodNeverAllocates) {
  // Two closed-loop devices on one bus, their graspers, the organ: the right hand grasps the
  // organ's tissue from 6.968 s (docs/grasping.md, "In a run").
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  const Scene scene = numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/bimanual.toml");
  const RunSummary s = expect_no_allocation(scene, "bimanual");
  EXPECT_GT(s.grasps_started, 0) << "the grasp path was not exercised";
}

TEST(RunAllocations, PegTransferScenePeriodNeverAllocates) {
  // Two devices, rigid objects grasped, carried and handed over in mid-air: the first object
  // is lifted at 1.434 s and handed over at 3.134 s (docs/grasping.md, "Peg transfer").
  NUMEN_REQUIRE_ARTICULATION();
  const Scene scene = numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/peg_transfer.toml");
  const RunSummary s = expect_no_allocation(scene, "peg_transfer");
  EXPECT_GE(s.grasps_started, 3) << "the grasp and hand-over path was not exercised";
}

TEST(RunAllocations, SuturingScenePeriodNeverAllocates) {
  // Two devices, the needle grasped, driven through the pad (its puncture points tied to it), handed
  // over and pulled through, handed back and driven through again, its thread stepped every period
  // and drawn through all four puncture points (docs/suturing.md, "The suturing scene"): the
  // whole scene.
  NUMEN_SKIP_UNDER_SANITIZER(kDeformableRunTooSlow);
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  const Scene scene = numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/suturing.toml");
  std::int64_t smallest_frame = 0;
  const RunSummary s = expect_no_allocation(scene, "suturing", &smallest_frame,
                                            static_cast<int>(std::lround(scene.duration_s / scene.model.dt)));
  EXPECT_GE(s.needle_punctures, 1) << "the puncture path was not exercised";
  EXPECT_GE(s.needle_exits, 1) << "the exit path was not exercised";
  EXPECT_EQ(s.needle_passes, 2) << "the second pass was not exercised";
  EXPECT_EQ(s.thread_eyelets_taken, 4) << "the thread was not drawn through the second pass";
  // Every frame carried the thread's 101 nodes (issue 69: the view draws it), encoded on the loop.
  const numen::platform::StateFrameLayout layout = numen::sim::view_frame_layout(scene);
  EXPECT_EQ(layout.num_thread_nodes, 101u);
  EXPECT_GE(smallest_frame, static_cast<std::int64_t>(layout.frame_bytes(0)));
  EXPECT_GT(s.needle_tissue_force_max_n, 0.0) << "no force on the tissue";
}

TEST(RunAllocations, MouseScenePeriodNeverAllocates) {
  NUMEN_REQUIRE_EVDEV();  // the scene names its event codes
  expect_no_allocation(mouse_scene(), "mouse");  // 5 s scene: the trajectory holds its end
}

}  // namespace

TEST(RunAllocations, TwoDevicePeriodNeverAllocates) {
  // kTwoDeviceScene with a wall the right device's tool presses into (y = 0.065: the tool's
  // 10 mm sphere reaches it from y = 0.055): two devices read, supervised, stepped and sent
  // their torques every period, the contact path exercised, nothing allocated.
  numen::test::TempDir dir;
  const std::string text = numen::test::kTwoDeviceScene + R"(
[[obstacle]]
name = "wall"
type = "plane"
point = [0.0, 0.065, 0.0]
normal = [0.0, -1.0, 0.0]
)";
  const Scene scene = numen::sim::load_scene(dir.write("two.toml", text));
  SceneRunner runner(scene, 1000);
  std::int64_t count = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 1000; ++k) runner.period();
    count = guard.count();
  }
  EXPECT_EQ(count, 0) << "heap allocations in 1,000 periods of two devices";
  runner.finish();
  const RunSummary s = runner.summary();
  EXPECT_GT(s.contacts_max, 0) << "the contact path was not exercised";
  ASSERT_EQ(s.devices.size(), 2u);
  EXPECT_LT(s.devices[1].invalid_periods, 100);
  EXPECT_FALSE(s.nan_detected);
}
