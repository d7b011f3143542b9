/// @file dcf_fuzz.cpp
/// libFuzzer harness of the EDS/DCF reader (hal/canopen/dcf.hpp; what a scene's `dcf =` key
/// loads) and the configuration plan built from it (dcf_configuration.hpp): the input as the
/// text of a DCF through parse_dcf_text() for node 1–127 (the input's size picks it, so that an
/// input always takes the same path), whose only accepted failure is DcfError (a located
/// std::runtime_error); a file that parses goes through DcfConfiguration. Inputs of a size
/// divisible by 8 also go through parse_dcf_file() as a file. Checks: the entries are sorted by
/// index and sub-index without duplicates, find() finds each, every step of the plan has a
/// size of 1, 2, 4 or 8 bytes and names an entry of the file.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "fuzz_input.hpp"
#include "numen/hal/canopen/dcf.hpp"
#include "numen/hal/canopen/dcf_configuration.hpp"

namespace {

using numen::fuzz::finding;

void check(const numen::hal::Dcf& dcf) {
  for (std::size_t i = 0; i < dcf.entries.size(); ++i) {
    const auto& e = dcf.entries[i];
    if (i > 0) {
      const auto& p = dcf.entries[i - 1].address;
      if (p.index > e.address.index || (p.index == e.address.index && p.subindex >= e.address.subindex))
        finding("dcf: entries not sorted or duplicated", e.name);
    }
    if (dcf.find(e.address) != &e) finding("dcf: find() misses an entry", e.name);
  }
  try {
    const numen::hal::DcfConfiguration plan(std::make_shared<const numen::hal::Dcf>(dcf));
    if (plan.num_writes() > plan.steps().size()) finding("dcf: more writes than steps");
    for (const auto& s : plan.steps()) {
      if (s.size != 1 && s.size != 2 && s.size != 4 && s.size != 8) finding("dcf: step size");
      if (s.entry >= dcf.entries.size()) finding("dcf: step of no entry");
    }
  } catch (const numen::hal::DcfError&) {
    // an inconsistent PDO mapping, located: expected
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto node = static_cast<std::uint8_t>(1 + size % 127);
  try {
    check(numen::hal::parse_dcf_text(text, "fuzz.dcf", node));
  } catch (const numen::hal::DcfError&) {
    // a located error: the expected outcome for a bad file
  }
  if (size % 8 == 0) {
    try {
      (void)numen::hal::parse_dcf_file(numen::fuzz::input_file(data, size, ".dcf"), node);
    } catch (const numen::hal::DcfError&) {
    }
  }
  return 0;
}
