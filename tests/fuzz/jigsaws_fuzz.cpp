/// @file jigsaws_fuzz.cpp
/// libFuzzer harness of the JIGSAWS kinematics loader (sim/input/jigsaws.hpp): the input as a
/// kinematics file through load_jigsaws() (every row is checked whichever manipulator is
/// taken). The only accepted failure is sim::InputError; any other exception is a finding.

#include <cstdint>

#include "fuzz_input.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/input/jigsaws.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)numen::sim::load_jigsaws(numen::fuzz::input_file(data, size, ".txt"),
                                   numen::sim::JigsawsManipulator::slave_right);
  } catch (const numen::sim::InputError&) {
    // a located error: the expected outcome for a bad file
  }
  return 0;
}
