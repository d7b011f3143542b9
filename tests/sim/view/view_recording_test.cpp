#include "numen/sim/view/view_recording.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "build_features.hpp"
#include "child_process.hpp"
#include "fine_surface_organ.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_scene.hpp"
#include "lattice_scene.hpp"
#include "temp_dir.hpp"

namespace {

using numen::sim::ViewRecordingReader;
using numen::test::TempDir;

/// A recording of `seconds` of `scene` written by run_scene itself.
std::string record(const TempDir& dir, const std::string& scene_path, double seconds,
                   numen::sim::RunSummary* summary = nullptr) {
  const numen::sim::Scene scene = numen::sim::load_scene(scene_path);
  numen::sim::RunOptions options;
  options.duration_s = seconds;
  options.record_view_path = (dir / "run.nmv").string();
  const numen::sim::RunSummary s = numen::sim::run_scene(scene, options);
  EXPECT_EQ(s.exit_status, 0);
  if (summary != nullptr) *summary = s;
  return options.record_view_path;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string write_bytes(const TempDir& dir, const std::string& name, const std::string& bytes) {
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

std::string reader_error(const std::string& path) {
  try {
    ViewRecordingReader reader(path);
  } catch (const numen::sim::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ViewRecording, ARunRecordsEveryDueFrameInOrder) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  numen::sim::RunSummary s;
  const std::string path = record(dir, numen::test::lattice_scene_path(), 0.5, &s);
  EXPECT_TRUE(s.view_recorded);
  EXPECT_EQ(s.view_frames_published, 30);  // 0.5 s at 60 Hz
  EXPECT_EQ(s.view_frames_dropped, 0);
  EXPECT_EQ(s.view_record_frames, 30);
  EXPECT_EQ(s.view_record_io_errors, 0);
  const ViewRecordingReader reader(path);
  ASSERT_EQ(reader.size(), 30u);
  const auto scene = nlohmann::json::parse(reader.scene_message());
  EXPECT_EQ(scene["format"], "numen-view");
  EXPECT_EQ(scene["layout"]["bodies"].get<int>(), s.num_bodies);
  EXPECT_EQ(reader.period(0), 0u);
  for (std::size_t i = 1; i < reader.size(); ++i) {
    EXPECT_GT(reader.time_ns(i), reader.time_ns(i - 1));
    EXPECT_NEAR(static_cast<double>(reader.time_ns(i) - reader.time_ns(i - 1)), 1e9 / 60, 1e6);
  }
  EXPECT_EQ(reader.frame_at_or_after(reader.time_ns(7)), 7u);
  EXPECT_EQ(reader.frame_at_or_after(reader.time_ns(7) + 1), 8u);
  EXPECT_EQ(reader.frame_at_or_after(INT64_MAX), reader.size());
  std::vector<std::byte> frame;
  reader.frame(29, frame);
  numen::platform::StateFrameView view;
  ASSERT_TRUE(numen::platform::StateFrameDecoder::decode(frame, view).ok());
  // The last frame's tool pose is finite and where a 0.5 s run of the default scene has it.
  float pose[7];
  view.body_pose(static_cast<std::uint32_t>(view.header().held_body), pose);
  for (float v : pose) EXPECT_TRUE(std::isfinite(v));
}

// A run of an organ with a fine surface (mapped by hand: tests/support/fine_surface_organ.hpp)
// records it in the scene message, and the reader `numen view` uses accepts the file: the
// surface as the scene message of the run gives it, every frame of the layout.
TEST(ViewRecording, ARunOfAnOrganWithAFineSurfaceRecordsItAndReadsBack) {
  NUMEN_REQUIRE_DEFORMABLE();
  TempDir dir;
  numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_TEST_DATA_DIR) + "/node_contacts.toml");
  ASSERT_EQ(numen::test::map_fine_icosphere_onto_net(scene.model, 0, 3), "");
  numen::sim::RunOptions options;
  options.duration_s = 0.2;
  options.record_view_path = (dir / "fine.nmv").string();
  const numen::sim::RunSummary s = numen::sim::run_scene(scene, options);
  ASSERT_EQ(s.exit_status, 0);
  const ViewRecordingReader reader(options.record_view_path);
  EXPECT_EQ(reader.size(), 12u);  // 0.2 s at 60 Hz
  const auto recorded = nlohmann::json::parse(reader.scene_message());
  const auto sent = nlohmann::json::parse(numen::sim::view_scene_message(
      scene, numen::sim::view_frame_layout(scene), numen::sim::RunOptions{}.view_rate_hz));
  ASSERT_TRUE(recorded["nets"][0].contains("surface"));
  EXPECT_EQ(recorded["nets"][0]["surface"]["point_count"].get<int>(), 642);
  EXPECT_EQ(recorded["nets"][0]["surface"], sent["nets"][0]["surface"]);
  EXPECT_FALSE(recorded["nets"][1].contains("surface"));
}

// Issue 70: the view carried device 0's feedback, axis torques and state alone. A run of the
// two-device bimanual scene records both: device 0's in the header and its arrays as ever,
// "right"'s in extra_device and extra_axis_torque, named in the scene message; every period
// recorded, the largest feedback force of each device is the summary's for it.
TEST(ViewRecording, ATwoDeviceRunRecordsEachDevicesFeedbackTorquesAndState) {
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/bimanual.toml");
  ASSERT_EQ(scene.extra_devices.size(), 1u);
  numen::sim::RunOptions options;
  options.duration_s = 0.3;
  options.view_rate_hz = std::numeric_limits<double>::infinity();  // every period
  options.record_view_path = (dir / "two.nmv").string();
  const numen::sim::RunSummary s = numen::sim::run_scene(scene, options);
  ASSERT_EQ(s.exit_status, 0) << s.exit_reasons.front();
  ASSERT_EQ(s.devices.size(), 2u);
  const ViewRecordingReader reader(options.record_view_path);
  ASSERT_EQ(reader.size(), 300u);
  const auto message = nlohmann::json::parse(reader.scene_message());
  EXPECT_EQ(message["extra_devices"][0]["name"], "right");
  EXPECT_EQ(message["layout"]["extra_devices"], 1);
  const std::size_t axes = scene.extra_devices[0].device.axes.size();
  EXPECT_EQ(message["layout"]["extra_axes"], axes);
  double first_max = 0.0, second_max = 0.0, second_tau_max = 0.0;
  std::vector<std::byte> bytes;
  for (std::size_t i = 0; i < reader.size(); ++i) {
    reader.frame(i, bytes);
    numen::platform::StateFrameView v;
    ASSERT_TRUE(numen::platform::StateFrameDecoder::decode(bytes, v).ok());
    ASSERT_EQ(v.header().num_extra_devices, 1u);
    ASSERT_EQ(v.header().num_extra_axes, axes);
    float w[6];
    v.feedback(w);
    first_max = std::max(first_max, std::hypot(double{w[0]}, double{w[1]}, double{w[2]}));
    const numen::platform::FrameDevice d = v.extra_device(0);
    EXPECT_EQ(d.num_axes, axes);
    second_max = std::max(second_max, std::hypot(double{d.feedback[0]}, double{d.feedback[1]},
                                                 double{d.feedback[2]}));
    for (std::uint32_t a = 0; a < axes; ++a)
      second_tau_max = std::max(second_tau_max, std::abs(double{v.extra_axis_torque(a)}));
    if (i == reader.size() - 1) {
      EXPECT_TRUE(d.flags & numen::platform::kFrameSampleValid);
      EXPECT_EQ(d.fault_cause, 0u);
    }
  }
  EXPECT_GT(second_max, 0.01);  // device 1 renders a force of its own
  EXPECT_GT(second_tau_max, 0.0);
  EXPECT_NEAR(first_max, s.devices[0].feedback_force_max_n, 1e-5 * (1.0 + first_max));
  EXPECT_NEAR(second_max, s.devices[1].feedback_force_max_n, 1e-5 * (1.0 + second_max));
}

TEST(ViewRecording, EveryDamagedFileIsRefusedWithItsByteOffset) {
  NUMEN_REQUIRE_ARTICULATION();
  TempDir dir;
  const std::string good = read_bytes(record(dir, numen::test::lattice_scene_path(), 0.1));
  ASSERT_GT(good.size(), 100u);
  const std::uint32_t scene_bytes = static_cast<unsigned char>(good[8]) |
                                    static_cast<unsigned char>(good[9]) << 8 |
                                    static_cast<unsigned char>(good[10]) << 16;
  const std::size_t first_frame = 12 + scene_bytes;  // its length field
  auto error = [&](const std::string& bytes) { return reader_error(write_bytes(dir, "bad.nmv", bytes)); };

  EXPECT_NE(reader_error((dir / "missing.nmv").string()).find("cannot open"), std::string::npos);
  EXPECT_NE(error("").find("byte 0: not a numen view recording"), std::string::npos);
  EXPECT_NE(error("NMVREC01").find("byte 8: the file ends before the scene message"), std::string::npos);
  std::string b = good;
  b[11] = '\x7f';  // a scene message of ~2 GB
  EXPECT_NE(error(b).find("byte 8: the length of the scene message is"), std::string::npos);
  b = good;
  b[12] = '[';
  EXPECT_NE(error(b).find("not a numen-view JSON object"), std::string::npos);
  b = good.substr(0, good.size() - 3);  // the last frame cut short: a killed run
  EXPECT_NE(error(b).find("frame 5 is cut short"), std::string::npos) << error(b);
  b = good;
  b[first_frame + 4] = 'X';  // the first frame's magic
  EXPECT_NE(error(b).find("byte " + std::to_string(first_frame + 4) + ": frame 0: byte 0: not a state frame"),
            std::string::npos)
      << error(b);
  {
    // Frame 1 stamped before frame 0 (its period still after): frame_at_or_after() would
    // search unsorted times. Found by tests/fuzz/view_recording_fuzz.cpp.
    b = good;
    const std::uint32_t frame0 = static_cast<unsigned char>(b[first_frame]) |
                                 static_cast<unsigned char>(b[first_frame + 1]) << 8;
    const std::size_t second = first_frame + 4 + frame0;
    for (int i = 0; i < 8; ++i) b[second + 4 + 40 + i] = '\xff';  // time_ns = -1
    EXPECT_NE(error(b).find("byte " + std::to_string(second + 4) + ": frame 1 is at -1 ns, before the previous frame's"),
              std::string::npos)
        << error(b);
  }
  b = good + good.substr(first_frame);  // the frames again: periods go back
  EXPECT_NE(error(b).find("is period 0, not after the previous frame's"), std::string::npos) << error(b);
  EXPECT_EQ(error(good), "");
}

/// A recording of no frames whose scene message is `scene` (JSON text).
std::string recording_bytes(const std::string& scene) {
  std::string b(numen::sim::kViewRecordingMagic, 8);
  for (int i = 0; i < 4; ++i) b += static_cast<char>((scene.size() >> (8 * i)) & 0xFF);
  return b + scene;
}

// A known member of the scene message with the wrong JSON type (or value) is an InputError
// naming the file and the key, at the message's byte offset; it was a json type_error naming
// nothing ("[json.exception.type_error.302] type must be string, but is object").
TEST(ViewRecording, ASceneMessageMemberOfTheWrongTypeIsNamedByItsKey) {
  TempDir dir;
  const std::string layout =
      R"("layout": {"bodies": 2, "nodes": 0, "axes": 3, "grasps": 0, "extra_devices": 0, "extra_axes": 0, )"
      R"("threads": 0, "thread_nodes": 0})";
  const std::string v = std::to_string(numen::sim::kViewSceneVersion);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"format": {"a": 1}, "version": )" + v + ", " + layout + "}", "format"},
      {R"({"format": 1, "version": )" + v + ", " + layout + "}", "format"},
      {R"({"format": "numen-view", "version": ")" + v + "\", " + layout + "}", "version"},
      {R"({"format": "numen-view", "version": 1.5, )" + layout + "}", "version"},
      {R"({"format": "numen-view", "version": )" + std::to_string(numen::sim::kViewSceneVersion - 1) +
           ", " + layout + "}",
       "version"},
      {R"({"format": "numen-view", "version": )" + v + "}", "layout"},
      {R"({"format": "numen-view", "version": )" + v + R"(, "layout": [2, 0, 3]})", "layout"},
      {R"({"format": "numen-view", "version": )" + v +
           R"(, "layout": {"bodies": -2, "nodes": 0, "axes": 3, "grasps": 0}})",
       "layout.bodies"},
      {R"({"format": "numen-view", "version": )" + v +
           R"(, "layout": {"bodies": 2, "nodes": "0", "axes": 3, "grasps": 0}})",
       "layout.nodes"},
      {R"({"format": "numen-view", "version": )" + v + R"(, "layout": {"bodies": 2, "nodes": 0, "grasps": 0}})",
       "layout.axes"},
      {R"({"format": "numen-view", "version": )" + v + R"(, "layout": {"bodies": 2, "nodes": 0, "axes": 3}})",
       "layout.grasps"},
      {R"({"format": "numen-view", "version": )" + v +
           R"(, "layout": {"bodies": 2, "nodes": 0, "axes": 3, "grasps": 0, "extra_axes": 0}})",
       "layout.extra_devices"},
      {R"({"format": "numen-view", "version": )" + v +
           R"(, "layout": {"bodies": 2, "nodes": 0, "axes": 3, "grasps": 0, "extra_devices": 1.5, "extra_axes": 0}})",
       "layout.extra_devices"},
      {R"({"format": "numen-view", "version": )" + v +
           R"(, "layout": {"bodies": 2, "nodes": 0, "axes": 3, "grasps": 0, "extra_devices": 0, "extra_axes": 0}})",
       "layout.threads"},
      {R"({"format": "numen-view", "version": )" + v +
           R"(, "layout": {"bodies": 2, "nodes": 0, "axes": 3, "grasps": 0, "extra_devices": 0, "extra_axes": 0, )"
           R"("threads": 1, "thread_nodes": -101}})",
       "layout.thread_nodes"},
  };
  for (const auto& [scene, key] : cases) {
    const std::string path = write_bytes(dir, "bad.nmv", recording_bytes(scene));
    try {
      ViewRecordingReader reader(path);
      ADD_FAILURE() << scene << " was accepted";
    } catch (const numen::sim::InputError& e) {
      EXPECT_EQ(e.file(), path) << scene;
      EXPECT_EQ(e.key(), key) << scene << ": " << e.what();
      EXPECT_EQ(e.message().rfind("byte 12: ", 0), 0u) << scene << ": " << e.what();
    }
  }
  // A syntax error is reported at its own byte of the file (the '}' after "nul": 12 + 14).
  const std::string path = write_bytes(dir, "bad.nmv", recording_bytes(R"({"format": nul})"));
  EXPECT_NE(reader_error(path).find("byte 26: the scene message is not a numen-view JSON object"),
            std::string::npos)
      << reader_error(path);
  // The members as a recorder writes them: accepted (no frames).
  EXPECT_EQ(reader_error(write_bytes(
                dir, "good.nmv",
                recording_bytes(R"({"format": "numen-view", "version": )" + v + ", " + layout + "}"))),
            "");
}

// Issue 69: the frames carry the threads (version 5) and the scene message the needles and threads
// (version 4). A recording of an older numen (scene message 3, frames 4) is refused at its version,
// saying to record the run again, not with an unexplained count mismatch.
TEST(ViewRecording, ARecordingOfAnOlderNumenIsRefusedSayingToRecordItAgain) {
  TempDir dir;
  const std::string older = R"({"format": "numen-view", "version": 3, "frame_version": 4, )"
                            R"("layout": {"bodies": 2, "nodes": 0, "axes": 3, "grasps": 0, "extra_devices": 0, )"
                            R"("extra_axes": 0}})";
  const std::string path = write_bytes(dir, "old.nmv", recording_bytes(older));
  EXPECT_EQ(reader_error(path), path + ": version: byte 12: scene message version number 3, this reader knows integer 4 "
                                       "(a recording of an older numen: record the run again with this one)");
}

// Arrays and objects nested more than 64 deep are refused while the scene message is parsed,
// at the byte of the bracket that opens level 65 (12 + 64); a scene message of 200 000 nested
// arrays crashed the reader (SIGSEGV: the error message quoted it through a recursive dump()).
// A member of the wrong type is quoted by its first 40 bytes, however large or deep it is.
TEST(ViewRecording, ADeeplyNestedSceneMessageIsRefusedWhereItGoesTooDeep) {
  TempDir dir;
  for (const std::size_t depth : {std::size_t{65}, std::size_t{200000}}) {
    const std::string path = write_bytes(
        dir, "deep.nmv", recording_bytes(std::string(depth, '[') + std::string(depth, ']')));
    EXPECT_EQ(reader_error(path),
              path +
                  ": byte 76: the scene message is not a numen-view JSON object (arrays and "
                  "objects nested more than 64 deep)")
        << depth;
  }
  // 64 deep is JSON the reader reads: then refused for being an array, quoted short.
  std::string path =
      write_bytes(dir, "array.nmv", recording_bytes(std::string(64, '[') + std::string(64, ']')));
  EXPECT_EQ(reader_error(path), path +
                                    ": byte 12: the scene message is not a numen-view JSON "
                                    "object but array [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[...");
  std::string zeros = "[0";
  for (int i = 1; i < 100000; ++i) zeros += ",0";
  path = write_bytes(dir, "format.nmv", recording_bytes(R"({"format": )" + zeros + "]}"));
  EXPECT_EQ(reader_error(path), path +
                                    ": format: byte 12: array "
                                    "[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0..., expected "
                                    "string \"numen-view\": not a numen-view scene message");
}

TEST(ViewRecording, AnUnwritablePathIsAnInputErrorAtTheOption) {
  try {
    numen::sim::ViewRecordingWriter w("/nonexistent-dir/run.nmv", "{}");
    FAIL() << "no error";
  } catch (const numen::sim::InputError& e) {
    EXPECT_EQ(e.key(), "--record-view");
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/run.nmv"), std::string::npos);
  }
}

TEST(ViewRecording, AFullDiskIsFoundBeforeTheRunStarts) {
  NUMEN_REQUIRE_ARTICULATION();
  if (!std::filesystem::exists("/dev/full")) GTEST_SKIP() << "no /dev/full on this machine";
  const numen::sim::Scene scene = numen::sim::load_scene(numen::test::lattice_scene_path());
  numen::sim::RunOptions options;
  options.duration_s = 0.5;
  options.record_view_path = "/dev/full";
  try {
    numen::sim::run_scene(scene, options);
    FAIL() << "no error";
  } catch (const numen::sim::InputError& e) {
    EXPECT_EQ(e.key(), "--record-view");
    EXPECT_NE(std::string(e.what()).find("/dev/full: cannot write"), std::string::npos) << e.what();
  }
}

}  // namespace
