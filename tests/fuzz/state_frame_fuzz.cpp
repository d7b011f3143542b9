/// @file state_frame_fuzz.cpp
/// libFuzzer harness of the state-frame decoder the viewer page relies on
/// (platform/state_frame.hpp; the frames `numen view` replays and the live stream sends): the
/// input as one frame through StateFrameDecoder::decode(). A frame it accepts is read whole
/// through every accessor of the view (each body's pose and target, each node, contact and
/// axis, the wrench, the penetrations, the closed loop's figures, each thread and thread node): the decoder's checks must
/// keep them inside the bytes (AddressSanitizer sees a read past them: the input is copied into
/// a buffer of its exact size). Checks: an accepted frame's header says its own size, and a refused one has a reason.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "fuzz_input.hpp"
#include "numen/platform/state_frame.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::byte> bytes(size);
  if (size > 0) std::memcpy(bytes.data(), data, size);
  numen::platform::StateFrameView view;
  const auto result = numen::platform::StateFrameDecoder::decode(bytes, view);
  if (!result.ok()) return 0;
  const auto& h = view.header();
  if (h.frame_bytes != size) numen::fuzz::finding("state frame: accepted with another size");
  float out[7];
  float sum = 0;  // keeps the reads
  for (std::uint32_t b = 0; b < h.num_bodies; ++b) {
    view.body_pose(b, out);
    sum += out[0];
    if (view.target_pose(b, out)) sum += out[6];
  }
  for (std::uint32_t n = 0; n < h.num_nodes; ++n) {
    view.node_position(n, out);
    sum += out[2];
  }
  for (std::uint32_t c = 0; c < h.num_contacts; ++c) sum += view.contact(c).depth;
  for (std::uint32_t a = 0; a < h.num_axes; ++a) sum += view.axis_torque(a);
  view.feedback(out);
  sum += out[5] + view.tool_penetration() + view.target_penetration();
  view.device_loop(out);
  sum += out[0] + out[1] + out[2];
  for (std::uint32_t t = 0; t < h.num_threads; ++t) sum += view.thread(t).max_tension;
  for (std::uint32_t n = 0; n < h.num_thread_nodes; ++n) {
    view.thread_node(n, out);
    sum += out[1];
  }
  volatile float keep = sum;
  (void)keep;
  return 0;
}
