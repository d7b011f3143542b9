#pragma once
/// @file articulation.hpp
/// Topology of tree-structured articulations (paper §4.1): the articulation
/// forest of the joints (bodies and joints as nodes; a joint joined to its child
/// and, unless the world, its parent body), numbered into trees, and the
/// leaves-first elimination order over it that makes the joints' KKT solve
/// linear-time (D. Baraff, "Linear-time dynamics using Lagrange multipliers",
/// SIGGRAPH 96, §5–7). Built once by finalize_model() into Model::articulation.
/// The factor and solve themselves, and their scratch, are private to numen::core
/// (core/src/scratch/articulation_solve.hpp).

#include <string>
#include <vector>

namespace numen::core {

struct Model;

/// One node of the elimination tree.
struct ArticulationNode {
  bool is_joint = false;  ///< true: a joint node (dimension JointModel::num_rows); false: a body (6).
  int index = 0;          ///< Body or joint index in the Model.
  int parent = -1;        ///< Node index (in ArticulationTopology::nodes) of the elimination parent; -1: a root.
};

/// Elimination order of the articulation forest, derived from Model::joints by
/// build_articulation_topology(). Every body appears (a body without joints is
/// a one-node tree), every joint appears, each node before its parent.
struct ArticulationTopology {
  std::vector<ArticulationNode> nodes;  ///< Elimination order (leaves first).
  std::vector<int> body_node;           ///< Node index of each body.
  std::vector<int> joint_node;          ///< Node index of each joint.
  /// Articulation (connected tree) of each body: bodies joined by joints share
  /// an id and never collide with each other. Ids are 0..num_trees-1.
  std::vector<int> body_tree;
  int num_trees = 0;
  int num_rows = 0;  ///< Σ JointModel::num_rows.
};

/// Builds Model::articulation from Model::joints (and JointModel::num_rows).
/// Errors (returned as "joint 'NAME': ..."; empty on success): bad body index,
/// child == parent, num_rows outside [1, kMaxJointRows], a prescribed flag on
/// a type that cannot be prescribed, a body that is the child of two joints, a
/// cycle. Two joints to the world in one tree (a loop through the ground)
/// always make some body the child of two joints, and the message says so.
/// Children are visited in joint index order and trees numbered by their
/// smallest body index, so the result is deterministic. Allocates: load time.
std::string build_articulation_topology(Model& model);

}  // namespace numen::core
