// Tests of sim/run_summary_text: the text summary prints only figures of the table, prints
// every one of them (over the summaries that switch its optional parts on), and keeps the
// wording that scripts read (tests/hil/*.sh).
#include "numen/sim/run/run_summary_text.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "numen/sim/run/run_figures.hpp"
#include "run_summary_samples.hpp"

namespace {

using numen::sim::RunSummaryCondition;

TEST(RunSummaryText, LayoutNamesOnlyFiguresOfTheTable) {
  for (const numen::sim::RunSummarySegment& seg : numen::sim::run_summary_text_layout()) {
    for (const RunSummaryCondition& c : {seg.when, seg.and_when, seg.and_also}) {
      if (c.test == RunSummaryCondition::Test::kAlways) continue;
      EXPECT_NE(numen::sim::find_run_figure(c.figure), nullptr) << c.figure << " in " << seg.text;
      if (!c.or_figure.empty()) {
        EXPECT_NE(numen::sim::find_run_figure(c.or_figure), nullptr) << c.or_figure;
      }
    }
    if (!seg.each.empty()) {
      const numen::sim::RunFigure* f = numen::sim::find_run_figure(seg.each);
      ASSERT_NE(f, nullptr) << seg.each;
      EXPECT_EQ(f->kind, numen::sim::FigureKind::kTextList) << seg.each;
    }
    const std::string_view t = seg.text;
    for (std::size_t open = t.find('{'); open != std::string_view::npos;
         open = t.find('{', open + 1)) {
      const std::size_t close = t.find('}', open);
      ASSERT_NE(close, std::string_view::npos) << t;
      const std::string_view field = t.substr(open + 1, close - open - 1);
      if (field == "*") continue;
      const std::string_view name = field.substr(0, field.find(':'));
      EXPECT_NE(numen::sim::find_run_figure(name), nullptr) << name << " in " << t;
    }
  }
}

TEST(RunSummaryText, EveryFigureOfTheTableIsPrinted) {
  std::set<std::string_view> written;
  for (const numen::sim::RunSummary& s :
       {numen::test::full_managed_summary(), numen::test::admittance_summary(),
        numen::test::igtl_summary()}) {
    std::vector<std::string_view> names;
    const std::string text = numen::sim::format_summary_text(s, &names);
    EXPECT_EQ(text, numen::sim::format_summary(s));
    written.insert(names.begin(), names.end());
  }
  for (const numen::sim::RunFigure& f : numen::sim::run_figures())
    EXPECT_TRUE(written.count(f.name)) << f.name << " is not in the text summary";
}

TEST(RunSummaryText, PrintsTheValuesInTheirFormats) {
  const std::string text = numen::sim::format_summary(numen::test::full_managed_summary());
  for (const char* part : {
           "scene sample: god-object coupling, implicit-euler, dt 1.000 ms, device closed\n",
           "  closed loop: hand 24.250 mm deep, handle 1.250 mm; force on the hand max 5.500 N, "
           "hand–handle separation max 29.500 mm; port energy 0.080 J, min -0.013 J at 0.125 s\n",
           "  device: limit cycle at 0.375 s: 1.875 mm at 15.000 Hz\n",
           "  needles: 1 punctures, 1 exits, 2 releases, 1 tunnels (2 steps held back at the surface); 1 through; "
           "tip force at the last puncture 1.000 N (threshold 1.000 N; its contacts asked 1.125 N); deviation from the arc max 0.375 mm; force on the tissue "
           "max 0.625 N at 2.500 s; from the marks: entry "
           "0.250 mm, exit 0.500 mm\n  needle needle: 1 puncture, 1 exit, 2 releases, 1 tunnel; through",
           "  grasps: 2 started, 1 released, 1 slipped\n  grasp event: 6.968 s grasp grasper: organ "
           "(5 nodes)\n  grasp event: 7.026 s release grasper: organ (5 nodes, pull 0.738 N)\n",
           "  grasper grasper (device left): 2 started, 1 released, 1 slipped; hand-overs 1 given, 0 taken; "
           "feedback force on its hand max 1.500 N\n  task: 1 of 2 objects transferred (1 placed); hand-overs 1, "
           "drops 1; time 4.250 s\n  task object: ring_1: 2 grasps, 1 hand-over, 0 drops; placed on peg_1 at 5.470 s\n"
           "  task object: ring_2: ",
           "  device left: feedback force max 1.500 N, torque max 0.000 N·m, torque sent in 0 "
           "periods; closed loop: force on the hand max 2.250 N, hand–handle separation max 0.000 "
           "mm, port energy 0.000 J; invalid periods 0, rejected samples 0, lifecycle active, safe "
           "states 0\n  device right: ",
           "  trocar placed at the port\n",
           "  500 steps, 0.500 s simulated in 0.250 s wall (2.000x real time)\n",
           " after a start-up of 3 steps from 2.500 mm (the tool started inside); any body 3.500 mm\n",
           "residual max 1.50e-07, not converged 11 steps\n",
           "  loop period 1000.0 us, overrun budget 900.0 us, 48 periods\n",
           "  loop end-to-end (SYNC to torque out) us: min 100.1, median 200.2, p99 300.3, p99.9 "
           "400.4, max 500.5 (48 periods)\n",
           "  loop overruns: 50 (longest streak 51), skipped periods 52, invalid periods 49, SAFE "
           "STOP raised\n",
           "  end: stopped by signal 15, shutdown 60 periods, drives disabled; trace records 55, "
           "dropped 56, written 57, I/O errors 58\n",
           "  safety: 27 safe stop(s), 28 fault record(s); first: encoder timeout (id 2, value "
           "0.500) at 0.250 s, period 29; EMCY 30",
           "  SDO: 71 node configuration(s) from DCFs; in-loop reads 72, errors 73\n",
           "  multirate: scene loop every 10.000 ms (10 device periods), margin 12.500 mm; 81 scene "
           "steps, planes max 82, dropped 83, stale models 84, tool switches 85, folded scene steps 92; "
           "the new planes "
           "added 0.375 J (at most 0.125 J at a sample); feedback force jump max 0.250 N at a new "
           "model, 0.125 N otherwise\n",
           "  multirate scene thread: 86 overruns; scene step us: median 87.500, p99 88.500, max 90.500\n",
           "  re-arm: 2 request(s), 1 accepted, first before period 59\n",
           "  soft start: feedback ramped in over 100.000 ms, 2 ramp(s)\n",
           "  drives: yaw: operation enabled, pitch: switch on disabled\n",
           "  nan detected: YES (non-finite steps 14); INVALID TARGETS: 3 steps (coupling "
           "skipped, feedback held)\n  divergence: speed 38.125, tie stretch "
           "0.250 of their limits; energy 0.875x what the scene started with plus the hand's work "
           "(limit 100x) (speed limit 24.500 m/s, scene 0.291 m); DIVERGED "
           "at 0.412 s (period 412): node speed of net \"bag\" 933.500, limit 24.500\n  realtime "
           "setup: SCHED_FIFO 80: ok\n",
           "; overrun policy: latch after 4\n",
           "  warning: first warning\n  warning: second warning\n",
           "  exit status 3 (safety stop): first reason; second reason\n"})
    EXPECT_NE(text.find(part), std::string::npos) << "missing: " << part << "\n" << text;
  const std::string adm = numen::sim::format_summary(numen::test::admittance_summary());
  for (const char* part : {
           "(k_hand 200.000 N/m × sep = 4.950 N), separation max 30.500 mm\n",
           "set-points clamped 68, rate limited 69, hold periods 70\n",
           "  bus log:recorded.log: 61 frames replayed of 62 records; lost by the recording 63",
           "lifecycle active, 27 safe stop(s)\n",
           "  nan detected: no (non-finite steps 14)",
           "; overrun policy: count only\n"})
    EXPECT_NE(adm.find(part), std::string::npos) << "missing: " << part << "\n" << adm;
  EXPECT_EQ(adm.find("tracking error in free space"), std::string::npos);
  EXPECT_EQ(adm.find("soft start"), std::string::npos);  // poses, not forces: no ramp
  numen::sim::RunSummary off = numen::test::full_managed_summary();
  off.soft_start_s = 0.0;
  EXPECT_NE(numen::sim::format_summary(off).find("  soft start: off\n"), std::string::npos);
  EXPECT_EQ(adm.find("canopen:"), std::string::npos);
}

// Issue 66: a grasper's name with control characters was printed raw (an escape sequence in a
// scene file reached the terminal). Text from a scene or the network is printed with each
// control byte as \xNN; UTF-8 stays as it is.
TEST(RunSummaryText, ControlCharactersOfNamesAreEscaped) {
  numen::sim::RunSummary s = numen::test::full_managed_summary();
  s.grasper_lines = {"g\x1B[2J\rfake (device left): 0 started"};
  s.scene = "sc\x07\xC3\xA9ne";
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("  grasper g\\x1B[2J\\x0Dfake (device left): 0 started\n"), std::string::npos)
      << text;
  EXPECT_NE(text.find("scene sc\\x07\xC3\xA9ne:"), std::string::npos) << text;
  EXPECT_EQ(text.find('\x1B'), std::string::npos);
  EXPECT_EQ(text.find('\r'), std::string::npos);
  EXPECT_EQ(text.find('\x07'), std::string::npos);
}

}  // namespace
