// Tests of numen/hal/device/device_config.hpp and kinematics_factory.hpp: defaults, validation
// messages that name the field, kinematics of each kind (trocar, pose tracker, phantom).
#include "numen/hal/device/device_config.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "numen/hal/device/kinematics_factory.hpp"

namespace {

using namespace numen::hal;

std::string error_of(const DeviceConfig& c) {
  try {
    validate(c);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(DeviceConfig, DefaultsAreValid) {
  EXPECT_EQ(error_of(make_default_trocar_config()), "");
  EXPECT_EQ(error_of(make_default_pose_tracker_config(20)), "");
  const DeviceConfig t = make_default_trocar_config(10);
  ASSERT_EQ(t.axes.size(), 5u);
  EXPECT_EQ(t.axes[0].encoder_cob_id, 0x18Au);
  EXPECT_EQ(t.axes[2].drive_cob_id, 0x20Cu);
  EXPECT_FALSE(t.axes[3].has_drive());
  EXPECT_TRUE(t.axes[3].wraps);
  EXPECT_THROW(make_default_trocar_config(124), std::invalid_argument);
  EXPECT_THROW(make_default_pose_tracker_config(0), std::invalid_argument);
}

TEST(DeviceConfig, DefaultMaxSampleAgeIsThreePeriods) {
  DeviceConfig c = make_default_trocar_config();
  c.control_period_s = 0.002;
  EXPECT_DOUBLE_EQ(c.effective_max_sample_age_s(), 0.006);
  c.max_sample_age_s = 0.01;
  EXPECT_DOUBLE_EQ(c.effective_max_sample_age_s(), 0.01);
}

TEST(DeviceConfig, ValidationNamesDeviceAndField) {
  DeviceConfig c = make_default_trocar_config();
  c.name = "left";
  c.axes.pop_back();
  std::string e = error_of(c);
  EXPECT_NE(e.find("device 'left'"), std::string::npos) << e;
  EXPECT_NE(e.find("axes"), std::string::npos) << e;

  c = make_default_trocar_config();
  c.axes[2].counts_per_unit = -3;
  e = error_of(c);
  EXPECT_NE(e.find("axes[2] 'depth'"), std::string::npos) << e;
  EXPECT_NE(e.find("counts_per_unit"), std::string::npos) << e;

  c = make_default_trocar_config();
  c.axes[4].encoder_cob_id = c.axes[1].encoder_cob_id;
  e = error_of(c);
  EXPECT_NE(e.find("axes[4] 'jaw'"), std::string::npos) << e;
  EXPECT_NE(e.find("already used by axes[1]"), std::string::npos) << e;

  c = make_default_trocar_config();
  c.axes[3].encoder_cob_id = c.axes[0].drive_cob_id;  // encoder on a drive's id
  EXPECT_NE(error_of(c).find("already used"), std::string::npos);

  c = make_default_trocar_config();
  c.control_period_s = 0;
  EXPECT_NE(error_of(c).find("control_period_s"), std::string::npos);

  c = make_default_trocar_config();
  c.max_sample_age_s = -1.0;
  EXPECT_NE(error_of(c).find("max_sample_age_s"), std::string::npos);

  c = make_default_trocar_config();
  c.jump_tolerance_counts = -1.0;
  EXPECT_NE(error_of(c).find("jump_tolerance_counts"), std::string::npos);

  c = make_default_trocar_config();
  c.trocar.orientation = numen::core::Quat(0, 0, 0, 0);
  EXPECT_NE(error_of(c).find("trocar.orientation"), std::string::npos);

  c = make_default_pose_tracker_config();
  c.tool_offset.position.y() = std::numeric_limits<double>::infinity();
  EXPECT_NE(error_of(c).find("tool_offset.position"), std::string::npos);
}

TEST(DeviceConfig, VelocityCutoffMustBePositiveOrInfinite) {
  DeviceConfig c = make_default_trocar_config();
  EXPECT_EQ(c.velocity_cutoff_hz, kDefaultVelocityCutoffHz);
  for (const double bad : {0.0, -50.0, std::numeric_limits<double>::quiet_NaN(),
                           -std::numeric_limits<double>::infinity()}) {
    c.velocity_cutoff_hz = bad;
    const std::string e = error_of(c);
    EXPECT_NE(e.find("velocity_cutoff_hz"), std::string::npos) << bad << ": " << e;
  }
  c.velocity_cutoff_hz = std::numeric_limits<double>::infinity();  // the bare difference
  EXPECT_EQ(error_of(c), "");
  c.velocity_cutoff_hz = 1e-3;
  EXPECT_EQ(error_of(c), "");
}

TEST(DeviceConfig, VelocityEstimatorAndFoawSettingsAreChecked) {
  DeviceConfig c = make_default_trocar_config();
  EXPECT_EQ(c.velocity_estimator, VelocityEstimator::kFoaw);
  EXPECT_STREQ(to_string(VelocityEstimator::kDifference), "difference");
  EXPECT_STREQ(to_string(VelocityEstimator::kFilter), "filter");
  EXPECT_STREQ(to_string(VelocityEstimator::kFoaw), "foaw");
  c.velocity_estimator = static_cast<VelocityEstimator>(7);
  EXPECT_NE(error_of(c).find("velocity_estimator"), std::string::npos);
  c.velocity_estimator = VelocityEstimator::kFoaw;
  EXPECT_EQ(error_of(c), "");
  for (const int bad : {0, -1, kFoawMaxWindow + 1}) {
    c.foaw_max_window = bad;
    EXPECT_NE(error_of(c).find("foaw_max_window"), std::string::npos) << bad;
  }
  c.foaw_max_window = 1;
  EXPECT_EQ(error_of(c), "");
  for (const double bad : {-0.5, std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::infinity()}) {
    c.foaw_noise_counts = bad;
    EXPECT_NE(error_of(c).find("foaw_noise_counts"), std::string::npos) << bad;
  }
  c.foaw_noise_counts = 0.0;
  EXPECT_EQ(error_of(c), "");
}

TEST(DeviceConfig, SoftStartIsOffByDefaultAndBoundedToTenSeconds) {
  DeviceConfig c = make_default_trocar_config();
  EXPECT_EQ(c.soft_start_s, 0.0);  // the hal's default: unscaled torques (scenes: 0.1 s)
  for (const double bad : {-1e-3, 10.001, std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::infinity()}) {
    c.soft_start_s = bad;
    const std::string e = error_of(c);
    EXPECT_NE(e.find("soft_start_s must be finite and in [0, 10] s"), std::string::npos)
        << bad << ": " << e;
  }
  for (const double good : {0.0, 1e-4, kDefaultSceneSoftStartS, kMaxSoftStartS}) {
    c.soft_start_s = good;
    EXPECT_EQ(error_of(c), "") << good;
  }
}

TEST(DeviceConfig, PassivityIsOffByDefaultAndItsSettingsAreChecked) {
  DeviceConfig c = make_default_trocar_config();
  EXPECT_FALSE(c.passivity.enabled);
  EXPECT_EQ(c.passivity.velocity_threshold, kDefaultPassivityVelocityThreshold);
  for (const double bad : {-1e-3, std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::infinity()}) {
    c.passivity.velocity_threshold = bad;
    const std::string e = error_of(c);
    EXPECT_NE(e.find("passivity.velocity_threshold must be finite and >= 0"), std::string::npos)
        << bad << ": " << e;
  }
  c.passivity.velocity_threshold = 0.0;
  EXPECT_EQ(error_of(c), "");
  EXPECT_TRUE(std::isinf(c.passivity.energy_limit));  // none: the paper's observer
  for (const double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN()}) {
    c.passivity.energy_limit = bad;
    EXPECT_NE(error_of(c).find("passivity.energy_limit must be > 0 J"), std::string::npos) << bad;
  }
}

TEST(DeviceConfig, KindDecidesTheKinematics) {
  const auto t = make_kinematics(make_default_trocar_config());
  EXPECT_EQ(t->num_axes(), 5);
  EXPECT_NE(dynamic_cast<const TrocarKinematics*>(t.get()), nullptr);
  const auto p = make_kinematics(make_default_pose_tracker_config());
  EXPECT_EQ(p->num_axes(), 6);
  EXPECT_NE(dynamic_cast<const PoseTrackerKinematics*>(p.get()), nullptr);
  DeviceConfig bad = make_default_pose_tracker_config();
  bad.kind = DeviceKind::kTrocarInstrument;  // 6 axes for a 5-axis kind
  EXPECT_THROW(make_kinematics(bad), std::invalid_argument);
}

TEST(DeviceConfig, KindNamesAndAxisCounts) {
  EXPECT_STREQ(to_string(DeviceKind::kTrocarInstrument), "trocar instrument");
  EXPECT_STREQ(to_string(DeviceKind::kPoseTracker), "pose tracker");
  EXPECT_STREQ(to_string(DeviceKind::kPhantom), "phantom");
  EXPECT_EQ(expected_axis_count(DeviceKind::kTrocarInstrument), 5);
  EXPECT_EQ(expected_axis_count(DeviceKind::kPoseTracker), 6);
  EXPECT_EQ(expected_axis_count(DeviceKind::kPhantom), 6);
  EXPECT_STREQ(to_string(static_cast<DeviceKind>(200)), "unknown");
  EXPECT_EQ(expected_axis_count(static_cast<DeviceKind>(200)), 0);
}

TEST(DeviceConfig, DefaultPhantomHasDrivesOnTheFirstThreeAxesOnly) {
  const DeviceConfig c = make_default_phantom_config(30);
  EXPECT_EQ(error_of(c), "");
  EXPECT_EQ(c.kind, DeviceKind::kPhantom);
  ASSERT_EQ(c.axes.size(), 6u);
  const char* names[] = {"turret",     "shoulder",     "elbow",
                         "gimbal_yaw", "gimbal_pitch", "stylus_roll"};
  for (std::size_t i = 0; i < 6; ++i) {
    const AxisConfig& a = c.axes[i];
    EXPECT_EQ(a.name, names[i]);
    EXPECT_EQ(a.encoder_cob_id, 0x180u + 30u + i) << i;
    EXPECT_EQ(a.has_drive(), i < 3) << i;
    if (i < 3) {
      EXPECT_EQ(a.drive_cob_id, 0x200u + 30u + i) << i;
      EXPECT_GT(a.max_torque, 0.0);
      EXPECT_LE(1000.0 * a.max_torque / a.rated_torque, 32767.0);  // fits the int16 RPDO
    } else {
      EXPECT_EQ(a.max_torque, 0.0);
    }
    EXPECT_LT(a.min, 0.0);  // the home posture q = 0 is inside every range
    EXPECT_GT(a.max, 0.0);
  }
  EXPECT_TRUE(c.axes[5].wraps);
  EXPECT_LT(c.axes[4].max, std::numbers::pi / 2);  // clear of the gimbal lock
  EXPECT_DOUBLE_EQ(c.phantom.l1, 0.14);
  EXPECT_DOUBLE_EQ(c.phantom.l2, 0.14);
  EXPECT_NO_THROW(make_default_phantom_config(122));
  EXPECT_THROW(make_default_phantom_config(123), std::invalid_argument);
  EXPECT_THROW(make_default_phantom_config(0), std::invalid_argument);
}

TEST(DeviceConfig, PhantomGeometryIsValidated) {
  DeviceConfig c = make_default_phantom_config();
  c.name = "arm";
  c.phantom.l1 = 0.0;
  std::string e = error_of(c);
  EXPECT_NE(e.find("device 'arm'"), std::string::npos) << e;
  EXPECT_NE(e.find("phantom.l1"), std::string::npos) << e;

  c = make_default_phantom_config();
  c.phantom.l2 = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(error_of(c).find("phantom.l2"), std::string::npos);

  c = make_default_phantom_config();
  c.phantom.base.orientation = numen::core::Quat(0.5, 0, 0, 0);
  EXPECT_NE(error_of(c).find("phantom.base.orientation"), std::string::npos);

  c = make_default_phantom_config();
  c.phantom.base.position.x() = std::numeric_limits<double>::infinity();
  EXPECT_NE(error_of(c).find("phantom.base.position"), std::string::npos);

  // Only the kind's own geometry is checked.
  c = make_default_phantom_config();
  c.trocar.orientation = numen::core::Quat(0, 0, 0, 0);
  EXPECT_EQ(error_of(c), "");
  DeviceConfig t = make_default_trocar_config();
  t.phantom.l1 = -1.0;
  EXPECT_EQ(error_of(t), "");

  c = make_default_phantom_config();
  c.axes.pop_back();
  EXPECT_NE(error_of(c).find("must have 6 entries for a phantom"), std::string::npos);
}

TEST(DeviceConfig, PhantomKindBuildsPhantomKinematics) {
  DeviceConfig c = make_default_phantom_config();
  c.phantom.l1 = 0.2;
  c.phantom.base.position = numen::core::Vec3(1, 2, 3);
  c.tool_offset.position = numen::core::Vec3(0.05, 0, 0);
  const auto k = make_kinematics(c);
  EXPECT_EQ(k->num_axes(), 6);
  EXPECT_EQ(k->num_links(), 5);
  const auto* p = dynamic_cast<const PhantomKinematics*>(k.get());
  ASSERT_NE(p, nullptr);
  EXPECT_DOUBLE_EQ(p->geometry().l1, 0.2);
  EXPECT_EQ(p->geometry().base.position, c.phantom.base.position);
  EXPECT_EQ(p->tool_offset().position, c.tool_offset.position);
  c.phantom.l2 = -0.1;
  EXPECT_THROW(make_kinematics(c), std::invalid_argument);
}

}  // namespace

namespace {
std::string canopen_error(const numen::hal::DeviceConfig& c) {
  try {
    numen::hal::validate(c);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(DeviceConfigCanopen, DefaultsAreManagedAndValid) {
  const numen::hal::DeviceConfig c = numen::hal::make_default_trocar_config(1);
  EXPECT_TRUE(c.canopen.managed);
  ASSERT_EQ(c.canopen.axes.size(), 5u);
  EXPECT_EQ(c.canopen.axes[0].drive_tpdo_cob_id, 0x281u);
  EXPECT_EQ(c.canopen.axes[3].drive_tpdo_cob_id, 0u);  // roll: no drive
  EXPECT_EQ(c.canopen.axes[0].drive_rpdo.size(), 2u);
  EXPECT_EQ(canopen_error(c), "");
}

TEST(DeviceConfigCanopen, ErrorsNameTheDeviceAxisAndField) {
  using numen::hal::DeviceConfig;
  const DeviceConfig base = numen::hal::make_default_trocar_config(1);
  DeviceConfig c = base;
  c.canopen.axes[1].drive_tpdo_cob_id = 0x181;  // pivot_x's encoder TPDO
  EXPECT_NE(
      canopen_error(c).find("axes[1] 'pivot_y' drive TPDO: COB-ID 0x181 is already used by the"),
      std::string::npos)
      << canopen_error(c);
  c = base;
  c.canopen.axes[0].drive_rpdo = {numen::hal::PdoObject::kControlword};
  EXPECT_NE(canopen_error(c).find("drive_rpdo: must map object 0x6071:00"), std::string::npos)
      << canopen_error(c);
  c = base;
  c.canopen.axes[2].heartbeat_timeout_ms = 10;
  EXPECT_NE(canopen_error(c).find("heartbeat_timeout_ms (10) must exceed heartbeat_period_ms"),
            std::string::npos)
      << canopen_error(c);
  c = base;
  c.canopen.axes[4].node_id = 127;
  EXPECT_NE(canopen_error(c).find("is the controller's node id"), std::string::npos);
  c = base;
  c.axes[0].encoder_cob_id = 0x701;  // a heartbeat COB-ID
  EXPECT_NE(canopen_error(c).find("reserved in the managed stack"), std::string::npos)
      << canopen_error(c);
  c = base;
  c.canopen.axes.pop_back();
  EXPECT_NE(canopen_error(c).find("one entry per axis"), std::string::npos);
  c.canopen.managed = false;  // the minimal protocol ignores the CANopen entries
  EXPECT_EQ(canopen_error(c), "");
}
