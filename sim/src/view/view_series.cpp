/// @file view_series.cpp
/// view_replay_series(): every frame of a recording read once, decimated (view_series.hpp).

#include "numen/sim/view/view_series.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <utility>
#include <vector>

#include "numen/platform/state_frame.hpp"
#include "numen/sim/view/view_server.hpp"

namespace numen::sim {

namespace {

/// What the series keeps of one frame.
struct FramePoint {
  double t = 0.0, tool_mm = 0.0, hand_mm = 0.0, intent_mm = 0.0, force_n = 0.0, step_us = 0.0;
  std::uint32_t contacts = 0, step_status = 0;
  int lifecycle = 0, fault_cause = 0;
};

double round6(double x) { return std::round(x * 1e6) * 1e-6; }

}  // namespace

std::string view_replay_series(ViewFrameSource& source, std::size_t max_points) {
  const std::size_t n = source.frame_count();
  std::vector<FramePoint> all(n);
  std::vector<std::byte> bytes;
  nlohmann::json events = nlohmann::json::array(), grasp_events = nlohmann::json::array();
  std::size_t event_count = 0, grasp_event_count = 0;
  std::vector<platform::FrameGrasp> grasps;  // the previous frame's graspers
  for (std::size_t k = 0; k < n; ++k) {
    source.read_frame(k, bytes);
    platform::StateFrameView v;
    const platform::StateFrameDecodeResult r = platform::StateFrameDecoder::decode(bytes, v);
    if (!r.ok()) throw std::runtime_error("frame " + std::to_string(k) + ": " + r.error);
    const platform::StateFrameHeader& h = v.header();
    float fb[6];
    v.feedback(fb);
    FramePoint& p = all[k];
    p.t = static_cast<double>(h.time_ns) * 1e-9;
    p.tool_mm = 1e3 * v.tool_penetration();
    p.hand_mm = 1e3 * v.target_penetration();
    float loop[3];
    v.device_loop(loop);
    p.intent_mm = 1e3 * loop[0];
    p.force_n = std::hypot(static_cast<double>(fb[0]), static_cast<double>(fb[1]),
                           static_cast<double>(fb[2]));
    p.step_us = 1e-3 * h.step_ns;
    p.contacts = h.num_contacts;
    p.lifecycle = h.lifecycle;
    p.step_status = h.step_status;
    p.fault_cause = h.fault_cause;
    if (k > 0 && (p.lifecycle != all[k - 1].lifecycle || p.step_status != all[k - 1].step_status)) {
      if (events.size() < kViewSeriesMaxEvents)
        events.push_back({{"frame", k}, {"t", round6(p.t)}, {"lifecycle", p.lifecycle},
                          {"step_status", p.step_status}, {"fault_cause", p.fault_cause}});
      ++event_count;
    }
    // Grasp events: a grasper's grasp, release or slip count grew since the previous frame.
    if (k == 0) grasps.assign(h.num_grasps, platform::FrameGrasp{-1, -1, 0, 0, 0, 0, 0, 0, -1});
    for (std::uint32_t g = 0; g < h.num_grasps && g < grasps.size(); ++g) {
      const platform::FrameGrasp now = v.grasp(g), before = grasps[g];
      // In the order they happened: holding now, the last one is the grasp (an end before it
      // let go of what the previous frame held); not holding, the grasp came first.
      const bool holding = now.body >= 0 || now.net >= 0 || now.thread >= 0;
      const std::pair<const char*, double> grasp{"grasp", now.grasps - before.grasps},
          release{"release", now.releases - before.releases}, slip{"slip", now.slips - before.slips};
      const std::array<std::pair<const char*, double>, 3> kinds =
          holding ? std::array{release, slip, grasp} : std::array{grasp, release, slip};
      for (const auto& [kind, grew] : kinds) {
        if (!(grew > 0)) continue;
        const bool ended = kind[0] != 'g';
        if (grasp_events.size() < kViewSeriesMaxEvents)
          grasp_events.push_back({{"frame", k}, {"t", round6(p.t)}, {"grasper", g}, {"event", kind},
                                  {"body", static_cast<int>(ended ? before.body : now.body)},
                                  {"net", static_cast<int>(ended ? before.net : now.net)},
                                  {"thread", static_cast<int>(ended ? before.thread : now.thread)}});
        ++grasp_event_count;
      }
      grasps[g] = now;
    }
  }
  const std::size_t stride = std::max<std::size_t>(1, (n + max_points - 1) / std::max<std::size_t>(1, max_points));
  std::vector<std::size_t> sampled;
  for (std::size_t i = 0; i < n; i += stride) sampled.push_back(i);
  if (n > 0 && (n - 1) % stride != 0) sampled.push_back(n - 1);
  nlohmann::json frame = nlohmann::json::array(), t = nlohmann::json::array(),
                 tool = nlohmann::json::array(), hand = nlohmann::json::array(),
                 intent = nlohmann::json::array(),
                 force = nlohmann::json::array(), step = nlohmann::json::array(),
                 contacts = nlohmann::json::array(), lifecycle = nlohmann::json::array(),
                 status = nlohmann::json::array();
  for (const std::size_t i : sampled) {
    FramePoint m = all[i];  // the window's peaks
    for (std::size_t k = i + 1; k < std::min(n, i + stride); ++k) {
      const FramePoint& p = all[k];
      m.tool_mm = std::max(m.tool_mm, p.tool_mm);
      m.hand_mm = std::max(m.hand_mm, p.hand_mm);
      m.intent_mm = std::max(m.intent_mm, p.intent_mm);
      m.force_n = std::max(m.force_n, p.force_n);
      m.step_us = std::max(m.step_us, p.step_us);
      m.contacts = std::max(m.contacts, p.contacts);
      m.lifecycle = std::max(m.lifecycle, p.lifecycle);
      m.step_status |= p.step_status;
    }
    frame.push_back(i);
    t.push_back(round6(m.t));
    tool.push_back(round6(m.tool_mm));
    hand.push_back(round6(m.hand_mm));
    intent.push_back(round6(m.intent_mm));
    force.push_back(round6(m.force_n));
    step.push_back(std::round(m.step_us * 1e3) * 1e-3);
    contacts.push_back(m.contacts);
    lifecycle.push_back(m.lifecycle);
    status.push_back(m.step_status);
  }
  const nlohmann::json j{{"frames", n},         {"stride", stride},      {"frame", frame},
                         {"t", t},              {"tool_mm", tool},       {"hand_mm", hand},
                         {"intent_mm", intent},
                         {"force_n", force},    {"step_us", step},       {"contacts", contacts},
                         {"lifecycle", lifecycle}, {"step_status", status}, {"events", events},
                         {"event_count", event_count}, {"grasp_events", grasp_events},
                         {"grasp_event_count", grasp_event_count}};
  return j.dump();
}

}  // namespace numen::sim
