// Tests of sim/run/needle_summary: the suture needles of a run in its summary
// (docs/suturing.md "The needle through tissue", docs/outputs.md `needle.*`).

#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/needle_puncture.hpp"
#include "numen/sim/run/needle_summary.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::core::Vec3;

/// A model of one net (three nodes, one triangle, its rigid component at z = 10 mm) and one
/// needle with a 1 N threshold; its marks 1 mm off the entry's and 2 mm off the exit's rest point.
numen::sim::Scene pad_scene() {
  numen::sim::Scene scene;
  numen::core::Model& m = scene.model;
  m.bodies.resize(1);
  m.bodies[0].initial_pose.position = Vec3(0.0, 0.0, 0.01);
  m.nets.resize(1);
  m.nets[0].body = 0;
  m.nets[0].node_count = 3;
  m.nets[0].face_count = 1;
  m.node_rest = {Vec3(0.0, 0.0, 0.0), Vec3(0.01, 0.0, 0.0), Vec3(0.0, 0.01, 0.0)};
  m.net_faces = {{0, 1, 2}};
  m.needles.resize(1);
  m.needles[0].name = "sh";
  m.needles[0].puncture_force = 1.0;
  scene.needle_marks.resize(1);
  scene.needle_marks[0].entry = {Vec3(0.0, 0.001, 0.01)};   // entry at rest: (0, 0, 10) mm
  scene.needle_marks[0].exit = {Vec3(0.01, 0.002, 0.01)};   // exit at rest: (10, 0, 10) mm
  return scene;
}

}  // namespace

// The step's outputs over a run: the counts, the largest deviation, the first entry's and exit's
// material points at rest against the marks, the tip force at the puncture against its threshold;
// a tunnel is a warning naming the needle and makes the run's exit status 7 (diverged).
TEST(NeedleSummary, CountsThePassItsErrorsFromTheMarksAndATunnelIsAWarningAndAFailedRun) {
  const numen::sim::Scene scene = pad_scene();
  const numen::core::Model& m = scene.model;
  numen::core::Data d;
  d.needles.resize(1);
  numen::sim::RunSummary s;
  numen::sim::begin_needle_figures(scene, s);
  numen::core::NeedleState& n = d.needles[0];
  {
    numen::test::AllocationGuard guard;
    d.time = 0.25;  // nothing yet
    numen::sim::accumulate_needle_figures(m, d, s);
    d.time = 0.5;   // the puncture: an entry at node 0
    n.punctures_made = 1;
    n.num_punctures = 1;
    n.punctures[0].net = 0;
    n.punctures[0].face = 0;
    n.punctures[0].weights = Vec3(1.0, 0.0, 0.0);
    n.puncture_tip_force = 1.0;
    n.puncture_contact_force = 1.03;
    numen::sim::accumulate_needle_figures(m, d, s);
    d.time = 0.75;  // the exit at node 1; the entry's point 0.3 mm off the arc
    n.exits = 1;
    n.num_punctures = 2;
    n.punctures[1] = n.punctures[0];
    n.punctures[1].exit = true;
    n.punctures[1].weights = Vec3(0.0, 1.0, 0.0);
    n.max_deviation = 3e-4;
    numen::sim::accumulate_needle_figures(m, d, s);
    d.time = 1.0;  // pulled through: the entry let go; a tunnel
    n.releases = 1;
    n.max_deviation = 1e-4;
    n.tunnels = 1;
    n.tunnels_stopped = 3;
    numen::sim::accumulate_needle_figures(m, d, s);
    d.time = 1.25;
    numen::sim::accumulate_needle_figures(m, d, s);
    EXPECT_EQ(guard.count(), 0);
  }
  const std::size_t warnings = s.warnings.size();
  numen::sim::summarize_needles(s);
  EXPECT_TRUE(s.needles);
  EXPECT_EQ(s.needle_punctures, 1);
  EXPECT_EQ(s.needle_exits, 1);
  EXPECT_EQ(s.needle_releases, 1);
  EXPECT_EQ(s.needle_tunnels, 1);
  EXPECT_EQ(s.needle_tunnels_stopped, 3);
  EXPECT_EQ(s.needle_passes, 1);
  EXPECT_DOUBLE_EQ(s.needle_puncture_tip_force_n, 1.0);
  EXPECT_DOUBLE_EQ(s.needle_puncture_contact_force_n, 1.03);
  EXPECT_DOUBLE_EQ(s.needle_puncture_force_n, 1.0);
  EXPECT_DOUBLE_EQ(s.needle_deviation_max_mm, 0.3);
  EXPECT_TRUE(s.needle_marks);
  EXPECT_NEAR(s.needle_entry_error_mm, 1.0, 1e-9);
  EXPECT_NEAR(s.needle_exit_error_mm, 2.0, 1e-9);
  ASSERT_EQ(s.needle_lines.size(), 1u);
  EXPECT_EQ(s.needle_lines[0],
            "sh: 1 puncture, 1 exit, 1 release, 1 tunnel; through (in at 0.500 s, out at 0.750 s); tip force "
            "at the last puncture 1.000 N (threshold 1.000 N; its contacts asked 1.030 N); deviation from the arc max 0.300 mm; entry "
            "1.000 mm from its mark; exit 2.000 mm from its mark");
  ASSERT_EQ(s.warnings.size(), warnings + 1);
  EXPECT_NE(s.warnings.back().find("needle 'sh' went into tissue without puncturing it 1 time, the first at 1.000 s"),
            std::string::npos)
      << s.warnings.back();
  const numen::sim::RunVerdict v = numen::sim::run_verdict(s);
  EXPECT_EQ(v.status, numen::sim::ExitStatus::kDiverged);
  ASSERT_FALSE(v.reasons.empty());
  EXPECT_EQ(v.reasons[0].rfind("diverged: 1 needle tunnel(s)", 0), 0u) << v.reasons[0];
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j["needle"]["tunnels"].get<std::int64_t>(), 1);
  EXPECT_EQ(j["needle"]["tunnels_stopped"].get<std::int64_t>(), 3);
  EXPECT_EQ(j["needle"]["passes"].get<std::int64_t>(), 1);
  EXPECT_NEAR(j["needle"]["entry_error_mm"].get<double>(), 1.0, 1e-9);
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("  needles: 1 punctures, 1 exits, 1 releases, 1 tunnels (3 steps held back at the surface); "
                      "1 through; tip force at the last puncture 1.000 N (threshold 1.000 N; its contacts asked 1.030 N); deviation from the arc max 0.300 mm; force on "
                      "the tissue max 0.000 N at -1.000 s; from the marks: entry 1.000 mm, exit 2.000 mm\n  "
                      "needle sh: "),
            std::string::npos)
      << text;
}

// Two passes, each against its own marks (`entry_mark`, `exit_mark` lists): an attempt drawn back
// out before its exit is replaced by the next entry; the second pass's errors are its own marks';
// a marked pass that never came out makes the exit error −1 ("missed"). No allocation.
TEST(NeedleSummary, EachPassIsMeasuredAgainstItsOwnMarks) {
  numen::sim::Scene scene = pad_scene();
  scene.needle_marks[0].entry.push_back(Vec3(0.0, 0.0105, 0.01));    // pass 2's entry: node 2, 0.5 mm off
  scene.needle_marks[0].exit.push_back(Vec3(0.01, 0.0, 0.0115));     // its exit: node 1, 1.5 mm off
  scene.needle_marks[0].exit.push_back(Vec3(0.0, 0.0, 0.01));        // a third pass, never made
  const numen::core::Model& m = scene.model;
  numen::core::Data d;
  d.needles.resize(1);
  numen::sim::RunSummary s;
  numen::sim::begin_needle_figures(scene, s);
  numen::core::NeedleState& n = d.needles[0];
  const auto point = [](bool exit, int node) {
    numen::core::NeedlePuncture p;
    p.net = 0, p.face = 0, p.exit = exit;
    p.weights = Vec3::Zero();
    p.weights[node] = 1.0;
    return p;
  };
  const auto entry = [&](double t, int node) {
    d.time = t, ++n.punctures_made, n.num_punctures = 1, n.punctures[0] = point(false, node);
    numen::sim::accumulate_needle_figures(m, d, s);
  };
  const auto exit = [&](double t, int node) {
    d.time = t, ++n.exits, n.num_punctures = 2, n.punctures[1] = point(true, node);
    numen::sim::accumulate_needle_figures(m, d, s);
  };
  {
    numen::test::AllocationGuard guard;
    entry(0.5, 1);   // an attempt at node 1, drawn back out
    d.time = 0.6, n.num_punctures = 0, ++n.releases;
    numen::sim::accumulate_needle_figures(m, d, s);
    entry(0.7, 0);   // pass 1: in at node 0, out at node 1
    exit(0.9, 1);
    d.time = 1.0, n.num_punctures = 0, n.releases += 2;
    numen::sim::accumulate_needle_figures(m, d, s);
    entry(2.0, 2);   // pass 2: in at node 2, out at node 1
    exit(2.5, 1);
    EXPECT_EQ(guard.count(), 0);
  }
  const numen::sim::NeedleRunFigures& r = s.needle_runs[0];
  ASSERT_EQ(r.num_passes, 2u);
  EXPECT_DOUBLE_EQ(r.passes[0].entry_s, 0.7);
  EXPECT_DOUBLE_EQ(r.passes[1].exit_s, 2.5);
  numen::sim::summarize_needles(s);
  EXPECT_EQ(s.needle_punctures, 3);
  EXPECT_EQ(s.needle_passes, 2);
  EXPECT_DOUBLE_EQ(s.needle_entry_error_mm, 1.0) << "pass 1's 1 mm, pass 2's 0.5 mm";
  EXPECT_DOUBLE_EQ(s.needle_exit_error_mm, -1.0) << "the third pass's exit mark: missed";
  ASSERT_EQ(s.needle_lines.size(), 1u);
  EXPECT_EQ(s.needle_lines[0],
            "sh: 3 punctures, 2 exits, 3 releases, 0 tunnels; 2 of 3 passes through; tip force at the last "
            "puncture 0.000 N (threshold 1.000 N; its contacts asked 0.000 N); deviation from the arc max 0.000 mm; pass 1: through (in "
            "at 0.700 s, out at 0.900 s), entry 1.000 mm from its mark, exit 2.000 mm from its mark; pass 2: "
            "through (in at 2.000 s, out at 2.500 s), entry 0.500 mm from its mark, exit 1.500 mm from its "
            "mark; pass 3: never in, exit mark missed (none)");
  numen::sim::RunSummary again;  // without the third mark: the largest of the two passes' errors
  scene.needle_marks[0].exit.pop_back();
  numen::sim::begin_needle_figures(scene, again);
  again.needle_runs[0].passes = r.passes, again.needle_runs[0].num_passes = r.num_passes;
  numen::sim::summarize_needles(again);
  EXPECT_DOUBLE_EQ(again.needle_exit_error_mm, 2.0);
}

// The largest force on the tissue: |Σ F| of the held node springs after the penalty contacts and
// the grasp springs — the needles' ties, then the threads' eyelets on tissue — at each step, and its
// time; the contacts and grasp springs before them are not counted. No allocation.
TEST(NeedleSummary, TheLargestForceOnTheTissueIsTheSumOfTheNeedleTiesAndThreadEyeletsSprings) {
  const numen::sim::Scene scene = pad_scene();
  numen::core::Data d;
  d.needles.resize(1);
  d.node_contacts.resize(8);
  numen::sim::RunSummary s;
  numen::sim::begin_needle_figures(scene, s);
  {
    numen::test::AllocationGuard guard;
    d.time = 0.5;  // a penalty contact and a grasp spring only: nothing on the tissue from a needle
    d.num_node_contacts = 1;
    d.num_node_grasp_springs = 1;
    d.node_contacts[0].force = Vec3(0.0, 0.0, 50.0);
    d.node_contacts[1].force = Vec3(0.0, 0.0, 40.0);
    numen::sim::accumulate_needle_figures(scene.model, d, s);
    EXPECT_EQ(s.needle_tissue_force_max_n, 0.0);
    EXPECT_EQ(s.needle_tissue_force_max_s, -1.0);
    d.time = 1.0;  // two needle tie springs and a thread eyelet's: (0.3, 0.4, 0) + (0, 0, 1.2) N
    d.num_node_needle_ties = 2;
    d.num_node_thread_ties = 1;
    d.node_contacts[2].force = Vec3(0.3, 0.0, 0.0);
    d.node_contacts[3].force = Vec3(0.0, 0.4, 0.0);
    d.node_contacts[4].force = Vec3(0.0, 0.0, 1.2);
    d.node_contacts[5].force = Vec3(0.0, 0.0, 99.0);  // past the ties: not counted
    numen::sim::accumulate_needle_figures(scene.model, d, s);
    d.time = 1.5;  // smaller: the largest stays
    d.node_contacts[4].force = Vec3(0.0, 0.0, 0.1);
    numen::sim::accumulate_needle_figures(scene.model, d, s);
    EXPECT_EQ(guard.count(), 0);
  }
  EXPECT_NEAR(s.needle_tissue_force_max_n, 1.3, 1e-12);
  EXPECT_DOUBLE_EQ(s.needle_tissue_force_max_s, 1.0);
  numen::sim::summarize_needles(s);
  EXPECT_NE(numen::sim::format_summary(s).find("force on the tissue max 1.300 N at 1.000 s"), std::string::npos);
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_NEAR(j["needle"]["tissue_force_max_n"].get<double>(), 1.3, 1e-9);
  EXPECT_DOUBLE_EQ(j["needle"]["tissue_force_max_s"].get<double>(), 1.0);
}

// A needle that went in and never came out: not through; its exit mark missed (−1); no tunnel,
// no warning, a clean verdict as far as the needle goes.
TEST(NeedleSummary, AnEntryWithoutAnExitIsNotThroughAndMissesTheExitMark) {
  const numen::sim::Scene scene = pad_scene();
  numen::core::Data d;
  d.needles.resize(1);
  numen::sim::RunSummary s;
  numen::sim::begin_needle_figures(scene, s);
  d.time = 0.5;
  d.needles[0].punctures_made = 1;
  d.needles[0].num_punctures = 1;
  d.needles[0].punctures[0].net = 0;
  d.needles[0].punctures[0].face = 0;
  d.needles[0].punctures[0].weights = Vec3(0.0, 0.0, 1.0);
  numen::sim::accumulate_needle_figures(scene.model, d, s);
  const std::size_t warnings = s.warnings.size();
  numen::sim::summarize_needles(s);
  EXPECT_EQ(s.needle_passes, 0);
  EXPECT_EQ(s.needle_tunnels, 0);
  EXPECT_EQ(s.warnings.size(), warnings);
  EXPECT_NEAR(s.needle_entry_error_mm, 9.0, 1e-9);  // node 2 at rest (0, 10, 10) mm, the mark (0, 1, 10)
  EXPECT_EQ(s.needle_exit_error_mm, -1.0);
  ASSERT_EQ(s.needle_lines.size(), 1u);
  EXPECT_NE(s.needle_lines[0].find("in at 0.500 s, not out"), std::string::npos) << s.needle_lines[0];
  EXPECT_NE(s.needle_lines[0].find("exit mark missed"), std::string::npos) << s.needle_lines[0];
}

// A scene without a needle: no needle figures in the summary (JSON, text), as before them.
TEST(NeedleSummary, ASceneWithoutANeedleHasNoNeedleFigures) {
  numen::test::TempDir dir;
  numen::sim::RunOptions opt;
  opt.duration_s = 0.05;
  // The shipped probe (one body, no joints, no nets) with a scripted hold, so that it runs.
  const std::string text = numen::test::shipped_scene_text_anywhere("probe.toml") +
                           "\n[trajectory]\nsource = \"scripted\"\nstart = { position = [0.0, 0.0, 0.01] }\n"
                           "[[trajectory.segment]]\ntype = \"hold\"\nduration = 0.1\n";
  const numen::sim::RunSummary s = numen::sim::run_scene(numen::sim::load_scene(dir.write("probe.toml", text)), opt);
  EXPECT_FALSE(s.needles);
  EXPECT_TRUE(s.needle_lines.empty());
  EXPECT_EQ(nlohmann::json::parse(numen::sim::format_summary_json(s)).count("needle"), 0u);
  EXPECT_EQ(numen::sim::format_summary(s).find("needle"), std::string::npos);
}
