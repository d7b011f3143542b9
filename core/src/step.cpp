/// @file step.cpp
/// PLACEHOLDER owned by the dynamics work: replaced by the real stages.

#include "numen/core/step.hpp"

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::core {

void SolverScratch::resize(const Model&) {}

void step(const Model& model, Data& data) noexcept {
  data.time += model.dt;
  ++data.step_count;
}

void set_attached_body(const Model& model, Data& data, int body) noexcept {
  data.attached_body = (body >= 0 && body < model.num_bodies()) ? body : -1;
}

}  // namespace numen::core
