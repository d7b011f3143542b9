#pragma once
/// @file data.hpp
/// core::Data: all mutable state, inputs, outputs and scratch of a scene,
/// allocated once by make_data() from a finalized Model. Stage functions take
/// (const Model&, Data&) and never allocate.

#include <array>
#include <cstdint>
#include <vector>

#include "numen/core/capacity.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/contact.hpp"
#include "numen/core/integrator.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;

/// State of a dynamic body: COM position and orientation (world), linear
/// velocity of the COM and angular velocity, both in world coordinates.
struct BodyState {
  Vec3 position = Vec3::Zero();            ///< m.
  Quat orientation = Quat::Identity();     ///< Unit, body → world.
  Vec3 linear_velocity = Vec3::Zero();     ///< m/s.
  Vec3 angular_velocity = Vec3::Zero();    ///< rad/s, world frame.
};

/// Status bits of the last step (Data::status).
enum StepStatus : std::uint32_t {
  kStepOk = 0,
  kContactOverflow = 1u << 0,      ///< More contacts than kMaxContacts: the rest were dropped.
  kNonFinite = 1u << 1,            ///< A NaN/Inf appeared; the state was restored from the last step.
  kSolverNotConverged = 1u << 2,   ///< The implicit solve hit max_iterations above tolerance.
  kInvalidTarget = 1u << 3,        ///< The device target was not finite: coupling skipped this step.
};

/// All mutable state of a scene.
struct Data {
  double time = 0.0;               ///< Simulated time (s).
  std::int64_t step_count = 0;

  std::vector<BodyState> bodies;   ///< Size Model::num_bodies().

  // ---- inputs (written by the caller before step) ----
  int attached_body = -1;          ///< Body the device drives; -1: none (tool switching).
  Pose target;                     ///< Device target pose of the attached body's COM frame (world).
  Twist target_twist;              ///< Device target twist (world).
  std::vector<Wrench> applied_wrench;  ///< Per body, world, at the COM (admittance input, N, N·m).

  // ---- outputs of the last step ----
  std::array<Contact, kMaxContacts> contacts{};  ///< [0, num_contacts) valid.
  int num_contacts = 0;
  int contacts_dropped = 0;        ///< Contacts lost to the capacity this step.
  std::int64_t contact_overflow_steps = 0;  ///< Steps with an overflow since reset.
  double max_penetration = 0.0;    ///< Deepest contact this step (m).
  Wrench coupling_wrench;          ///< Coupling (Eq. 2) on the attached body, at its COM.
  Wrench feedback_wrench;          ///< Eq. 8 device feedback, world, about the target point, saturated.
  int solver_iterations = 0;       ///< Iterations of the implicit solve this step.
  double solver_residual = 0.0;    ///< Relative residual reached.
  std::uint32_t status = kStepOk;  ///< StepStatus bits of the last step.
  std::int64_t nonfinite_steps = 0;  ///< Steps whose result was rejected as non-finite.

  // ---- scratch (sized once) ----
  std::vector<Wrench> body_wrench; ///< Accumulated explicit wrench per body (N, N·m, at COM).
  CollisionScratch collision;
  SolverScratch solver;
};

/// Allocates a Data for a finalized `model` and resets it. Allocates.
Data make_data(const Model& model);

/// Puts every body back at its initial pose and twist, clears inputs, outputs
/// and counters; attaches the device to Model::initial_attached_body.
/// No allocation.
void reset_data(const Model& model, Data& data) noexcept;

}  // namespace numen::core
