#pragma once
/// @file octahedron_net.hpp
/// The smallest closed volume mesh with an interior node, for tests of material nets
/// (core/include/numen/core/net_material.hpp). Header-only, for test files.

#include <string>

#include "numen/core/features.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_material.hpp"

namespace numen::test {

/// A regular octahedron of half-diagonal `r` (m) with a node at its centre: 6 surface nodes,
/// 8 faces wound outward, 8 tetrahedra (each face and the centre, node 6).
inline core::TetrahedralMesh octahedron_volume(double r) {
  using core::Vec3;
  core::TetrahedralMesh m;
  m.surface.vertices = {Vec3(r, 0, 0), Vec3(-r, 0, 0), Vec3(0, r, 0),
                        Vec3(0, -r, 0), Vec3(0, 0, r), Vec3(0, 0, -r)};
  m.surface.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                         {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  m.interior = {Vec3::Zero()};
  for (const auto& f : m.surface.triangles) m.tetrahedra.push_back({f[0], f[1], f[2], 6});
  return m;
}

/// A model with one anchored rigid component ("core", 0.1 kg) and the octahedron's (half-diagonal
/// 10 mm) material net "organ" of `tissue`; the constants derived into `*c` (may be null), and
/// core::add_material_net()'s error into `*err` ("" when made). Not finalized: no materials, a
/// device held body of 0 (Model's default). Without nets (NUMEN_WITH_DEFORMABLE=OFF) no net, and
/// that in `*err`.
inline core::Model octahedron_material_model(const core::NetMaterial& tissue, core::MaterialNetConstants* c,
                                             std::string* err) {
  core::Model m;
  core::BodyModel anchor;
  anchor.name = "core";
  anchor.mass = 0.1;
  anchor.inertia_body = 1e-4 * core::Mat3::Identity();
  anchor.anchored = true;
  m.bodies = {anchor};
  core::MaterialNetSettings s;
  s.name = "organ";
  s.body = 0;
  s.tissue = tissue;
  // Compiled in every build (data_size_test.cpp is in the options' all-off build, which leaves
  // net_material.cpp out): the call only where nets are.
  if constexpr (core::kWithDeformable)
    *err = core::add_material_net(m, octahedron_volume(0.01), s, c);
  else
    *err = "nets: this build has NUMEN_WITH_DEFORMABLE=OFF";
  return m;
}

}  // namespace numen::test
