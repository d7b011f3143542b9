#pragma once
/// @file step.hpp
/// One fixed time step of the god-object dynamics.

namespace numen::core {

struct Model;
struct Data;

/// Advances `data` by model.dt. Stages, in order:
///   1. detect_contacts — collision geometry (collision.hpp)
///   2. forces — gravity, applied wrenches, coupling (Eq. 2) on the attached
///      body, penalty contact forces, gyroscopic term
///   3. integrate — linearly implicit or symplectic Euler (Eq. 1, §5), or
///      the imposed pose in CouplingMode::kDirect
///   4. feedback — Eq. 8 virtual-coupling wrench for the device, saturated
///   5. checks — non-finite results are rejected (state kept, status set)
/// Never allocates, throws, locks or calls the OS. Deterministic.
void step(const Model& model, Data& data) noexcept;

/// Attaches the device to body `body` (or detaches with -1); out-of-range
/// values detach. Tool switching of the paper's construction game.
void set_attached_body(const Model& model, Data& data, int body) noexcept;

}  // namespace numen::core
