// Tests of sim/run/thread_summary: the suture threads of a run in its summary
// (docs/thread.md "The thread", docs/outputs.md `thread.*`).

#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/thread.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/thread_summary.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

// The step's outputs over a run: the largest tension and stretch kept, a break counted once at
// its step with its time, and named with its segment in a warning at the end.
TEST(ThreadSummary, TheLargestTensionAndEachBreakAreKeptAndTheBreakIsAWarning) {
  numen::core::Model m;
  m.threads.resize(2);
  m.threads[0].name = "suture";
  m.threads[0].break_strain = 0.05;
  numen::core::Data d;
  d.threads.resize(2);
  numen::sim::RunSummary s;
  {
    numen::test::AllocationGuard guard;
    d.time = 0.5;
    d.threads[0].output.max_tension = 1.5;
    d.threads[1].output.max_stretch = 0.004;
    numen::sim::accumulate_thread_figures(d, s);
    d.time = 0.6;
    d.threads[0].output.max_tension = 0.0;  // broken: no tension left
    d.threads[0].output.broke = true;
    d.threads[0].broken_segment = 7;
    numen::sim::accumulate_thread_figures(d, s);
    d.time = 0.7;
    d.threads[0].output.broke = false;  // an event: the next step has none
    numen::sim::accumulate_thread_figures(d, s);
    EXPECT_EQ(guard.count(), 0);
  }
  EXPECT_EQ(s.thread_tension_max_n, 1.5);
  EXPECT_EQ(s.thread_stretch_max, 0.004);
  EXPECT_EQ(s.thread_breaks, 1);
  EXPECT_EQ(s.thread_first_break_s, 0.6);
  const std::size_t warnings = s.warnings.size();
  numen::sim::summarize_threads(m, d, s);
  EXPECT_TRUE(s.threads);
  ASSERT_EQ(s.warnings.size(), warnings + 1);
  EXPECT_NE(s.warnings.back().find("thread 'suture' broke at segment 7"), std::string::npos) << s.warnings.back();
  EXPECT_NE(s.warnings.back().find("0.600 s"), std::string::npos) << s.warnings.back();
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j["thread"]["breaks"].get<std::int64_t>(), 1);
  EXPECT_EQ(j["thread"]["tension_max_n"].get<double>(), 1.5);
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("threads: tension max 1.500 N"), std::string::npos) << text;
}

// A step whose Newton iteration ran out (core::ThreadOutput::converged false) is counted once
// whatever the number of threads that ran out in it; the text says so only when there was one.
TEST(ThreadSummary, StepsWhoseNewtonIterationRanOutAreCounted) {
  numen::core::Data d;
  d.threads.resize(2);
  numen::sim::RunSummary s;
  s.threads = true;
  EXPECT_EQ(numen::sim::format_summary(s).find("Newton unconverged"), std::string::npos);
  {
    numen::test::AllocationGuard guard;
    numen::sim::accumulate_thread_figures(d, s);  // both converged
    d.threads[0].output.converged = false;
    d.threads[1].output.converged = false;
    numen::sim::accumulate_thread_figures(d, s);  // both ran out: one step
    d.threads[0].output.converged = true;
    numen::sim::accumulate_thread_figures(d, s);  // the second ran out
    d.threads[1].output.converged = true;
    numen::sim::accumulate_thread_figures(d, s);
    EXPECT_EQ(guard.count(), 0);
  }
  EXPECT_EQ(s.thread_newton_not_converged_steps, 2);
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j["thread"]["newton_not_converged_steps"].get<std::int64_t>(), 2);
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find(", Newton unconverged steps 2"), std::string::npos) << text;
}

// A thread through tissue: the puncture points it took over, let go and dropped summed over the
// threads; a dropped one (its eyelets all taken) is a warning naming the thread, and the text has
// the through-tissue part only where a thread took one over.
TEST(ThreadSummary, PuncturePointsTakenOverAreCountedAndADroppedOneIsAWarning) {
  numen::core::Model m;
  m.threads.resize(2);
  m.threads[0].name = "suture";
  numen::core::Data d;
  d.threads.resize(2);
  numen::sim::RunSummary none;
  numen::sim::summarize_threads(m, d, none);
  EXPECT_EQ(numen::sim::format_summary(none).find("through tissue"), std::string::npos);
  d.threads[0].eyelets_taken = 3;
  d.threads[0].eyelets_let_go = 1;
  d.threads[0].eyelets_dropped = 1;
  d.threads[1].eyelets_taken = 2;
  numen::sim::RunSummary s;
  numen::sim::summarize_threads(m, d, s);
  EXPECT_EQ(s.thread_eyelets_taken, 5);
  EXPECT_EQ(s.thread_eyelets_let_go, 1);
  EXPECT_EQ(s.thread_eyelets_dropped, 1);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("thread 'suture' did not follow its needle through 1 puncture point"),
            std::string::npos) << s.warnings[0];
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j["thread"]["eyelets_taken"].get<std::int64_t>(), 5);
  EXPECT_EQ(j["thread"]["eyelets_dropped"].get<std::int64_t>(), 1);
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("through tissue: 5 puncture points taken over, 1 let go, 1 dropped"), std::string::npos)
      << text;
}

// The default scene with a thread tied to a jaw: the run's summary has the thread's figures
// (its weight pulls: tension > 0) and no break; a scene without threads has none of them.
TEST(ThreadSummary, ASceneWithAThreadReportsItsTension) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  std::string text = numen::test::shipped_scene_text_anywhere("default.toml");
  numen::sim::RunOptions opt;
  opt.duration_s = 0.5;
  const numen::sim::RunSummary plain = numen::sim::run_scene(numen::sim::load_scene(dir.write("plain.toml", text)), opt);
  EXPECT_FALSE(plain.threads);
  EXPECT_EQ(nlohmann::json::parse(numen::sim::format_summary_json(plain)).count("thread"), 0u);
  text += "\n[[thread]]\nname = \"suture\"\nlength = 0.05\nsegments = 50\nattach_body = \"jaw_1\"\n"
          "direction = [1.0, 0.0, 0.0]\n";
  const numen::sim::RunSummary s = numen::sim::run_scene(numen::sim::load_scene(dir.write("thread.toml", text)), opt);
  EXPECT_FALSE(s.nan_detected);
  EXPECT_TRUE(s.threads);
  EXPECT_GT(s.thread_tension_max_n, 0.0);
  EXPECT_EQ(s.thread_breaks, 0);
  EXPECT_EQ(s.thread_first_break_s, -1.0);
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_GT(j["thread"]["tension_max_n"].get<double>(), 0.0);
}
