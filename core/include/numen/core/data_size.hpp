#pragma once
/// @file data_size.hpp
/// Memory footprint of a scene: bytes of core::Model and core::Data, the heap
/// part broken down by buffer group (what `numen info` prints). The heap bytes
/// of a group are Σ capacity·sizeof(element) over its std::vector buffers —
/// exactly what make_data() asked the allocator for (tests/core/data_size_test
/// checks it against the allocation counter). A group a scene does not need
/// (joints, nets, contacts) is 0: make_data() allocates nothing for it.

#include <array>
#include <cstddef>

namespace numen::core {

struct Model;
struct Data;

/// Heap bytes of one buffer group.
struct BufferGroupBytes {
  const char* group = "";  ///< e.g. "joints".
  std::size_t heap_bytes = 0;
};

/// Bytes of a Data: sizeof(Data) (includes the fixed contact array,
/// kMaxContacts × sizeof(Contact)) and its heap buffers by group.
struct DataFootprint {
  std::size_t sizeof_data = 0;
  /// bodies (states, inputs, outputs, wrenches, grasps), collision scratch, contact
  /// solver scratch (capacity.hpp), body solver scratch, joints (states,
  /// prescriptions, joint rows, tree solve), nets (nodes, node contacts,
  /// outputs, net scratch), needles and threads (their states and the threads'
  /// solve scratch), and the scratch block itself: the one heap object behind
  /// Data::scratch that holds the scratch buffers' headers (fixed size).
  std::array<BufferGroupBytes, 8> groups{};
  std::size_t heap_bytes() const noexcept;  ///< Σ groups.
};

/// Footprint of `data` (any Data made by make_data()). No allocation.
DataFootprint data_footprint(const Data& data) noexcept;

/// Bytes of a Model: sizeof(Model) and its heap arrays by group (names and
/// strings not counted). Groups: bodies (bodies, spheres, materials), obstacles
/// (obstacles, static spheres, static grid), joints (joints, articulation
/// topology), nets (nets, springs, node arrays), meshes (the mesh obstacles' and
/// bodies' shapes, Model::meshes: MeshShape::memory_bytes() each, narrow bands included).
struct ModelFootprint {
  std::size_t sizeof_model = 0;
  std::array<BufferGroupBytes, 5> groups{};
  std::size_t heap_bytes() const noexcept;  ///< Σ groups.
};

/// Footprint of a finalized `model`. No allocation.
ModelFootprint model_footprint(const Model& model) noexcept;

}  // namespace numen::core
