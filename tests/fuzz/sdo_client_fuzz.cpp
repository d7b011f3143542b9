/// @file sdo_client_fuzz.cpp
/// libFuzzer harness of the client side of SDO (hal/canopen/sdo.hpp, dcf_configuration.hpp,
/// sdo_poller.hpp): fuzzed server responses to the requests of
///  - an SdoClient uploading into a buffer of 0–16 bytes or downloading 1–12 bytes,
///  - a NodeConfigurator running the shipped encoder.dcf (its PDO sequence, writes and
///    read-backs),
///  - an SdoPoller reading four objects of nodes 1–3 every 1–3 periods,
/// with clock steps between them (time-outs). A response is mostly shaped after the request
/// it answers (a server command specifier, the request's multiplexer, an expedited or
/// segmented payload) so that the input reaches past decode_sdo() into each state; now and then
/// any bytes, another length, a remote or FD frame. Checks: an upload never reports more bytes
/// than its buffer holds, a transfer ends in kDone or kAborted only, and every request the
/// client sends is an 8-byte well-formed frame on 0x600 + node.

#include <array>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "fuzz_input.hpp"
#include "numen/hal/canopen/dcf.hpp"
#include "numen/hal/canopen/dcf_configuration.hpp"
#include "numen/hal/canopen/sdo.hpp"
#include "numen/hal/canopen/sdo_poller.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace {

using numen::fuzz::finding;
using numen::hal::CanFrame;
using numen::hal::SdoAddress;
using numen::hal::SdoFrame;
using numen::hal::SdoFrameKind;

/// Checks a request a client sent: on 0x600 + `node`, 8 bytes, well formed, decodable.
void check_request(const CanFrame& f, std::uint8_t node) {
  if (f.id != numen::hal::sdo_request_cob_id(node)) finding("sdo client: request on another id");
  if (f.len != numen::hal::kSdoFrameLen) finding("sdo client: request not 8 bytes");
  if (numen::hal::check_frame(f) != numen::hal::FrameError::kNone)
    finding("sdo client: malformed request");
  SdoFrame d;
  if (numen::hal::decode_sdo(f, f.id, d) != numen::hal::SdoDecodeStatus::kOk)
    finding("sdo client: request does not decode");
}

/// A response of `node` to `request` (a frame the client sent), made of the input.
CanFrame response(FuzzedDataProvider& in, std::uint8_t node, const CanFrame& request,
                  std::int64_t now_ns) {
  const std::uint32_t cob = numen::hal::sdo_response_cob_id(node);
  const std::uint8_t how = in.ConsumeIntegral<std::uint8_t>();
  if ((how & 0x0F) == 0) {  // any frame on the channel (or near it)
    CanFrame f = numen::fuzz::next_frame(in, {cob, cob + 1, cob - 1}, now_ns);
    return f;
  }
  SdoFrame r;
  SdoFrame q;
  const bool have_q =
      numen::hal::decode_sdo(request, request.id, q) == numen::hal::SdoDecodeStatus::kOk;
  static constexpr SdoFrameKind kKinds[] = {
      SdoFrameKind::kInitiateDownloadResponse, SdoFrameKind::kDownloadSegmentResponse,
      SdoFrameKind::kInitiateUploadResponse, SdoFrameKind::kUploadSegmentResponse,
      SdoFrameKind::kAbort};
  // Mostly the response the request calls for; else any server response.
  SdoFrameKind kind = kKinds[in.ConsumeIntegralInRange<std::size_t>(0, 4)];
  if (have_q && (how & 0x30) != 0) {
    switch (q.kind) {
      case SdoFrameKind::kInitiateDownloadRequest: kind = SdoFrameKind::kInitiateDownloadResponse; break;
      case SdoFrameKind::kDownloadSegmentRequest: kind = SdoFrameKind::kDownloadSegmentResponse; break;
      case SdoFrameKind::kInitiateUploadRequest: kind = SdoFrameKind::kInitiateUploadResponse; break;
      case SdoFrameKind::kUploadSegmentRequest: kind = SdoFrameKind::kUploadSegmentResponse; break;
      default: break;
    }
  }
  r.kind = kind;
  r.address = have_q && (how & 0x40) == 0 ? q.address
                                          : SdoAddress{in.ConsumeIntegral<std::uint16_t>(),
                                                       in.ConsumeIntegral<std::uint8_t>()};
  r.expedited = in.ConsumeBool();
  r.size_indicated = in.ConsumeBool();
  r.toggle = have_q && (how & 0x80) == 0 ? q.toggle : in.ConsumeBool();
  r.last = in.ConsumeBool();
  r.size = in.ConsumeIntegralInRange<std::uint32_t>(0, 24);
  if ((how & 0x0F) == 1) r.size = in.ConsumeIntegral<std::uint32_t>();
  r.abort_code = in.ConsumeIntegral<std::uint32_t>();
  const bool segment = kind == SdoFrameKind::kUploadSegmentResponse;
  r.data_len = in.ConsumeIntegralInRange<std::uint8_t>(segment ? 0 : 1, segment ? 7 : 4);
  for (std::uint8_t i = 0; i < r.data_len; ++i) r.data[i] = in.ConsumeIntegral<std::uint8_t>();
  CanFrame f;
  if (!numen::hal::encode_sdo(r, cob, now_ns, f)) {
    f = numen::fuzz::next_frame(in, {cob}, now_ns);
  }
  return f;
}

/// One SdoClient transfer.
void run_client(FuzzedDataProvider& in) {
  const std::uint8_t node = in.ConsumeIntegralInRange<std::uint8_t>(1, 127);
  numen::hal::SdoClient client(node, 10'000'000);
  std::array<std::uint8_t, 16> buffer{};
  std::array<std::uint8_t, 12> data{};
  for (auto& b : data) b = in.ConsumeIntegral<std::uint8_t>();
  std::int64_t now = 0;
  std::size_t buffer_len = 0;  // of an upload
  std::size_t limit = 0;       // bytes the transfer may move: the buffer's or the data's
  const SdoAddress address{in.ConsumeIntegral<std::uint16_t>(), in.ConsumeIntegral<std::uint8_t>()};
  if (in.ConsumeBool()) {
    buffer_len = in.ConsumeIntegralInRange<std::size_t>(0, buffer.size());
    if (!client.start_upload(address, std::span(buffer.data(), buffer_len), now))
      finding("sdo client: upload not started");
    limit = buffer_len;
  } else {
    const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(1, data.size());
    if (!client.start_download(address, std::span<const std::uint8_t>(data.data(), n), now))
      finding("sdo client: download not started");
    buffer_len = buffer.size();
    limit = n;
  }
  CanFrame last{};
  while (in.remaining_bytes() > 0) {
    CanFrame req;
    while (client.take_request(req, now)) {
      check_request(req, node);
      last = req;
    }
    const int what = in.ConsumeIntegralInRange<int>(0, 15);
    if (what == 0) {
      now += in.ConsumeIntegralInRange<std::int64_t>(0, 20'000'000);
      client.poll(now);
    } else if (what == 1) {
      client.cancel(in.ConsumeIntegral<std::uint32_t>(), now);
    } else if (what == 2 && client.status() != numen::hal::SdoStatus::kPending) {
      // A next transfer on the same client.
      if (in.ConsumeBool()) {
        if (client.start_upload(address, std::span(buffer.data(), buffer_len), now)) limit = buffer_len;
      } else if (client.start_download(address, std::span<const std::uint8_t>(data.data(), 5), now)) {
        limit = 5;
      }
    } else {
      (void)client.on_frame(response(in, node, last, now));
    }
    if (client.transferred() > limit) finding("sdo client: more bytes than the buffer or the data");
  }
}

/// The plan of the shipped encoder.dcf for node 4 (read once).
const numen::hal::DcfConfiguration& encoder_plan() {
  static const numen::hal::DcfConfiguration plan(std::make_shared<const numen::hal::Dcf>(
      numen::hal::parse_dcf_file(NUMEN_SOURCE_DIR "/sim/scenes/devices/encoder.dcf", 4)));
  return plan;
}

/// A NodeConfigurator of encoder.dcf against fuzzed responses.
void run_configurator(FuzzedDataProvider& in) {
  numen::hal::NodeConfigurator conf(encoder_plan(), 4, 10'000'000);
  std::int64_t now = 0;
  conf.start(now);
  conf.poll(now);
  CanFrame last{};
  while (in.remaining_bytes() > 0) {
    CanFrame req;
    while (conf.take_request(req, now)) {
      check_request(req, 4);
      last = req;
    }
    if (in.ConsumeIntegralInRange<int>(0, 15) == 0) {
      now += in.ConsumeIntegralInRange<std::int64_t>(0, 20'000'000);
    } else {
      (void)conf.on_frame(response(in, 4, last, now));
    }
    conf.poll(now);
    if (conf.status() == numen::hal::ConfigurationStatus::kFailed) {
      (void)conf.error();  // the located message must build for any failure
      if (in.ConsumeBool()) conf.start(now);
    }
    if (conf.step() > conf.plan().steps().size()) finding("node configurator: step past the plan");
  }
}

/// An SdoPoller of four reads of nodes 1–3 against fuzzed responses.
void run_poller(FuzzedDataProvider& in) {
  std::array<numen::hal::PeriodicRead, 4> reads{};
  for (std::size_t i = 0; i < reads.size(); ++i) {
    reads[i].node_id = in.ConsumeIntegralInRange<std::uint8_t>(1, 3);
    reads[i].address = {in.ConsumeBool() ? std::uint16_t{0x1001} : std::uint16_t{0x6041},
                        static_cast<std::uint8_t>(i & 1)};
    reads[i].every_periods = in.ConsumeIntegralInRange<std::uint32_t>(1, 3);
  }
  numen::hal::SdoPoller poller(reads, 5'000'000);
  numen::hal::SimBus bus{numen::hal::SimBusSettings{}};
  std::int64_t now = 0;
  std::array<CanFrame, 4> last{};
  while (in.remaining_bytes() > 0) {
    now += in.ConsumeIntegralInRange<std::int64_t>(0, 2'000'000);
    bus.set_time_ns(now);
    poller.update(now);
    poller.begin_period(now, bus.controller());
    CanFrame req;
    while (bus.device().read(req) == numen::hal::IoStatus::kOk) {
      const std::uint32_t n = req.id - numen::hal::kSdoRequestBaseCobId;
      if (n < 1 || n > 3) finding("sdo poller: request to a node it does not read");
      check_request(req, static_cast<std::uint8_t>(n));
      last[n] = req;
    }
    const int frames = in.ConsumeIntegralInRange<int>(0, 3);
    for (int i = 0; i < frames; ++i) {
      const auto n = in.ConsumeIntegralInRange<std::uint8_t>(1, 3);
      (void)poller.on_frame(response(in, n, last[n], now));
    }
    for (const auto& r : poller.results())
      if (r.size > 4) finding("sdo poller: a value of more than 4 bytes");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  switch (in.ConsumeIntegralInRange<int>(0, 2)) {
    case 0: run_client(in); break;
    case 1: run_configurator(in); break;
    default: run_poller(in); break;
  }
  return 0;
}
