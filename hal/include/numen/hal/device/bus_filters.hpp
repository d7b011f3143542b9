#pragma once
/// @file bus_filters.hpp
/// The acceptance filters (can_filter.hpp) of each side of one device's bus: what its
/// controller reads and what the device (or its emulator) reads. Used to open a real bus with
/// kernel or user-space filters (sim's open_real_bus) and to give each device its share of a
/// bus several devices use (BusShare; platform::ControlLoop with several devices on one bus).

#include <vector>

#include "numen/hal/device/device_config.hpp"
#include "numen/hal/transport/can_filter.hpp"

namespace numen::hal {

/// Filters for every frame the controller reads from the device of `config`: each axis's
/// encoder COB-ID whole (standard_id_filter(): data and remote; extended_id_filter(): the
/// 29-bit frame of that number), so that the frames the device counts as rejected or of an
/// unknown id reach it; managed stack: exact 11-bit filters (exact_standard_filter()) for each
/// drive TPDO, each node's heartbeat (0x700 + node, also its boot-up), EMCY (0x080 + node)
/// and, when configured or polled, SDO response. Filters are deduplicated. Allocates.
std::vector<CanFilter> controller_filters(const DeviceConfig& config);

/// Exact 11-bit filters for every frame the device of `config` reads: SYNC (0x080), each
/// driven axis's drive / torque RPDO; managed stack: NMT (0x000), the controller's heartbeat
/// (0x700 + controller_node_id) and each node's SDO requests (0x600 + node). Allocates.
std::vector<CanFilter> device_filters(const DeviceConfig& config);

}  // namespace numen::hal
