#pragma once
/// @file net_system_sparse.hpp
/// The coupled linearly implicit system of bodies and nets that
/// core::solve_net_system() solves (net_solve.hpp; integrator.hpp),
///   A [Δu; Δv] = b,  A = M − hD − h²K,  b = h (f0 + h K [u0; v0]) + [M (u* − u0); 0],
/// assembled as an Eigen::SparseMatrix from the header's formulas and the
/// step's states only — never from the solver's scratch — so that it can
/// check the solver (tests/core/net_solve_test.cpp, which also densifies it)
/// and be handed to other solvers on the identical system
/// (tests/bench/net_solve_peer_bench.cpp). Terms: mass and world inertia,
/// implicit gyroscopic split (u* of implicit_gyroscopic_velocity()), the
/// held body's coupling springs (Eq. 2; kGodObject), net springs
/// (S = h γ d̂d̂ᵀ + h² k K̃, K̃ = (1 − τ) d̂d̂ᵀ + τ I, τ = max(0, 1 − L/l)),
/// ties (c = h γ_tie + h² k_tie; A_ii += c I, A_ib = −c J_i,
/// A_bb += c J_iᵀ J_i, J_i = [I, −[ρ_i]×]), node contacts on obstacles and
/// on bodies and body–body contacts (W = (h c + h² k) n nᵀ + h μ (I − n nᵀ),
/// only where the penalty force f_n = k depth − c v_n is positive).
/// Geometric terms are neglected as in the solver. Joint rows are not part
/// of it (a jointed model's KKT rows are the caller's).
/// Unknowns: 6 per body (linear; angular, m/s and rad/s), then 3 per node
/// (m/s), in the node index order (not the solver's sweep order). Rows and
/// columns of an imposed body (kDirect: Δu = 0) are the identity with b = 0.
/// h is Model::dt: the linearly implicit Euler (Integrator::kLinearlyImplicitEuler).
/// Header-only; needs numen::core (with NUMEN_WITH_DEFORMABLE) and Eigen.

#include <Eigen/Sparse>
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "numen/core/collision.hpp"
#include "numen/core/coupling.hpp"
#include "numen/core/data.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/net_forces.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_collision.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"
#include "solver/implicit_system.hpp"
#include "net/net_solve.hpp"

namespace numen::test {

/// States and inputs of one step that the system is built from, taken after
/// the contact stages (impose_direct_target, detect_contacts,
/// detect_node_contacts) and before the forces stage (compute_forces), which
/// is when step() has them.
struct NetSystemInputs {
  std::vector<core::BodyState> bodies;       ///< the bodies' states at the step's start
  std::vector<core::NodeState> nodes;        ///< the nodes' states at the step's start
  std::vector<core::NodeContact> contacts;   ///< the node contacts found this step
  std::vector<core::Contact> body_contacts;  ///< the body–body and body–obstacle contacts
  std::vector<std::uint8_t> imposed;         ///< SolverScratch::imposed (kDirect bodies)
  core::Pose target;                         ///< the device's target pose (world)
  core::Twist target_twist;                  ///< its twist (world)
  int held = -1;                             ///< Data::held_body
};

/// Copies the inputs of the system from `data` (see NetSystemInputs for when).
inline NetSystemInputs take_net_system_inputs(const core::Data& data) {
  NetSystemInputs s;
  s.bodies = data.bodies;
  s.nodes = data.nodes;
  s.contacts.assign(data.node_contacts.begin(),
                    data.node_contacts.begin() + data.num_node_contacts);
  s.body_contacts.assign(data.contacts.begin(), data.contacts.begin() + data.num_contacts);
  s.imposed = data.scratch->solver.imposed;
  s.target = data.target;
  s.target_twist = data.target_twist;
  s.held = data.held_body;
  return s;
}

/// The stages of core::step() up to the coupled solve (step.cpp, integrator.cpp's
/// linearly implicit Euler): impose_direct_target, detect_contacts (when the
/// model can collide), detect_node_contacts, the system's step h_s, the
/// forces, linearize_nets, prepare_implicit_step, build_implicit_system, build_net_system.
/// Returns the inputs taken between the contact and force stages; after it,
/// core::solve_net_system(model, data) solves the step's system (and may be
/// called again on the same system after NetScratch::delta, its warm start,
/// is restored: it overwrites the rest of the solver's scratch before reading
/// it). The states are not advanced. For a model without joints.
inline NetSystemInputs stage_net_system(const core::Model& model, core::Data& data) {
  data.status = core::kStepOk;
  core::impose_direct_target(model, data);
  if (!data.scratch->solver.contact_terms.empty()) core::detect_contacts(model, data);
  core::detect_node_contacts(model, data);
  NetSystemInputs s = take_net_system_inputs(data);
  data.scratch->solver.system_step = core::linearized_system_step(model);
  core::compute_forces(model, data);
  core::linearize_nets(model, data, data.scratch->solver.system_step);
  core::prepare_implicit_step(model, data);
  core::build_implicit_system(model, data);
  core::build_net_system(model, data);
  return s;
}

/// A (symmetric, both triangles stored, column-major) and b of the coupled
/// system; per net spring (Model::net_springs order) the weights of
/// S = α d̂d̂ᵀ + β I for a cross-check of the solver's SweepSpring.
struct NetSystem {
  Eigen::SparseMatrix<double> a;  ///< (6 nb + 3 nn)², units of mass (kg, kg·m, kg·m²)
  Eigen::VectorXd b;              ///< impulses over one step (N·s; N·m·s)
  std::vector<double> spring_alpha, spring_beta;
};

/// Index of body `k`'s first unknown (its 6: linear, angular).
inline int net_system_body_index(int k) { return 6 * k; }
/// Index of node `i`'s first unknown (its 3).
inline int net_system_node_index(const core::Model& m, int i) { return 6 * m.num_bodies() + 3 * i; }

/// Builds A and b from the model and the step's inputs (see the file comment).
/// The sparsity pattern depends only on the model and on which contacts exist
/// (every block of a term is stored, zeros included).
inline NetSystem assemble_net_system(const core::Model& m, const NetSystemInputs& s) {
  using core::Mat3;
  using core::Vec3;
  using Mat36 = Eigen::Matrix<double, 3, 6>;
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  const auto at = [](int i) { return static_cast<std::size_t>(i); };
  const auto point_jacobian = [](const Vec3& r) {  // J = [I, −[r]×]
    Mat36 j;
    j << Mat3::Identity(), -core::skew(r);
    return j;
  };
  const double h = m.dt, h2 = h * h;
  const int nb = m.num_bodies(), nn = m.num_nodes();
  const int dim = 6 * nb + 3 * nn;
  const auto bi = [](int body) { return net_system_body_index(body); };
  const auto ni = [&m](int node) { return net_system_node_index(m, node); };
  const auto in_solve = [&](int body) { return body >= 0 && !s.imposed[at(body)]; };
  // Row/column of an unknown of an imposed body: left out of the triplets.
  const auto dropped = [&](int index) { return index < 6 * nb && !in_solve(index / 6); };

  NetSystem out;
  out.b = Eigen::VectorXd::Zero(dim);
  Eigen::VectorXd& b = out.b;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(36 * nb + 9 * nn + 18 * m.net_springs.size() + 36 * nn));
  const auto put = [&](int r0, int c0, const auto& blk) {
    for (int c = 0; c < blk.cols(); ++c) {
      if (dropped(c0 + c)) continue;
      for (int r = 0; r < blk.rows(); ++r)
        if (!dropped(r0 + r)) t.emplace_back(r0 + r, c0 + c, blk(r, c));
    }
  };
  std::vector<Vec6> fb(at(nb), Vec6::Zero());
  std::vector<Vec3> fn(at(nn), Vec3::Zero());

  for (int k = 0; k < nb; ++k) {
    const core::BodyModel& bm = m.bodies[at(k)];
    const core::BodyState& st = s.bodies[at(k)];
    const Mat3 r = st.orientation.toRotationMatrix();
    const Mat3 iw = r * bm.inertia_body * r.transpose();
    Mat3 lin = bm.mass * Mat3::Identity(), ang = iw;
    const Vec3 w_star =
        core::implicit_gyroscopic_velocity(r, bm.inertia_body, st.angular_velocity, h);
    b.segment<3>(bi(k) + 3) += iw * (w_star - st.angular_velocity);
    fb[at(k)].head<3>() += bm.mass * m.gravity;
    if (k == s.held && m.coupling_mode == core::CouplingMode::kGodObject) {
      const core::CouplingGains& g = bm.coupling;
      const core::Wrench w = core::coupling_wrench(g, s.target, s.target_twist, st);
      fb[at(k)] += (Vec6() << w.force, w.torque).finished();
      lin += (h * g.gamma_t + h2 * g.k_t) * Mat3::Identity();
      ang += (h * g.gamma_r + h2 * g.k_r) * Mat3::Identity();
      b.segment<3>(bi(k)) -= h2 * g.k_t * st.linear_velocity;
      b.segment<3>(bi(k) + 3) -= h2 * g.k_r * st.angular_velocity;
    }
    put(bi(k), bi(k), lin);
    put(bi(k) + 3, bi(k) + 3, ang);
  }
  for (int i = 0; i < nn; ++i) {
    put(ni(i), ni(i), Mat3(m.node_mass[at(i)] * Mat3::Identity()));
    fn[at(i)] = m.node_mass[at(i)] * m.gravity;
  }
  // Springs: S = h γ d̂d̂ᵀ + h² k K̃, K̃ = (1 − τ) d̂d̂ᵀ + τ I, τ = max(0, 1 − L/l).
  for (const core::NetSpring& sp : m.net_springs) {
    const core::NodeState& na = s.nodes[at(sp.node_a)];
    const core::NodeState& nbs = s.nodes[at(sp.node_b)];
    const Vec3 dx = nbs.position - na.position;
    const double l = dx.norm();
    const Vec3 n = dx / l;
    const double tau = std::max(0.0, 1.0 - sp.rest_length / l);
    const Mat3 kt = (1.0 - tau) * n * n.transpose() + tau * Mat3::Identity();
    const Mat3 sm = h * sp.damping * n * n.transpose() + h2 * sp.stiffness * kt;
    out.spring_beta.push_back(h2 * sp.stiffness * tau);
    out.spring_alpha.push_back(h * sp.damping + h2 * sp.stiffness - h2 * sp.stiffness * tau);
    const Vec3 f =
        (sp.stiffness * (l - sp.rest_length) + sp.damping * n.dot(nbs.velocity - na.velocity)) * n;
    fn[at(sp.node_a)] += f;
    fn[at(sp.node_b)] -= f;
    const int ia = ni(sp.node_a), ib = ni(sp.node_b);
    put(ia, ia, sm);
    put(ib, ib, sm);
    put(ia, ib, Mat3(-sm));
    put(ib, ia, Mat3(-sm));
    const Vec3 kv = h2 * sp.stiffness * kt * (na.velocity - nbs.velocity);
    b.segment<3>(ia) -= kv;
    b.segment<3>(ib) += kv;
  }
  // Ties: c = h γ + h² k; A_ii += c I, A_ib = −c J_i, A_bb += c J_iᵀ J_i.
  for (const core::NetModel& net : m.nets) {
    const core::BodyState& body = s.bodies[at(net.body)];
    const double c = h * net.tie_damping + h2 * net.tie_stiffness;
    const int ib = bi(net.body);
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
      const Vec3 rho = body.orientation * m.node_rest[at(i)];
      const Vec3 anchor = body.position + rho;
      const Vec3 va = body.linear_velocity + body.angular_velocity.cross(rho);
      const core::NodeState& nd = s.nodes[at(i)];
      const Vec3 f =
          -net.tie_stiffness * (nd.position - anchor) - net.tie_damping * (nd.velocity - va);
      fn[at(i)] += f;
      fb[at(net.body)].head<3>() -= f;
      fb[at(net.body)].tail<3>() -= rho.cross(f);
      put(ni(i), ni(i), Mat3(c * Mat3::Identity()));
      b.segment<3>(ni(i)) -= h2 * net.tie_stiffness * (nd.velocity - va);
      if (!in_solve(net.body)) continue;
      const Mat36 j = point_jacobian(rho);
      put(ni(i), ib, Mat36(-c * j));
      put(ib, ni(i), Eigen::Matrix<double, 6, 3>(-c * j.transpose()));
      put(ib, ib, Eigen::Matrix<double, 6, 6>(c * j.transpose() * j));
      b.segment<6>(ib) += h2 * net.tie_stiffness * j.transpose() * (nd.velocity - va);
    }
  }
  // Node contacts: the penalty law and W = (h c + h² k) n nᵀ + h μ (I − n nᵀ).
  for (const core::NodeContact& ct : s.contacts) {
    const core::MaterialPair& mp = m.material_pairs[at(ct.material_pair)];
    const core::NodeState& nd = s.nodes[at(ct.node)];
    Vec3 v_rel = nd.velocity;
    Vec3 r_b = Vec3::Zero();
    if (ct.body_b >= 0) {
      const core::BodyState& bb = s.bodies[at(ct.body_b)];
      r_b = ct.position - bb.position;
      v_rel -= bb.linear_velocity + bb.angular_velocity.cross(r_b);
    }
    const Vec3& n = ct.normal;
    const double vn = n.dot(v_rel);
    const double fnorm = mp.stiffness * ct.depth - mp.damping * vn;
    if (!(fnorm > 0.0)) continue;
    const Vec3 f = fnorm * n - mp.friction * (v_rel - vn * n);
    fn[at(ct.node)] += f;
    const Mat3 w = (h * mp.damping + h2 * mp.stiffness) * n * n.transpose() +
                   h * mp.friction * (Mat3::Identity() - n * n.transpose());
    const int ii = ni(ct.node);
    put(ii, ii, w);
    b.segment<3>(ii) -= h2 * mp.stiffness * vn * n;
    if (ct.body_b < 0) continue;
    fb[at(ct.body_b)].head<3>() -= f;
    fb[at(ct.body_b)].tail<3>() -= r_b.cross(f);
    if (!in_solve(ct.body_b)) continue;
    const Mat36 j = point_jacobian(r_b);
    const int ib = bi(ct.body_b);
    put(ii, ib, Mat36(-w * j));
    put(ib, ii, Eigen::Matrix<double, 6, 3>(-j.transpose() * w));
    put(ib, ib, Eigen::Matrix<double, 6, 6>(j.transpose() * w * j));
    b.segment<6>(ib) += h2 * mp.stiffness * vn * j.transpose() * n;
  }
  // Body–body contacts: the same law, W between the two bodies' points.
  for (const core::Contact& ct : s.body_contacts) {
    const core::MaterialPair& mp = m.material_pairs[at(ct.material_pair)];
    const core::BodyState& ba = s.bodies[at(ct.body_a)];
    const core::BodyState& bb = s.bodies[at(ct.body_b)];
    const Vec3 r_a = ct.position - ba.position, r_b = ct.position - bb.position;
    const Vec3 v_rel = ba.linear_velocity + ba.angular_velocity.cross(r_a) - bb.linear_velocity -
                       bb.angular_velocity.cross(r_b);
    const Vec3& n = ct.normal;
    const double vn = n.dot(v_rel);
    const double fnorm = mp.stiffness * ct.depth - mp.damping * vn;
    if (!(fnorm > 0.0)) continue;
    const Vec3 f = fnorm * n - mp.friction * (v_rel - vn * n);
    fb[at(ct.body_a)] += (Vec6() << f, r_a.cross(f)).finished();
    fb[at(ct.body_b)] -= (Vec6() << f, r_b.cross(f)).finished();
    const Mat3 w = (h * mp.damping + h2 * mp.stiffness) * n * n.transpose() +
                   h * mp.friction * (Mat3::Identity() - n * n.transpose());
    const Mat36 ja = point_jacobian(r_a), jb = point_jacobian(r_b);
    const int ia = bi(ct.body_a), ib = bi(ct.body_b);
    put(ia, ia, Eigen::Matrix<double, 6, 6>(ja.transpose() * w * ja));
    put(ib, ib, Eigen::Matrix<double, 6, 6>(jb.transpose() * w * jb));
    put(ia, ib, Eigen::Matrix<double, 6, 6>(-ja.transpose() * w * jb));
    put(ib, ia, Eigen::Matrix<double, 6, 6>(-jb.transpose() * w * ja));
    b.segment<6>(ia) -= h2 * mp.stiffness * vn * ja.transpose() * n;
    b.segment<6>(ib) += h2 * mp.stiffness * vn * jb.transpose() * n;
  }
  for (int k = 0; k < nb; ++k) b.segment<6>(bi(k)) += h * fb[at(k)];
  for (int i = 0; i < nn; ++i) b.segment<3>(ni(i)) += h * fn[at(i)];
  for (int k = 0; k < nb; ++k) {
    if (in_solve(k)) continue;
    for (int r = 0; r < 6; ++r) t.emplace_back(bi(k) + r, bi(k) + r, 1.0);
    b.segment<6>(bi(k)).setZero();
  }
  out.a.resize(dim, dim);
  out.a.setFromTriplets(t.begin(), t.end());  // duplicates summed
  out.a.makeCompressed();
  return out;
}

/// The solver's unknowns after core::solve_net_system() as one vector in the
/// system's order: SolverScratch::delta (Δu) per body, NetScratch::delta (Δv)
/// per node.
inline Eigen::VectorXd net_system_unknowns(const core::Model& m, const core::Data& d) {
  Eigen::VectorXd x(6 * m.num_bodies() + 3 * m.num_nodes());
  for (int k = 0; k < m.num_bodies(); ++k)
    x.segment<6>(net_system_body_index(k)) = d.scratch->solver.delta[static_cast<std::size_t>(k)];
  for (int i = 0; i < m.num_nodes(); ++i)
    x.segment<3>(net_system_node_index(m, i)) = d.scratch->net.delta[static_cast<std::size_t>(i)];
  return x;
}

}  // namespace numen::test
