/// @file view_recording_fuzz.cpp
/// libFuzzer harness of the view recording reader that `numen view REC` serves
/// (sim/view/view_recording.hpp): the input as a .nmv file through ViewRecordingReader, whose only
/// accepted failure is InputError (located: the file, the byte offset, the scene message's
/// key); any other exception escapes and is a finding. A file it accepts is read back frame by
/// frame (each must decode again, as its index said) and searched by time. Seeds: a recording
/// of the default scene cut to two frames, and one of a scene message without frames.

#include <cstdint>
#include <cstring>
#include <vector>

#include "fuzz_input.hpp"
#include "numen/platform/state_frame.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/view/view_recording.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = numen::fuzz::input_file(data, size, ".nmv");
  try {
    const numen::sim::ViewRecordingReader reader(path);
    std::vector<std::byte> frame;
    for (std::size_t i = 0; i < reader.size(); ++i) {
      reader.frame(i, frame);
      numen::platform::StateFrameView view;
      if (!numen::platform::StateFrameDecoder::decode(frame, view).ok())
        numen::fuzz::finding("view recording: an indexed frame does not decode");
      if (view.header().period != reader.period(i) || view.header().time_ns != reader.time_ns(i))
        numen::fuzz::finding("view recording: index and frame differ");
      if (reader.frame_at_or_after(reader.time_ns(i)) > i)
        numen::fuzz::finding("view recording: frame_at_or_after past the frame");
    }
  } catch (const numen::sim::InputError& e) {
    // a located error: the expected outcome for a bad file; it quotes a bounded prefix of
    // what it refuses, whatever the size or depth of the input
    if (std::strlen(e.what()) > numen::fuzz::kMaxMessageBytes)
      numen::fuzz::finding("view recording: an error message quotes the input unbounded");
  }
  return 0;
}
