/// @file dcf_check.cpp
/// check_dcfs(): a node's DCF against the device configuration the controller runs with.

#include <cstdio>
#include <stdexcept>
#include <string>

#include "../hex_text.hpp"
#include "numen/hal/device/device_config.hpp"

namespace numen::hal {
namespace {

constexpr std::uint32_t kCobIdInvalidBit = 0x80000000u;

using detail::hex_digits;

/// The entry's value (ParameterValue, else DefaultValue), or false if it has none.
bool value_of(const Dcf& dcf, SdoAddress a, std::uint64_t& v, const DcfEntry** entry) {
  const DcfEntry* e = dcf.find(a);
  if (entry != nullptr) *entry = e;
  if (e == nullptr || !(e->configured || e->has_default) || data_type_size(e->data_type) == 0) return false;
  v = e->value;
  return true;
}

[[noreturn]] void fail_file(const Dcf& dcf, const std::string& msg) {
  throw DcfError(DcfLocation{dcf.path, 0, "", ""}, msg);
}

/// Checks that `dcf` has an enabled PDO (communication objects from `first_comm`, 512 of them)
/// with COB-ID `cob_id` whose mapping is `mapping`; `what` names it in messages.
void check_pdo(const Dcf& dcf, std::uint16_t first_comm, std::uint32_t cob_id,
               const std::vector<PdoEntry>& mapping, const std::string& what) {
  const bool rx = first_comm == 0x1400;
  for (std::uint32_t comm = first_comm; comm < first_comm + 0x200u; ++comm) {
    std::uint64_t cob = 0;
    const DcfEntry* cob_entry = nullptr;
    if (!value_of(dcf, {static_cast<std::uint16_t>(comm), 1}, cob, &cob_entry)) continue;
    if ((cob & kCobIdInvalidBit) != 0 || (cob & 0x1FFFFFFFu) != cob_id) continue;
    const auto map = static_cast<std::uint16_t>(comm + 0x200);
    std::uint64_t n = 0;
    const DcfEntry* count = nullptr;
    if (!value_of(dcf, {map, 0}, n, &count)) {
      fail_file(dcf, std::string(rx ? "RPDO" : "TPDO") + " " + hex_digits(cob_id, 3) + " ([" +
                         hex_digits(comm, 4).substr(2) + "]) has no mapping count [" +
                         hex_digits(map, 4).substr(2) + "sub0] with a value (" + what + ")");
    }
    if (n != mapping.size()) {
      throw DcfError(count->location, "maps " + std::to_string(n) + " objects, " + what + " maps " +
                                          std::to_string(mapping.size()));
    }
    for (std::size_t i = 0; i < mapping.size(); ++i) {
      std::uint64_t v = 0;
      const DcfEntry* e = nullptr;
      const auto sub = static_cast<std::uint8_t>(i + 1);
      if (!value_of(dcf, {map, sub}, v, &e)) {
        fail_file(dcf, "mapping entry [" + hex_digits(map, 4).substr(2) + "sub" +
                           std::to_string(sub) + "] has no value (" + what + ")");
      }
      if (v != mapping_entry_value(mapping[i])) {
        throw DcfError(e->location, "maps " + hex_digits(v, 8) + ", " + what + " maps " +
                                        hex_digits(mapping_entry_value(mapping[i]), 8) +
                                        " as entry " + std::to_string(sub));
      }
    }
    return;
  }
  fail_file(dcf, std::string("no enabled ") + (rx ? "RPDO" : "TPDO") + " with COB-ID " +
                     hex_digits(cob_id, 3) + " (" + what + ")");
}

}  // namespace

void check_dcfs(const DeviceConfig& config) {
  if (!config.canopen.managed) return;
  const std::vector<CanopenAxisConfig>& axes = config.canopen.axes;
  for (std::size_t i = 0; i < axes.size() && i < config.axes.size(); ++i) {
    const CanopenAxisConfig& x = axes[i];
    const AxisConfig& a = config.axes[i];
    for (std::size_t j = 0; j < i; ++j) {
      if (axes[j].node_id != x.node_id) continue;
      const std::string pi = x.dcf ? x.dcf->path : "none";
      const std::string pj = axes[j].dcf ? axes[j].dcf->path : "none";
      if (pi != pj) {
        throw std::invalid_argument("device '" + config.name + "': canopen.axes[" + std::to_string(i) +
                                    "].dcf: axes '" + config.axes[j].name + "' and '" + a.name +
                                    "' share node " + std::to_string(x.node_id) +
                                    " but give different DCFs (" + pj + ", " + pi + ")");
      }
    }
    if (!x.dcf) continue;
    const Dcf& dcf = *x.dcf;
    const std::string axis = "axis '" + a.name + "'";
    check_pdo(dcf, 0x1800, a.encoder_cob_id, x.encoder_tpdo, "the encoder TPDO of " + axis);
    if (a.has_drive()) {
      check_pdo(dcf, 0x1400, a.drive_cob_id, x.drive_rpdo, "the drive RPDO of " + axis);
      check_pdo(dcf, 0x1800, x.drive_tpdo_cob_id, x.drive_tpdo, "the drive TPDO of " + axis);
    }
    std::uint64_t hb = 0;
    const DcfEntry* e = nullptr;
    if (value_of(dcf, {0x1017, 0}, hb, &e) && hb != x.heartbeat_period_ms) {
      throw DcfError(e->location, "producer heartbeat time " + std::to_string(hb) + " ms, the " + axis +
                                      " node's heartbeat_period is " +
                                      std::to_string(x.heartbeat_period_ms) + " ms");
    }
  }
}

}  // namespace numen::hal
