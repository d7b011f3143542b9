/// @file bus_filters.cpp
/// The controller's and the device's acceptance filters of one device's bus.

#include "numen/hal/device/bus_filters.hpp"

#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/hal/canopen/nmt.hpp"
#include "numen/hal/canopen/sdo.hpp"

namespace numen::hal {
namespace {

void add_unique(std::vector<CanFilter>& out, const CanFilter& f) {
  for (const CanFilter& g : out)
    if (g.id == f.id && g.mask == f.mask) return;
  out.push_back(f);
}

void add_unique(std::vector<CanFilter>& out, std::uint32_t cob_id) {
  add_unique(out, exact_standard_filter(cob_id));
}

}  // namespace

std::vector<CanFilter> controller_filters(const DeviceConfig& config) {
  std::vector<CanFilter> out;
  // An encoder's COB-ID passes whole: a remote request on it is a malformed sample and a
  // 29-bit frame of its number an unknown id (InstrumentDevice::on_frame()), counted in the
  // summary (frames rejected, unknown id) instead of vanishing in the filter.
  for (const AxisConfig& axis : config.axes) {
    add_unique(out, standard_id_filter(axis.encoder_cob_id));
    add_unique(out, extended_id_filter(axis.encoder_cob_id));
  }
  if (config.canopen.managed) {
    for (const CanopenAxisConfig& x : config.canopen.axes) {
      if (x.drive_tpdo_cob_id != 0) add_unique(out, x.drive_tpdo_cob_id);
      add_unique(out, heartbeat_cob_id(x.node_id));
      add_unique(out, emcy_cob_id(x.node_id));
      // SDO responses: the node's configuration from its DCF, the in-loop reads.
      if (x.dcf || config.canopen.sdo_poll_period_ms > 0)
        add_unique(out, sdo_response_cob_id(x.node_id));
    }
  }
  return out;
}

std::vector<CanFilter> device_filters(const DeviceConfig& config) {
  std::vector<CanFilter> out;
  add_unique(out, kSyncCobId);
  for (const AxisConfig& axis : config.axes)
    if (axis.drive_cob_id != 0) add_unique(out, axis.drive_cob_id);
  if (config.canopen.managed) {
    add_unique(out, kNmtCobId);
    add_unique(out, heartbeat_cob_id(config.canopen.controller_node_id));
    for (const CanopenAxisConfig& x : config.canopen.axes)  // each node's SDO server
      add_unique(out, sdo_request_cob_id(x.node_id));
  }
  return out;
}

}  // namespace numen::hal
