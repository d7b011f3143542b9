/// @file sdo_session.cpp

#include "numen/sim/device/sdo_session.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/platform/monotonic_clock.hpp"
#include "numen/sim/input/bus_spec.hpp"

namespace numen::sim {
namespace {

/// How long the transfer loop waits for a frame at most before polling the timeout again.
constexpr std::int64_t kWaitSliceNs = 5'000'000;

std::string hex(std::uint32_t v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, v);
  return buf;
}

/// Reads `a` of `node` into `out` (at most out.size() bytes). Returns the bytes read, or -1
/// and an error line in `errors`.
int read_object(const BringUpLink& link, std::uint8_t node, hal::SdoAddress a,
                std::span<std::uint8_t> out, std::int64_t timeout_ns,
                std::vector<std::string>& errors) {
  hal::SdoClient client(node, timeout_ns);
  client.start_upload(a, out, link.now_ns());
  if (run_sdo_transfer(link, client) == hal::SdoStatus::kDone)
    return static_cast<int>(client.transferred());
  errors.push_back(hal::to_string(a) + ": " + hal::sdo_abort_name(client.abort_code()) +
                   (client.aborted_by_server() ? "" : " (no answer or a bad one)"));
  return -1;
}

std::uint32_t u32(const std::array<std::uint8_t, 4>& b) {
  return static_cast<std::uint32_t>(b[0]) | static_cast<std::uint32_t>(b[1]) << 8 |
         static_cast<std::uint32_t>(b[2]) << 16 | static_cast<std::uint32_t>(b[3]) << 24;
}

}  // namespace

BringUpLink real_link(hal::Bus& bus) {
  return BringUpLink{&bus, [] { return platform::monotonic_now_ns(); },
                     [&bus](std::int64_t ns) { wait_bus(bus, ns); }};
}

std::vector<hal::CanFilter> bring_up_filters() {
  const std::uint32_t mask = 0x780u | hal::kFilterExtendedBit | hal::kFilterRemoteBit;
  return {hal::CanFilter{hal::kSdoResponseBaseCobId, mask}, hal::CanFilter{0x700, mask}};
}

hal::SdoStatus run_sdo_transfer(const BringUpLink& link, hal::SdoClient& client) {
  hal::CanFrame f;
  while (client.status() == hal::SdoStatus::kPending) {
    const std::int64_t now = link.now_ns();
    while (client.take_request(f, now)) {
      if (link.bus->write(f) != hal::IoStatus::kOk) client.cancel(hal::SdoAbort::kGeneral, now);
    }
    link.wait(kWaitSliceNs);
    while (client.status() == hal::SdoStatus::kPending && link.bus->read(f) == hal::IoStatus::kOk)
      client.on_frame(f);
    client.poll(link.now_ns());
  }
  while (client.take_request(f, link.now_ns())) link.bus->write(f);  // the abort we owe
  return client.status();
}

std::vector<ScannedNode> scan_nodes(const BringUpLink& link, const ScanSettings& settings) {
  std::map<std::uint8_t, hal::NmtState> heard;
  const std::int64_t end = link.now_ns() + settings.listen_ns;
  hal::CanFrame f;
  for (std::int64_t now = link.now_ns(); now < end; now = link.now_ns()) {
    link.wait(std::min(kWaitSliceNs, end - now));
    while (link.bus->read(f) == hal::IoStatus::kOk) {
      std::uint8_t node = 0;
      hal::NmtState state{};
      if (hal::decode_heartbeat(f, node, state) == hal::HeartbeatDecodeStatus::kOk) heard[node] = state;
    }
  }
  std::vector<ScannedNode> out;
  for (const auto& [node, state] : heard) {
    ScannedNode n;
    n.node_id = node;
    n.state = state;
    std::array<std::uint8_t, 4> word{};
    if (read_object(link, node, {0x1000, 0}, word, settings.sdo_timeout_ns, n.errors) >= 0) {
      n.answered = true;
      n.device_type = u32(word);
    } else if (n.errors.back().find("no answer") == std::string::npos) {
      n.answered = true;  // an abort is an answer
    }
    if (n.answered) {
      std::uint32_t* fields[] = {&n.vendor_id, &n.product_code, &n.revision, &n.serial};
      for (std::uint8_t sub = 1; sub <= 4; ++sub) {
        word = {};
        if (read_object(link, node, {0x1018, sub}, word, settings.sdo_timeout_ns, n.errors) >= 0)
          *fields[sub - 1] = u32(word);
      }
      std::array<std::uint8_t, 256> text{};
      int len = read_object(link, node, {0x1008, 0}, text, settings.sdo_timeout_ns, n.errors);
      if (len >= 0) n.name.assign(text.begin(), text.begin() + len);
      len = read_object(link, node, {0x100A, 0}, text, settings.sdo_timeout_ns, n.errors);
      if (len >= 0) n.software_version.assign(text.begin(), text.begin() + len);
    }
    out.push_back(std::move(n));
  }
  return out;
}

std::string format_scan_table(const std::vector<ScannedNode>& nodes) {
  std::string s;
  char line[512];
  std::snprintf(line, sizeof line, "%-4s  %-15s  %-10s  %-7s  %-10s  %-10s  %-10s  %-10s  %s\n", "node",
                "state", "type", "profile", "vendor", "product", "revision", "serial", "name / software");
  s += line;
  for (const ScannedNode& n : nodes) {
    if (!n.answered) {
      std::snprintf(line, sizeof line, "%-4d  %-15s  (no SDO answer)\n", n.node_id, hal::to_string(n.state));
      s += line;
      continue;
    }
    std::snprintf(line, sizeof line, "%-4d  %-15s  %-10s  %-7u  %-10s  %-10s  %-10s  %-10u  %s%s%s\n",
                  n.node_id, hal::to_string(n.state), hex(n.device_type, 8).c_str(),
                  n.device_type & 0xFFFFu, hex(n.vendor_id, 8).c_str(), hex(n.product_code, 8).c_str(),
                  hex(n.revision, 8).c_str(), n.serial, n.name.c_str(),
                  n.software_version.empty() ? "" : " / ", n.software_version.c_str());
    s += line;
  }
  if (nodes.empty()) s += "(no node heard: no boot-up or heartbeat on the bus)\n";
  for (const ScannedNode& n : nodes)
    for (const std::string& e : n.errors) s += "node " + std::to_string(n.node_id) + ": " + e + "\n";
  return s;
}

std::string format_scan_json(const std::vector<ScannedNode>& nodes) {
  nlohmann::json j;
  j["nodes"] = nlohmann::json::array();
  for (const ScannedNode& n : nodes) {
    j["nodes"].push_back({{"node_id", n.node_id},
                          {"state", hal::to_string(n.state)},
                          {"answered", n.answered},
                          {"device_type", n.device_type},
                          {"profile", n.device_type & 0xFFFFu},
                          {"vendor_id", n.vendor_id},
                          {"product_code", n.product_code},
                          {"revision", n.revision},
                          {"serial", n.serial},
                          {"name", n.name},
                          {"software_version", n.software_version},
                          {"errors", n.errors}});
  }
  return j.dump(2) + "\n";
}

hal::SdoAddress parse_sdo_address(const std::string& text) {
  const auto fail = [&] {
    return std::invalid_argument("'" + text +
                                 "' is not INDEX:SUB in hexadecimal (e.g. 1018:01 or 0x6060:0)");
  };
  const auto colon = text.find(':');
  if (colon == std::string::npos) throw fail();
  auto parse = [&](std::string part, std::uint32_t max) {
    if (part.size() > 2 && (part.rfind("0x", 0) == 0 || part.rfind("0X", 0) == 0)) part = part.substr(2);
    std::uint32_t v = 0;
    const auto [p, ec] = std::from_chars(part.data(), part.data() + part.size(), v, 16);
    if (part.empty() || ec != std::errc() || p != part.data() + part.size() || v > max) throw fail();
    return v;
  };
  return hal::SdoAddress{static_cast<std::uint16_t>(parse(text.substr(0, colon), 0xFFFF)),
                         static_cast<std::uint8_t>(parse(text.substr(colon + 1), 0xFF))};
}

}  // namespace numen::sim
