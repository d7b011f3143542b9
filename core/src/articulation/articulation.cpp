/// @file articulation.cpp
/// Elimination order of the articulation forest and the O(n) factor and solve
/// of its KKT system (D. Baraff, "Linear-time dynamics using Lagrange
/// multipliers", SIGGRAPH 96, Fig. 2), with a dense reference solve.
///
/// Notation. Every node i (body or joint) stores a symmetric positive definite
/// P_i: P_i = D_i for a body, P_i = −D_i for a joint, with D_i Baraff's
/// Schur-complement block. With s_i = +1 (body) or −1 (joint) and p = the
/// node's elimination parent, H_ip its off-diagonal block of H:
///   factor:  P_i = H_ii-part + Σ_{k child of i} H_kiᵀ P_k⁻¹ H_ki      (SPD increments,
///            since s_i = −s_k and D_i −= H_ik D_k⁻¹ H_ki),
///            E_i = P_i⁻¹ H_ip   (coupling; Baraff's D_i⁻¹ H_ip = s_i E_i);
///   solve:   forward (children first)  r_p −= s_k E_kᵀ r_k,  w_k = s_k P_k⁻¹ r_k;
///            backward (parents first)   x_k = w_k − s_k E_k x_p.
/// Joint nodes of m < 6 rows are padded with the identity in P (zero rows and
/// columns in H), so their padded entries solve to exactly 0.

#include "numen/core/articulation.hpp"

#include "linalg/block_cholesky.hpp"

#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "numen/core/model.hpp"

#include "scratch/articulation_solve.hpp"

namespace numen::core {
namespace {

/// ArticulationScratch::reroot of an inner node of a reversed path.
constexpr int kOnReversedPath = -2;

std::size_t idx(int i) noexcept { return static_cast<std::size_t>(i); }

bool body_unknown(const ArticulationScratch& s, int body) noexcept {
  return body >= 0 && s.known[idx(body)] == 0;
}

/// True if the edge between node i and its topology parent is live this step:
/// the body at one end is not known (which makes the joint at the other end
/// active).
bool edge_live(const Model& model, const ArticulationScratch& s, int i) noexcept {
  const ArticulationNode& n = model.articulation.nodes[idx(i)];
  if (n.parent < 0) return false;
  if (n.is_joint) return body_unknown(s, model.joints[idx(n.index)].parent);
  return body_unknown(s, n.index);
}

double sign(const ArticulationNode& n) noexcept { return n.is_joint ? -1.0 : 1.0; }

/// H_{i,e}: the off-diagonal block of H between adjacent nodes i and e (one a
/// joint, the other one of its bodies), 6×6 zero padded (rows ≥ m of a joint).
void off_diagonal_block(const Model& model, const ArticulationScratch& s,
                        const ArticulationNode& i, const ArticulationNode& e, Mat6& h) noexcept {
  const ArticulationNode& jn = i.is_joint ? i : e;
  const int body = i.is_joint ? e.index : i.index;
  const JointModel& jm = model.joints[idx(jn.index)];
  const JointRows& rows = s.rows[idx(jn.index)];
  const JointJacobian& g = body == jm.child ? rows.g_child : rows.g_parent;
  h.setZero();
  if (i.is_joint) {
    for (int r = 0; r < jm.num_rows; ++r) h.row(r) = g.row(r);
  } else {
    for (int r = 0; r < jm.num_rows; ++r) h.col(r) = g.row(r).transpose();
  }
}

/// Visits the nodes in this step's elimination order (each node after all its
/// elimination children): the topology order, with each reversed path taken
/// from its top down to its new root at the position of the top.
template <class F>
void for_each_forward(const Model& model, const ArticulationScratch& s, F&& visit) noexcept {
  const int nn = static_cast<int>(model.articulation.nodes.size());
  for (int i = 0; i < nn; ++i) {
    const int rr = s.reroot[idx(i)];
    if (rr == kOnReversedPath) continue;
    visit(i);
    if (rr >= 0)
      for (int n = s.elimination_parent[idx(i)]; n >= 0; n = s.elimination_parent[idx(n)]) visit(n);
  }
}

/// Visits the nodes in the reverse of for_each_forward()'s order (each node
/// after its elimination parent).
template <class F>
void for_each_backward(const Model& model, const ArticulationScratch& s, F&& visit) noexcept {
  const auto& nodes = model.articulation.nodes;
  for (int i = static_cast<int>(nodes.size()) - 1; i >= 0; --i) {
    const int rr = s.reroot[idx(i)];
    if (rr == kOnReversedPath) continue;
    if (rr < 0) {
      visit(i);
      continue;
    }
    // New root first, then up the topology parents to the top i.
    for (int n = rr;; n = nodes[idx(n)].parent) {
      visit(n);
      if (n == i) break;
    }
  }
}

/// Derives joint_active, elimination_parent and reroot from the known flags
/// (see the file comment of articulation.hpp). O(nodes), no allocation.
void build_step_tree(const Model& model, ArticulationScratch& s) noexcept {
  const ArticulationTopology& topo = model.articulation;
  const int nn = static_cast<int>(topo.nodes.size());
  for (int j = 0; j < model.num_joints(); ++j) {
    const JointModel& jm = model.joints[idx(j)];
    s.joint_active[idx(j)] = body_unknown(s, jm.child) || body_unknown(s, jm.parent) ? 1 : 0;
  }
  // Component top of each node, parents first (elimination_parent as scratch).
  std::vector<int>& top = s.elimination_parent;
  for (int i = nn - 1; i >= 0; --i) {
    top[idx(i)] = edge_live(model, s, i) ? top[idx(topo.nodes[idx(i)].parent)] : i;
    s.reroot[idx(i)] = -1;
  }
  // A joint grounded from below (known child, unknown parent) must become the
  // root of its component. Only when the component has no other grounded
  // joint: a top that is a joint is grounded from above. Further grounded
  // joints stay leaves and fail with a zero pivot.
  for (int j = 0; j < model.num_joints(); ++j) {
    const JointModel& jm = model.joints[idx(j)];
    if (body_unknown(s, jm.child) || !body_unknown(s, jm.parent)) continue;
    const int t = top[idx(topo.joint_node[idx(j)])];
    if (topo.nodes[idx(t)].is_joint || s.reroot[idx(t)] >= 0) continue;
    s.reroot[idx(t)] = topo.joint_node[idx(j)];
  }
  for (int i = 0; i < nn; ++i)
    s.elimination_parent[idx(i)] = edge_live(model, s, i) ? topo.nodes[idx(i)].parent : -1;
  for (int t = 0; t < nn; ++t) {
    const int g = s.reroot[idx(t)];
    if (g < 0) continue;
    // Reverse the path g → … → t (topology parents): the nodes below t on it
    // come before t in the topology order and were not tops.
    int below = -1;
    for (int n = g;;) {
      const int up = topo.nodes[idx(n)].parent;
      s.elimination_parent[idx(n)] = below;
      if (n == t) break;
      s.reroot[idx(n)] = kOnReversedPath;
      below = n;
      n = up;
    }
  }
}

}  // namespace

namespace {

std::string joint_name(const Model& model, int j) { return "joint '" + model.joints[idx(j)].name + "'"; }
std::string body_name(const Model& model, int b) { return "body '" + model.bodies[idx(b)].name + "'"; }

/// Checks each joint's bodies, prescription and rows, and records the joint of which each body
/// is the child (`parent_joint`, -1: none); "" or the error naming the joint.
std::string check_joints(const Model& model, std::vector<int>& parent_joint) {
  const int nb = model.num_bodies();
  parent_joint.assign(idx(nb), -1);
  for (int j = 0; j < model.num_joints(); ++j) {
    const JointModel& jm = model.joints[idx(j)];
    const std::string who = joint_name(model, j);
    if (jm.child < 0 || jm.child >= nb)
      return who + ": child body index " + std::to_string(jm.child) + " out of range [0, " +
             std::to_string(nb) + ")";
    if (jm.parent < -1 || jm.parent >= nb)
      return who + ": parent body index " + std::to_string(jm.parent) +
             " out of range [-1, " + std::to_string(nb) + ") (-1: the world)";
    if (jm.child == jm.parent)
      return who + ": child and parent are the same " + body_name(model, jm.child);
    if (jm.prescribed && !joint_can_be_prescribed(jm.type))
      return who + ": only revolute and prismatic joints can be prescribed (got " +
             to_string(jm.type) + ")";
    if (jm.num_rows < 1 || jm.num_rows > kMaxJointRows)
      return who + ": num_rows must be in [1, " + std::to_string(kMaxJointRows) + "] (got " +
             std::to_string(jm.num_rows) + "; set by finalize_model())";
    if (const int other = parent_joint[idx(jm.child)]; other >= 0) {
      std::string e = who + ": its child " + body_name(model, jm.child) +
                      " is already the child of " + joint_name(model, other) +
                      " (a body has at most one parent joint";
      // In a tree only the root body has no parent joint, so this is also how
      // a second joint to the world in one articulation shows up.
      if (jm.parent < 0 || model.joints[idx(other)].parent < 0)
        e += "; a joint to the world must hold the root body of its articulation, and one "
             "articulation has at most one: a second one closes a loop through the world";
      return e + ")";
    }
    parent_joint[idx(jm.child)] = j;
  }
  return "";
}

/// The bodies' connected components over the body-body joints (union-find) and each
/// component's joint to the world.
struct Components {
  std::vector<int> uf;           ///< Union-find parents; find() gives a component's representative.
  std::vector<int> world_joint;  ///< Per representative: its joint to the world, or -1.
  int find(int b) {
    while (uf[idx(b)] != b) {
      uf[idx(b)] = uf[idx(uf[idx(b)])];
      b = uf[idx(b)];
    }
    return b;
  }
};

/// Joins the bodies into `c`; "" or the error (a cycle, a second joint to the world).
std::string join_components(const Model& model, Components& c) {
  const int nb = model.num_bodies();
  const int nj = model.num_joints();
  c.uf.resize(idx(nb));
  std::iota(c.uf.begin(), c.uf.end(), 0);
  for (int j = 0; j < nj; ++j) {
    const JointModel& jm = model.joints[idx(j)];
    if (jm.parent < 0) continue;
    const int a = c.find(jm.child);
    const int b = c.find(jm.parent);
    if (a == b)
      return joint_name(model, j) + ": closes a cycle (its bodies " + body_name(model, jm.parent) +
             " and " + body_name(model, jm.child) + " are already joined); articulations must be trees";
    c.uf[idx(std::max(a, b))] = std::min(a, b);
  }
  c.world_joint.assign(idx(nb), -1);
  for (int j = 0; j < nj; ++j) {
    const JointModel& jm = model.joints[idx(j)];
    if (jm.parent >= 0) continue;
    const int r = c.find(jm.child);
    // Unreachable after the checks above (a second world joint needs a second
    // body without a parent joint in the tree), kept as a guard.
    if (c.world_joint[idx(r)] >= 0)
      return joint_name(model, j) + ": a second joint to the world in the articulation of " +
             joint_name(model, c.world_joint[idx(r)]) + " (a loop through the world; at most one per tree)";
    c.world_joint[idx(r)] = j;
  }
  return "";
}

/// A node of the traversal: a body or a joint.
struct TreeItem {
  bool is_joint;
  int index;
};

/// Post-order depth-first traversal of each tree from its root, a body's child joints in index
/// order: fills topo.nodes, body_node and joint_node; "" or an internal error.
std::string traverse_trees(const Model& model, const std::vector<TreeItem>& roots,
                           ArticulationTopology& topo) {
  const int nb = model.num_bodies();
  const int nj = model.num_joints();
  // Child joints of each body (compressed rows, joint index order).
  std::vector<int> first(idx(nb) + 1, 0);
  for (const JointModel& jm : model.joints)
    if (jm.parent >= 0) ++first[idx(jm.parent) + 1];
  for (int b = 0; b < nb; ++b) first[idx(b) + 1] += first[idx(b)];
  std::vector<int> child_joints(idx(first[idx(nb)]));
  {
    std::vector<int> fill(first.begin(), first.end() - 1);
    for (int j = 0; j < nj; ++j) {
      const int p = model.joints[idx(j)].parent;
      if (p >= 0) child_joints[idx(fill[idx(p)]++)] = j;
    }
  }
  topo.nodes.reserve(idx(nb + nj));
  topo.body_node.assign(idx(nb), -1);
  topo.joint_node.assign(idx(nj), -1);
  struct Frame {
    TreeItem item;
    int next_child;
  };
  std::vector<Frame> stack;
  for (const TreeItem& root : roots) {
    if (root.index < 0) return "articulation: internal error (a tree without a root)";
    stack.push_back(Frame{root, 0});
    while (!stack.empty()) {
      Frame& f = stack.back();
      TreeItem next{false, -1};
      if (f.item.is_joint) {
        if (f.next_child == 0) next = TreeItem{false, model.joints[idx(f.item.index)].child};
      } else {
        const int k = first[idx(f.item.index)] + f.next_child;
        if (k < first[idx(f.item.index) + 1]) next = TreeItem{true, child_joints[idx(k)]};
      }
      if (next.index >= 0) {
        ++f.next_child;
        stack.push_back(Frame{next, 0});
        continue;
      }
      const TreeItem done = f.item;
      stack.pop_back();
      (done.is_joint ? topo.joint_node : topo.body_node)[idx(done.index)] =
          static_cast<int>(topo.nodes.size());
      topo.nodes.push_back(ArticulationNode{done.is_joint, done.index, -1});
    }
  }
  if (topo.nodes.size() != idx(nb + nj))
    return "articulation: internal error (traversal missed a body or joint)";
  return "";
}

}  // namespace

std::string build_articulation_topology(Model& model) {
  ArticulationTopology& topo = model.articulation;
  topo = ArticulationTopology{};
  const int nb = model.num_bodies();
  std::vector<int> parent_joint;  // joint of which the body is the child
  if (std::string err = check_joints(model, parent_joint); !err.empty()) return err;
  Components components;
  if (std::string err = join_components(model, components); !err.empty()) return err;

  // Tree ids in the order of their smallest body index.
  topo.body_tree.assign(idx(nb), -1);
  std::vector<int> tree_of_rep(idx(nb), -1);
  for (int b = 0; b < nb; ++b) {
    const int r = components.find(b);
    if (tree_of_rep[idx(r)] < 0) tree_of_rep[idx(r)] = topo.num_trees++;
    topo.body_tree[idx(b)] = tree_of_rep[idx(r)];
  }
  // Root of each tree: its world joint, else its body without a parent joint.
  std::vector<TreeItem> roots(idx(topo.num_trees), TreeItem{false, -1});
  for (int b = 0; b < nb; ++b) {
    const int t = topo.body_tree[idx(b)];
    const int wj = components.world_joint[idx(components.find(b))];
    if (wj >= 0)
      roots[idx(t)] = TreeItem{true, wj};
    else if (parent_joint[idx(b)] < 0)
      roots[idx(t)] = TreeItem{false, b};
  }
  if (std::string err = traverse_trees(model, roots, topo); !err.empty()) return err;
  for (ArticulationNode& n : topo.nodes) {
    if (n.is_joint) {
      const int p = model.joints[idx(n.index)].parent;
      n.parent = p >= 0 ? topo.body_node[idx(p)] : -1;
    } else {
      const int pj = parent_joint[idx(n.index)];
      n.parent = pj >= 0 ? topo.joint_node[idx(pj)] : -1;
    }
  }
  for (const JointModel& jm : model.joints) topo.num_rows += jm.num_rows;
  return {};
}

void ArticulationScratch::resize(const Model& model) {
  const auto nb = idx(model.num_bodies());
  const auto nj = idx(model.num_joints());
  const auto nn = model.articulation.nodes.size();
  rows.assign(nj, JointRows{});
  for (std::size_t j = 0; j < nj; ++j) rows[j].count = model.joints[j].num_rows;
  known.assign(nb, 0);
  joint_active.assign(nj, 1);
  off_diagonal.assign(nn, Mat6::Zero());
  factor.assign(nn, BlockCholesky{});
  coupling.assign(nn, Mat6::Zero());
  work.assign(nn, Vec6::Zero());
  elimination_parent.assign(nn, -1);
  reroot.assign(nn, -1);
}

bool factor_articulation(const Model& model, std::span<const Mat6> body_blocks,
                         ArticulationScratch& s) noexcept {
  const auto& nodes = model.articulation.nodes;
  build_step_tree(model, s);

  // Diagonal parts: A_b for unknown bodies, −H_jj = 0 for active joint rows,
  // and the identity for known bodies, disabled joints and padding.
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const ArticulationNode& n = nodes[i];
    Mat6& p = s.factor[i].lower;
    if (!n.is_joint) {
      if (body_unknown(s, n.index))
        p = body_blocks[idx(n.index)];
      else
        p.setIdentity();
    } else {
      p.setIdentity();
      if (s.joint_active[idx(n.index)]) {
        const int m = model.joints[idx(n.index)].num_rows;
        for (int r = 0; r < m; ++r) p(r, r) = 0.0;
      }
    }
    s.off_diagonal[i].setZero();
    s.coupling[i].setZero();
  }

  bool ok = true;
  for_each_forward(model, s, [&](int i) {
    BlockCholesky& l = s.factor[idx(i)];
    ok = factor_block_in_place(l) && ok;
    const int e = s.elimination_parent[idx(i)];
    if (e < 0) return;
    const ArticulationNode& n = nodes[idx(i)];
    const ArticulationNode& pn = nodes[idx(e)];
    Mat6& h = s.off_diagonal[idx(i)];
    off_diagonal_block(model, s, n, pn, h);
    // E = P⁻¹ H, column by column (only the parent's valid columns).
    const int cols = pn.is_joint ? model.joints[idx(pn.index)].num_rows : 6;
    Mat6& c = s.coupling[idx(i)];
    for (int k = 0; k < cols; ++k) {
      Vec6 v = h.col(k);
      solve_block(l, v, v);
      c.col(k) = v;
    }
    // P_parent += Hᵀ P⁻¹ H (lower triangle is what the Cholesky reads).
    s.factor[idx(e)].lower.noalias() += h.transpose() * c;
  });
  return ok;
}

void solve_articulation(const Model& model, ArticulationScratch& s, std::span<const Vec6> b,
                        std::span<const JointVector> c, std::span<Vec6> x,
                        std::span<JointVector> y) noexcept {
  const auto& nodes = model.articulation.nodes;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const ArticulationNode& n = nodes[i];
    Vec6& w = s.work[i];
    if (!n.is_joint) {
      if (body_unknown(s, n.index))
        w = b[idx(n.index)];
      else
        w.setZero();
    } else {
      w.setZero();
      if (s.joint_active[idx(n.index)]) {
        const int m = model.joints[idx(n.index)].num_rows;
        w.head(m) = c[idx(n.index)].head(m);
      }
    }
  }
  // Forward: r_p −= s_k E_kᵀ r_k, then w_k = s_k P_k⁻¹ r_k.
  for_each_forward(model, s, [&](int k) {
    Vec6& r = s.work[idx(k)];
    const double sk = sign(nodes[idx(k)]);
    const int e = s.elimination_parent[idx(k)];
    if (e >= 0) s.work[idx(e)].noalias() -= sk * (s.coupling[idx(k)].transpose() * r);
    solve_block(s.factor[idx(k)], r, r);
    r *= sk;
  });
  // Backward: x_k = w_k − s_k E_k x_parent.
  for_each_backward(model, s, [&](int k) {
    const int e = s.elimination_parent[idx(k)];
    if (e < 0) return;
    s.work[idx(k)].noalias() -= sign(nodes[idx(k)]) * (s.coupling[idx(k)] * s.work[idx(e)]);
  });
  for (int bi = 0; bi < model.num_bodies(); ++bi) {
    if (body_unknown(s, bi))
      x[idx(bi)] = s.work[idx(model.articulation.body_node[idx(bi)])];
    else
      x[idx(bi)].setZero();
  }
  for (int j = 0; j < model.num_joints(); ++j) {
    JointVector& yj = y[idx(j)];
    yj.setZero();
    if (!s.joint_active[idx(j)]) continue;
    const int m = model.joints[idx(j)].num_rows;
    yj.head(m) = s.work[idx(model.articulation.joint_node[idx(j)])].head(m);
  }
}

void solve_articulation_dense(const Model& model, const ArticulationScratch& scratch,
                              std::span<const Mat6> body_blocks, std::span<const Vec6> b,
                              std::span<const JointVector> c, std::span<Vec6> x,
                              std::span<JointVector> y) {
  const int nb = model.num_bodies();
  const int nj = model.num_joints();
  std::vector<int> offset(idx(nj), -1);
  int size = 6 * nb;
  for (int j = 0; j < nj; ++j) {
    const JointModel& jm = model.joints[idx(j)];
    if (body_unknown(scratch, jm.child) || body_unknown(scratch, jm.parent)) {
      offset[idx(j)] = size;
      size += jm.num_rows;
    }
  }
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(size, size);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(size);
  for (int bi = 0; bi < nb; ++bi) {
    if (body_unknown(scratch, bi)) {
      h.block<6, 6>(6 * bi, 6 * bi) = body_blocks[idx(bi)];
      rhs.segment<6>(6 * bi) = b[idx(bi)];
    } else {
      h.block<6, 6>(6 * bi, 6 * bi).setIdentity();
    }
  }
  for (int j = 0; j < nj; ++j) {
    const int o = offset[idx(j)];
    if (o < 0) continue;
    const JointModel& jm = model.joints[idx(j)];
    const JointRows& rows = scratch.rows[idx(j)];
    const int m = jm.num_rows;
    for (const auto& [body, g] : {std::pair<int, const JointJacobian*>{jm.child, &rows.g_child},
                                  std::pair<int, const JointJacobian*>{jm.parent, &rows.g_parent}}) {
      if (!body_unknown(scratch, body)) continue;
      h.block(o, 6 * body, m, 6) = g->topRows(m);
      h.block(6 * body, o, 6, m) = g->topRows(m).transpose();
    }
    rhs.segment(o, m) = c[idx(j)].head(m);
  }
  const Eigen::VectorXd sol = h.fullPivLu().solve(rhs);
  for (int bi = 0; bi < nb; ++bi) {
    if (body_unknown(scratch, bi))
      x[idx(bi)] = sol.segment<6>(6 * bi);
    else
      x[idx(bi)].setZero();
  }
  for (int j = 0; j < nj; ++j) {
    y[idx(j)].setZero();
    const int o = offset[idx(j)];
    if (o >= 0) {
      const int m = model.joints[idx(j)].num_rows;
      y[idx(j)].head(m) = sol.segment(o, m);
    }
  }
}

}  // namespace numen::core
