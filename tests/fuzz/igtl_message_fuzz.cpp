/// @file igtl_message_fuzz.cpp
/// libFuzzer harness of the OpenIGTLink message decoder (hal/igtl/igtl_message.hpp): every input
/// through decode_igtl_message() as the tracker's receiver decodes a message off the network.
/// A fault must be located inside the message (its byte offset within the header and the body
/// the header announces); a decoded pose (TRANSFORM, POSITION, QTRANS) must be finite, its
/// rotation orthonormal (|RᵀR − I| ≤ the tolerance, det > 0). Inputs long enough also go
/// through with their body's CRC-64 made right (their floats packed again by the library as a
/// TRANSFORM, a POSITION of 28 and of 24 bytes, and a QTRANS), so that the checks behind the
/// CRC (NaN, rigidity, unit quaternion) are reached; then the input once more, the decoder
/// holding the state those left.

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "fuzz_input.hpp"
#include "numen/hal/igtl/igtl_message.hpp"
#include "numen/hal/igtl/igtl_pack.hpp"

namespace {

void igtl_fuzz_check(numen::hal::IgtlDecoder& decoder, const std::uint8_t* data, std::size_t size) {
  using numen::fuzz::finding;
  namespace hal = numen::hal;
  hal::IgtlHeader header;
  hal::IgtlTransform tf;
  const hal::IgtlDecodeResult r = hal::decode_igtl_message(
      decoder, std::span<const std::uint8_t>(data, size), 1 << 20, header, tf);
  if (!r.ok()) {
    if (r.byte_offset > hal::kIgtlHeaderBytes + hal::kIgtlTransformBodyBytes &&
        r.byte_offset > size)
      finding("igtl: a fault located past the message");
    return;
  }
  if (!hal::igtl_pose_type(header.type)) return;
  if (!tf.rotation.allFinite() || !tf.translation.allFinite())
    finding("igtl: a decoded pose is not finite");
  const double err =
      (tf.rotation.transpose() * tf.rotation - numen::core::Mat3::Identity()).cwiseAbs().maxCoeff();
  if (!(err <= hal::kIgtlRigidTolerance) || !(tf.rotation.determinant() > 0.0))
    finding("igtl: a decoded pose is not rigid");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static numen::hal::IgtlDecoder decoder;  // made once, as the receiver's
  igtl_fuzz_check(decoder, data, size);
  // The same floats with a right CRC: the body's checks past the CRC.
  namespace hal = numen::hal;
  constexpr std::size_t n = hal::kIgtlHeaderBytes + hal::kIgtlTransformBodyBytes;
  const auto check = [&](const std::string& packed) {
    igtl_fuzz_check(decoder, reinterpret_cast<const std::uint8_t*>(packed.data()), packed.size());
  };
  if (size >= hal::kIgtlHeaderBytes + hal::kIgtlQtransBodyBytes) {
    float f[7];
    std::memcpy(f, data + hal::kIgtlHeaderBytes, sizeof f);
    const numen::core::Vec3 t(f[0], f[1], f[2]);
    const numen::core::Quat q(f[6], f[3], f[4], f[5]);  // w, x, y, z
    check(hal::pack_igtl_position("Fuzz", 0, q, t));
    check(hal::pack_igtl_position("Fuzz", 0, q, t, true));
    check(hal::pack_igtl_qtrans("Fuzz", 0, q, t));
  }
  if (size >= n) {
    numen::core::Mat3 rot;
    numen::core::Vec3 t;
    float f[12];
    std::memcpy(f, data + hal::kIgtlHeaderBytes, sizeof f);
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) rot(r, c) = f[3 * c + r];
    t = numen::core::Vec3(f[9], f[10], f[11]);
    check(hal::pack_igtl_transform("Fuzz", 0, rot, t));
  }
  // The input again, after the decoder read the other forms: a receiver's decoder is reused,
  // and the library's message objects keep the previous message's form (a finding: a 28-byte
  // body under a header the library did not read, after a 24-byte POSITION).
  igtl_fuzz_check(decoder, data, size);
  return 0;
}
