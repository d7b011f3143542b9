/// @file types.cpp
/// rotation_between(): Eigen's Quaternion::FromTwoVectors, instantiated once (types.hpp).

#include "numen/core/types.hpp"

namespace numen::core {

Quat rotation_between(const Vec3& from, const Vec3& to) { return Quat::FromTwoVectors(from, to); }

}  // namespace numen::core
