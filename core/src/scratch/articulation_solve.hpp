#pragma once
/// @file articulation_solve.hpp
/// Private to numen::core (core/src/scratch; tests and benchmarks reach it through
/// numen_core_internal): the scratch and the factor and solve of the joints' tree solve,
/// used by the integrator (joint_system.hpp) and the nets' arrowhead solve. The
/// elimination order it follows is public (ArticulationTopology, articulation.hpp).
///
/// Linear-time solve of the constrained (KKT) system of tree-structured
/// articulations (paper §4.1, Eq. 4, Eq. 7; D. Baraff, "Linear-time dynamics
/// using Lagrange multipliers", SIGGRAPH 96, §5–7):
///
///     H [x; y] = [b; c],   H = [ A  Gᵀ ]
///                              [ G  0  ]
///
/// A = blockdiag(A_i): one symmetric positive definite 6×6 block per body (the
/// mass matrix, or the implicit integrator's M − hD − h²K restricted to the
/// body); G: the joint rows (JointRows, one block row per joint, non-zero only
/// in the columns of its child and parent bodies). x: one Vec6 per body
/// (velocity change), y: one JointVector per joint (−impulse per row).
///
/// H is block sparse with the graph of the articulation forest: nodes are
/// bodies and joints, edges join a joint to its child and (if not the world)
/// its parent body. Eliminating nodes leaves-first (ArticulationTopology::nodes)
/// creates no fill-in, so factor and solve are O(n) in the number of bodies
/// (Baraff's Fig. 2 algorithm, with Cholesky factors: a body node's D_i is
/// positive definite, a joint node's D_i negative definite, factored as −D_i).
///
/// Bodies whose twist is known this step (an imposed kDirect body) are
/// decoupled: their block is the identity, their right-hand side is 0 and
/// their joint rows' blocks on them are dropped. A joint whose bodies are all
/// known (or world) has its rows disabled (y = 0).
///
/// Rooting. The static elimination tree follows the joints' direction: a body
/// is below the joint of which it is the child, a joint below its parent body;
/// the root of a tree is its joint to the world, if any, else its one body
/// that is no joint's child. A joint must not be a leaf of the elimination
/// (its pivot would be 0): with only one side an unknown body (a known child,
/// say), it must instead be the root of its component. Known bodies and
/// disabled joints cut the forest into components; in each, at most
/// one joint may be "grounded" (tied to the world or a known body): the
/// component is then re-rooted at that joint for the step (factor_articulation,
/// ArticulationScratch::elimination_parent). Two grounded joints in one
/// component close a loop through the world or the known bodies, which is not
/// a tree: factor_articulation() returns false for it.

#include <cstdint>
#include <span>
#include <vector>

#include "linalg/block_cholesky.hpp"
#include "numen/core/articulation.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;

/// Scratch of the tree factorisation and solve, sized once by resize().
struct ArticulationScratch {
  std::vector<JointRows> rows;   ///< Per joint: C and G at the step's start (filled by the caller).
  std::vector<std::uint8_t> known;  ///< Per body: 1 if its twist is known this step (see file comment).
  std::vector<std::uint8_t> joint_active;  ///< Per joint, derived by factor_articulation(): 0 if disabled.
  /// Per node: H_{i,parent(i)} (dim_i × dim_parent, zero padded), parent(i)
  /// being this step's elimination_parent; zero for a root.
  std::vector<Mat6> off_diagonal;
  std::vector<BlockCholesky> factor;  ///< Per node: Cholesky factor of D_i (body) or −D_i (joint), padded with I.
  /// Per node: P_i⁻¹ H_{i,parent(i)}, P_i = D_i (body) or −D_i (joint): Baraff's
  /// D_i⁻¹ H_{i,parent(i)} up to the node's sign. Zero for a root.
  std::vector<Mat6> coupling;
  std::vector<Vec6> work;          ///< Per node: right-hand side, then solution (solve_articulation()).
  /// Per node, derived by factor_articulation(): the elimination parent this
  /// step (ArticulationTopology's, cut at known bodies and disabled joints and
  /// reversed along a re-rooted path; see file comment), -1 for a root.
  std::vector<int> elimination_parent;
  /// Per node, derived by factor_articulation(): -1 normally; at the top
  /// (topology order) of a re-rooted component, the node index of its new root
  /// (a grounded joint); -2 on the other nodes of the reversed path from the
  /// new root to that top, which are eliminated right after the top.
  std::vector<int> reroot;

  /// Sizes every buffer for `model` (finalized): rows (count set to
  /// JointModel::num_rows, zero rows), known (all 0), joint_active (all 1),
  /// and the per-node buffers. Allocates: make_data() only.
  void resize(const Model& model);
};

/// Factors H for the body blocks `body_blocks` (one symmetric positive
/// definite Mat6 per body, full storage; blocks of known bodies are ignored)
/// and the joint rows and known flags already in `scratch`. Rows [0,
/// JointModel::num_rows) of each JointRows are read (the rest are treated as
/// zero); JointRows::count is not read. Returns false if a pivot is not
/// positive — below 1e-12 of its diagonal entry, so that exactly dependent
/// rows (a zero row, a duplicated row) are caught despite round-off — i.e. for
/// rank-deficient joint rows, a non-SPD body block, or a loop through the
/// world or known bodies (file comment). The failing node's factor is then
/// NaN, which spreads to its whole component, and solve_articulation() gives
/// NaN there (other components are solved normally).
/// O(number of bodies + joints); no allocation.
bool factor_articulation(const Model& model, std::span<const Mat6> body_blocks,
                         ArticulationScratch& scratch) noexcept;

/// Solves H [x; y] = [b; c] with the factors of factor_articulation().
/// b: one Vec6 per body (entries of known bodies ignored); c: one JointVector
/// per joint (rows ≥ num_rows ignored). x: per body (0 for known bodies);
/// y: per joint (rows ≥ num_rows and disabled joints 0). Spans may not alias.
/// O(number of bodies + joints); no allocation.
void solve_articulation(const Model& model, ArticulationScratch& scratch,
                        std::span<const Vec6> b, std::span<const JointVector> c,
                        std::span<Vec6> x, std::span<JointVector> y) noexcept;

/// Reference solve of the same system with a dense (6n + Σm)² matrix (Σm over
/// the enabled joints; known bodies get an identity block and a zero
/// right-hand side) and a full-pivot LU — for tests and for checking the
/// linear-time solve. Reads scratch.rows and scratch.known only (joint
/// activity is derived from `known`), so it needs no factor_articulation().
/// Also solves (when regular) the loops through known bodies that the tree
/// solve refuses.
/// Allocates; not for the real-time path. Same argument conventions.
void solve_articulation_dense(const Model& model, const ArticulationScratch& scratch,
                              std::span<const Mat6> body_blocks, std::span<const Vec6> b,
                              std::span<const JointVector> c, std::span<Vec6> x,
                              std::span<JointVector> y);


}  // namespace numen::core
