/// @file scan_command.cpp
/// `numen scan`: the CANopen nodes on a bus (boot-ups and heartbeats heard) and their identity
/// objects read by SDO (docs/sdo.md).

#include <cmath>
#include <iostream>

#include "commands.hpp"
#include "numen/sim/device/sdo_session.hpp"
#include "numen/sim/input/bus_spec.hpp"
#include "signals.hpp"

namespace numen::app {

ScanCommand::ScanCommand(CLI::App& parent)
    : cli_(parent.add_subcommand(
          "scan", "List the CANopen nodes on a bus and read their identities by SDO (never "
                  "starts or stops a node)")) {
  cli_->add_option("--bus", bus_, "can:IFACE or serial:PATH[@BAUD]")
      ->required()
      ->check([](const std::string& v) { return check_bus(v, true); });
  cli_->add_option("--listen", listen_s_,
                   "Seconds to listen for boot-ups and heartbeats (default 1.5; a node's "
                   "heartbeat period must be shorter)")
      ->check(seconds_check(0.0, 3600.0, true));
  cli_->add_option("--timeout", timeout_s_, "SDO response timeout, seconds (default 0.5)")
      ->check(seconds_check(0.0, 60.0, true));
  cli_->add_flag("--json", json_, "Print the nodes as JSON");
}

int ScanCommand::execute() const {
  const std::unique_ptr<hal::Bus> bus =
      sim::open_real_bus(sim::parse_bus_spec(bus_), sim::bring_up_filters());
  loading_done();
  sim::ScanSettings settings;
  settings.listen_ns = std::llround(listen_s_ * 1e9);
  settings.sdo_timeout_ns = std::llround(timeout_s_ * 1e9);
  const std::vector<sim::ScannedNode> nodes = sim::scan_nodes(sim::real_link(*bus), settings);
  std::cout << (json_ ? sim::format_scan_json(nodes) : sim::format_scan_table(nodes));
  if (nodes.empty()) {
    std::cerr << "numen scan: no boot-up or heartbeat heard on " << bus_ << " in " << listen_s_
              << " s\n";
    return 1;
  }
  return 0;
}

}  // namespace numen::app
