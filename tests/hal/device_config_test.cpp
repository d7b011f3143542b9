// Tests of numen/hal/device_config.hpp and kinematics_factory.hpp: defaults, validation
// messages that name the field, kinematics of each kind.
#include "numen/hal/device_config.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "numen/hal/kinematics_factory.hpp"

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

}  // namespace
