/// @file bus_spec.cpp
/// Parsing, filters and opening of the real buses of `numen run` / `numen device`.

#include "numen/sim/input/bus_spec.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <time.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <sstream>
#include <stdexcept>

#include "numen/hal/features.hpp"
#if NUMEN_WITH_SERIAL
#include "numen/hal/transport/serial_bus.hpp"
#endif
#if NUMEN_WITH_SOCKETCAN
#include "numen/hal/transport/socketcan_bus.hpp"
#endif

namespace numen::sim {
namespace {

bool starts_with(const std::string& s, const char* prefix) {
  return s.rfind(prefix, 0) == 0;
}

}  // namespace

BusSpec parse_bus_spec(const std::string& spec) {
  BusSpec out;
  auto bad = [&](const std::string& why) {
    return std::invalid_argument("--bus '" + spec + "': " + why);
  };
  if (spec == "sim") return out;
  if (spec == "igtl" || starts_with(spec, "igtl:")) {
    out.kind = BusKind::kIgtl;
    if (spec == "igtl") return out;
    const std::string rest = spec.substr(5);
    const std::size_t colon = rest.rfind(':');
    const std::string p = colon == std::string::npos ? rest : rest.substr(colon + 1);
    std::uint32_t port = 0;
    const auto r = std::from_chars(p.data(), p.data() + p.size(), port);
    if (p.empty() || r.ec != std::errc() || r.ptr != p.data() + p.size() || port < 1 || port > 65535)
      throw bad("port '" + p + "' is not a TCP port in [1, 65535]");
    out.igtl_port = static_cast<std::uint16_t>(port);
    if (colon != std::string::npos) {
      out.igtl_host = rest.substr(0, colon);
      if (out.igtl_host.empty()) throw bad("empty host before ':PORT'");
      // One port: a host with a colon is an IPv6 address ([::1] or ::1), nothing else
      // ("igtl:127.0.0.1:19098:5" was taken as host "127.0.0.1:19098" and failed at run time).
      std::string host = out.igtl_host;
      if (host.size() > 2 && host.front() == '[' && host.back() == ']')
        host = host.substr(1, host.size() - 2);
      in6_addr v6{};
      if (host.find(':') != std::string::npos) {
        if (::inet_pton(AF_INET6, host.c_str(), &v6) != 1)
          throw bad("host '" + out.igtl_host +
                    "' is not an IPv6 address, and the spec has one port: igtl[:[HOST:]PORT], "
                    "an IPv6 host as [::1]:PORT");
      } else if (host != out.igtl_host || !std::all_of(host.begin(), host.end(), [](char c) {
                   return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' ||
                          c == '_';
                 })) {
        throw bad("host '" + out.igtl_host +
                  "' is not a host name or an IP address (letters, digits, '.', '-', '_'; an "
                  "IPv6 address in brackets)");
      }
      out.igtl_host = host;
    }
    out.target = rest;
    return out;
  }
  if (starts_with(spec, "log:")) {
    out.kind = BusKind::kLog;
    out.target = spec.substr(4);
  } else if (starts_with(spec, "can:")) {
    out.kind = BusKind::kCan;
    out.target = spec.substr(4);
    if (out.target.size() >= 16) throw bad("interface name longer than 15 characters (IFNAMSIZ)");
  } else if (starts_with(spec, "serial:")) {
    out.kind = BusKind::kSerial;
    std::string rest = spec.substr(7);
    const std::size_t at = rest.rfind('@');
    if (at != std::string::npos) {
      const std::string b = rest.substr(at + 1);
      std::uint32_t baud = 0;
      const auto r = std::from_chars(b.data(), b.data() + b.size(), baud);
      if (b.empty() || r.ec != std::errc() || r.ptr != b.data() + b.size())
        throw bad("baud '" + b + "' is not a decimal number of bit/s");
#if NUMEN_WITH_SERIAL  // else refused whole by missing_backend()
      const auto bauds = hal::serial_supported_bauds();
      if (std::find(bauds.begin(), bauds.end(), baud) == bauds.end())
        throw bad("baud " + b + " is not a supported termios speed (9600 ... 4000000)");
#endif
      out.baud = baud;
      rest.resize(at);
    }
    out.target = rest;
  } else {
    throw bad("expected sim, log:FILE, can:IFACE, serial:PATH[@BAUD] or igtl[:[HOST:]PORT]");
  }
  if (out.target.empty()) throw bad("nothing after the prefix");
  return out;
}

std::string missing_backend(const BusSpec& spec) {
  const std::string scheme = spec.kind == BusKind::kCan ? "can:" : "serial:";
  if (spec.kind == BusKind::kCan && !hal::kWithSocketCan)
    return "bus '" + scheme + spec.target + "' needs SocketCAN: this build has NUMEN_WITH_SOCKETCAN=OFF";
  if (spec.kind == BusKind::kSerial && !hal::kWithSerial)
    return "bus '" + scheme + spec.target + "' needs the serial backend: this build has NUMEN_WITH_SERIAL=OFF";
  if (spec.kind == BusKind::kIgtl && !hal::kWithOpenIgtLink)
    return "bus 'igtl' needs OpenIGTLink: this build has NUMEN_WITH_OPENIGTLINK=OFF";
  return {};
}

std::unique_ptr<hal::Bus> open_real_bus(const BusSpec& spec,
                                        const std::vector<hal::CanFilter>& filters) {
  if (const std::string missing = missing_backend(spec); !missing.empty())
    throw std::invalid_argument(missing);
#if NUMEN_WITH_SOCKETCAN
  if (spec.kind == BusKind::kCan) {
    hal::SocketCanOptions options;
    options.fd_frames = false;  // the protocol uses classic frames; works on MTU 16 and 72
    return std::make_unique<hal::SocketCanBus>(spec.target, filters, options);
  }
#endif
#if NUMEN_WITH_SERIAL
  if (spec.kind == BusKind::kSerial) {
    return std::make_unique<hal::SerialBus>(spec.target, spec.baud, filters);
  }
#endif
  (void)filters;
  throw std::invalid_argument("open_real_bus: '" + spec.target + "' is not a can: or serial: bus");
}

bool wait_bus(hal::Bus& bus, std::int64_t timeout_ns) noexcept {
  int fd = -1;
#if NUMEN_WITH_SOCKETCAN
  if (auto* c = dynamic_cast<hal::SocketCanBus*>(&bus)) fd = c->native_handle();
#endif
#if NUMEN_WITH_SERIAL
  if (auto* s = dynamic_cast<hal::SerialBus*>(&bus)) fd = s->native_handle();
#endif
  (void)bus;
  if (timeout_ns < 0) timeout_ns = 0;
  const timespec ts{static_cast<time_t>(timeout_ns / 1'000'000'000),
                    static_cast<long>(timeout_ns % 1'000'000'000)};
  if (fd < 0) {
    nanosleep(&ts, nullptr);
    return true;
  }
  pollfd p{fd, POLLIN, 0};
  const int r = ppoll(&p, 1, &ts, nullptr);
  return r > 0;
}

std::string describe_transport_counters(const hal::Bus& bus) {
  std::ostringstream os;
#if NUMEN_WITH_SOCKETCAN
  if (const auto* c = dynamic_cast<const hal::SocketCanBus*>(&bus)) {
    const hal::SocketCanCounters& x = c->socketcan_counters();
    os << "socketcan " << c->name() << ": error frames " << x.error_frames << ", bus off "
       << x.bus_off << ", restarts " << x.restarts << ", link down " << x.link_down
       << ", malformed " << x.malformed_rx << ", tx retries " << x.tx_retries << ", reopens "
       << x.reopens << ", last errno " << x.last_errno;
    return os.str();
  }
#endif
#if NUMEN_WITH_SERIAL
  if (const auto* s = dynamic_cast<const hal::SerialBus*>(&bus)) {
    const hal::SerialCounters x = s->serial_counters();
    os << "serial " << s->path() << " @" << s->baud() << ": frames " << x.frames
       << ", rejected " << x.rejected() << " (torn " << x.torn_frames << ", cobs "
       << x.cobs_errors << ", crc " << x.crc_errors << ", malformed " << x.malformed_frames
       << "), garbage bytes " << x.garbage_bytes << ", resyncs " << x.resyncs << ", filtered "
       << x.filtered;
  }
#endif
  (void)bus;
  return os.str();
}

std::uint64_t link_down_events(const hal::Bus& bus) noexcept {
#if NUMEN_WITH_SOCKETCAN
  if (const auto* c = dynamic_cast<const hal::SocketCanBus*>(&bus))
    return c->socketcan_counters().link_down;
#endif
#if NUMEN_WITH_SERIAL
  if (const auto* s = dynamic_cast<const hal::SerialBus*>(&bus))
    return s->state() == hal::BusState::kBusOff ? 1 : 0;
#endif
  (void)bus;
  return 0;
}

}  // namespace numen::sim
