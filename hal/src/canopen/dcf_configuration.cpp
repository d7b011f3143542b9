/// @file dcf_configuration.cpp
/// A node's configuration from its DCF: the CiA 301 write sequence, the read-back, and the
/// non-blocking runner over SdoClient.

#include "numen/hal/canopen/dcf_configuration.hpp"

#include <cstdio>
#include <set>

#include "../hex_text.hpp"

namespace numen::hal {
namespace {

constexpr std::uint32_t kPdoInvalidBit = 0x80000000u;  // COB-ID bit 31: PDO does not exist

bool is_pdo_communication(std::uint16_t index) noexcept {
  return (index >= 0x1400 && index <= 0x15FF) || (index >= 0x1800 && index <= 0x19FF);
}
bool is_pdo_mapping(std::uint16_t index) noexcept {
  return (index >= 0x1600 && index <= 0x17FF) || (index >= 0x1A00 && index <= 0x1BFF);
}

// The value in hex, two digits per byte of its object.
std::string hex_of_size(std::uint64_t v, std::size_t bytes) {
  return detail::hex_digits(v, static_cast<int>(2 * bytes));
}

}  // namespace

DcfConfiguration::DcfConfiguration(std::shared_ptr<const Dcf> dcf) : dcf_(std::move(dcf)) {
  const std::vector<DcfEntry>& entries = dcf_->entries;
  auto configured = [&](std::size_t i) {
    const DcfEntry& e = entries[i];
    return e.configured && data_type_size(e.data_type) != 0;
  };
  auto step = [&](ConfigurationStep::Kind kind, std::size_t i, std::uint64_t value) {
    const DcfEntry& e = entries[i];
    steps_.push_back(ConfigurationStep{kind, e.address, value,
                                       static_cast<std::uint8_t>(data_type_size(e.data_type)), i});
  };
  auto write = [&](std::size_t i) {
    if (configured(i) && writable(entries[i].access)) step(ConfigurationStep::Kind::kWrite, i, entries[i].value);
  };
  std::set<std::uint16_t> done;  // objects written by the PDO sequence
  auto index_of = [&](SdoAddress a) -> long {
    const DcfEntry* e = dcf_->find(a);
    return e == nullptr ? -1 : static_cast<long>(e - entries.data());
  };
  // The PDOs: communication objects and their mapping objects, in the CiA 301 sequence.
  std::set<std::uint16_t> pdos;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (!configured(i) || !writable(entries[i].access)) continue;
    const std::uint16_t index = entries[i].address.index;
    if (is_pdo_communication(index)) pdos.insert(index);
    if (is_pdo_mapping(index)) pdos.insert(static_cast<std::uint16_t>(index - 0x200));
  }
  for (const std::uint16_t comm : pdos) {
    const auto map = static_cast<std::uint16_t>(comm + 0x200);
    const long cob = index_of({comm, 1});
    const bool has_cob = cob >= 0 && configured(static_cast<std::size_t>(cob)) &&
                         writable(entries[static_cast<std::size_t>(cob)].access);
    if (has_cob) step(ConfigurationStep::Kind::kWrite, static_cast<std::size_t>(cob),
                      entries[static_cast<std::size_t>(cob)].value | kPdoInvalidBit);
    for (std::size_t i = 0; i < entries.size(); ++i) {
      if (entries[i].address.index == comm && entries[i].address.subindex != 1) write(i);
    }
    const long count = index_of({map, 0});
    std::uint64_t n = 0;
    bool any_mapping = false;
    for (std::size_t i = 0; i < entries.size(); ++i) {
      const SdoAddress a = entries[i].address;
      if (a.index == map && a.subindex != 0 && configured(i)) {
        any_mapping = true;
        ++n;
      }
    }
    const bool has_count = count >= 0 && configured(static_cast<std::size_t>(count)) &&
                           writable(entries[static_cast<std::size_t>(count)].access);
    if (has_count) n = entries[static_cast<std::size_t>(count)].value;
    if (has_count || any_mapping) {
      if (count < 0) {
        throw DcfError(
            entries[static_cast<std::size_t>(index_of({map, 1}) >= 0 ? index_of({map, 1}) : 0)]
                .location,
            "mapping entries without the mapping count [" + hex_of_size(map, 2).substr(2) +
                "sub0]");
      }
      const auto c = static_cast<std::size_t>(count);
      if (data_type_size(entries[c].data_type) == 0) {
        throw DcfError(entries[c].location,
                       "the mapping count [" + hex_of_size(map, 2).substr(2) +
                           "sub0] has DataType " + hex_of_size(entries[c].data_type, 2) +
                           ", not a numeric one (CiA 301: UNSIGNED8)");
      }
      step(ConfigurationStep::Kind::kWrite, c, 0);
      for (std::size_t i = 0; i < entries.size(); ++i) {
        const SdoAddress a = entries[i].address;
        if (a.index == map && a.subindex != 0) write(i);
      }
      step(ConfigurationStep::Kind::kWrite, c, n);
    }
    if (has_cob) step(ConfigurationStep::Kind::kWrite, static_cast<std::size_t>(cob),
                      entries[static_cast<std::size_t>(cob)].value);
    done.insert(comm);
    done.insert(map);
  }
  // Every other configured object, in index order.
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (done.count(entries[i].address.index) == 0) write(i);
  }
  writes_ = steps_.size();
  // The read-back of every configured value.
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (configured(i) && entries[i].access != DcfAccess::kWriteOnly)
      step(ConfigurationStep::Kind::kVerify, i, entries[i].value);
  }
}

const char* to_string(ConfigurationStatus status) noexcept {
  switch (status) {
    case ConfigurationStatus::kIdle:
      return "idle";
    case ConfigurationStatus::kRunning:
      return "running";
    case ConfigurationStatus::kDone:
      return "done";
    case ConfigurationStatus::kFailed:
      return "failed";
  }
  return "unknown";
}

NodeConfigurator::NodeConfigurator(const DcfConfiguration& plan, std::uint8_t node_id,
                                   std::int64_t timeout_ns) noexcept
    : plan_(&plan), client_(node_id, timeout_ns) {}

void NodeConfigurator::start(std::int64_t now_ns) noexcept {
  if (client_.status() == SdoStatus::kPending) client_.cancel(SdoAbort::kGeneral, now_ns);
  step_ = 0;
  step_retries_ = 0;
  abort_code_ = 0;
  by_server_ = false;
  read_value_ = 0;
  read_size_ = 0;
  status_ = ConfigurationStatus::kRunning;
  begin_step(now_ns);
}

void NodeConfigurator::begin_step(std::int64_t now_ns) noexcept {
  const auto steps = plan_->steps();
  if (step_ >= steps.size()) {
    status_ = ConfigurationStatus::kDone;
    return;
  }
  const ConfigurationStep& s = steps[step_];
  if (s.kind == ConfigurationStep::Kind::kWrite) {
    for (std::size_t i = 0; i < s.size; ++i) buffer_[i] = static_cast<std::uint8_t>(s.value >> (8 * i));
    client_.start_download(s.address, std::span<const std::uint8_t>(buffer_.data(), s.size), now_ns);
  } else {
    buffer_.fill(0);
    client_.start_upload(s.address, std::span<std::uint8_t>(buffer_.data(), buffer_.size()), now_ns);
  }
}

bool NodeConfigurator::take_request(CanFrame& out, std::int64_t now_ns) noexcept {
  return client_.take_request(out, now_ns);
}

bool NodeConfigurator::on_frame(const CanFrame& frame) noexcept { return client_.on_frame(frame); }

void NodeConfigurator::poll(std::int64_t now_ns) noexcept {
  if (status_ != ConfigurationStatus::kRunning) return;
  client_.poll(now_ns);
  switch (client_.status()) {
    case SdoStatus::kIdle:
    case SdoStatus::kPending:
      return;
    case SdoStatus::kAborted:
      if (!client_.aborted_by_server() && client_.abort_code() == SdoAbort::kTimeout &&
          step_retries_ < kTimeoutRetries) {
        ++step_retries_;
        ++retries_;
        begin_step(now_ns);
        return;
      }
      abort_code_ = client_.abort_code();
      by_server_ = client_.aborted_by_server();
      status_ = ConfigurationStatus::kFailed;
      return;
    case SdoStatus::kDone:
      break;
  }
  const ConfigurationStep& s = plan_->steps()[step_];
  if (s.kind == ConfigurationStep::Kind::kVerify) {
    read_size_ = client_.transferred();
    read_value_ = 0;
    for (std::size_t i = 0; i < read_size_ && i < 8; ++i)
      read_value_ |= static_cast<std::uint64_t>(buffer_[i]) << (8 * i);
    if (read_size_ != s.size || read_value_ != s.value) {
      status_ = ConfigurationStatus::kFailed;
      return;
    }
  }
  ++step_;
  step_retries_ = 0;
  begin_step(now_ns);
}

std::string NodeConfigurator::error() const {
  if (status_ != ConfigurationStatus::kFailed) return {};
  const ConfigurationStep& s = plan_->steps()[step_];
  const DcfEntry& e = plan_->dcf().entries[s.entry];
  std::string where = to_string(e.location) + ": node " + std::to_string(node_id()) + " ";
  if (abort_code_ != 0) {
    const bool write = s.kind == ConfigurationStep::Kind::kWrite;
    std::string what =
        write ? "writing " + to_string(s.address) + " = " + hex_of_size(s.value, s.size)
              : "reading " + to_string(s.address);
    const std::string name =
        std::string(sdo_abort_name(abort_code_)) + " (" + hex_of_size(abort_code_, 4) + ")";
    return where + (by_server_ ? "refused " + what + ": " + name
                               : what + " failed: " + name + (abort_code_ == SdoAbort::kTimeout
                                                                  ? ", the node did not answer (" +
                                                                        std::to_string(1 + kTimeoutRetries) +
                                                                        " tries)"
                                                                  : ", a bad answer"));
  }
  if (read_size_ != s.size) {
    return where + to_string(s.address) + " read back " + std::to_string(read_size_) +
           " bytes, the DCF's data type has " + std::to_string(s.size);
  }
  return where + to_string(s.address) + " read back " + hex_of_size(read_value_, s.size) +
         ", the DCF configures " + hex_of_size(s.value, s.size);
}

}  // namespace numen::hal
