/// @file stepper.cpp

#include "numen/platform/stepper.hpp"

#include "numen/core/step.hpp"

namespace numen::platform {

void CoreStepper::step(const core::Model& model, core::Data& data) noexcept { core::step(model, data); }

}  // namespace numen::platform
