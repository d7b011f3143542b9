#pragma once
/// @file frame_layout_json.hpp
/// The state frame's layout as JSON, for renderers that are not C++ (docs/viewer.md,
/// "Server"): the view server sends it in its session message ("frame_layout"), live and in
/// replay, so the page decodes frames from the same declaration the encoder writes them from
/// (platform::kStateFrameFields, platform::kStateFrameArrays). Setup code (allocates).

#include <string>

namespace numen::sim {

/// The layout as compact JSON (UTF-8):
///
///     {"magic": "NMVF", "version": 4, "header_bytes": 76, "float_bytes": 4,
///      "header": [{"name": "magic", "offset": 0, "type": "char[4]"}, ...],
///      "arrays": [{"name": "body_pose", "floats": 7, "count": "num_bodies"}, ...,
///                 {"name": "feedback", "floats": 6, "count": null}, ...],
///      "fault_causes": ["none", ..., "heartbeat lost", ...]}
///
/// "header": every field in order (offset in bytes; type "u8", "u16", "u32", "i32", "u64",
/// "i64" little-endian, or "char[4]"). "arrays": the float32 arrays after the header in order:
/// floats per item and the header field that counts the items (null: one item).
/// "fault_causes": hal::to_string() of each hal::FaultCause by value (the header's
/// fault_cause).
std::string state_frame_layout_json();

}  // namespace numen::sim
