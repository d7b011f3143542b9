#pragma once
/// @file dcf_configuration.hpp
/// Configuring one CANopen node from its DCF over SDO, then reading every configured object
/// back (CiA 301 §7.4.8 PDO sequence, CiA 302-2 configuration at boot-up; docs/protocol.md
/// "DCF"). Two parts:
///  - DcfConfiguration (setup, allocates): the ordered SDO transfers a Dcf asks for. Every
///    numeric entry with a ParameterValue is written if it is writable (wo, rw, rwr, rww) and
///    read back in any case (a configured read-only value, e.g. 0x1000 device type or 0x1018
///    vendor id, checks that the node is the device the DCF describes). Each PDO is written
///    in the sequence of CiA 301: its COB-ID with bit 31 set (PDO disabled), the other
///    communication sub-indices, the mapping count 0, the mapping entries, the mapping count,
///    then the COB-ID as configured (re-enabled). Then every other configured object in index
///    order (0x1005 SYNC, 0x1016/0x1017 heartbeats, 0x6060 modes of operation, 0x6072 max
///    torque, …), then the read-back. String and DOMAIN entries are not configured.
///  - NodeConfigurator (run time, noexcept, allocation-free, non-blocking): runs those
///    transfers through an SdoClient, one at a time, advanced once per call of poll(). A
///    transfer the node did not answer in time is tried again (kTimeoutRetries more times: a
///    lost frame on a noisy line; every write is idempotent); the first abort by the node, a
///    last timeout or a read-back mismatch stops it with a located error (error(), which
///    allocates: reports only).

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "numen/hal/canopen/dcf.hpp"
#include "numen/hal/canopen/sdo.hpp"
#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// One SDO transfer of a node's configuration.
struct ConfigurationStep {
  /// kWrite: download `value`; kVerify: upload and compare with `value`.
  enum class Kind : std::uint8_t { kWrite, kVerify };
  Kind kind = Kind::kWrite;
  SdoAddress address;
  std::uint64_t value = 0;  ///< Little endian on the bus, `size` bytes.
  std::uint8_t size = 0;    ///< 1, 2, 4 or 8 bytes.
  std::size_t entry = 0;    ///< Index of the Dcf entry it comes from (its location).
};

/// The SDO transfers configuring one node from `dcf` (see the file comment). Setup code.
class DcfConfiguration {
 public:
  /// Builds the steps of `dcf` (not null). Throws DcfError (located at the entry) for a PDO
  /// whose mapping entries are configured without a mapping count ([16xx/1Axx sub0]) or with
  /// one of a string or DOMAIN type, which no SDO step can write.
  explicit DcfConfiguration(std::shared_ptr<const Dcf> dcf);

  /// The steps, in order: writes, then verifications.
  std::span<const ConfigurationStep> steps() const noexcept { return steps_; }
  /// Number of write steps (the first ones).
  std::size_t num_writes() const noexcept { return writes_; }
  /// The DCF.
  const Dcf& dcf() const noexcept { return *dcf_; }

 private:
  std::shared_ptr<const Dcf> dcf_;
  std::vector<ConfigurationStep> steps_;
  std::size_t writes_ = 0;
};

/// Times a NodeConfigurator tries a transfer again after the node did not answer it.
inline constexpr int kTimeoutRetries = 2;

/// State of a NodeConfigurator.
enum class ConfigurationStatus : std::uint8_t {
  kIdle,     ///< Not started (or restarted and not yet polled).
  kRunning,  ///< A transfer runs.
  kDone,     ///< Every step completed and every read-back matched.
  kFailed,   ///< Stopped at failed_step(): an abort, a timeout or a mismatch.
};

/// Short English name of a ConfigurationStatus (static string).
const char* to_string(ConfigurationStatus status) noexcept;

/// Runs a DcfConfiguration on node `node_id` (see the file comment). Usage: start(); then, every
/// period, send what take_request() gives, feed received frames to on_frame(), call poll(now),
/// until status() is kDone or kFailed. Every member but error() is noexcept and
/// allocation-free. Not thread-safe.
class NodeConfigurator {
 public:
  /// Configurator of `plan` (not owned; must outlive it) for node `node_id` (1–127); each
  /// transfer aborts (0x05040000) after `timeout_ns` without a response.
  NodeConfigurator(const DcfConfiguration& plan, std::uint8_t node_id, std::int64_t timeout_ns) noexcept;

  /// (Re)starts from the first step at `now_ns` (a transfer still pending is cancelled).
  void start(std::int64_t now_ns) noexcept;
  /// The next request to send; false if none.
  bool take_request(CanFrame& out, std::int64_t now_ns) noexcept;
  /// Takes a received frame; true if it was this node's SDO response channel.
  bool on_frame(const CanFrame& frame) noexcept;
  /// Times out a silent node, checks a completed transfer and starts the next one.
  void poll(std::int64_t now_ns) noexcept;

  /// The state.
  ConfigurationStatus status() const noexcept { return status_; }
  /// Steps completed (or the index of the failed one).
  std::size_t step() const noexcept { return step_; }
  /// kFailed: the abort code (0 for a read-back mismatch).
  std::uint32_t abort_code() const noexcept { return abort_code_; }
  /// kFailed by a mismatch: the value read and its length, bytes.
  std::uint64_t read_value() const noexcept { return read_value_; }
  std::size_t read_size() const noexcept { return read_size_; }
  /// Transfers tried again after a timeout, since construction.
  std::uint64_t retries() const noexcept { return retries_; }
  /// The node.
  std::uint8_t node_id() const noexcept { return client_.server_node(); }
  /// The plan.
  const DcfConfiguration& plan() const noexcept { return *plan_; }
  /// The SDO client (its counters).
  const SdoClient& client() const noexcept { return client_; }
  /// kFailed: the located error, e.g. "encoder.dcf:211: [1A00sub1] ParameterValue: node 4
  /// 0x1A00:01 read back 0x60640020, the DCF configures 0x60040020" or "…: node 1 refused
  /// writing 0x1600:01 = 0x60720010: object cannot be mapped to the PDO (0x06040041)".
  /// Allocates (reports only). Empty otherwise.
  std::string error() const;

 private:
  void begin_step(std::int64_t now_ns) noexcept;

  const DcfConfiguration* plan_;
  SdoClient client_;
  ConfigurationStatus status_ = ConfigurationStatus::kIdle;
  std::size_t step_ = 0;
  int step_retries_ = 0;
  std::uint64_t retries_ = 0;
  std::array<std::uint8_t, 8> buffer_{};
  std::uint32_t abort_code_ = 0;
  bool by_server_ = false;
  std::uint64_t read_value_ = 0;
  std::size_t read_size_ = 0;
};

}  // namespace numen::hal
