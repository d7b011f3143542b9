#pragma once
/// @file multirate_run.hpp
/// The multirate god-object of a run (scene [multirate]; docs/multirate.md), owned by the run
/// harness (RunHarness, for either kind of device, through its platform::ControlLoop):
/// the core::MultirateGodObject the loop steps in place of
/// core::step (a platform::Stepper given to ControlLoop::set_stepper()), its scene thread in a paced run
/// (platform::MultirateThreads), the single-rate view the measurements read, and the run
/// summary's multirate figures.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/multirate.hpp"
#include "numen/platform/multirate_threads.hpp"
#include "numen/platform/stepper.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

struct RunSummary;  // run_summary.hpp

/// A scene's multirate god-object wired for a run. Empty (enabled() false) for a single-rate
/// scene; then every member does nothing.
class MultirateRun final : public platform::Stepper {
 public:
  /// The empty run of a single-rate scene (enabled() false).
  MultirateRun() = default;
  /// Builds the god-object for `scene` (must outlive this) if it has [multirate]: the device
  /// holds Model::initial_held_body, may switch to any of MultirateScene::tools. Allocates;
  /// throws std::invalid_argument with core::MultirateGodObject's message.
  explicit MultirateRun(const Scene& scene);
  ~MultirateRun() override;  ///< Stops the scene thread.
  MultirateRun(const MultirateRun&) = delete;
  MultirateRun& operator=(const MultirateRun&) = delete;

  /// True when the scene has [multirate] (a god-object was built).
  bool enabled() const noexcept { return god_object_ != nullptr; }

  /// One device period in place of core::step(model, run_data) (the loop's step stage),
  /// `run_data` the loop's Data of the scene (`model`, the scene's, is not read: the
  /// god-object has its own): the device holds run_data.held_body (tool switching), the
  /// device loop gets run_data's targets and measured device wrench
  /// (core::MultirateGodObject::take_targets()), the device period runs (and the scene period
  /// on one thread, or the newest model from the scene thread), run_data gets the god-object's
  /// state and feedback (write_feedback()). Never allocates, throws, locks or blocks.
  void step(const core::Model& model, core::Data& run_data) noexcept override;
  /// The single-rate view of both loops into `run_data` (core::MultirateGodObject::view()),
  /// called by the loop after the commands were sent (outside the timed step), before the
  /// run measures. Never allocates.
  void finish(const core::Model& model, core::Data& run_data) noexcept override;
  /// The last device period took a new scene model (a scene-step boundary).
  bool took_model() const noexcept { return god_object_ && god_object_->took_model(); }

  /// A paced run: steps the scene loop on its own thread at scene_dt from now on, with
  /// `settings` (scheduling, CPUs), until stop(). Allocates (call before the first period).
  /// Throws std::system_error if the thread cannot start. Nothing if not enabled or started.
  void start_scene_thread(const platform::SceneThreadSettings& settings);
  /// Stops and joins the scene thread (idempotent).
  void stop() noexcept;
  /// The scene thread (null: none started).
  const platform::MultirateThreads* scene_thread() const noexcept { return scene_thread_.get(); }

  /// The multirate figures of the run so far into `s` (RunSummary::multirate: scene steps,
  /// planes, switches, stale models, the scene thread's overruns and step time; a warning for
  /// planes dropped). Read the scene thread's after stop().
  void summarize(RunSummary& s) const;
  /// The scene thread's scheduling and CPU affinity lines, as asked in `settings`
  /// (--scene-rt-priority, --scene-cpu), each prefixed "scene thread ", appended to `lines`.
  void describe_scene_thread(const platform::SceneThreadSettings& settings,
                             std::vector<std::string>& lines) const;

 private:
  const Scene* scene_ = nullptr;
  std::unique_ptr<core::MultirateGodObject> god_object_;
  std::unique_ptr<platform::MultirateThreads> scene_thread_;
};

}  // namespace numen::sim
