/// @file frame_layout_json.cpp
/// The state frame's layout as JSON (frame_layout_json.hpp).

#include "numen/sim/view/frame_layout_json.hpp"

#include <nlohmann/json.hpp>
#include <string>

#include "numen/hal/device/device_status.hpp"
#include "numen/platform/state_frame.hpp"

namespace numen::sim {

std::string state_frame_layout_json() {
  namespace p = numen::platform;
  nlohmann::ordered_json header = nlohmann::ordered_json::array();
  for (const p::StateFrameField& f : p::kStateFrameFields)
    header.push_back({{"name", std::string(f.name)},
                      {"offset", f.offset},
                      {"type", std::string(p::frame_field_type_name(f.type))}});
  nlohmann::ordered_json arrays = nlohmann::ordered_json::array();
  for (const p::StateFrameArray& a : p::kStateFrameArrays) {
    nlohmann::ordered_json count = nullptr;
    if (a.count) count = std::string(p::frame_field(*a.count).name);
    arrays.push_back(
        {{"name", std::string(a.name)}, {"floats", a.floats}, {"count", std::move(count)}});
  }
  // The header's fault_cause by value (hal::FaultCause, hal::to_string): the page names the
  // cause of a latched safe state with them.
  nlohmann::ordered_json causes = nlohmann::ordered_json::array();
  for (int c = 0; c <= static_cast<int>(hal::kLastFaultCause); ++c)
    causes.push_back(hal::to_string(static_cast<hal::FaultCause>(c)));
  const nlohmann::ordered_json layout{
      {"magic", std::string(p::kStateFrameMagic, sizeof p::kStateFrameMagic)},
      {"version", p::kStateFrameVersion},
      {"header_bytes", p::kStateFrameHeaderBytes},
      {"float_bytes", p::kFrameFloatBytes},
      {"header", std::move(header)},
      {"arrays", std::move(arrays)},
      {"fault_causes", std::move(causes)}};
  return layout.dump();
}

}  // namespace numen::sim
