#pragma once
/// @file grasp_terms.hpp
/// The grasp springs in the linearised step (grasp.hpp; integrator.cpp). Private to numen::core.

#include "numen/core/types.hpp"

#include "scratch/solver_scratch.hpp"

namespace numen::core {
struct Model;
struct Data;
}  // namespace numen::core

namespace numen::core::detail {

/// Spring points the graspers of `model` may hold at once (cross blocks of the linear solve
/// beside the body–body contacts'): kMaxGraspPoints per grasper.
int grasp_point_capacity(const Model& model) noexcept;

/// One body's share of a zero-length point spring of weight W = β I (β = h c + h² k) at lever
/// arm r (m, world): b += Jᵀ impulse, and β Jᵀ J through the body's isotropic moments
/// (added to its block once, with the contacts'), J = [I, −[r]×].
inline void add_point_spring_terms(double beta, const Vec3& impulse, const Vec3& r, Vec6& rhs,
                                   IsotropicMoments& moments) noexcept {
  rhs.head<3>() += impulse;
  rhs.tail<3>() += r.cross(impulse);
  const Vec3 br = beta * r;
  moments.sum += beta;
  moments.first += br;
  moments.second.noalias() += br * r.transpose();
}

/// Adds every held body's grasp springs to the step's system (build_implicit_system(), after
/// the contacts, before the isotropic parts are added): each point's β Jᵀ J on both bodies in the
/// solve, its −h² k Jᵀ (G u0) on the right-hand side, and a cross block (SolverScratch::
/// cross_contacts, α = 0) when both bodies are in the solve. No allocation.
void add_grasp_terms(const Model& model, Data& data) noexcept;

}  // namespace numen::core::detail
