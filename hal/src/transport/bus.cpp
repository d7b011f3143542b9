/// @file bus.cpp
/// Names of the Bus status values.

#include "numen/hal/transport/bus.hpp"

namespace numen::hal {

const char* to_string(IoStatus status) noexcept {
  switch (status) {
    case IoStatus::kOk:
      return "ok";
    case IoStatus::kWouldBlock:
      return "would block";
    case IoStatus::kError:
      return "error";
  }
  return "unknown";
}

const char* to_string(BusState state) noexcept {
  switch (state) {
    case BusState::kOk:
      return "ok (error active)";
    case BusState::kErrorWarning:
      return "error warning";
    case BusState::kErrorPassive:
      return "error passive";
    case BusState::kBusOff:
      return "bus off";
  }
  return "unknown";
}

}  // namespace numen::hal
