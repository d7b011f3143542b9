/// @file can_frame.cpp
/// Well-formedness rules of CAN frames (ISO 11898-1:2015).

#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

FrameError check_frame(const CanFrame& frame) noexcept {
  if (frame.error_frame()) {
    if (frame.id > kExtendedIdMask) return FrameError::kIdOutOfRange;
    if (frame.len > kMaxClassicLen) return FrameError::kLengthTooLong;
    return FrameError::kNone;
  }
  const std::uint32_t mask = frame.extended() ? kExtendedIdMask : kStandardIdMask;
  if ((frame.id & ~mask) != 0) return FrameError::kIdOutOfRange;
  if (frame.fd()) {
    if (frame.remote()) return FrameError::kRemoteFd;
    if (!is_valid_fd_length(frame.len)) return FrameError::kInvalidFdLength;
  } else {
    if ((frame.flags & (CanFlag::kBitRateSwitch | CanFlag::kErrorStateIndicator)) != 0) {
      return FrameError::kFdFlagWithoutFd;
    }
    if (frame.len > kMaxClassicLen) return FrameError::kLengthTooLong;
  }
  return FrameError::kNone;
}

const char* to_string(FrameError error) noexcept {
  switch (error) {
    case FrameError::kNone:
      return "well formed";
    case FrameError::kIdOutOfRange:
      return "identifier out of range";
    case FrameError::kLengthTooLong:
      return "classic frame longer than 8 bytes";
    case FrameError::kInvalidFdLength:
      return "invalid CAN FD length";
    case FrameError::kRemoteFd:
      return "remote request flagged CAN FD";
    case FrameError::kFdFlagWithoutFd:
      return "FD flag on a classic frame";
  }
  return "unknown frame error";
}

}  // namespace numen::hal
