/// @file sdo_server_fuzz.cpp
/// libFuzzer harness of the SDO server past each handler's entry (hal/emulation/sdo_server.hpp,
/// object_dictionary.hpp, and the emulated device that applies a download:
/// DeviceEmulator::apply_dictionary()): requests to the real entries of the nodes' object
/// dictionaries of the managed trocar, pose-tracker and phantom devices. The input picks a
/// node, then an entry of its dictionary (ObjectDictionary::entries(); now and then the next
/// sub-index or index, an absent one), a request (initiate upload or download, expedited or
/// segmented, a segment with the toggle the protocol expects or not, an abort, or any bytes)
/// and the data (the entry's value with bits flipped, or any bytes), with NMT commands and
/// clock steps between them. A random input is thus mostly valid requests: the seeds in
/// corpus/sdo_server are such inputs. Checks: every response is an 8-byte well-formed frame on
/// 0x580 + node that decodes as a server response, and an entry never grows past its
/// capacity.

#include <algorithm>
#include <cstdint>
#include <vector>

#include "fuzz_input.hpp"
#include "numen/hal/canopen/sdo.hpp"
#include "numen/hal/emulation/device_emulator.hpp"
#include "numen/hal/emulation/object_dictionary.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace {

using numen::fuzz::finding;
using numen::hal::CanFrame;
using numen::hal::SdoFrame;
using numen::hal::SdoFrameKind;

/// Reads every response on `port` and checks it.
void check_responses(numen::hal::Bus& port) {
  CanFrame f;
  while (port.read(f) == numen::hal::IoStatus::kOk) {
    if (f.id < numen::hal::kSdoResponseBaseCobId + 1 || f.id > numen::hal::kSdoResponseBaseCobId + 127)
      continue;  // heartbeats, EMCY, PDOs
    if (numen::hal::check_frame(f) != numen::hal::FrameError::kNone)
      finding("sdo server: malformed response");
    SdoFrame d;
    if (numen::hal::decode_sdo(f, f.id, d) != numen::hal::SdoDecodeStatus::kOk)
      finding("sdo server: response does not decode");
    if (d.kind == SdoFrameKind::kUnknown || d.kind == SdoFrameKind::kBlock)
      finding("sdo server: response of no known kind");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  // Managed stack: even choices of device_config() (0, 1, 2 mod 6).
  numen::hal::DeviceEmulator emulator(
      numen::fuzz::device_config(in.ConsumeIntegralInRange<std::uint8_t>(0, 2)));
  numen::hal::SimBus bus{numen::hal::SimBusSettings{}};
  std::int64_t now = 0;
  emulator.tick(now, bus.device());  // boot-up: pre-operational, SDO served
  numen::fuzz::drain(bus.controller());
  std::vector<std::uint8_t> nodes;
  for (int n = 1; n <= 127; ++n)
    if (emulator.object_dictionary(static_cast<std::uint8_t>(n)) != nullptr)
      nodes.push_back(static_cast<std::uint8_t>(n));
  if (nodes.empty()) finding("sdo server: a managed device without a dictionary");
  bool toggle = false;  // what the protocol expects of the next segment request
  while (in.remaining_bytes() > 0) {
    const int op = in.ConsumeIntegralInRange<int>(0, 31);
    if (op == 0) {
      now += in.ConsumeIntegralInRange<std::int64_t>(0, 5'000'000);
      bus.set_time_ns(now);
      emulator.tick(now, bus.device());
      check_responses(bus.controller());
      continue;
    }
    if (op == 1) {  // NMT: a node stopped, reset or started now and then
      CanFrame f;
      f.id = 0x000;
      f.len = 2;
      f.timestamp_ns = now;
      static constexpr std::uint8_t kCommands[] = {0x01, 0x02, 0x80, 0x81, 0x82};
      f.data[0] = kCommands[in.ConsumeIntegralInRange<std::size_t>(0, 4)];
      f.data[1] = in.ConsumeBool() ? 0 : nodes[in.ConsumeIntegralInRange<std::size_t>(0, nodes.size() - 1)];
      emulator.on_frame(f, bus.device());
      check_responses(bus.controller());
      continue;
    }
    const std::uint8_t node = nodes[in.ConsumeIntegralInRange<std::size_t>(0, nodes.size() - 1)];
    const numen::hal::ObjectDictionary& od = *emulator.object_dictionary(node);
    const auto entries = od.entries();
    const numen::hal::OdEntry& entry =
        entries[in.ConsumeIntegralInRange<std::size_t>(0, entries.size() - 1)];
    SdoFrame q;
    q.address = entry.address;
    const std::uint8_t miss = in.ConsumeIntegral<std::uint8_t>();
    if (miss == 0) ++q.address.subindex;  // maybe no such sub-index
    if (miss == 1) ++q.address.index;     // maybe no such object
    const int kind = in.ConsumeIntegralInRange<int>(0, 15);
    if (kind < 4) {
      q.kind = SdoFrameKind::kInitiateUploadRequest;
      toggle = false;
    } else if (kind < 7) {
      q.kind = SdoFrameKind::kUploadSegmentRequest;
    } else if (kind < 11) {
      q.kind = SdoFrameKind::kInitiateDownloadRequest;
      toggle = false;
    } else if (kind < 14) {
      q.kind = SdoFrameKind::kDownloadSegmentRequest;
    } else if (kind == 14) {
      q.kind = SdoFrameKind::kAbort;
      q.abort_code = in.ConsumeIntegral<std::uint32_t>();
    }
    // The data: the entry's value with some bits flipped, or any bytes.
    std::vector<std::uint8_t> value = entry.value;
    if (in.ConsumeBool()) {
      if (!value.empty())
        value[in.ConsumeIntegralInRange<std::size_t>(0, value.size() - 1)] ^=
            in.ConsumeIntegral<std::uint8_t>();
    } else {
      value = in.ConsumeBytes<std::uint8_t>(in.ConsumeIntegralInRange<std::size_t>(0, 12));
    }
    if (q.kind == SdoFrameKind::kInitiateDownloadRequest) {
      q.expedited = value.size() >= 1 && value.size() <= 4 && in.ConsumeIntegral<std::uint8_t>() != 0;
      q.size_indicated = in.ConsumeIntegral<std::uint8_t>() != 0;
      if (q.expedited) {
        q.data_len = static_cast<std::uint8_t>(value.size());
        for (std::size_t i = 0; i < value.size(); ++i) q.data[i] = value[i];
      } else {
        q.size = in.ConsumeBool() ? static_cast<std::uint32_t>(value.size())
                                  : in.ConsumeIntegral<std::uint32_t>();
      }
    } else if (q.kind == SdoFrameKind::kDownloadSegmentRequest) {
      q.toggle = in.ConsumeIntegral<std::uint8_t>() == 0 ? !toggle : toggle;
      toggle = !toggle;
      q.data_len = static_cast<std::uint8_t>(std::min<std::size_t>(value.size(), 7));
      for (std::size_t i = 0; i < q.data_len; ++i) q.data[i] = value[i];
      q.last = in.ConsumeBool();
    } else if (q.kind == SdoFrameKind::kUploadSegmentRequest) {
      q.toggle = in.ConsumeIntegral<std::uint8_t>() == 0 ? !toggle : toggle;
      toggle = !toggle;
    }
    CanFrame f;
    const std::uint32_t cob = numen::hal::sdo_request_cob_id(node);
    if (q.kind == SdoFrameKind::kUnknown || !numen::hal::encode_sdo(q, cob, now, f))
      f = numen::fuzz::next_frame(in, {cob}, now);  // any bytes on the channel
    emulator.on_frame(f, bus.device());
    check_responses(bus.controller());
  }
  for (const std::uint8_t node : nodes)
    for (const numen::hal::OdEntry& e : emulator.object_dictionary(node)->entries())
      if (e.variable_length && e.value.size() > e.capacity)
        finding("sdo server: an entry grew past its capacity");
  return 0;
}
