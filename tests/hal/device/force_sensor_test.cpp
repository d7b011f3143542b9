// Tests of hal/force_sensor: the two 6-byte TPDOs of the 6-axis force/torque sensor, the
// device-side encoding and the controller-side decoder with its checks.
#include "numen/hal/device/force_sensor.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

#include "alloc_counter.hpp"

namespace hal = numen::hal;
using numen::core::Vec3;
using numen::core::Wrench;

namespace {

hal::ForceSensorConfig config() {
  hal::ForceSensorConfig c;
  c.node_id = 32;
  c.force_scale = 0.01;
  c.torque_scale = 1e-4;
  c.max_force = 100.0;
  c.max_torque = 2.0;
  c.max_age_s = 3e-3;
  return c;
}

Wrench wrench(const Vec3& f, const Vec3& t) {
  Wrench w;
  w.force = f;
  w.torque = t;
  return w;
}

}  // namespace

TEST(ForceSensor, MappingsAreTheDocumentedSixByteLayouts) {
  const hal::PdoMapping f = hal::force_tpdo_mapping();
  const hal::PdoMapping t = hal::torque_tpdo_mapping();
  ASSERT_EQ(f.length(), 6);
  ASSERT_EQ(t.length(), 6);
  EXPECT_EQ(f.mapping_parameter()[0], 0x22000110u);
  EXPECT_EQ(f.mapping_parameter()[2], 0x22000310u);
  EXPECT_EQ(t.mapping_parameter()[1], 0x22010210u);
  EXPECT_EQ(config().effective_force_cob_id(), 0x1A0u);
  EXPECT_EQ(config().effective_torque_cob_id(), 0x2A0u);
}

TEST(ForceSensor, WorkedFrameOfProtocolSection18) {
  // F = (1.5, −2.0, 0.25) N at 0.01 N/count → 150, −200, 25; T = (0.01, −0.02, 0) N·m at
  // 1e-4 N·m/count → 100, −200, 0 (INTEGER16 little endian).
  hal::CanFrame f, t;
  hal::encode_force_tpdos(config(), wrench(Vec3(1.5, -2.0, 0.25), Vec3(0.01, -0.02, 0.0)), 7, f, t);
  EXPECT_EQ(f.id, 0x1A0u);
  EXPECT_EQ(t.id, 0x2A0u);
  ASSERT_EQ(f.len, 6);
  ASSERT_EQ(t.len, 6);
  const std::uint8_t fb[6] = {0x96, 0x00, 0x38, 0xFF, 0x19, 0x00};
  const std::uint8_t tb[6] = {0x64, 0x00, 0x38, 0xFF, 0x00, 0x00};
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(f.data[static_cast<std::size_t>(i)], fb[i]) << i;
    EXPECT_EQ(t.data[static_cast<std::size_t>(i)], tb[i]) << i;
  }
  EXPECT_EQ(f.timestamp_ns, 7);
}

TEST(ForceSensor, DecodesWhatTheDeviceEncodesToTheCount) {
  hal::ForceSensor s(config());
  hal::CanFrame f, t;
  const Wrench w = wrench(Vec3(12.345, -0.004, 3.0), Vec3(-0.5, 0.25, 1.2345));
  hal::encode_force_tpdos(config(), w, 1'000'000, f, t);
  EXPECT_TRUE(s.on_frame(f));
  EXPECT_TRUE(s.on_frame(t));
  const hal::ForceSample r = s.sample(1'500'000);
  ASSERT_TRUE(r.valid);
  EXPECT_EQ(r.faults, hal::SampleFault::kNone);
  EXPECT_NEAR(r.wrench.force.x(), 12.35, 1e-12);  // rounded to the count
  EXPECT_NEAR(r.wrench.force.y(), 0.0, 1e-12);
  EXPECT_NEAR(r.wrench.force.z(), 3.0, 1e-12);
  EXPECT_NEAR(r.wrench.torque.z(), 1.2345, 1e-12);
  EXPECT_EQ(r.periods_since_valid, 0u);
  hal::CanFrame other;
  other.id = 0x181;
  other.len = 4;
  EXPECT_FALSE(s.on_frame(other));
  EXPECT_EQ(s.counters().frames, 2u);
}

TEST(ForceSensor, StaleReadingIsRejectedAndTheLastOneHeld) {
  hal::ForceSensor s(config());
  EXPECT_FALSE(s.sample(0).valid);  // nothing yet
  EXPECT_EQ(s.sample(0).faults & hal::SampleFault::kNoData, hal::SampleFault::kNoData);
  hal::CanFrame f, t;
  hal::encode_force_tpdos(config(), wrench(Vec3(1.0, 0.0, 0.0), Vec3::Zero()), 0, f, t);
  s.on_frame(f);
  s.on_frame(t);
  EXPECT_TRUE(s.sample(3'000'000).valid);  // exactly max_age: still fresh
  const hal::ForceSample r = s.sample(3'000'001);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.faults, hal::SampleFault::kStale);
  EXPECT_EQ(r.periods_since_valid, 1u);
  EXPECT_DOUBLE_EQ(r.wrench.force.x(), 1.0);  // held
  EXPECT_EQ(s.sample(4'000'000).periods_since_valid, 2u);
  // Only the force half refreshed: still stale (the torque half is old).
  hal::encode_force_tpdos(config(), wrench(Vec3(2.0, 0.0, 0.0), Vec3::Zero()), 5'000'000, f, t);
  s.on_frame(f);
  EXPECT_FALSE(s.sample(5'000'000).valid);
  EXPECT_EQ(s.counters().stale, 3u);
}

TEST(ForceSensor, SaturatedOrTooLargeReadingsAreOutOfRange) {
  hal::ForceSensor s(config());
  hal::CanFrame f, t;
  // 400 N does not fit ±327.67 N: sent saturated (32767) and rejected.
  hal::encode_force_tpdos(config(), wrench(Vec3(400.0, 0.0, 0.0), Vec3::Zero()), 0, f, t);
  EXPECT_EQ(f.data[0], 0xFF);
  EXPECT_EQ(f.data[1], 0x7F);
  s.on_frame(f);
  s.on_frame(t);
  EXPECT_EQ(s.sample(0).faults, hal::SampleFault::kOutOfRange);
  // 60 N on two axes: |F| = 84.9 N < 100 N is accepted; 80 N on two: 113 N is not.
  hal::encode_force_tpdos(config(), wrench(Vec3(60.0, 60.0, 0.0), Vec3::Zero()), 0, f, t);
  s.on_frame(f);
  s.on_frame(t);
  EXPECT_TRUE(s.sample(0).valid);
  hal::encode_force_tpdos(config(), wrench(Vec3(80.0, 80.0, 0.0), Vec3::Zero()), 0, f, t);
  s.on_frame(f);
  s.on_frame(t);
  const hal::ForceSample r = s.sample(0);
  EXPECT_FALSE(r.valid);
  EXPECT_NEAR(r.wrench.force.x(), 60.0, 1e-12);  // the last accepted one
  // A NaN component is sent saturated.
  hal::encode_force_tpdos(config(), wrench(Vec3(0.0, 0.0, 0.0), Vec3(0.0, std::nan(""), 0.0)), 0, f,
                          t);
  s.on_frame(f);
  s.on_frame(t);
  EXPECT_EQ(s.sample(0).faults, hal::SampleFault::kOutOfRange);
  EXPECT_EQ(s.counters().out_of_range, 3u);
}

TEST(ForceSensor, MalformedFramesAreCountedAndSpoilThePeriod) {
  hal::ForceSensor s(config());
  hal::CanFrame f, t;
  hal::encode_force_tpdos(config(), wrench(Vec3(1.0, 0.0, 0.0), Vec3::Zero()), 0, f, t);
  s.on_frame(f);
  s.on_frame(t);
  hal::CanFrame bad = f;
  bad.len = 4;
  EXPECT_TRUE(s.on_frame(bad));
  hal::CanFrame remote = t;
  remote.flags |= hal::CanFlag::kRemote;
  EXPECT_TRUE(s.on_frame(remote));
  EXPECT_EQ(s.counters().malformed, 2u);
  EXPECT_EQ(s.sample(0).faults, hal::SampleFault::kMalformed);
  EXPECT_TRUE(s.sample(0).valid);  // the good halves are still fresh next period
}

// Issue 17 #7: an error report whose class bits read the torque COB-ID (0x2A0 for node 32)
// does not spoil the admittance scene's force sample; a CAN FD frame on a sensor id does.
TEST(ForceSensor, ErrorFramesAreIgnoredFdFramesAreMalformed) {
  hal::ForceSensor s(config());
  hal::CanFrame f, t;
  hal::encode_force_tpdos(config(), wrench(Vec3(1.0, 0.0, 0.0), Vec3::Zero()), 0, f, t);
  s.on_frame(f);
  s.on_frame(t);
  hal::CanFrame err;
  err.id = config().effective_torque_cob_id();
  err.flags = hal::CanFlag::kErrorFrame;
  err.len = 8;
  EXPECT_FALSE(s.on_frame(err));
  err.id = config().effective_force_cob_id();
  EXPECT_FALSE(s.on_frame(err));
  hal::CanFrame ext = f;
  ext.flags = hal::CanFlag::kExtendedId;
  EXPECT_FALSE(s.on_frame(ext));
  EXPECT_EQ(s.counters().malformed, 0u);
  EXPECT_TRUE(s.sample(0).valid);
  hal::CanFrame fd = f;  // 6 bytes: a valid FD length, right mapping length
  fd.flags = hal::CanFlag::kFd;
  EXPECT_TRUE(s.on_frame(fd));
  EXPECT_EQ(s.counters().malformed, 1u);
  EXPECT_EQ(s.sample(0).faults, hal::SampleFault::kMalformed);
}

TEST(ForceSensor, ValidateNamesTheField) {
  const auto throws_with = [](hal::ForceSensorConfig c, const char* what) {
    try {
      hal::validate(c, "sensor");
      ADD_FAILURE() << "no throw for " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  hal::ForceSensorConfig c = config();
  c.node_id = 0;
  throws_with(c, "node_id");
  c = config();
  c.force_cob_id = 0x080;
  throws_with(c, "force_cob_id");
  c = config();
  c.torque_cob_id = 0x1A0;
  throws_with(c, "equal");
  c = config();
  c.torque_scale = 0.0;
  throws_with(c, "torque_scale");
  c = config();
  c.max_age_s = std::nan("");
  throws_with(c, "max_age");
  c = config();
  c.sensor_in_tool.orientation.coeffs() *= 2.0;
  throws_with(c, "sensor_in_tool");
  EXPECT_NO_THROW(hal::validate(config()));
}

TEST(ForceSensor, PeriodicCallsDoNotAllocate) {
  hal::ForceSensor s(config());
  hal::CanFrame f, t;
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 1000; ++i) {
    hal::encode_force_tpdos(config(), wrench(Vec3(0.01 * i, 0.0, 1.0), Vec3::Zero()), i * 1'000'000,
                            f, t);
    s.on_frame(f);
    s.on_frame(t);
    (void)s.sample(i * 1'000'000 + 200'000);
  }
  EXPECT_EQ(guard.count(), 0);
}
