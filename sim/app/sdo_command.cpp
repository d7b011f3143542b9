/// @file sdo_command.cpp
/// `numen sdo`: one SDO read or write on a bus, for bench work (docs/sdo.md).

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

#include "commands.hpp"
#include "numen/sim/device/sdo_session.hpp"
#include "numen/sim/input/bus_spec.hpp"
#include "numen/sim/input/input_error.hpp"
#include "signals.hpp"

namespace numen::app {
namespace {

/// The bytes of `value` as `type` puts it on the bus (little endian); throws InputError at
/// VALUE when it does not parse or does not fit.
std::vector<std::uint8_t> encode_value(const std::string& value, const std::string& type) {
  const auto bad = [&](const std::string& why) {
    return sim::InputError("", 0, 0, "VALUE", "'" + value + "' " + why);
  };
  if (type == "string") {
    if (value.empty()) throw bad("is empty: an SDO write carries at least one byte");
    return std::vector<std::uint8_t>(value.begin(), value.end());
  }
  if (type == "hex") {
    std::string digits;
    for (char c : value)
      if (!std::isspace(static_cast<unsigned char>(c))) digits += c;
    if (digits.empty() || digits.size() % 2 != 0) throw bad("is not an even number of hex digits");
    std::vector<std::uint8_t> out;
    for (std::size_t i = 0; i < digits.size(); i += 2) {
      unsigned v = 0;
      const auto [p, ec] = std::from_chars(digits.data() + i, digits.data() + i + 2, v, 16);
      if (ec != std::errc() || p != digits.data() + i + 2) throw bad("is not hex bytes");
      out.push_back(static_cast<std::uint8_t>(v));
    }
    return out;
  }
  const bool is_signed = type[0] == 'i';
  const int bits = std::stoi(type.substr(1));
  std::string text = value;
  int base = 10;
  if (text.rfind("0x", 0) == 0 || text.rfind("0X", 0) == 0) {
    text = text.substr(2);
    base = 16;
  }
  long long v = 0;
  const auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v, base);
  if (text.empty() || ec != std::errc() || p != text.data() + text.size())
    throw bad("is not an integer (decimal, or hexadecimal with 0x)");
  const long long lo = is_signed ? -(1LL << (bits - 1)) : 0;
  const long long hi = is_signed ? (1LL << (bits - 1)) - 1 : (1LL << bits) - 1;
  if (v < lo || v > hi)
    throw bad("does not fit " + type + " [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  std::vector<std::uint8_t> out(static_cast<std::size_t>(bits / 8));
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<std::uint8_t>(static_cast<unsigned long long>(v) >> (8 * i));
  return out;
}

/// A read value: its bytes, as unsigned and signed little endian (≤ 4 bytes), as text (printable).
std::string describe_value(const std::vector<std::uint8_t>& b) {
  std::string s = "bytes:";
  char buf[32];
  for (std::uint8_t x : b) {
    std::snprintf(buf, sizeof buf, " %02X", x);
    s += buf;
  }
  s += " (" + std::to_string(b.size()) + ")\n";
  if (!b.empty() && b.size() <= 4) {
    std::uint32_t u = 0;
    for (std::size_t i = 0; i < b.size(); ++i) u |= static_cast<std::uint32_t>(b[i]) << (8 * i);
    const unsigned shift = static_cast<unsigned>(32 - 8 * b.size());
    const std::int32_t i = static_cast<std::int32_t>(u << shift) >> shift;
    std::snprintf(buf, sizeof buf, "0x%0*X", static_cast<int>(2 * b.size()), u);
    s += "unsigned: " + std::to_string(u) + " (" + buf + "), signed: " + std::to_string(i) + "\n";
  }
  bool text = !b.empty();
  for (std::uint8_t x : b) text = text && x >= 0x20 && x < 0x7F;
  if (text) s += "text: \"" + std::string(b.begin(), b.end()) + "\"\n";
  return s;
}

}  // namespace

SdoCommand::SdoCommand(CLI::App& parent)
    : cli_(parent.add_subcommand("sdo", "Read or write one object of a CANopen node by SDO")) {
  cli_->add_option("--bus", bus_, "can:IFACE or serial:PATH[@BAUD]")
      ->required()
      ->check([](const std::string& v) { return check_bus(v, true); });
  cli_->add_option("node", node_, "Node id, 1-127")->required()->check(CLI::Range(1, 127));
  cli_->add_option("action", action_, "read or write")->required()->check(CLI::IsMember({"read", "write"}));
  cli_->add_option("address", address_, "INDEX:SUB in hexadecimal, e.g. 1018:01")
      ->required()
      ->check([](const std::string& v) -> std::string {
        try {
          sim::parse_sdo_address(v);
          return {};
        } catch (const std::invalid_argument& e) {
          return e.what();
        }
      });
  cli_->add_option("value", value_, "write: the value, as --type says");
  cli_->add_option("--type", type_, "write: u8 u16 u32 i8 i16 i32 string hex")
      ->check(CLI::IsMember({"u8", "u16", "u32", "i8", "i16", "i32", "string", "hex"}));
  cli_->add_option("--timeout", timeout_s_, "SDO response timeout, seconds (default 0.5)")
      ->check(seconds_check(0.0, 60.0, true));
}

int SdoCommand::execute() const {
  const hal::SdoAddress address = sim::parse_sdo_address(address_);
  std::vector<std::uint8_t> data;
  if (action_ == "write") {
    if (type_.empty()) throw sim::InputError("", 0, 0, "--type", "a write needs the value's --type");
    if (value_.empty() && type_ != "string")
      throw sim::InputError("", 0, 0, "VALUE", "a write needs a value");
    data = encode_value(value_, type_);
  } else if (!value_.empty() || !type_.empty()) {
    throw sim::InputError("", 0, 0, "VALUE", "a read takes no value and no --type");
  }
  const auto node = static_cast<std::uint8_t>(node_);
  const std::unique_ptr<hal::Bus> bus = sim::open_real_bus(
      sim::parse_bus_spec(bus_), {hal::exact_standard_filter(hal::sdo_response_cob_id(node))});
  loading_done();
  hal::SdoClient client(node, std::llround(timeout_s_ * 1e9));
  const sim::BringUpLink link = sim::real_link(*bus);
  std::vector<std::uint8_t> buffer(4096);
  if (action_ == "read") {
    client.start_upload(address, buffer, link.now_ns());
  } else {
    client.start_download(address, data, link.now_ns());
  }
  const std::string where = "node " + std::to_string(node_) + " " + hal::to_string(address);
  if (sim::run_sdo_transfer(link, client) != hal::SdoStatus::kDone) {
    char code[16];
    std::snprintf(code, sizeof code, "0x%08X", client.abort_code());
    std::cerr << "numen sdo: " << where << ": " << (client.aborted_by_server() ? "the node aborted: " : "aborted: ")
              << code << " " << hal::sdo_abort_name(client.abort_code()) << "\n";
    return 1;
  }
  if (action_ == "read") {
    buffer.resize(client.transferred());
    std::cout << where << " read\n" << describe_value(buffer);
  } else {
    std::cout << where << " written (" << data.size() << " bytes)\n";
  }
  return 0;
}

}  // namespace numen::app
