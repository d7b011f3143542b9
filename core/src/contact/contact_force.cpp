/// @file contact_force.cpp
/// Penalty contact forces and their Jacobians (paper §5).

#include "numen/core/contact_force.hpp"

#include <algorithm>
#include <limits>

#include <Eigen/Eigenvalues>

#include "numen/core/contact.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"

#include "scratch/data_scratch.hpp"

namespace numen::core {

namespace {

// Bodies of the public laws below, kept inline so that the per-contact loop of
// compute_contact_forces() pays no call.

inline Vec3 relative_velocity(const BodyState& a, const Vec3& r_a, const BodyState* b,
                              const Vec3& r_b) noexcept {
  Vec3 v = a.linear_velocity + a.angular_velocity.cross(r_a);
  if (b != nullptr) v -= b->linear_velocity + b->angular_velocity.cross(r_b);
  return v;
}

inline ContactForceResult penalty_force(const Vec3& normal, double depth, const Vec3& v_rel,
                                        const MaterialPair& material) noexcept {
  ContactForceResult out;
  const double v_n = normal.dot(v_rel);
  const double k = material.stiffness;
  const double onset = material.onset_depth;
  if (!(onset > 0.0) || depth >= onset) {
    // The linear law, or the smoothed law past its onset: k (d − δ0/2) − c v_n.
    const double elastic = onset > 0.0 ? k * (depth - 0.5 * onset) : k * depth;
    const double f_n = elastic - material.damping * v_n;
    if (f_n > 0.0) {
      out.normal_force = f_n;
      out.active = true;
      out.force = f_n * normal - material.friction * (v_rel - v_n * normal);
      out.stiffness = k;
      out.damping = material.damping;
      out.friction = material.friction;
    }
    return out;
  }
  if (!(depth > 0.0)) return out;
  // The onset, 0 < d < δ0: e = k d²/(2δ0), s = 3t² − 2t³, t = d/δ0.
  const double t = depth / onset;
  const double fade = t * t * (3.0 - 2.0 * t);
  const double fade_rate = 6.0 * t * (1.0 - t) / onset;  // s'(d)
  const double f_n = 0.5 * k * depth * t - material.damping * fade * v_n;
  if (f_n > 0.0) {
    out.normal_force = f_n;
    out.active = true;
    out.force = f_n * normal - (material.friction * fade) * (v_rel - v_n * normal);
    out.stiffness = std::max(0.0, k * t - material.damping * fade_rate * v_n);
    out.damping = material.damping * fade;
    out.friction = material.friction * fade;
  }
  return out;
}

/// 1/m + (r × n)ᵀ I_w⁻¹ (r × n) of one body, with I_w⁻¹ = R I_b⁻¹ Rᵀ: w = Rᵀ (r × n).
inline double inverse_mass_along(const BodyModel& body, const BodyState& state, const Vec3& r,
                                 const Vec3& n) noexcept {
  const Vec3 w = state.orientation.conjugate() * r.cross(n);
  return 1.0 / body.mass + w.dot(body.inertia_body_inv * w);
}

}  // namespace

double contact_effective_mass(const BodyModel& a, const BodyState& sa, const Vec3& r_a,
                              bool a_imposed, const BodyModel* b, const BodyState* sb,
                              const Vec3& r_b, bool b_imposed, const Vec3& normal) noexcept {
  double inv = a_imposed ? 0.0 : inverse_mass_along(a, sa, r_a, normal);
  if (b != nullptr && sb != nullptr && !b_imposed) inv += inverse_mass_along(*b, *sb, r_b, normal);
  return inv > 0.0 ? 1.0 / inv : std::numeric_limits<double>::infinity();
}

double contact_stiffness_limit(double effective_mass, double dt, double max_omega_dt) noexcept {
  const double w = max_omega_dt / dt;  // ω_c (rad/s); +∞ when the floor is off
  return effective_mass * w * w;
}

double body_contact_stiffness_limit(const Model& model, int body) {
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(body)];
  double limit = std::numeric_limits<double>::infinity();
  for (int i = bm.sphere_begin; i < bm.sphere_begin + bm.sphere_count; ++i) {
    const Mat3 rx = skew(model.body_spheres[static_cast<std::size_t>(i)].center);
    // max over unit n of (r × n)ᵀ I⁻¹ (r × n) = λ_max([r]×ᵀ I⁻¹ [r]×) (body frame).
    const Mat3 s = rx.transpose() * bm.inertia_body_inv * rx;
    const double lambda = Eigen::SelfAdjointEigenSolver<Mat3>(s, Eigen::EigenvaluesOnly)
                              .eigenvalues()
                              .maxCoeff();
    limit = std::min(limit, contact_stiffness_limit(1.0 / (1.0 / bm.mass + lambda), model.dt,
                                                    model.solver.contact_max_omega_dt));
  }
  return limit;
}

Vec3 contact_relative_velocity(const BodyState& a, const Vec3& r_a, const BodyState* b,
                               const Vec3& r_b) noexcept {
  return relative_velocity(a, r_a, b, r_b);
}

ContactForceResult contact_penalty_force(const Vec3& normal, double depth, const Vec3& v_rel,
                                         const MaterialPair& material) noexcept {
  return penalty_force(normal, depth, v_rel, material);
}

double contact_elastic_energy(double depth, const MaterialPair& material) noexcept {
  if (!(depth > 0.0)) return 0.0;
  const double k = material.stiffness, d = depth, d0 = material.onset_depth;
  if (!(d0 > 0.0)) return 0.5 * k * d * d;
  return d < d0 ? k * d * d * d / (6.0 * d0) : k * d0 * d0 / 6.0 + 0.5 * k * (d * d - d * d0);
}

Mat3x12 contact_velocity_jacobian(const Vec3& r_a, const Vec3& r_b) noexcept {
  Mat3x12 g;
  g.block<3, 3>(0, 0) = Mat3::Identity();
  g.block<3, 3>(0, 3) = -skew(r_a);
  g.block<3, 3>(0, 6) = -Mat3::Identity();
  g.block<3, 3>(0, 9) = skew(r_b);
  return g;
}

void contact_stiffness_damping(const Vec3& normal, const Vec3& r_a, const Vec3& r_b, bool active,
                               const MaterialPair& material, Mat12& stiffness,
                               Mat12& damping) noexcept {
  if (!active) {
    stiffness.setZero();
    damping.setZero();
    return;
  }
  const Mat3x12 g = contact_velocity_jacobian(r_a, r_b);
  const Mat3 nn = normal * normal.transpose();
  const Mat3 tt = Mat3::Identity() - nn;
  stiffness.noalias() = -material.stiffness * (g.transpose() * nn * g);
  damping.noalias() = -material.damping * (g.transpose() * nn * g);
  damping.noalias() -= material.friction * (g.transpose() * tt * g);
}

void compute_contact_forces(const Model& model, Data& data) noexcept {
  const int nb = model.num_bodies();
  const int np = static_cast<int>(model.material_pairs.size());
  // The contact scratch has room for what the model can produce (contact_capacity());
  // contacts beyond it (written by a caller, not by detect_contacts) are an overflow.
  const int room = static_cast<int>(data.scratch->solver.contact_terms.size());
  if (data.num_contacts > room) {
    data.contacts_dropped += data.num_contacts - room;
    data.status |= kContactOverflow;
    data.num_contacts = room;
  }
  const int nc = std::clamp(data.num_contacts, 0, kMaxContacts);
  const double max_omega_dt = model.solver.contact_max_omega_dt;
  const std::vector<std::uint8_t>& imposed = data.scratch->solver.imposed;
  data.contacts_clamped = 0;
  for (int i = 0; i < nc; ++i) {
    Contact& c = data.contacts[static_cast<std::size_t>(i)];
    ContactTerm& t = data.scratch->solver.contact_terms[static_cast<std::size_t>(i)];
    t.active = false;
    t.normal_force = 0.0;
    t.normal_velocity = 0.0;
    t.r_a.setZero();
    t.r_b.setZero();
    t.stiffness = 0.0;
    t.clamped = false;
    c.force.setZero();
    if (c.body_a < 0 || c.body_a >= nb || c.body_b >= nb || c.body_b == c.body_a ||
        c.material_pair < 0 || c.material_pair >= np)
      continue;
    const BodyState& a = data.bodies[static_cast<std::size_t>(c.body_a)];
    const BodyState* b =
        c.body_b >= 0 ? &data.bodies[static_cast<std::size_t>(c.body_b)] : nullptr;
    t.r_a = c.position - a.position;
    if (b != nullptr) t.r_b = c.position - b->position;
    Vec3 v_rel = relative_velocity(a, t.r_a, b, t.r_b);
    if (b == nullptr) v_rel -= c.surface_velocity;
    // The time-constant floor: k_eff = min(k, m_eff (ω_c h / h)²) (SolverSettings).
    MaterialPair material = model.material_pairs[static_cast<std::size_t>(c.material_pair)];
    material.stiffness *= c.stiffness_scale;  // 1 but for multirate node planes (contact.hpp)
    material.damping *= c.damping_scale;
    if (material.stiffness > 0.0 && max_omega_dt < std::numeric_limits<double>::infinity()) {
      const auto ia = static_cast<std::size_t>(c.body_a);
      const bool b_imposed = b != nullptr && imposed[static_cast<std::size_t>(c.body_b)] != 0;
      const double m_eff = contact_effective_mass(
          model.bodies[ia], a, t.r_a, imposed[ia] != 0,
          b != nullptr ? &model.bodies[static_cast<std::size_t>(c.body_b)] : nullptr, b, t.r_b,
          b_imposed, c.normal);
      const double limit = contact_stiffness_limit(m_eff, model.dt, max_omega_dt);
      if (material.stiffness > limit) {
        material.stiffness = limit;
        t.clamped = true;
        ++data.contacts_clamped;
      }
    }
    t.stiffness = material.stiffness;
    const ContactForceResult f = penalty_force(c.normal, c.depth, v_rel, material);
    if (!f.active) continue;
    t.active = true;
    t.stiffness = f.stiffness;  // the law's ∂f_n/∂d: k_eff for the linear law
    t.damping = f.damping;
    t.friction = f.friction;
    t.normal_force = f.normal_force;
    t.normal_velocity = c.normal.dot(v_rel);
    c.force = f.force;
    Wrench& wa = data.body_wrench[static_cast<std::size_t>(c.body_a)];
    wa.force += f.force;
    wa.torque += t.r_a.cross(f.force);
    if (b != nullptr) {
      Wrench& wb = data.body_wrench[static_cast<std::size_t>(c.body_b)];
      wb.force -= f.force;
      wb.torque -= t.r_b.cross(f.force);
    }
  }
}

}  // namespace numen::core
