// Tests of sim/run_verdict: the exit status of a finished run from its summary (issue 17,
// defect 4: runs with non-finite steps, rejected samples, no replayed frame or lost records
// used to exit 0).

#include "numen/sim/run/run_verdict.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include <cstdint>
#include <string>
#include <vector>

#include "numen/sim/run/run_summary.hpp"
#include "run_summary_samples.hpp"

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

/// `s` ended after `steps` periods without a valid sample, the managed start-up in `phase`.
void end_before_startup(RunSummary& s, std::int64_t steps, const std::string& phase) {
  s.steps = steps;
  s.invalid_periods = steps;
  s.managed = true;
  s.startup = phase;
}

/// `s` with the emulated device's axis 2 run away at `speed` against `limit` at `time_s`.
void plant_ran_away(RunSummary& s, double speed, double limit, double time_s) {
  s.divergence.latched = true;
  s.divergence.cause = "device plant";
  s.divergence.subject = "device axis 2";
  s.divergence.value = speed;
  s.divergence.limit = limit;
  s.divergence.time_s = time_s;
}

TEST(RunVerdict, AStepWithANonFiniteDeviceTargetIsARejectedSample) {
  RunSummary s = clean();
  s.invalid_target_steps = 2;
  const auto v = run_verdict(s);
  EXPECT_EQ(v.status, ExitStatus::kSamplesRejected);
  ASSERT_EQ(v.reasons.size(), 1u);
  EXPECT_EQ(v.reasons[0], "samples rejected: 2 steps with a non-finite device target (coupling "
                          "skipped, feedback held)");
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

// A run a signal stopped returned 128 + N, but its summary said "exit status 0 (clean)" with no
// reason: the verdict carries the status the process returns and names the signal.
TEST(RunVerdict, AStoppedRunCarriesTheSignalsStatusAndName) {
  RunSummary s = clean();
  s.stopped = true;
  s.stop_signal = 15;
  auto v = run_verdict(s);
  EXPECT_EQ(v.status, ExitStatus::kClean);
  EXPECT_EQ(v.exit_status, 143);
  EXPECT_EQ(v.reasons, std::vector<std::string>{"stopped by a signal: SIGTERM (15) after 1000 periods"});
  EXPECT_STREQ(numen::sim::exit_status_name(v.exit_status), "stopped by a signal");
  s.stop_signal = 2;
  EXPECT_EQ(run_verdict(s).exit_status, 130);
  EXPECT_EQ(run_verdict(s).reasons.at(0), "stopped by a signal: SIGINT (2) after 1000 periods");
  // A worse verdict keeps its status; the signal is its last reason.
  s.rejected_samples = 4;
  v = run_verdict(s);
  EXPECT_EQ(v.exit_status, 6);
  ASSERT_EQ(v.reasons.size(), 2u);
  EXPECT_EQ(v.reasons[1], "stopped by a signal: SIGINT (2) after 1000 periods");
  // Not stopped: the status is the verdict's, no signal named.
  EXPECT_EQ(run_verdict(clean()).exit_status, 0);
  EXPECT_STREQ(numen::sim::exit_status_name(0), "clean");
  EXPECT_STREQ(numen::sim::exit_status_name(6), "samples rejected");
  EXPECT_STREQ(numen::sim::exit_status_name(7), "diverged");
  EXPECT_STREQ(numen::sim::exit_status_name(8), "?");
  EXPECT_STREQ(numen::sim::exit_status_name(99), "?");
  // Every status the verdict can give has its name (the HIL scripts print it).
  for (int status = 0; status <= 7; ++status)
    EXPECT_STRNE(numen::sim::exit_status_name(status), "?") << status;
}

// A run that ends before the managed start-up has made the encoders send said "no period had
// a valid sample": it names the start-up that never finished and the periods the run had.
TEST(RunVerdict, ARunEndedBeforeTheStartUpFinishedSaysSo) {
  RunSummary s = clean();
  end_before_startup(s, 33, "wait operational");
  const auto v = run_verdict(s);
  EXPECT_EQ(v.status, ExitStatus::kSamplesRejected);
  EXPECT_EQ(v.reasons, std::vector<std::string>{
                           "samples rejected: no period had a valid sample: the run's 33 periods "
                           "ended before the CANopen start-up finished (still in phase 'wait "
                           "operational'); the encoders send once their nodes are operational: "
                           "run longer"});
  s.startup = "operational";  // it finished: the frames are to blame
  EXPECT_EQ(run_verdict(s).reasons,
            std::vector<std::string>{"samples rejected: no period had a valid sample"});
}

// The emulated device's axis that runs away is named with its speed and its runaway speed (it
// read "device plant of device axis 2: 0.0002667 above its limit 0 (m/s)": the sub-step's
// time against 0); a run that this divergence stopped in its second period, before the
// start-up finished, is not told to run longer.
TEST(RunVerdict, ADevicePlantDivergenceNamesTheAxisSpeedAndItsLimit) {
  RunSummary s = clean();
  end_before_startup(s, 2, "wait operational");
  plant_ran_away(s, 31234.5, 1000.0, 0.001);
  const auto v = run_verdict(s);
  EXPECT_EQ(v.status, ExitStatus::kDiverged);
  EXPECT_EQ(v.reasons,
            (std::vector<std::string>{
                "diverged: device plant of device axis 2: 3.123e+04 above its limit 1000 (m/s or "
                "rad/s) at 0.0010 s",
                "samples rejected: no period had a valid sample: the divergence stopped the run "
                "after 2 periods, before the CANopen start-up finished (still in phase 'wait "
                "operational'); the encoders send once their nodes are operational"}));
  // Just past its limit the value gets the digits that tell it from the limit.
  s = clean();
  plant_ran_away(s, 200.008, 200.0, 0.081);
  EXPECT_EQ(run_verdict(s).reasons,
            std::vector<std::string>{"diverged: device plant of device axis 2: 200.01 above its "
                                     "limit 200 (m/s or rad/s) at 0.0810 s"});
}

// Encoder frames of the wrong kind (CAN FD, remote) or length reject their samples: the verdict
// counts and names them, beside whatever the run latched (it read "first: drive stuck" only).
TEST(RunVerdict, RejectedEncoderFramesAreNamed) {
  RunSummary s = clean();
  s.faults = 1;
  s.first_fault = "drive stuck";
  s.frames_rejected = 4950;
  s.encoder_frames_fd = 4950;
  const auto v = run_verdict(s);
  EXPECT_EQ(v.status, ExitStatus::kSafetyStop);
  ASSERT_EQ(v.reasons.size(), 2u);
  EXPECT_EQ(v.reasons[1],
            "samples rejected: 4950 encoder frames rejected (CAN FD 4950, remote 0, wrong length "
            "0): encoder TPDOs are classic CAN data frames of their mapped length");
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

// --bus igtl: every message rejected, pose dropped, stream ended early is a reason of its own;
// a lost connection is one only in a paced run (following a replay, its end is the stream's).
TEST(RunVerdict, TheTrackersRejectedInputIsNamed) {
  numen::sim::RunSummary s = numen::test::igtl_summary();
  numen::sim::RunVerdict v = numen::sim::run_verdict(s);
  const auto says = [&v](const std::string& what) {
    for (const std::string& r : v.reasons)
      if (r.find(what) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(says("samples rejected: 2 OpenIGTLink messages rejected (CRC mismatch: TRANSFORM 'StylusToTracker', "
                   "message 12 at stream byte 1272, field at byte 50 (2 such))"));
  EXPECT_TRUE(says("10 OpenIGTLink poses dropped: the queue was full (a flood)"));
  EXPECT_TRUE(says("the tracker's stream ended 5 periods before the run did"));
  EXPECT_FALSE(says("closed the connection"));
  s.igtl_follows = false;
  v = numen::sim::run_verdict(s);
  EXPECT_TRUE(says("the OpenIGTLink server 127.0.0.1:18944 'StylusToTracker' closed the connection 1 times"));
  s = numen::test::igtl_summary();
  s.igtl_faults = 0;
  s.igtl_dropped = 0;
  s.igtl_periods_after_end = 0;
  s.igtl_poses = 0;
  v = numen::sim::run_verdict(s);
  EXPECT_TRUE(says("no pose (TRANSFORM, POSITION or QTRANS) of the tool 127.0.0.1:18944 "
                   "'StylusToTracker' in 1203 messages (device names sent: 'PointerToTracker')"));
}

// Issue 66: poses refused for their timestamps are said per reason (a pose 10^6 s ahead had
// been "9606 axis samples rejected" only; backwards or zero stamps "the tracker's stream ended
// 1699 periods before the run did").
TEST(RunVerdict, TrackerPosesRefusedForTheirStampsAreCountedPerReason) {
  numen::sim::RunSummary s = numen::test::igtl_summary();
  s.igtl_faults = 0;
  s.igtl_dropped = 0;
  s.igtl_periods_after_end = 0;
  const numen::sim::RunVerdict v = numen::sim::run_verdict(s);
  EXPECT_NE(std::find(v.reasons.begin(), v.reasons.end(),
                      "samples rejected: 21 tracker poses refused for their timestamps (6 before "
                      "the last pose taken, 7 more than 10 s after it, 8 unstamped while "
                      "following the tracker's clock; 1 re-basings on a clock that jumped)"),
            v.reasons.end())
      << ::testing::PrintToString(v.reasons);
  s.igtl_stamps_backwards = s.igtl_stamps_ahead = s.igtl_stamps_unstamped = 0;
  for (const std::string& r : numen::sim::run_verdict(s).reasons)
    EXPECT_EQ(r.find("timestamps"), std::string::npos) << r;
}

TEST(RunVerdict, AnotherDevicesRejectedSamplesAndSafeStatesAreNamed) {
  // A scene of two devices: device 0's figures are the summary's own; device 1's rejected
  // samples and latched safe states set the status too, named with the device.
  RunSummary s = clean();
  numen::sim::DeviceRunSummary left, right;
  left.name = "left";
  right.name = "right";
  right.rejected_samples = 3;
  s.devices = {left, right};
  const auto v = run_verdict(s);
  EXPECT_EQ(v.status, ExitStatus::kSamplesRejected);
  ASSERT_EQ(v.reasons.size(), 1u);
  EXPECT_EQ(v.reasons[0], "samples rejected: 3 axis samples rejected (device \"right\")");
  s.devices[1].faults = 1;
  const auto w = run_verdict(s);
  EXPECT_EQ(w.status, ExitStatus::kSafetyStop);
  EXPECT_NE(std::find(w.reasons.begin(), w.reasons.end(),
                      "safety stop: 1 safe state(s) latched (device \"right\")"),
            w.reasons.end());
}
