// Tests of core/capacity: contact scratch only where a contact is possible.
#include "numen/core/capacity.hpp"

#include <gtest/gtest.h>

#include "build_features.hpp"
#include "lean_scenes.hpp"
#include "numen/core/model.hpp"

namespace core = numen::core;
using numen::test::LeanPart;
using numen::test::make_lean_model;

TEST(Capacity, NothingToCollideNeedsNoContactRoom) {
  const core::Model m = make_lean_model(LeanPart::kNone);
  EXPECT_EQ(core::contact_capacity(m), 0);
  EXPECT_EQ(core::cross_contact_capacity(m), 0);
}

TEST(Capacity, AnObstacleNeedsTheFullRoomButNoBodyPairs) {
  const core::Model m = make_lean_model(LeanPart::kObstacle);
  EXPECT_EQ(core::contact_capacity(m), core::kMaxContacts);
  EXPECT_EQ(core::cross_contact_capacity(m), 0);
}

TEST(Capacity, BodiesOfOneArticulationNeverCollide) {
  NUMEN_REQUIRE_ARTICULATION();
  const core::Model m = make_lean_model(LeanPart::kJoint);
  ASSERT_EQ(m.num_bodies(), 2);
  EXPECT_EQ(core::contact_capacity(m), 0);
  EXPECT_EQ(core::cross_contact_capacity(m), 0);
}

TEST(Capacity, TwoFreeBodiesWithSpheresCanCollide) {
  NUMEN_REQUIRE_ARTICULATION();
  core::Model m = make_lean_model(LeanPart::kJoint);
  m.joints.clear();
  ASSERT_EQ(core::finalize_model(m), "");
  EXPECT_EQ(core::contact_capacity(m), core::kMaxContacts);
  EXPECT_EQ(core::cross_contact_capacity(m), core::kMaxContacts);
  // Without spheres on the second body, no pair is left.
  m.bodies[1].sphere_count = 0;
  ASSERT_EQ(core::finalize_model(m), "");
  EXPECT_EQ(core::contact_capacity(m), 0);
}
