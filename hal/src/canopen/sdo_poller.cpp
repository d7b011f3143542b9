/// @file sdo_poller.cpp
/// Periodic SDO reads advanced once per control period.

#include "numen/hal/canopen/sdo_poller.hpp"

#include <stdexcept>
#include <string>

namespace numen::hal {

SdoPoller::SdoPoller(std::span<const PeriodicRead> reads, std::int64_t timeout_ns)
    : reads_(reads.begin(), reads.end()), results_(reads.size()), last_start_(reads.size(), 0) {
  if (timeout_ns <= 0) throw std::invalid_argument("SdoPoller: timeout_ns must be > 0");
  for (std::size_t i = 0; i < reads_.size(); ++i) {
    const PeriodicRead& r = reads_[i];
    const std::string what = "SdoPoller: read " + std::to_string(i) + " (" + to_string(r.address) + ")";
    if (r.node_id < 1 || r.node_id > 127) throw std::invalid_argument(what + ": node id must be 1–127");
    if (r.every_periods < 1) throw std::invalid_argument(what + ": every_periods must be >= 1");
    std::size_t c = 0;
    while (c < channels_.size() && channels_[c].client.server_node() != r.node_id) ++c;
    if (c == channels_.size()) channels_.push_back(Channel{SdoClient(r.node_id, timeout_ns), -1, {}});
    channel_of_.push_back(c);
  }
}

void SdoPoller::begin_period(std::int64_t now_ns, Bus& bus) noexcept {
  CanFrame f;
  for (Channel& ch : channels_) {
    while (ch.client.take_request(f, now_ns)) {
      if (bus.write(f) == IoStatus::kOk) {
        ++counters_.requests;
      } else {
        ++counters_.write_errors;
      }
    }
  }
}

bool SdoPoller::on_frame(const CanFrame& frame) noexcept {
  for (Channel& ch : channels_) {
    if (ch.client.on_frame(frame)) return true;
  }
  return false;
}

void SdoPoller::update(std::int64_t now_ns) noexcept {
  ++periods_;
  for (Channel& ch : channels_) {
    ch.client.poll(now_ns);
    if (ch.read < 0 || ch.client.status() == SdoStatus::kPending) continue;
    PeriodicReadResult& r = results_[static_cast<std::size_t>(ch.read)];
    if (ch.client.status() == SdoStatus::kDone) {
      r.size = static_cast<std::uint8_t>(ch.client.transferred());
      r.value = 0;
      for (std::size_t i = 0; i < r.size && i < 4; ++i) r.value |= static_cast<std::uint32_t>(ch.buffer[i]) << (8 * i);
      ++r.reads;
      r.last_period = periods_;
      ++counters_.completed;
    } else {
      ++r.aborts;
      r.last_abort = ch.client.abort_code();
      if (ch.client.abort_code() == SdoAbort::kTimeout && !ch.client.aborted_by_server()) {
        ++counters_.timeouts;
      } else {
        ++counters_.aborted;
      }
    }
    ch.read = -1;
  }
  // Start the due reads, one per idle node, in list order.
  for (std::size_t i = 0; i < reads_.size(); ++i) {
    Channel& ch = channels_[channel_of_[i]];
    if (ch.read >= 0) continue;
    if (last_start_[i] != 0 && periods_ - last_start_[i] < reads_[i].every_periods) continue;
    ch.buffer.fill(0);
    if (!ch.client.start_upload(reads_[i].address, std::span<std::uint8_t>(ch.buffer), now_ns)) continue;
    ch.read = static_cast<int>(i);
    last_start_[i] = periods_;
    ++counters_.started;
  }
}

}  // namespace numen::hal
