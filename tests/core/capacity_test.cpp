// Tests of core/capacity: contact scratch only where a contact is possible.
#include "numen/core/capacity.hpp"

#include <gtest/gtest.h>

#include "build_features.hpp"
#include "lean_scenes.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"

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
}

TEST(Capacity, ContactsBeyondTheRoomAreAnOverflowNotAnOutOfBoundsWrite) {
  // A caller of the stage functions may write contacts itself; a model in which
  // nothing can collide has no room for them: they are dropped and reported.
  const core::Model m = make_lean_model(LeanPart::kNone);
  core::Data d = core::make_data(m);
  d.num_contacts = 2;
  d.contacts[0].body_a = d.contacts[1].body_a = 0;
  d.contacts[0].body_b = d.contacts[1].body_b = -1;
  d.contacts[0].normal = d.contacts[1].normal = core::Vec3::UnitZ();
  d.contacts[0].depth = d.contacts[1].depth = 0.001;
  core::compute_forces(m, d);
  EXPECT_EQ(d.num_contacts, 0);
  EXPECT_EQ(d.contacts_dropped, 2);
  EXPECT_NE(d.status & core::kContactOverflow, 0u);
}
