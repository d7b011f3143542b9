// Tests of numen/sim/device/device_process.hpp (`numen device`) on a real pseudo-terminal: the test
// plays the controller on the master side, run_device() the default scene's instrument on the
// slave.

#include <poll.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <span>
#include <thread>
#include <vector>

#include "build_features.hpp"
#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/hal/canopen/sdo.hpp"
#include "numen/hal/transport/serial_frame.hpp"
#include "numen/sim/device/device_process.hpp"
#include "numen/sim/scene/scene.hpp"
#include "lattice_scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "pseudo_terminal.hpp"
#include "serial_test_frames.hpp"

namespace {

using numen::hal::CanFrame;
using numen::hal::SdoFrame;
using numen::hal::SdoFrameKind;
using numen::test::Pty;

// The line bytes of an SDO initiate upload request of 0x1000:00 to `node`.
numen::test::Bytes upload_device_type(std::uint8_t node) {
  SdoFrame f;
  f.kind = SdoFrameKind::kInitiateUploadRequest;
  f.address = {0x1000, 0};
  CanFrame c;
  EXPECT_TRUE(numen::hal::encode_sdo(f, numen::hal::sdo_request_cob_id(node), 0, c));
  return numen::test::encode(c);
}

// on_ready means the device answers (DeviceOptions::on_ready): an SDO request sent from within
// the call, and on the device's side of the line before the call returns, is answered. The
// nodes leave initialisation (boot-up) in the device's first tick and ignore SDO before it
// (CiA 301): announced before that tick, the device's first pass would read the request while
// node 1 is still initialising and never answer it (interop_device_server's timeout under
// load). No timing: a second request, sent once the five boot-ups came, is answered after the
// first one was handled, whatever the machine's load.
TEST(DeviceProcess, AnSdoRequestSentWhenReadyIsAnswered) {
  NUMEN_REQUIRE_ARTICULATION();  // the default scene's instrument
  const numen::sim::Scene scene = numen::sim::load_scene(numen::test::lattice_scene_path());
  ASSERT_TRUE(scene.device.canopen.managed);
  Pty line;
  std::atomic<bool> stop{false};
  std::atomic<int> ready_calls{0};
  numen::sim::DeviceOptions options;
  options.bus = "serial:" + line.path + "@1000000";
  options.stop = &stop;
  options.on_ready = [&] {
    ASSERT_TRUE(numen::test::write_all(line.master, upload_device_type(1)));
    // Until the request is in the device's input (a pty hands bytes on through a kernel
    // worker): its next read takes it.
    pollfd p{line.slave, POLLIN, 0};
    ::poll(&p, 1, 10'000);
    ++ready_calls;  // after the write: the probe below must follow request 1 on the line
  };
  numen::sim::DeviceSummary summary;
  std::thread device([&] { summary = numen::sim::run_device(scene, options); });

  // The far end: frames in the order they came.
  std::vector<CanFrame> frames;
  numen::hal::SerialFrameDecoder decoder;
  int boot_ups = 0;
  bool probe_sent = false;
  bool probe_answered = false;
  const auto guard = std::chrono::steady_clock::now() + std::chrono::seconds(60);  // hang guard
  std::array<std::uint8_t, 4096> buf{};
  while (!probe_answered && std::chrono::steady_clock::now() < guard) {
    pollfd p{line.master, POLLIN, 0};
    ::poll(&p, 1, 100);
    const ssize_t n = ::read(line.master, buf.data(), buf.size());
    std::span<const std::uint8_t> rest(buf.data(), n > 0 ? static_cast<std::size_t>(n) : 0);
    while (!rest.empty()) {
      CanFrame f;
      const auto r = decoder.feed(rest, f);
      rest = rest.subspan(r.consumed);
      if (!r.frame_ready) continue;
      frames.push_back(f);
      if (f.id > numen::hal::kHeartbeatBaseCobId && f.id <= numen::hal::kHeartbeatBaseCobId + 5 &&
          f.len == 1 && f.data[0] == 0)
        ++boot_ups;
      if (f.id == numen::hal::sdo_response_cob_id(2)) probe_answered = true;
    }
    // The boot-ups go out before on_ready runs: the probe waits for request 1 to be written,
    // or it could overtake it on the line.
    if (boot_ups == 5 && !probe_sent && ready_calls.load() > 0) {
      ASSERT_TRUE(numen::test::write_all(line.master, upload_device_type(2)));
      probe_sent = true;
    }
  }
  stop = true;
  device.join();
  std::printf("%s", numen::sim::format_device_summary(summary).c_str());

  EXPECT_EQ(ready_calls.load(), 1);
  ASSERT_TRUE(probe_answered) << "node 2 did not answer in 60 s (boot-ups seen: " << boot_ups << ")";
  // Node 1's answer came, before node 2's, after node 1's boot-up.
  std::ptrdiff_t boot_up_1 = -1, answer_1 = -1, answer_2 = -1;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const auto k = static_cast<std::ptrdiff_t>(i);
    if (frames[i].id == numen::hal::heartbeat_cob_id(1) && boot_up_1 < 0) boot_up_1 = k;
    if (frames[i].id == numen::hal::sdo_response_cob_id(1) && answer_1 < 0) answer_1 = k;
    if (frames[i].id == numen::hal::sdo_response_cob_id(2) && answer_2 < 0) answer_2 = k;
  }
  ASSERT_GE(answer_1, 0) << "node 1 never answered the request sent when the device was ready";
  EXPECT_LT(boot_up_1, answer_1);
  EXPECT_LT(answer_1, answer_2);
  SdoFrame response;
  ASSERT_EQ(numen::hal::decode_sdo(frames[static_cast<std::size_t>(answer_1)],
                                   numen::hal::sdo_response_cob_id(1), response),
            numen::hal::SdoDecodeStatus::kOk);
  EXPECT_EQ(response.kind, SdoFrameKind::kInitiateUploadResponse);
  EXPECT_EQ(response.address, (numen::hal::SdoAddress{0x1000, 0}));
  // Neither request was ignored; both were taken by a server.
  EXPECT_EQ(summary.sdo_not_allowed, 0);
  EXPECT_EQ(summary.sdo_requests, 2);
}

}  // namespace

TEST(DeviceProcess, ASceneOfSeveralDevicesIsRefused) {
  // numen device emulates one instrument; a [[device]] scene of two is refused, not halved.
  numen::test::TempDir dir;
  const numen::sim::Scene scene =
      numen::sim::load_scene(dir.write("two.toml", numen::test::kTwoDeviceScene));
  numen::sim::DeviceOptions options;
  options.bus = "serial:/dev/null";
  try {
    (void)numen::sim::run_device(scene, options);
    FAIL() << "a scene of two devices was emulated";
  } catch (const numen::sim::InputError& e) {
    EXPECT_EQ(e.key(), "device");
    EXPECT_NE(e.message().find("has 2 devices"), std::string::npos) << e.what();
  }
}

TEST(DeviceProcess, AHandWithAServoIsRefused) {
  // A servo moves the hand by what it sees of the scene's bodies, which this process has not.
  numen::test::TempDir dir;
  std::string text = numen::test::replace(numen::test::kMiniScene, "duration = 0.25\n",
                                          "duration = 0.25\nservo_target = [0.01, 0.0, 0.0]\n");
  text += "\n[trajectory.servo]\nbody = \"tool\"\n";
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("servo.toml", text));
  numen::sim::DeviceOptions options;
  options.bus = "serial:/dev/null";
  try {
    (void)numen::sim::run_device(scene, options);
    FAIL() << "a sighted hand was emulated blind";
  } catch (const numen::sim::InputError& e) {
    EXPECT_EQ(e.key(), "device");
    EXPECT_NE(e.message().find("has a servo"), std::string::npos) << e.what();
  }
}
