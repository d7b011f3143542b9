// Tests of sim/run_verdict: the exit status of a finished run from its summary (issue 17,
// defect 4: runs with non-finite steps, rejected samples, no replayed frame or lost records
// used to exit 0).

#include "numen/sim/run_verdict.hpp"

#include <gtest/gtest.h>

#include "numen/sim/run.hpp"

namespace {

using numen::sim::ExitStatus;
using numen::sim::RunSummary;
using numen::sim::run_verdict;

RunSummary clean() {
  RunSummary s;
  s.steps = 1000;
  s.invalid_periods = 2;  // the periods before the first sample
  return s;
}

TEST(RunVerdict, CleanRunIsZeroWithNoReason) {
  const auto v = run_verdict(clean());
  EXPECT_EQ(v.status, ExitStatus::kClean);
  EXPECT_EQ(code(v.status), 0);
  EXPECT_TRUE(v.reasons.empty());
}

TEST(RunVerdict, EachConditionHasItsStatus) {
  RunSummary s = clean();
  s.nonfinite_steps = 3;
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kNonFinite);
  s = clean();
  s.nan_detected = true;
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kNonFinite);
  s = clean();
  s.faults = 1;
  s.first_fault = "encoder out of range";
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kSafetyStop);
  s = clean();
  s.managed = true;
  s.startup = "failed (node 3)";
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kSafetyStop);
  s = clean();
  s.bus_frames_recorded = 100;
  s.bus_record_written = 100;
  s.bus_record_dropped = 1;
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kLostRecords);
  s = clean();
  s.bus_frames_recorded = 100;
  s.bus_record_written = 0;  // /dev/full
  s.bus_record_io_errors = 2;
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kLostRecords);
  s = clean();
  s.trace_pushed = 10;
  s.trace_written = 9;
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kLostRecords);
  s = clean();
  s.rejected_samples = 1;
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kSamplesRejected);
  s = clean();
  s.invalid_periods = s.steps;
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kSamplesRejected);
  s.stopped = true;  // a signal ended it before the first sample: not the input's fault
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kClean);
  s = clean();
  s.bus = "log:x.log";
  s.bus_frames_replayed = 0;
  EXPECT_EQ(run_verdict(s).status, ExitStatus::kSamplesRejected);
}

TEST(RunVerdict, TheMostSevereConditionWinsAndEveryOneIsListed) {
  RunSummary s = clean();
  s.rejected_samples = 5;
  s.faults = 1;
  s.nonfinite_steps = 7;
  const auto v = run_verdict(s);
  EXPECT_EQ(v.status, ExitStatus::kNonFinite);
  ASSERT_EQ(v.reasons.size(), 3u);
  EXPECT_EQ(v.reasons[0], "non-finite state: 7 steps");
  EXPECT_EQ(v.reasons[1].rfind("safety stop: 1 safe state(s) latched", 0), 0u) << v.reasons[1];
  EXPECT_EQ(v.reasons[2], "samples rejected: 5 axis samples rejected");
}

TEST(RunVerdict, StatusesAreDistinctAndNamed) {
  EXPECT_STREQ(to_string(ExitStatus::kClean), "clean");
  EXPECT_STREQ(to_string(ExitStatus::kSafetyStop), "safety stop");
  EXPECT_EQ(code(ExitStatus::kInputRejected), 2);
  EXPECT_EQ(code(ExitStatus::kSafetyStop), 3);
  EXPECT_EQ(code(ExitStatus::kNonFinite), 4);
  EXPECT_EQ(code(ExitStatus::kLostRecords), 5);
  EXPECT_EQ(code(ExitStatus::kSamplesRejected), 6);
}

}  // namespace
