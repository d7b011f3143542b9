#pragma once
/// @file igtl_run.hpp
/// The OpenIGTLink tracker of a run (`numen run --bus igtl[:[HOST:]PORT]`; docs/openigtlink.md):
/// the scene's [device.igtl] read through hal::IgtlTrackerBus as the pose tracker's encoders,
/// and what the run's summary says about it. Behind an interface so that the run harness is the
/// same whether the build has OpenIGTLink (NUMEN_WITH_OPENIGTLINK) or not.

#include <cstdint>
#include <memory>

#include "numen/hal/transport/bus.hpp"
#include "numen/sim/input/bus_spec.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

/// The tracker bus of one run. Not thread safe (the run's thread); set_time_ns() and the bus's
/// read / write are the period's (never allocate, lock or throw; they block only while
/// following the tracker, hal::IgtlTrackerSettings::wait_for_tracker).
class IgtlRun {
 public:
  virtual ~IgtlRun() = default;
  /// The controller's port.
  virtual hal::Bus& bus() noexcept = 0;
  /// Sets the bus clock, ns.
  virtual void set_time_ns(std::int64_t t_ns) noexcept = 0;
  /// Stops the receiver thread (after the last period).
  virtual void finish() = 0;
  /// Writes the igtl_* figures into `s` (run_figures.cpp; docs/openigtlink.md).
  virtual void summarize(RunSummary& s) const = 0;
};

/// The tracker of `scene` for a `--bus igtl` `spec` (host and port from the spec where it gives
/// them, else from [device.igtl]), following the tracker's clock unless `paced`. nullptr for
/// any other bus. Throws InputError (key "--bus") if the scene has no [device.igtl], its device
/// runs the managed CANopen stack, or this build has no OpenIGTLink; std::invalid_argument from
/// the bus's checks.
std::unique_ptr<IgtlRun> make_igtl_run(const Scene& scene, const BusSpec& spec, bool paced);

/// Empty if `scene` can run on `spec` (not --bus igtl, or a pose tracker with [device.igtl] on
/// the minimal protocol and not admittance, in a build with OpenIGTLink), else why not.
std::string igtl_run_refusal(const Scene& scene, const BusSpec& spec);

}  // namespace numen::sim
