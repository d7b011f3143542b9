#include "numen/platform/state_frame.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <vector>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "deformable_ball.hpp"
#include "free_bodies.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"

namespace {

using numen::core::Vec3;
using numen::platform::FrameContact;
using numen::platform::StateFrameDecoder;
using numen::platform::StateFrameFigures;
using numen::platform::StateFrameLayout;
using numen::platform::StateFrameView;

/// The two bodies of every frame here: "tool" (attached) at the origin, "block" at (0.1, 0.2, 0.3).
numen::core::Model two_bodies() {
  return numen::test::free_bodies_model({"tool", "block"}, [](numen::core::Model& m) {
    m.bodies[1].initial_pose.position = Vec3(0.1, 0.2, 0.3);
  });
}

/// A period of the two-body model with known values in every field of a frame.
struct Period {
  numen::core::Model model = two_bodies();
  numen::core::Data data = numen::core::make_data(model);
  numen::platform::PeriodReport report;
  std::array<double, 3> torques{0.25, -0.5, 1.5};
  StateFrameFigures figures{42, 0.0015, 0.012};
  StateFrameLayout layout{2, 0, 3, 4};

  Period() {
    data.time = 0.042;
    data.bodies[0].position = Vec3(0.01, 0.02, 0.03);
    data.bodies[0].orientation = numen::core::Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ()));
    data.target.position = Vec3(0.01, 0.02, 0.02);
    data.status = numen::core::kContactOverflow;
    data.num_contacts = 1;
    data.contacts[0].position = Vec3(0.0, 0.0, 0.001);
    data.contacts[0].normal = Vec3::UnitZ();
    data.contacts[0].depth = 0.0015;
    data.contacts[0].force = Vec3(0.0, 0.1, 15.0);
    report.sample_valid = true;
    report.torque_commanded = true;
    report.step_ns = 12345;
    report.lifecycle = numen::hal::LifecycleState::kActive;
    report.startup = numen::hal::StartupPhase::kOperational;
    report.feedback.force = Vec3(1.0, 2.0, 3.0);
    report.feedback.torque = Vec3(-0.1, 0.2, -0.3);
  }
};

TEST(StateFrame, SizeFollowsTheLayout) {
  const StateFrameLayout layout{2, 10, 3, 5};
  // 64 header + 2·28 poses + 2·32 targets + 10·12 nodes + c·40 contacts + 24 wrench + 4·3 axes + 8.
  EXPECT_EQ(layout.frame_bytes(0), 64u + 56 + 64 + 120 + 24 + 12 + 8);
  EXPECT_EQ(layout.frame_bytes(4), layout.frame_bytes(0) + 160);
  EXPECT_EQ(layout.max_frame_bytes(), layout.frame_bytes(5));
}

TEST(StateFrame, RoundTripsEveryField) {
  Period p;
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  const std::size_t n =
      numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, buf);
  ASSERT_EQ(n, p.layout.frame_bytes(1));
  StateFrameView v;
  const auto r = StateFrameDecoder::decode(std::span(buf.data(), n), v);
  ASSERT_TRUE(r.ok()) << r.error;
  const auto& h = v.header();
  EXPECT_EQ(h.frame_bytes, n);
  EXPECT_EQ(h.num_bodies, 2u);
  EXPECT_EQ(h.num_nodes, 0u);
  EXPECT_EQ(h.num_contacts, 1u);
  EXPECT_EQ(h.num_axes, 3u);
  EXPECT_EQ(h.attached_body, 0);
  EXPECT_EQ(h.period, 42u);
  EXPECT_EQ(h.time_ns, 42'000'000);
  EXPECT_EQ(h.step_status, numen::core::kContactOverflow);
  EXPECT_EQ(h.flags, numen::platform::kFrameSampleValid | numen::platform::kFrameTorqueCommanded);
  EXPECT_EQ(h.step_ns, 12345u);
  EXPECT_EQ(h.lifecycle, static_cast<std::uint8_t>(numen::hal::LifecycleState::kActive));
  EXPECT_EQ(h.startup, static_cast<std::uint8_t>(numen::hal::StartupPhase::kOperational));

  float pose[7];
  v.body_pose(0, pose);
  EXPECT_FLOAT_EQ(pose[0], 0.01F);
  EXPECT_FLOAT_EQ(pose[2], 0.03F);
  EXPECT_FLOAT_EQ(pose[5], static_cast<float>(std::sin(0.15)));  // q_z of 0.3 rad about z
  EXPECT_FLOAT_EQ(pose[6], static_cast<float>(std::cos(0.15)));
  v.body_pose(1, pose);
  EXPECT_FLOAT_EQ(pose[1], 0.2F);
  EXPECT_TRUE(v.target_pose(0, pose));  // the attached body: Data::target
  EXPECT_FLOAT_EQ(pose[2], 0.02F);
  EXPECT_FALSE(v.target_pose(1, pose));  // no own target: its own pose, flagged off
  EXPECT_FLOAT_EQ(pose[2], 0.3F);

  const FrameContact c = v.contact(0);
  EXPECT_FLOAT_EQ(c.point[2], 0.001F);
  EXPECT_FLOAT_EQ(c.normal[2], 1.0F);
  EXPECT_FLOAT_EQ(c.depth, 0.0015F);
  EXPECT_FLOAT_EQ(c.force[2], 15.0F);
  float w[6];
  v.feedback(w);
  EXPECT_FLOAT_EQ(w[0], 1.0F);
  EXPECT_FLOAT_EQ(w[5], -0.3F);
  EXPECT_FLOAT_EQ(v.axis_torque(0), 0.25F);
  EXPECT_FLOAT_EQ(v.axis_torque(2), 1.5F);
  EXPECT_FLOAT_EQ(v.tool_penetration(), 0.0015F);
  EXPECT_FLOAT_EQ(v.target_penetration(), 0.012F);
}

TEST(StateFrame, IsLittleEndianOnTheWire) {
  Period p;
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  const std::size_t n =
      numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, buf);
  ASSERT_GT(n, 64u);
  EXPECT_EQ(std::memcmp(buf.data(), "NMVF", 4), 0);
  EXPECT_EQ(std::to_integer<int>(buf[4]), 1);  // version, low byte first
  EXPECT_EQ(std::to_integer<int>(buf[5]), 0);
  EXPECT_EQ(std::to_integer<int>(buf[32]), 42);  // period 42, low byte first
  // body 0's x = 0.01f: 0x3C23D70A, bytes 0A D7 23 3C
  EXPECT_EQ(std::to_integer<int>(buf[64]), 0x0A);
  EXPECT_EQ(std::to_integer<int>(buf[67]), 0x3C);
}

TEST(StateFrame, ContactsBeyondTheCapacityAreCutAndFlagged) {
  Period p;
  p.layout.max_contacts = 2;
  p.data.num_contacts = 3;
  for (int i = 0; i < 3; ++i) p.data.contacts[i].depth = 0.001 * (i + 1);
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  const std::size_t n =
      numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, buf);
  StateFrameView v;
  ASSERT_TRUE(StateFrameDecoder::decode(std::span(buf.data(), n), v).ok());
  EXPECT_EQ(v.header().num_contacts, 2u);
  EXPECT_TRUE(v.header().flags & numen::platform::kFrameContactsTruncated);
  EXPECT_FLOAT_EQ(v.contact(1).depth, 0.002F);
}

TEST(StateFrame, RefusesDataThatDoesNotMatchTheLayout) {
  Period p;
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  StateFrameLayout wrong = p.layout;
  wrong.num_bodies = 3;
  std::vector<std::byte> big(wrong.max_frame_bytes());
  EXPECT_EQ(numen::platform::encode_state_frame(wrong, p.data, p.report, p.torques, p.figures, big), 0u);
  const std::array<double, 2> two{0.0, 0.0};
  EXPECT_EQ(numen::platform::encode_state_frame(p.layout, p.data, p.report, two, p.figures, buf), 0u);
  std::vector<std::byte> small(p.layout.max_frame_bytes() - 1);
  EXPECT_EQ(numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, small), 0u);
}

TEST(StateFrame, EncodesWithoutAllocating) {
  Period p;
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  numen::test::AllocationGuard guard;
  const std::size_t n =
      numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, buf);
  EXPECT_GT(n, 0u);
  EXPECT_EQ(guard.count(), 0);
}

TEST(StateFrame, CarriesNetNodesAndNodeContacts) {
  NUMEN_REQUIRE_DEFORMABLE();
  const numen::core::Model m = numen::test::make_deformable_ball(1);
  numen::core::Data d = numen::core::make_data(m);
  numen::test::run_deformable_ball(m, d, 0, 200);
  const StateFrameLayout layout{static_cast<std::uint32_t>(m.num_bodies()),
                                static_cast<std::uint32_t>(m.num_nodes()), 0, 64};
  ASSERT_GT(layout.num_nodes, 0u);
  std::vector<std::byte> buf(layout.max_frame_bytes());
  const numen::platform::PeriodReport report;
  const std::size_t n = numen::platform::encode_state_frame(layout, d, report, {}, {}, buf);
  StateFrameView v;
  const auto r = StateFrameDecoder::decode(std::span(buf.data(), n), v);
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(v.header().num_contacts,
            static_cast<std::uint32_t>(std::min(d.num_contacts + d.num_node_contacts, 64)));
  for (std::uint32_t i = 0; i < layout.num_nodes; ++i) {
    float x[3];
    v.node_position(i, x);
    for (int j = 0; j < 3; ++j) EXPECT_FLOAT_EQ(x[j], static_cast<float>(d.nodes[i].position[j]));
  }
}

TEST(StateFrameDecoder, RejectsEveryMalformedFrameWithItsOffset) {
  Period p;
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  const std::size_t n =
      numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, buf);
  buf.resize(n);
  StateFrameView v;
  auto decode = [&](std::vector<std::byte> b) { return StateFrameDecoder::decode(b, v).error; };
  EXPECT_NE(decode({}).find("shorter than its 64-byte header"), std::string::npos);
  auto b = buf;
  b[0] = std::byte{'X'};
  EXPECT_NE(decode(b).find("byte 0: not a state frame"), std::string::npos);
  b = buf;
  b[4] = std::byte{2};
  EXPECT_NE(decode(b).find("byte 4: frame version 2"), std::string::npos);
  b = buf;
  b.pop_back();
  EXPECT_NE(decode(b).find("byte 8: frame size field"), std::string::npos);
  b = buf;
  b[16] = std::byte{0xFF};  // 255 nodes that are not there
  EXPECT_NE(decode(b).find("byte 12: counts"), std::string::npos);
  b = buf;
  b[19] = std::byte{0xFF};  // ~4e9 nodes: no overflow, no read past the end
  EXPECT_NE(decode(b).find("byte 12: counts"), std::string::npos);
  b = buf;
  b[28] = std::byte{5};
  EXPECT_NE(decode(b).find("byte 28: attached body 5"), std::string::npos);
  EXPECT_EQ(decode(buf), "");
}

}  // namespace
