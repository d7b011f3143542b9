// Tests of the shipped suturing scene (sim/scenes/suturing.toml, written by
// sim/data/make_suturing.py; docs/suturing.md "The suturing scene"): each of the two scripted
// passes goes in at its entry mark and out at its exit mark, punctures at its threshold, never
// tunnels; the needle is handed over, pulled through and handed back. SuturingFigures.* (label
// figures): the passes with both paths moved by a smooth offset of up to ±2 mm, twenty seeds.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "build_features.hpp"
#include "csv_lines.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::test::csv_column;

constexpr double kThreshold = 1.0;  // N: the scene's puncture_force

/// The shipped suturing scene run to its end, its text first passed through `edit`; with a
/// `trace` path, its per-step trace written there.
numen::sim::RunSummary run_suturing(const std::string& text, const std::string& trace = "") {
  numen::test::TempDir dir;
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("suturing.toml", text));
  numen::sim::RunOptions options;
  options.trace_path = trace;
  return numen::sim::run_scene(scene, options);
}

void print_suturing_run(const char* what, const numen::sim::RunSummary& s) {
  std::printf(
      "%s: %lld punctures, %lld exits, %lld releases, %lld tunnels, %lld through; tip force at the "
      "puncture %.4f N (its contacts asked %.4f N); deviation max %.3f mm; entry %.3f mm, exit "
      "%.3f mm from the marks; thread tension max %.3f N; grasps %lld\n",
      what, static_cast<long long>(s.needle_punctures), static_cast<long long>(s.needle_exits),
      static_cast<long long>(s.needle_releases), static_cast<long long>(s.needle_tunnels),
      static_cast<long long>(s.needle_passes), s.needle_puncture_tip_force_n,
      s.needle_puncture_contact_force_n, s.needle_deviation_max_mm, s.needle_entry_error_mm,
      s.needle_exit_error_mm, s.thread_tension_max_n, static_cast<long long>(s.grasps_started));
  for (const std::string& line : s.needle_lines) std::printf("  %s\n", line.c_str());
}

/// `text` with each device's scripted path moved by a smooth offset of at most ±2 mm on each
/// coordinate, drawn from `seed` (as `sim/data/make_suturing.py --perturb SEED` draws its own):
/// three sines a coordinate, frequencies in [0.2, 1] Hz, random phases and weights in [0.5, 1],
/// ramped in over the first second; every knot (`to = [x, y, z]` of a segment) moved by the offset
/// at its time (the segments' `duration`s summed), so that the perturbed paths keep the
/// recordings' speeds (at most 2π · 1 Hz · 2 mm = 13 mm/s added).
std::string perturbed(const std::string& text, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> frequency(0.2, 1.0), phase(0.0, 2.0 * M_PI), weight(0.5, 1.0);
  struct Wave {
    double f, phi, a;
  };
  std::array<std::array<Wave, 3>, 3> waves{};
  bool in_path = false;
  double t = 0.0;
  const auto offset = [&](int c, double at) {
    double sum = 0.0, weights = 0.0;
    for (const Wave& w : waves[static_cast<std::size_t>(c)]) sum += w.a * std::sin(2.0 * M_PI * w.f * at + w.phi), weights += w.a;
    return 0.002 * std::min(1.0, at) * sum / weights;
  };
  std::istringstream in(text);
  std::vector<std::string> out;
  std::string line;
  std::ptrdiff_t knot = -1;
  while (std::getline(in, line)) {
    if (line.rfind("[device.trajectory]", 0) == 0) {
      for (auto& coordinate : waves)
        for (Wave& w : coordinate) w = Wave{frequency(rng), phase(rng), weight(rng)};
      in_path = true;
      t = 0.0;
    }
    double x = 0, y = 0, z = 0, d = 0;
    if (in_path && line.rfind("to = [", 0) == 0) knot = static_cast<std::ptrdiff_t>(out.size());
    if (in_path && std::sscanf(line.c_str(), "duration = %lf", &d) == 1) {
      t += d;
      if (knot >= 0 && std::sscanf(out[static_cast<std::size_t>(knot)].c_str(), "to = [%lf, %lf, %lf]", &x, &y, &z) == 3) {
        char buf[128];
        std::snprintf(buf, sizeof buf, "to = [%.6f, %.6f, %.6f]", x + offset(0, t), y + offset(1, t), z + offset(2, t));
        out[static_cast<std::size_t>(knot)] = buf;
      }
      knot = -1;
    }
    out.push_back(line);
  }
  std::string joined;
  for (const std::string& l : out) joined += l + '\n';
  return joined;
}

}  // namespace

TEST(SuturingScene, BothPassesGoInAndOutAtTheirMarksAtTheThresholdWithoutATunnel) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  const std::string trace = (dir / "suturing.csv").string();
  const numen::sim::RunSummary s = run_suturing(numen::test::shipped_scene_text("suturing.toml"), trace);
  print_suturing_run("scripted passes", s);
  EXPECT_FALSE(s.nan_detected);
  EXPECT_EQ(s.exit_status, 0) << (s.exit_reasons.empty() ? "" : s.exit_reasons[0]);
  ASSERT_TRUE(s.needles);
  EXPECT_EQ(s.needle_punctures, 2);
  EXPECT_EQ(s.needle_exits, 2);
  EXPECT_EQ(s.needle_passes, 2) << "each in, then out";
  ASSERT_EQ(s.needle_runs.size(), 1u);
  ASSERT_EQ(s.needle_runs[0].num_passes, 2u);
  EXPECT_LT(s.needle_runs[0].passes[0].exit_s, s.needle_runs[0].passes[1].entry_s) << "one after the other";
  EXPECT_EQ(s.needle_tunnels, 0);
  ASSERT_TRUE(s.needle_marks);
  EXPECT_GE(s.needle_entry_error_mm, 0.0);
  EXPECT_LT(s.needle_entry_error_mm, 1.0) << "mm from the entry marks (the larger of the two passes')";
  EXPECT_GE(s.needle_exit_error_mm, 0.0);
  EXPECT_LT(s.needle_exit_error_mm, 1.0) << "mm from the exit marks";
  // The tip's contacts reach the threshold within 10 % in the puncture's step; the tissue gives way
  // at it there (core::find_punctures()).
  EXPECT_GE(s.needle_puncture_contact_force_n, kThreshold);
  EXPECT_LT(s.needle_puncture_contact_force_n, 1.1 * kThreshold)
      << "N: within 10 % of the threshold";
  EXPECT_DOUBLE_EQ(s.needle_puncture_tip_force_n, kThreshold);
  EXPECT_DOUBLE_EQ(s.needle_puncture_force_n, kThreshold);
  EXPECT_GT(s.thread_tension_max_n, 0.0);
  EXPECT_EQ(s.thread_breaks, 0);
  EXPECT_EQ(s.thread_eyelets_taken, 4) << "the thread drawn through both passes' entries and exits";
  // The slack thread between the passes: 284 of the 25 800 steps ran out of Newton iterations
  // with the compressed segments' part across in the matrix from the second iteration on, 7 045
  // with it dropped (docs/thread.md, "The compressed segments' part across").
  EXPECT_LT(s.thread_newton_not_converged_steps, 1000);

  // The trace's thread and needle columns (docs/outputs.md) tell the same story step by step.
  const std::vector<std::string> lines = numen::test::read_lines(trace);
  ASSERT_GT(lines.size(), 2u);
  const std::vector<std::string> names = numen::test::split_csv(lines[0]);
  const std::size_t time = csv_column(names, "time_s"),
                    tension = csv_column(names, "thread_tension_n"),
                    stretch = csv_column(names, "thread_stretch"),
                    unconverged = csv_column(names, "thread_unconverged"),
                    iterations = csv_column(names, "thread_newton_iterations"),
                    tip = csv_column(names, "needle_tip_force_n"),
                    points = csv_column(names, "needle_points"),
                    event = csv_column(names, "needle_event");
  double tension_max = 0.0, tension_max_s = -1.0, stretch_max = 0.0, last_puncture_tip = -1.0;
  int punctures = 0, exits = 0, points_max = 0, iterations_max = 0;
  std::int64_t unconverged_steps = 0;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> row = numen::test::split_csv(lines[i]);
    ASSERT_EQ(row.size(), names.size()) << "row " << i;
    if (std::stod(row[tension]) > tension_max) {
      tension_max = std::stod(row[tension]);
      tension_max_s = std::stod(row[time]);
    }
    stretch_max = std::max(stretch_max, std::stod(row[stretch]));
    unconverged_steps += std::stoi(row[unconverged]);
    iterations_max = std::max(iterations_max, std::stoi(row[iterations]));
    points_max = std::max(points_max, std::stoi(row[points]));
    const int e = std::stoi(row[event]);
    if (e == 1) {
      ++punctures;
      last_puncture_tip = std::stod(row[tip]);
    }
    exits += e == 2 ? 1 : 0;
  }
  EXPECT_NEAR(tension_max, s.thread_tension_max_n, 1e-6 * s.thread_tension_max_n);
  EXPECT_NEAR(tension_max_s, s.thread_tension_max_s, 1e-9);
  EXPECT_NEAR(stretch_max, s.thread_stretch_max, 1e-6 * s.thread_stretch_max);
  EXPECT_EQ(unconverged_steps, s.thread_newton_not_converged_steps);
  EXPECT_GE(iterations_max, 1);
  EXPECT_LE(iterations_max, 6);
  EXPECT_EQ(punctures, 2);
  EXPECT_EQ(exits, 2);
  EXPECT_EQ(points_max, 2) << "an entry and its exit held at once";
  EXPECT_NEAR(last_puncture_tip, s.needle_puncture_tip_force_n, 1e-6) << "the second puncture's step";
}

TEST(SuturingFigures, TwentyPassesWithTheirPathsPerturbedByTwoMillimetres) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  const std::string text = numen::test::shipped_scene_text("suturing.toml");
  int through = 0, first_through = 0, at_marks = 0, diverged = 0;
  constexpr unsigned kSeeds = 20;
  for (unsigned seed = 1; seed <= kSeeds; ++seed) {
    const numen::sim::RunSummary s = run_suturing(perturbed(text, seed));
    print_suturing_run(("seed " + std::to_string(seed)).c_str(), s);
    EXPECT_FALSE(s.nan_detected) << "seed " << seed;
    EXPECT_EQ(s.needle_tunnels, 0) << "seed " << seed << ": in without a puncture";
    if (s.divergence.latched) {  // the run stopped there: not a pass, whatever it did before
      std::printf("  diverged at %.3f s: %s of %s %.3f (limit %.3f)\n", s.divergence.time_s,
                  s.divergence.cause.c_str(), s.divergence.subject.c_str(), s.divergence.value,
                  s.divergence.limit);
      ++diverged;
      continue;
    }
    through += s.needle_passes == 2 ? 1 : 0;
    first_through += s.needle_runs.at(0).num_passes > 0 && s.needle_runs[0].passes[0].exit_s >= 0.0 ? 1 : 0;
    at_marks += (s.needle_entry_error_mm >= 0.0 && s.needle_entry_error_mm < 1.0 && s.needle_exit_error_mm >= 0.0 &&
                 s.needle_exit_error_mm < 1.0)
                    ? 1
                    : 0;
  }
  std::printf("perturbed by ±2 mm: %d of %u with both passes through (the first %d), %d of %u within 1 mm of "
              "all four marks, %d diverged\n",
              through, kSeeds, first_through, at_marks, kSeeds, diverged);
  // The issue asks 10 of 10 with both passes through within 1 mm of their marks. The drivers
  // look at the needle they hold and at their own instrument as they come to take it (their
  // servos, docs/suturing.md "The drivers' sight"): measured 20 of 20 both through and within
  // 1 mm of all four marks (the largest 0.86 mm), none diverged. One run in twenty may be lost to
  // a platform's rounding (these runs are chaotic: a grip that closes 0.1 mm aside goes another
  // way), not more.
  EXPECT_GE(first_through, 19);
  EXPECT_GE(through, 19);
  EXPECT_GE(at_marks, 19);
  EXPECT_EQ(diverged, 0);
}

// A thread shorter than the needle's arc (26 mm: the longest path the needle makes through the
// pad) is warned at load, located at its `length`.
TEST(SuturingScene, AThreadShorterThanTheNeedlesArcIsWarnedAtItsLength) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  const std::string text = numen::test::shipped_scene_text("suturing.toml");
  const auto warned = [](const numen::sim::Scene& s) {
    for (const std::string& w : s.warnings)
      if (w.find("thread[0].length:") != std::string::npos) return w;
    return std::string();
  };
  EXPECT_EQ(warned(numen::sim::load_scene(dir.write("long.toml", text))), "") << "the shipped 0.15 m thread";
  const std::string short_text = numen::test::replace(text, "length = 0.15\n", "length = 0.02\n");
  const std::size_t at = short_text.find("length = 0.02\n");
  const int line = 1 + static_cast<int>(std::count(short_text.begin(), short_text.begin() + static_cast<long>(at), '\n'));
  const std::string w = warned(numen::sim::load_scene(dir.write("short.toml", short_text)));
  EXPECT_NE(w.find("short.toml:" + std::to_string(line) + ":10: thread[0].length: thread \"suture\" (0.02 m) is "
                   "shorter than the arc of needle \"needle\""),
            std::string::npos)
      << w;
}

// The marks are read where given and need a puncture force; a bad one is a located error.
TEST(SuturingScene, MarksAreReadAndNeedAPunctureForce) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  const std::string text = numen::test::shipped_scene_text("suturing.toml");
  const numen::sim::Scene s = numen::sim::load_scene(dir.write("s.toml", text));
  ASSERT_EQ(s.needle_marks.size(), 1u);
  ASSERT_EQ(s.needle_marks[0].entry.size(), 2u) << "one per pass";
  ASSERT_EQ(s.needle_marks[0].exit.size(), 2u);
  for (const numen::core::Vec3& p : s.needle_marks[0].entry) EXPECT_NEAR(p.z(), 0.0, 1e-6) << "on the pad's top";
  for (const numen::core::Vec3& p : s.needle_marks[0].exit) EXPECT_NEAR(p.z(), 0.0, 1e-6) << "on the pad's top";
  const std::size_t at = text.find("puncture_force = 1.0\n");
  ASSERT_NE(at, std::string::npos);
  const std::string no_force = text.substr(0, at) + text.substr(at + std::string("puncture_force = 1.0\n").size());
  const numen::sim::InputError e = numen::test::load_error(dir, no_force);
  EXPECT_NE(std::string(e.what()).find("needle[0].entry_mark: a needle without a puncture_force never goes into tissue"),
            std::string::npos)
      << e.what();
  const numen::sim::InputError bad =
      numen::test::load_error(dir, numen::test::replace(text, "entry_mark = [", "entry_mark = [\"x\", "));
  EXPECT_NE(std::string(bad.what()).find("needle[0].entry_mark"), std::string::npos) << bad.what();
}
