// Every device of a scene of several starts as device 0 does (issue 70): two mirrored trocar
// instruments (tests/data/tube_clash.toml, their trocars at x = ±90 mm, tips at x = ±28 mm)
// start pressed 16.7 mm into a board laid under their jaws. Each device's god-object is pushed
// out while its hand stays in: each feels the same force (its composite taken about its own
// tool, core::Data::feedback_point; about device 1's trocar the moment of that force took the
// torque limit and scaled device 1's feedback to less than half), and each device's start-up
// push-out is reported, with a warning naming the device (device 0's only, before).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "build_features.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace run_device_start_test {  // named: the unity build shares a TU with other test files

/// tube_clash.toml with a board (a plane, normal +z) at height `z` (m), first 0.1 s only (both
/// hands still).
std::string pressed_text(double z) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/tests/data/tube_clash.toml");
  std::ostringstream os;
  os << in.rdbuf();
  std::string text = os.str();
  const std::size_t at = text.find("[[device]]");
  EXPECT_NE(at, std::string::npos);
  std::ostringstream board;
  board << "[[obstacle]]\nname = \"board\"\ntype = \"plane\"\nmaterial = \"steel\"\n"
        << "point = [0.0, 0.0, " << z << "]\nnormal = [0.0, 0.0, 1.0]\n\n";
  text.insert(at, board.str());
  return numen::test::with_absolute_dcf_paths(text, std::string(NUMEN_SOURCE_DIR) + "/sim/scenes");
}

const numen::sim::RunSummary& pressed_run() {
  static const numen::sim::RunSummary s = [] {
    numen::test::TempDir dir;
    const numen::sim::Scene scene =
        numen::sim::load_scene(dir.write("pressed.toml", pressed_text(0.055)));
    numen::sim::RunOptions o;
    o.duration_s = 0.1;
    return numen::sim::run_scene(scene, o);
  }();
  return s;
}

bool says(const numen::sim::RunSummary& s, const std::string& what) {
  return std::any_of(s.warnings.begin(), s.warnings.end(),
                     [&](const std::string& w) { return w.find(what) != std::string::npos; });
}

TEST(RunDeviceStart, MirroredDevicesPressedAlikeFeelTheSameForce) {
  NUMEN_REQUIRE_ARTICULATION();
  const numen::sim::RunSummary& s = pressed_run();
  ASSERT_EQ(s.devices.size(), 2u);
  const double left = s.devices[0].feedback_force_max_n, right = s.devices[1].feedback_force_max_n;
  std::printf("[   info   ] feedback force max: left %.3f N, right %.3f N\n", left, right);
  EXPECT_GT(left, 2.0);  // pressed: the hand ~17 mm under its pushed-out god-object
  EXPECT_NEAR(right, left, 0.02 * left);
  EXPECT_NEAR(s.devices[1].feedback_torque_max_nm, s.devices[0].feedback_torque_max_nm,
              0.02 * s.devices[0].feedback_torque_max_nm + 1e-3);
  EXPECT_EQ(s.exit_status, 0) << (s.exit_reasons.empty() ? "" : s.exit_reasons.front());
}

TEST(RunDeviceStart, EveryDevicesToolStartingInsideIsPushedOutAndWarned) {
  NUMEN_REQUIRE_ARTICULATION();
  const numen::sim::RunSummary& s = pressed_run();
  for (const std::string& w : s.warnings) std::printf("[   info   ] %s\n", w.c_str());
  EXPECT_GT(s.startup_steps, 0);  // device 0's, as before
  EXPECT_TRUE(says(s, "the tool started inside obstacle 'board'"));
  EXPECT_TRUE(says(s, "device 'right': the tool started inside obstacle 'board', 16."))
      << "device 1's start inside the board is not said";
  EXPECT_FALSE(s.divergence.latched) << s.divergence.cause;
}

}  // namespace run_device_start_test
