// Tests of sim/run_harness: the one run harness, wired for either kind of device, driven
// through its own face (RunHarness&) as run_scene()'s period loop drives it.
#include "numen/sim/run/run_harness.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "numen/sim/run/admittance_run.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"

namespace sim = numen::sim;

namespace {

sim::Scene shipped(const std::string& name) {
  return sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/" + name + ".toml");
}

/// Runs `periods` periods of `h` through the harness's face and checks what every run's
/// harness keeps, whichever kind of device its wiring assembled.
void run_through_the_face(sim::RunHarness& h, int periods, double dt) {
  EXPECT_EQ(h.periods(), 0);
  for (int k = 0; k < periods; ++k) h.period();
  h.finish();
  EXPECT_EQ(h.periods(), periods);
  EXPECT_FALSE(h.diverged());
  EXPECT_EQ(h.trace().records().size(), static_cast<std::size_t>(periods));
  EXPECT_FALSE(h.multirate().enabled());
  const sim::RunSummary s = h.summary();  // RunHarness::summarize_periods()
  EXPECT_EQ(s.steps, periods);
  EXPECT_DOUBLE_EQ(s.sim_time_s, periods * dt);
  EXPECT_GT(s.step_time_us.median, 0.0);  // the loop's step time, recorded every period
  EXPECT_FALSE(s.nan_detected);
  EXPECT_EQ(s.nonfinite_steps, 0);
}

}  // namespace

TEST(RunHarness, AssemblesTheRigOfEitherKindAndRunsItThroughOneFace) {
  const sim::Scene impedance = shipped("mesh");  // rigid: it loads in every build (all options off too)
  const sim::Scene admittance = shipped("admittance");
  std::unique_ptr<sim::RunHarness> a = std::make_unique<sim::SceneRunner>(impedance, 200);
  std::unique_ptr<sim::RunHarness> b = std::make_unique<sim::AdmittanceRunner>(admittance, 200);
  EXPECT_EQ(a->loop().num_devices(), 1u);
  EXPECT_EQ(b->loop().num_devices(), 1u);
  run_through_the_face(*a, 200, impedance.model.dt);
  run_through_the_face(*b, 200, admittance.model.dt);
  // The bus the harness owns carried the SYNCs of both kinds (one a period at least).
  for (auto* h : {a.get(), b.get()})
    EXPECT_GE(h->bus().link_counters(numen::hal::SimBus::Direction::kControllerToDevice).delivered,
              200u);
}
