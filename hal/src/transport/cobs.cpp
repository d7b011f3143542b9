/// @file cobs.cpp
/// COBS encoder and decoder (Cheshire & Baker 1999) over caller-provided buffers.

#include "numen/hal/transport/cobs.hpp"

namespace numen::hal {
namespace {

// Code byte of a full block: 254 data bytes and no implied zero.
constexpr std::uint8_t kFullBlock = 0xFF;

}  // namespace

std::size_t cobs_encoded_length(std::span<const std::uint8_t> input) noexcept {
  std::size_t length = 1;  // the first code byte
  std::size_t run = 0;     // data bytes in the open block
  for (std::size_t i = 0; i < input.size(); ++i) {
    if (input[i] == 0) {
      ++length;  // the zero becomes the next block's code byte
      run = 0;
      continue;
    }
    ++length;
    if (++run == kFullBlock - 1u && i + 1 < input.size()) {
      ++length;  // a full block closes; a new code byte opens unless the input ends here
      run = 0;
    }
  }
  return length;
}

CobsResult cobs_encode(std::span<const std::uint8_t> input,
                       std::span<std::uint8_t> output) noexcept {
  if (output.size() < cobs_encoded_length(input)) return {0, CobsError::kOutputTooSmall};
  std::size_t code_at = 0;  // where the open block's code byte goes
  std::size_t out = 1;
  std::uint8_t code = 1;  // 1 + data bytes in the open block
  for (std::size_t i = 0; i < input.size(); ++i) {
    const std::uint8_t b = input[i];
    if (b == 0) {
      output[code_at] = code;
      code_at = out++;
      code = 1;
      continue;
    }
    output[out++] = b;
    if (++code == kFullBlock) {
      output[code_at] = code;
      code = 1;
      if (i + 1 == input.size()) return {out, CobsError::kNone};  // no empty final block
      code_at = out++;
    }
  }
  output[code_at] = code;
  return {out, CobsError::kNone};
}

CobsResult cobs_decode(std::span<const std::uint8_t> input,
                       std::span<std::uint8_t> output) noexcept {
  std::size_t in = 0;
  std::size_t out = 0;
  while (in < input.size()) {
    const std::uint8_t code = input[in++];
    if (code == 0) return {0, CobsError::kZeroInInput};
    for (std::uint8_t k = 1; k < code; ++k) {
      if (in == input.size()) return {0, CobsError::kCodeOverrun};
      const std::uint8_t b = input[in++];
      if (b == 0) return {0, CobsError::kZeroInInput};
      if (out == output.size()) return {0, CobsError::kOutputTooSmall};
      output[out++] = b;
    }
    // A block shorter than 254 bytes ends with a zero, except the last one (whose zero is
    // the virtual one appended by the encoder).
    if (code != kFullBlock && in < input.size()) {
      if (out == output.size()) return {0, CobsError::kOutputTooSmall};
      output[out++] = 0;
    }
  }
  return {out, CobsError::kNone};
}

const char* to_string(CobsError error) noexcept {
  switch (error) {
    case CobsError::kNone:
      return "ok";
    case CobsError::kOutputTooSmall:
      return "output buffer too small";
    case CobsError::kZeroInInput:
      return "zero byte inside COBS data";
    case CobsError::kCodeOverrun:
      return "COBS code byte overruns the input";
  }
  return "unknown COBS error";
}

}  // namespace numen::hal
