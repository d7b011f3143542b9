// The state frame's layout as JSON (sim/view/frame_layout_json): what the view server sends the
// page in its session message. A frame decoded by the JSON alone, as the page decodes it, reads
// what StateFrameView reads, and the JSON's names are the declaration's.
#include "numen/sim/view/frame_layout_json.hpp"

#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "free_bodies.hpp"
#include "numen/core/model.hpp"
#include "numen/hal/device/safety_supervisor.hpp"
#include "numen/platform/state_frame.hpp"

namespace {

namespace platform = numen::platform;

/// The little-endian integer of `bytes` bytes at `at`, sign-extended when `is_signed`.
std::int64_t layout_json_integer(const std::vector<std::byte>& f, std::size_t at, std::size_t bytes,
                                 bool is_signed) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < bytes; ++i)
    v |= std::to_integer<std::uint64_t>(f.at(at + i)) << (8 * i);
  if (is_signed && bytes < 8 && (v >> (8 * bytes - 1)) != 0) v |= ~std::uint64_t{0} << (8 * bytes);
  return static_cast<std::int64_t>(v);
}

/// A frame of two free bodies, three axes and one contact, with distinct values.
std::vector<std::byte> layout_json_frame() {
  const numen::core::Model m = numen::test::free_bodies_model({"tool", "block"});
  numen::core::Data d = numen::core::make_data(m);
  d.time = 0.125;
  d.bodies[1].position = numen::core::Vec3(0.1, 0.2, 0.3);
  d.num_contacts = 1;
  d.contacts[0].position = numen::core::Vec3(0.004, 0.005, 0.006);
  d.contacts[0].depth = 0.0025;
  platform::PeriodReport report;
  report.step_ns = 777;
  report.feedback.force = numen::core::Vec3(1.5, 2.5, 3.5);
  const std::array<double, 3> torques{0.25, -0.5, 1.5};
  const platform::StateFrameFigures figures{9, 0.0015, 0.012};
  const platform::StateFrameLayout layout{2, 0, 3, 4};
  std::vector<std::byte> f(layout.max_frame_bytes());
  f.resize(platform::encode_state_frame(layout, d, report, torques, figures, f));
  return f;
}

TEST(FrameLayoutJson, HasEveryDeclaredFieldAndArrayInOrder) {
  const auto j = nlohmann::json::parse(numen::sim::state_frame_layout_json());
  EXPECT_EQ(j.at("magic"), "NMVF");
  EXPECT_EQ(j.at("version"), platform::kStateFrameVersion);
  EXPECT_EQ(j.at("header_bytes"), platform::kStateFrameHeaderBytes);
  EXPECT_EQ(j.at("float_bytes"), 4);
  ASSERT_EQ(j.at("header").size(), platform::kStateFrameFields.size());
  for (std::size_t i = 0; i < platform::kStateFrameFields.size(); ++i) {
    const platform::StateFrameField& f = platform::kStateFrameFields[i];
    EXPECT_EQ(j["header"][i].at("name"), std::string(f.name));
    EXPECT_EQ(j["header"][i].at("offset"), f.offset) << f.name;
    EXPECT_EQ(j["header"][i].at("type"), std::string(platform::frame_field_type_name(f.type)))
        << f.name;
  }
  ASSERT_EQ(j.at("arrays").size(), platform::kStateFrameArrays.size());
  for (std::size_t i = 0; i < platform::kStateFrameArrays.size(); ++i) {
    const platform::StateFrameArray& a = platform::kStateFrameArrays[i];
    EXPECT_EQ(j["arrays"][i].at("name"), std::string(a.name));
    EXPECT_EQ(j["arrays"][i].at("floats"), a.floats) << a.name;
    if (a.count)
      EXPECT_EQ(j["arrays"][i].at("count"), std::string(platform::frame_field(*a.count).name))
          << a.name;
    else
      EXPECT_TRUE(j["arrays"][i].at("count").is_null()) << a.name;
  }
}

// The page's decoding (viewer.js decodeFrame), done here from the JSON alone: header fields by
// name are StateFrameHeader's members of the same name, the arrays end at frame_bytes, and
// their floats are the view's.
// The page names a latched safe state's cause (the header's fault_cause) from the layout's
// list: every hal::FaultCause by value, each with its name, the last one kLastFaultCause.
TEST(FrameLayoutJson, NamesEveryFaultCauseByValue) {
  const auto j = nlohmann::json::parse(numen::sim::state_frame_layout_json());
  const auto& causes = j.at("fault_causes");
  ASSERT_EQ(causes.size(), static_cast<std::size_t>(numen::hal::kLastFaultCause) + 1);
  for (std::size_t c = 0; c < causes.size(); ++c) {
    const char* name = numen::hal::to_string(static_cast<numen::hal::FaultCause>(c));
    EXPECT_EQ(causes[c], name) << c;
    EXPECT_STRNE(name, "unknown") << c;
  }
  EXPECT_EQ(causes[static_cast<std::size_t>(numen::hal::FaultCause::kHeartbeatLost)], "heartbeat lost");
  EXPECT_STREQ(numen::hal::to_string(static_cast<numen::hal::FaultCause>(causes.size())), "unknown")
      << "a FaultCause after kLastFaultCause: make it the last";
}

TEST(FrameLayoutJson, AFrameDecodedFromTheJsonReadsWhatTheViewReads) {
  const std::vector<std::byte> frame = layout_json_frame();
  ASSERT_FALSE(frame.empty());
  platform::StateFrameView view;
  const auto decoded = platform::StateFrameDecoder::decode(frame, view);
  ASSERT_TRUE(decoded.ok()) << decoded.error;
  const platform::StateFrameHeader& h = view.header();
  const std::map<std::string, std::int64_t> members = {
      {"frame_bytes", h.frame_bytes},
      {"num_bodies", h.num_bodies},
      {"num_nodes", h.num_nodes},
      {"num_contacts", h.num_contacts},
      {"num_axes", h.num_axes},
      {"attached_body", h.held_body},
      {"period", static_cast<std::int64_t>(h.period)},
      {"time_ns", h.time_ns},
      {"step_status", h.step_status},
      {"flags", h.flags},
      {"step_ns", h.step_ns},
      {"lifecycle", h.lifecycle},
      {"startup", h.startup},
      {"fault_cause", h.fault_cause},
      {"version", 6},
      {"header_bytes", 84},
      {"sample_faults", h.sample_faults},
      {"num_grasps", h.num_grasps},
      {"num_extra_devices", h.num_extra_devices},
      {"num_extra_axes", h.num_extra_axes},
      {"num_threads", h.num_threads},
      {"num_thread_nodes", h.num_thread_nodes}};
  const auto j = nlohmann::json::parse(numen::sim::state_frame_layout_json());
  std::map<std::string, std::int64_t> fields;
  for (const auto& f : j.at("header")) {
    const std::string type = f.at("type");
    const std::size_t at = f.at("offset");
    if (type == "char[4]") {
      EXPECT_EQ(std::memcmp(frame.data() + at, "NMVF", 4), 0) << f.at("name");
      continue;
    }
    const std::size_t bytes = std::stoul(type.substr(1)) / 8;
    fields[f.at("name").get<std::string>()] = layout_json_integer(frame, at, bytes, type[0] == 'i');
  }
  EXPECT_EQ(fields, members);  // one name per quantity: the JSON's are StateFrameHeader's
  EXPECT_EQ(fields.at("time_ns"), 125'000'000);
  EXPECT_EQ(fields.at("step_ns"), 777);

  std::map<std::string, std::vector<float>> arrays;
  std::size_t at = j.at("header_bytes");
  for (const auto& a : j.at("arrays")) {
    const std::size_t items =
        a.at("count").is_null()
            ? 1
            : static_cast<std::size_t>(fields.at(a.at("count").get<std::string>()));
    std::vector<float>& floats = arrays[a.at("name").get<std::string>()];
    for (std::size_t i = 0; i < items * a.at("floats").get<std::size_t>(); ++i, at += 4)
      floats.push_back(std::bit_cast<float>(
          static_cast<std::uint32_t>(layout_json_integer(frame, at, 4, false))));
  }
  EXPECT_EQ(at, frame.size());
  float pose[7];
  view.body_pose(1, pose);
  EXPECT_EQ(arrays.at("body_pose").at(7 + 1), pose[1]);
  EXPECT_FLOAT_EQ(pose[1], 0.2F);
  EXPECT_EQ(arrays.at("contact").at(0), view.contact(0).point[0]);
  EXPECT_EQ(arrays.at("contact").at(6), view.contact(0).depth);
  float wrench[6];
  view.feedback(wrench);
  EXPECT_EQ(arrays.at("feedback").at(2), wrench[2]);
  EXPECT_EQ(arrays.at("axis_torque").at(2), view.axis_torque(2));
  EXPECT_EQ(arrays.at("penetration").at(0), view.tool_penetration());
  EXPECT_EQ(arrays.at("penetration").at(1), view.target_penetration());
  float loop[3];
  view.device_loop(loop);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(arrays.at("device_loop").at(i), loop[i]);
  EXPECT_TRUE(arrays.at("node_position").empty());
}

}  // namespace
