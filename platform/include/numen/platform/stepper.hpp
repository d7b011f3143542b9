#pragma once
/// @file stepper.hpp
/// platform::Stepper: the dynamics step of a control period (ControlLoop's step stage), typed
/// over the loop's (const core::Model&, core::Data&). The loop calls it; it never calls back
/// into the code that configured the loop. core::step is the default (CoreStepper); a
/// multirate run gives the multirate god-object's device period (sim::MultirateRun,
/// docs/multirate.md).

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::platform {

/// One control period of the dynamics over the loop's Model and Data. Every member runs in the
/// real-time period: it must not allocate, throw, lock or block.
class Stepper {
 public:
  virtual ~Stepper() = default;
  /// Advances `data` by one control period of `model` as core::step(model, data) would: reads
  /// the targets (Data::target, target_twist, body_targets, joint_prescribed, device_wrench)
  /// and leaves the held bodies' states and their Eq. 8 feedback (Data::body_feedback) in
  /// `data`. Timed as the period's step (PeriodReport::step_ns). `model` is never written.
  virtual void step(const core::Model& model, core::Data& data) noexcept = 0;
  /// After the period's commands were sent, outside the timed step: completes `data` with
  /// what the measurements read and the step did not write (a multirate run: the scene loop's
  /// bodies, contacts and nets, core::MultirateGodObject::view()). Default: nothing.
  virtual void finish(const core::Model& model, core::Data& data) noexcept {
    (void)model;
    (void)data;
  }

 protected:
  Stepper() = default;
  Stepper(const Stepper&) = default;
  Stepper& operator=(const Stepper&) = default;
};

/// The single-rate step: core::step(model, data).
class CoreStepper final : public Stepper {
 public:
  void step(const core::Model& model, core::Data& data) noexcept override;
};

}  // namespace numen::platform
