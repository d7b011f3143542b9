#include "numen/platform/state_frame.hpp"

#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
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
using numen::platform::FrameArray;
using numen::platform::FrameContact;
using numen::platform::FrameField;
using numen::platform::StateFrameDecoder;
using numen::platform::StateFrameFigures;
using numen::platform::StateFrameLayout;
using numen::platform::StateFrameView;

/// The two bodies of every frame here: "tool" (held) at the origin, "block" at (0.1, 0.2, 0.3).
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
  StateFrameFigures figures{42, 0.0015, 0.012, 0.02, 3.5, -0.25};
  StateFrameLayout layout{2, 0, 3, 4, 1};

  Period() {
    // One grasper holding the block with 10 grip springs (a model of one [[grasp]] would size
    // Data::grasps so; the encoder reads Data alone).
    data.grasps.resize(1);
    numen::core::GraspState& g = data.grasps[0];
    g.body = 1;
    g.num_points = 10;
    g.num_nodes = 3;  // not read while a body is held
    g.opening = 0.1;
    g.grip_force = 1.5;
    g.grasps = 2;
    g.releases = 1;
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
    report.sample_faults = numen::hal::SampleFault::kJump;
    report.feedback.force = Vec3(1.0, 2.0, 3.0);
    report.feedback.torque = Vec3(-0.1, 0.2, -0.3);
  }
};

TEST(StateFrame, SizeFollowsTheLayout) {
  const StateFrameLayout layout{2, 10, 3, 5, 2};
  // 84 header + 2·28 poses + 2·32 targets + 10·12 nodes + c·40 contacts + 24 wrench + 4·3 axes
  // + 8 penetrations + 12 closed-loop figures + 2·36 graspers.
  EXPECT_EQ(layout.frame_bytes(0), 84u + 56 + 64 + 120 + 24 + 12 + 8 + 12 + 72);
  EXPECT_EQ(layout.frame_bytes(4), layout.frame_bytes(0) + 160);
  EXPECT_EQ(layout.max_frame_bytes(), layout.frame_bytes(5));
  // Two other devices of 6 and 7 axes: 2·48 + 13·4.
  StateFrameLayout two_more = layout;
  two_more.num_extra_devices = 2;
  two_more.num_extra_axes = 13;
  EXPECT_EQ(two_more.frame_bytes(0), layout.frame_bytes(0) + 96 + 52);
  // Two threads of 101 and 11 nodes: 2·8 + 112·12.
  StateFrameLayout threads = layout;
  threads.num_threads = 2;
  threads.num_thread_nodes = 112;
  EXPECT_EQ(threads.frame_bytes(0), layout.frame_bytes(0) + 16 + 1344);
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
  EXPECT_EQ(h.held_body, 0);
  EXPECT_EQ(h.period, 42u);
  EXPECT_EQ(h.time_ns, 42'000'000);
  EXPECT_EQ(h.step_status, numen::core::kContactOverflow);
  EXPECT_EQ(h.flags, numen::platform::kFrameSampleValid | numen::platform::kFrameTorqueCommanded);
  EXPECT_EQ(h.step_ns, 12345u);
  EXPECT_EQ(h.lifecycle, static_cast<std::uint8_t>(numen::hal::LifecycleState::kActive));
  EXPECT_EQ(h.startup, static_cast<std::uint8_t>(numen::hal::StartupPhase::kOperational));
  EXPECT_EQ(h.sample_faults, numen::hal::SampleFault::kJump);
  EXPECT_EQ(h.num_grasps, 1u);

  float pose[7];
  v.body_pose(0, pose);
  EXPECT_FLOAT_EQ(pose[0], 0.01F);
  EXPECT_FLOAT_EQ(pose[2], 0.03F);
  EXPECT_FLOAT_EQ(pose[5], static_cast<float>(std::sin(0.15)));  // q_z of 0.3 rad about z
  EXPECT_FLOAT_EQ(pose[6], static_cast<float>(std::cos(0.15)));
  v.body_pose(1, pose);
  EXPECT_FLOAT_EQ(pose[1], 0.2F);
  EXPECT_TRUE(v.target_pose(0, pose));  // the held body: Data::target
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
  float loop[3];
  v.device_loop(loop);
  EXPECT_FLOAT_EQ(loop[0], 0.02F);   // hand penetration
  EXPECT_FLOAT_EQ(loop[1], 3.5F);    // handle force
  EXPECT_FLOAT_EQ(loop[2], -0.25F);  // port energy
  const numen::platform::FrameGrasp g = v.grasp(0);
  EXPECT_FLOAT_EQ(g.body, 1.0F);
  EXPECT_FLOAT_EQ(g.net, -1.0F);
  EXPECT_FLOAT_EQ(g.held, 10.0F);  // a body held: its grip springs
  EXPECT_FLOAT_EQ(g.opening, 0.1F);
  EXPECT_FLOAT_EQ(g.grip_force, 1.5F);
  EXPECT_FLOAT_EQ(g.grasps, 2.0F);
  EXPECT_FLOAT_EQ(g.releases, 1.0F);
  EXPECT_FLOAT_EQ(g.slips, 0.0F);
  EXPECT_FLOAT_EQ(g.thread, -1.0F);
}

/// Period `p`'s frame encoded and decoded: its first grasper's item.
numen::platform::FrameGrasp first_grasp(const Period& p) {
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  const std::size_t n =
      numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, buf);
  StateFrameView v;
  EXPECT_TRUE(StateFrameDecoder::decode(std::span(buf.data(), n), v).ok());
  return v.grasp(0);
}

// Tissue held: the grasp item carries the net and its held nodes.
TEST(StateFrame, CarriesAGraspOfTissue) {
  Period p;
  p.data.grasps[0].body = -1;
  p.data.grasps[0].net = 0;
  p.data.grasps[0].slips = 4;
  const numen::platform::FrameGrasp g = first_grasp(p);
  EXPECT_FLOAT_EQ(g.body, -1.0F);
  EXPECT_FLOAT_EQ(g.net, 0.0F);
  EXPECT_FLOAT_EQ(g.held, 3.0F);  // held nodes
  EXPECT_FLOAT_EQ(g.slips, 4.0F);
  EXPECT_FLOAT_EQ(g.thread, -1.0F);
}

// A thread held: the grasp item carries the thread and its held nodes (neither body nor net).
TEST(StateFrame, CarriesAGraspOfAThread) {
  Period p;
  p.data.grasps[0].body = -1;
  p.data.grasps[0].net = -1;
  p.data.grasps[0].thread = 0;
  p.data.grasps[0].num_thread_nodes = 2;
  const numen::platform::FrameGrasp g = first_grasp(p);
  EXPECT_FLOAT_EQ(g.body, -1.0F);
  EXPECT_FLOAT_EQ(g.net, -1.0F);
  EXPECT_FLOAT_EQ(g.thread, 0.0F);
  EXPECT_FLOAT_EQ(g.held, 2.0F);  // held thread nodes
}

/// Decodes the first `n` bytes of `buf` into `v`: the decoder's reason, empty when accepted.
std::string decode_into(const std::vector<std::byte>& buf, std::size_t n, StateFrameView& v) {
  return StateFrameDecoder::decode(std::span(buf.data(), n), v).error;
}

// Issue 70: the frame carried device 0's state alone. The loop's other devices come after the
// graspers, each its flags, lifecycle, start-up, fault, sample faults, axis count and feedback,
// their axis torques in one array; device 0's header fields and arrays are as they were.
TEST(StateFrame, CarriesTheLoopsOtherDevices) {
  namespace hal = numen::hal;
  Period p;
  p.layout.num_extra_devices = 2;
  p.layout.num_extra_axes = 5;
  numen::platform::PeriodReport second;  // device 1: safe state latched, stale samples
  second.sample_valid = false;
  second.target_ready = true;
  second.lifecycle = hal::LifecycleState::kFault;
  second.startup = hal::StartupPhase::kOperational;
  second.fault_cause = hal::FaultCause::kEncoderTimeout;
  second.sample_faults = hal::SampleFault::kStale;
  numen::platform::PeriodReport third;  // device 2: rendering 3.6 N
  third.sample_valid = true;
  third.torque_commanded = true;
  third.lifecycle = hal::LifecycleState::kActive;
  third.feedback.force = Vec3(0.0, -3.6, 0.0);
  third.feedback.torque = Vec3(0.0, 0.0, 0.05);
  const std::array<double, 2> second_tau{0.0, 0.0};
  const std::array<double, 3> third_tau{-0.125, 0.5, 2.25};
  const std::array<numen::platform::FrameDeviceInput, 2> extra{{
      {&second, second_tau, true}, {&third, third_tau, false}}};
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  const std::size_t n = numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques,
                                                            p.figures, buf, extra);
  ASSERT_EQ(n, p.layout.frame_bytes(1));
  StateFrameView v;
  ASSERT_EQ(decode_into(buf, n, v), "");
  EXPECT_EQ(v.header().num_extra_devices, 2u);
  EXPECT_EQ(v.header().num_extra_axes, 5u);
  // Device 0's, unchanged.
  EXPECT_EQ(v.header().flags, numen::platform::kFrameSampleValid | numen::platform::kFrameTorqueCommanded);
  EXPECT_EQ(v.header().fault_cause, 0u);
  EXPECT_EQ(v.header().sample_faults, hal::SampleFault::kJump);
  float w[6];
  v.feedback(w);
  EXPECT_FLOAT_EQ(w[0], 1.0F);
  EXPECT_FLOAT_EQ(v.axis_torque(2), 1.5F);
  // The others'.
  const numen::platform::FrameDevice d1 = v.extra_device(0);
  EXPECT_EQ(d1.flags, numen::platform::kFrameTargetReady | numen::platform::kFrameBusDown);
  EXPECT_EQ(d1.lifecycle, static_cast<std::uint8_t>(hal::LifecycleState::kFault));
  EXPECT_EQ(d1.startup, static_cast<std::uint8_t>(hal::StartupPhase::kOperational));
  EXPECT_EQ(d1.fault_cause, static_cast<std::uint8_t>(hal::FaultCause::kEncoderTimeout));
  EXPECT_EQ(d1.sample_faults, hal::SampleFault::kStale);
  EXPECT_EQ(d1.num_axes, 2u);
  EXPECT_FLOAT_EQ(d1.feedback[1], 0.0F);
  const numen::platform::FrameDevice d2 = v.extra_device(1);
  EXPECT_EQ(d2.flags, numen::platform::kFrameSampleValid | numen::platform::kFrameTorqueCommanded);
  EXPECT_EQ(d2.lifecycle, static_cast<std::uint8_t>(hal::LifecycleState::kActive));
  EXPECT_EQ(d2.fault_cause, 0u);
  EXPECT_EQ(d2.num_axes, 3u);
  EXPECT_FLOAT_EQ(d2.feedback[1], -3.6F);
  EXPECT_FLOAT_EQ(d2.feedback[5], 0.05F);
  EXPECT_FLOAT_EQ(v.extra_axis_torque(0), 0.0F);  // device 1's two axes, then device 2's three
  EXPECT_FLOAT_EQ(v.extra_axis_torque(2), -0.125F);
  EXPECT_FLOAT_EQ(v.extra_axis_torque(4), 2.25F);
  // Inputs that do not match the layout are refused: one device short, an axis short, no report.
  EXPECT_EQ(numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures,
                                                buf, std::span(extra.data(), 1)),
            0u);
  auto short_axis = extra;
  short_axis[1].axis_torques = std::span(third_tau.data(), 2);
  EXPECT_EQ(numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures,
                                                buf, short_axis),
            0u);
  auto no_report = extra;
  no_report[0].report = nullptr;
  EXPECT_EQ(numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures,
                                                buf, no_report),
            0u);
  // A frame whose devices' axis counts do not add up to num_extra_axes is refused by name.
  std::vector<std::byte> bad(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
  const std::size_t count_at =
      n - 4 * 5 - 4 * 12 * 2 + 4 * 5;  // device 1's axis count: its item's sixth float
  const float three = 3.0F;
  std::memcpy(bad.data() + count_at, &three, 4);  // little-endian hosts
  StateFrameView u;
  EXPECT_NE(StateFrameDecoder::decode(bad, u).error.find(
                "byte 72: the other devices' axis counts add up to 6, the header says 5"),
            std::string::npos)
      << StateFrameDecoder::decode(bad, u).error;
}

// Issue 69: the suture threads after the other devices, each its broken segment and largest
// tension, then all their nodes; a thread count or node count that does not match the Data is
// refused, as is a frame whose counts need more bytes than it has. No allocation.
TEST(StateFrame, CarriesTheThreadsNodesAndTheirBreak) {
  Period p;
  p.data.threads.resize(2);
  p.data.threads[0].position = {Vec3(0.0, 0.0, 0.01), Vec3(0.001, 0.0, 0.01), Vec3(0.002, 0.0, 0.011)};
  p.data.threads[0].output.max_tension = 0.25;
  p.data.threads[1].position = {Vec3(0.5, 0.0, 0.0), Vec3(0.5, 0.001, 0.0)};
  p.data.threads[1].broken_segment = 0;
  p.layout.num_threads = 2;
  p.layout.num_thread_nodes = 5;
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  std::size_t n = 0;
  {
    numen::test::AllocationGuard guard;
    n = numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, buf);
    EXPECT_EQ(guard.count(), 0);
  }
  ASSERT_EQ(n, p.layout.frame_bytes(1));
  StateFrameView v;
  ASSERT_EQ(decode_into(buf, n, v), "");
  EXPECT_EQ(v.header().num_threads, 2u);
  EXPECT_EQ(v.header().num_thread_nodes, 5u);
  EXPECT_EQ(v.thread(0).broken_segment, -1);
  EXPECT_FLOAT_EQ(v.thread(0).max_tension, 0.25F);
  EXPECT_EQ(v.thread(1).broken_segment, 0);
  float x[3];
  v.thread_node(2, x);  // thread 0's last node
  EXPECT_FLOAT_EQ(x[0], 0.002F);
  EXPECT_FLOAT_EQ(x[2], 0.011F);
  v.thread_node(4, x);  // thread 1's last node
  EXPECT_FLOAT_EQ(x[0], 0.5F);
  EXPECT_FLOAT_EQ(x[1], 0.001F);
  float pose[7];
  v.body_pose(1, pose);  // the rest of the frame as it was
  EXPECT_FLOAT_EQ(pose[0], 0.1F);
  // Data that does not match: a thread short, a node more.
  StateFrameLayout wrong = p.layout;
  wrong.num_threads = 1;
  EXPECT_EQ(numen::platform::encode_state_frame(wrong, p.data, p.report, p.torques, p.figures, buf), 0u);
  wrong = p.layout;
  wrong.num_thread_nodes = 6;
  std::vector<std::byte> big(wrong.max_frame_bytes());
  EXPECT_EQ(numen::platform::encode_state_frame(wrong, p.data, p.report, p.torques, p.figures, big), 0u);
  // A frame that says one node more than it carries is refused with its counts.
  std::vector<std::byte> bad(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
  bad[80] = std::byte{6};
  EXPECT_NE(StateFrameDecoder::decode(bad, v).error.find("threads 2, their nodes 6) need"), std::string::npos)
      << StateFrameDecoder::decode(bad, v).error;
}

/// The `bytes` bytes at `at`, little-endian, as an unsigned number.
std::uint64_t frame_le_bytes(const std::vector<std::byte>& frame, std::size_t at,
                             std::size_t bytes) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < bytes; ++i)
    v |= std::to_integer<std::uint64_t>(frame.at(at + i)) << (8 * i);
  return v;
}

// Each declared header field's bytes at its declared offset, and each array's first float at
// the offset the declaration gives it (the arrays in order from the header's end).
TEST(StateFrame, EachDeclaredFieldIsAtItsDeclaredOffset) {
  Period p;
  p.data.target.position.x() = 0.5;            // first float of target_pose (body 0 is held)
  p.data.contacts[0].position.x() = 0.004;      // first float of contact
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  const std::size_t n =
      numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, buf);
  ASSERT_EQ(n, p.layout.frame_bytes(1));
  for (const numen::platform::StateFrameField& f : numen::platform::kStateFrameFields) {
    const std::size_t bytes = numen::platform::frame_field_bytes(f.type);
    const std::uint64_t got = frame_le_bytes(buf, f.offset, bytes);
    std::uint64_t want = 0;
    switch (f.id) {
      case FrameField::kMagic: want = 0x46564D4E; break;  // "NMVF"
      case FrameField::kVersion: want = 6; break;
      case FrameField::kHeaderBytes: want = 84; break;
      case FrameField::kFrameBytes: want = n; break;
      case FrameField::kNumBodies: want = 2; break;
      case FrameField::kNumNodes: want = 0; break;
      case FrameField::kNumContacts: want = 1; break;
      case FrameField::kNumAxes: want = 3; break;
      case FrameField::kHeldBody: want = 0; break;
      case FrameField::kPeriod: want = 42; break;
      case FrameField::kTimeNs: want = 42'000'000; break;
      case FrameField::kStepStatus: want = numen::core::kContactOverflow; break;
      case FrameField::kFlags:
        want = numen::platform::kFrameSampleValid | numen::platform::kFrameTorqueCommanded;
        break;
      case FrameField::kStepNs: want = 12345; break;
      case FrameField::kLifecycle:
        want = static_cast<std::uint64_t>(numen::hal::LifecycleState::kActive);
        break;
      case FrameField::kStartup:
        want = static_cast<std::uint64_t>(numen::hal::StartupPhase::kOperational);
        break;
      case FrameField::kFaultCause: want = 0; break;  // none latched
      case FrameField::kSampleFaults: want = numen::hal::SampleFault::kJump; break;
      case FrameField::kNumGrasps: want = 1; break;
      case FrameField::kNumExtraDevices: want = 0; break;  // one device
      case FrameField::kNumExtraAxes: want = 0; break;
      case FrameField::kNumThreads: want = 0; break;  // no thread
      case FrameField::kNumThreadNodes: want = 0; break;
    }
    EXPECT_EQ(got, want) << f.name << " at byte " << f.offset;
  }
  // Counts B = 2, N = 0, C = 1, A = 3, G = 1: each array's first float where the declaration
  // puts it.
  std::size_t at = numen::platform::kStateFrameHeaderBytes;
  for (const numen::platform::StateFrameArray& a : numen::platform::kStateFrameArrays) {
    std::size_t items = 1;
    if (a.count == FrameField::kNumBodies) items = 2;
    if (a.count == FrameField::kNumNodes) items = 0;
    if (a.count == FrameField::kNumContacts) items = 1;
    if (a.count == FrameField::kNumAxes) items = 3;
    if (a.count == FrameField::kNumGrasps) items = 1;
    if (a.count == FrameField::kNumExtraDevices || a.count == FrameField::kNumExtraAxes) items = 0;
    if (a.count == FrameField::kNumThreads || a.count == FrameField::kNumThreadNodes) items = 0;
    float want = 0.0F;
    switch (a.id) {
      case FrameArray::kBodyPose: want = 0.01F; break;    // body 0's x
      case FrameArray::kTargetPose: want = 0.5F; break;   // body 0's target x
      case FrameArray::kNodePosition: break;              // no node
      case FrameArray::kContact: want = 0.004F; break;    // the contact point's x
      case FrameArray::kFeedback: want = 1.0F; break;     // force x
      case FrameArray::kAxisTorque: want = 0.25F; break;  // axis 0
      case FrameArray::kPenetration: want = 0.0015F; break;  // tool penetration
      case FrameArray::kDeviceLoop: want = 0.02F; break;     // hand penetration
      case FrameArray::kGrasp: want = 1.0F; break;           // the held body
      case FrameArray::kExtraDevice:                         // none: one device
      case FrameArray::kExtraAxisTorque:
      case FrameArray::kThread:                              // none: no thread
      case FrameArray::kThreadNode: break;
    }
    if (items > 0) {
      const auto bits = static_cast<std::uint32_t>(frame_le_bytes(buf, at, 4));
      EXPECT_FLOAT_EQ(std::bit_cast<float>(bits), want) << a.name << " at byte " << at;
    }
    at += 4 * a.floats * items;
  }
  EXPECT_EQ(at, n);
}

TEST(StateFrame, IsLittleEndianOnTheWire) {
  Period p;
  std::vector<std::byte> buf(p.layout.max_frame_bytes());
  const std::size_t n =
      numen::platform::encode_state_frame(p.layout, p.data, p.report, p.torques, p.figures, buf);
  ASSERT_GT(n, 84u);
  EXPECT_EQ(std::memcmp(buf.data(), "NMVF", 4), 0);
  EXPECT_EQ(std::to_integer<int>(buf[4]), 6);  // version, low byte first
  EXPECT_EQ(std::to_integer<int>(buf[5]), 0);
  EXPECT_EQ(std::to_integer<int>(buf[32]), 42);  // period 42, low byte first
  // body 0's x = 0.01f: 0x3C23D70A, bytes 0A D7 23 3C
  EXPECT_EQ(std::to_integer<int>(buf[84]), 0x0A);
  EXPECT_EQ(std::to_integer<int>(buf[87]), 0x3C);
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
  wrong = p.layout;
  wrong.num_grasps = 2;  // one grasper in the Data
  big.resize(wrong.max_frame_bytes());
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
  EXPECT_NE(decode({}).find("shorter than its 84-byte header"), std::string::npos);
  auto b = buf;
  b[0] = std::byte{'X'};
  EXPECT_NE(decode(b).find("byte 0: not a state frame"), std::string::npos);
  b = buf;
  b[4] = std::byte{5};  // the version before a grasp's held thread: a recording of an older numen
  EXPECT_NE(decode(b).find("byte 4: frame version 5, this reader knows 6 (written by an older numen: "
                           "record the run again with this one)"),
            std::string::npos)
      << decode(b);
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
  b[64] = std::byte{2};  // two graspers, one there
  EXPECT_NE(decode(b).find("graspers 2, other devices 0, their axes 0, threads 0, their nodes 0) need"),
            std::string::npos)
      << decode(b);
  b = buf;
  b[28] = std::byte{5};
  EXPECT_NE(decode(b).find("byte 28: held body 5"), std::string::npos);
  EXPECT_EQ(decode(buf), "");
}


/// The rows of the Markdown table whose header line is `head` in `doc`, each as its cells
/// (trimmed); empty if there is no such table.
std::vector<std::vector<std::string>> frame_doc_table(const std::string& doc,
                                                      const std::string& head) {
  std::vector<std::vector<std::string>> rows;
  std::size_t at = doc.find(head + "\n");
  if (at == std::string::npos) return rows;
  at = doc.find('\n', doc.find('\n', at) + 1);  // past the header and the rule
  std::istringstream lines(doc.substr(at + 1));
  for (std::string line; std::getline(lines, line) && line.rfind("| ", 0) == 0;) {
    std::vector<std::string> cells;
    std::istringstream in(line.substr(1));
    for (std::string cell; std::getline(in, cell, '|');) {
      const std::size_t b = cell.find_first_not_of(' '), e = cell.find_last_not_of(' ');
      cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
    }
    rows.push_back(std::move(cells));
  }
  return rows;
}

// docs/viewer.md "Frames" gives the header's and the arrays' layout in two tables: their
// offset, name and type columns (name, floats and count for the arrays) are the declaration's,
// row for row.
TEST(StateFrameDeclaration, DocsTablesAreTheDeclaration) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/docs/viewer.md");
  ASSERT_TRUE(in) << "docs/viewer.md";
  std::stringstream ss;
  ss << in.rdbuf();
  const auto fields = frame_doc_table(ss.str(), "| offset | field | type | contents |");
  ASSERT_EQ(fields.size(), numen::platform::kStateFrameFields.size())
      << "docs/viewer.md's header table has " << fields.size() << " rows, kStateFrameFields "
      << numen::platform::kStateFrameFields.size();
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const auto& f = numen::platform::kStateFrameFields[i];
    ASSERT_GE(fields[i].size(), 3u) << "row " << i;
    EXPECT_EQ(fields[i][0], std::to_string(f.offset)) << f.name;
    EXPECT_EQ(fields[i][1], "`" + std::string(f.name) + "`") << "offset " << f.offset;
    EXPECT_EQ(fields[i][2], numen::platform::frame_field_type_name(f.type)) << f.name;
  }
  const auto arrays = frame_doc_table(ss.str(), "| array | floats | count | contents |");
  ASSERT_EQ(arrays.size(), numen::platform::kStateFrameArrays.size())
      << "docs/viewer.md's array table has " << arrays.size() << " rows, kStateFrameArrays "
      << numen::platform::kStateFrameArrays.size();
  for (std::size_t i = 0; i < arrays.size(); ++i) {
    const auto& a = numen::platform::kStateFrameArrays[i];
    ASSERT_GE(arrays[i].size(), 3u) << "row " << i;
    EXPECT_EQ(arrays[i][0], "`" + std::string(a.name) + "`") << "array " << i;
    EXPECT_EQ(arrays[i][1], std::to_string(a.floats)) << a.name;
    EXPECT_EQ(arrays[i][2],
              a.count ? "`" + std::string(numen::platform::frame_field(*a.count).name) + "`" : "1")
        << a.name;
  }
}

}  // namespace
