// Tests of numen/hal/emulation/sdo_server.hpp and object_dictionary.hpp: SdoClient against
// SdoServer, directly and over SimBus: reads and writes of every length (expedited 1–4 bytes,
// segmented across segment boundaries), the dictionary's checks answered with their abort
// codes, block and unknown requests refused, a client abort ending the server's transfer,
// and no allocation on either side.
#include "numen/hal/emulation/sdo_server.hpp"

#include <gtest/gtest.h>

#include <array>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/hal/canopen/sdo.hpp"
#include "numen/hal/transport/sim_bus.hpp"

namespace {

using namespace numen::hal;

/// A drive's dictionary: device type (ro), heartbeat producer time (rw, u16), device name
/// (ro string), a 20-byte rw string, a write-only command (u8), a 3-sub-index record.
ObjectDictionary drive_dictionary() {
  ObjectDictionary od;
  od.add_unsigned({0x1000, 0}, OdAccess::kReadOnly, 0x00020192, 4);
  od.add_unsigned({0x1017, 0}, OdAccess::kReadWrite, 0, 2);
  od.add_string({0x1008, 0}, OdAccess::kReadOnly, "numen emulated drive", 20);
  od.add_string({0x2000, 0}, OdAccess::kReadWrite, "", 20);
  od.add_unsigned({0x2001, 0}, OdAccess::kWriteOnly, 0, 1);
  od.add_unsigned({0x1018, 0}, OdAccess::kReadOnly, 2, 1);
  od.add_unsigned({0x1018, 1}, OdAccess::kReadOnly, 0x12345678, 4);
  od.add_unsigned({0x1018, 2}, OdAccess::kReadOnly, 7, 4);
  return od;
}

/// Runs the client's transfer against the server, frame by frame, until it ends (≤ 100
/// exchanges). Returns the client's status.
SdoStatus exchange(SdoClient& c, SdoServer& s) {
  CanFrame f;
  for (int i = 0; i < 100 && c.status() == SdoStatus::kPending; ++i) {
    if (!c.take_request(f, i)) break;
    s.on_frame(f);
    if (s.take_response(f, i)) c.on_frame(f);
  }
  if (c.take_request(f, 0)) s.on_frame(f);  // an abort the client queued
  return c.status();
}

std::string upload_text(SdoClient& c, SdoServer& s, SdoAddress a) {
  std::array<std::uint8_t, 64> buf{};
  EXPECT_TRUE(c.start_upload(a, buf, 0));
  EXPECT_EQ(exchange(c, s), SdoStatus::kDone) << sdo_abort_name(c.abort_code());
  return std::string(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(c.transferred()));
}

TEST(SdoServer, ReadsEveryKindOfEntry) {
  ObjectDictionary od = drive_dictionary();
  SdoServer server(3, od);
  SdoClient client(3);
  std::array<std::uint8_t, 8> buf{};
  ASSERT_TRUE(client.start_upload({0x1000, 0}, buf, 0));
  ASSERT_EQ(exchange(client, server), SdoStatus::kDone);
  EXPECT_EQ(client.transferred(), 4u);
  EXPECT_EQ(buf[0] | buf[1] << 8 | buf[2] << 16 | buf[3] << 24, 0x00020192);
  EXPECT_EQ(upload_text(client, server, {0x1008, 0}), "numen emulated drive");  // 20 bytes: 3 segments
  EXPECT_EQ(upload_text(client, server, {0x2000, 0}), "");                      // empty: one last segment
  EXPECT_EQ(server.counters().uploads, 3u);
}

TEST(SdoServer, WritesOfEveryLengthRoundTrip) {
  ObjectDictionary od = drive_dictionary();
  SdoServer server(3, od);
  SdoClient client(3);
  const std::array<std::uint8_t, 2> hb{0xF4, 0x01};  // 500 ms
  ASSERT_TRUE(client.start_download({0x1017, 0}, hb, 0));
  ASSERT_EQ(exchange(client, server), SdoStatus::kDone);
  std::uint32_t v = 0;
  ASSERT_TRUE(od.read_unsigned({0x1017, 0}, v));
  EXPECT_EQ(v, 500u);
  // Strings of 1–20 bytes: expedited up to 4, then 1, 2 and 3 segments, each boundary crossed.
  for (std::size_t n = 1; n <= 20; ++n) {
    std::string text;
    for (std::size_t i = 0; i < n; ++i) text += static_cast<char>('a' + i);
    ASSERT_TRUE(client.start_download(
        {0x2000, 0}, std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), n), 0));
    ASSERT_EQ(exchange(client, server), SdoStatus::kDone) << n << ": " << sdo_abort_name(client.abort_code());
    EXPECT_EQ(upload_text(client, server, {0x2000, 0}), text) << n;
  }
}

TEST(SdoServer, RefusalsArriveAsTheirAbortCodes) {
  ObjectDictionary od = drive_dictionary();
  SdoServer server(3, od);
  SdoClient client(3);
  std::array<std::uint8_t, 8> buf{};
  struct Case {
    bool upload;
    SdoAddress address;
    std::size_t bytes;
    std::uint32_t code;
  };
  const Case cases[] = {
      {true, {0x3000, 0}, 0, SdoAbort::kNoObject},
      {true, {0x1018, 9}, 0, SdoAbort::kNoSubIndex},
      {true, {0x2001, 0}, 0, SdoAbort::kWriteOnly},
      {false, {0x1000, 0}, 4, SdoAbort::kReadOnly},
      {false, {0x1017, 0}, 4, SdoAbort::kLengthTooHigh},
      {false, {0x1017, 0}, 1, SdoAbort::kLengthTooLow},
      {false, {0x2000, 0}, 8, 0},  // a variable-length entry takes any length up to its capacity
  };
  for (const Case& k : cases) {
    const bool started = k.upload ? client.start_upload(k.address, buf, 0)
                                  : client.start_download(k.address, std::span<const std::uint8_t>(buf.data(), k.bytes), 0);
    ASSERT_TRUE(started);
    const SdoStatus st = exchange(client, server);
    if (k.code == 0) {
      EXPECT_EQ(st, SdoStatus::kDone);
    } else {
      EXPECT_EQ(st, SdoStatus::kAborted);
      EXPECT_TRUE(client.aborted_by_server());
      EXPECT_EQ(client.abort_code(), k.code) << sdo_abort_name(client.abort_code());
    }
  }
  // A 21-byte write into the 20-byte string: refused when announced.
  const std::string long_text(21, 'x');
  client.start_download({0x2000, 0}, std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(long_text.data()), 21), 0);
  EXPECT_EQ(exchange(client, server), SdoStatus::kAborted);
  EXPECT_EQ(client.abort_code(), SdoAbort::kLengthTooHigh);
}

TEST(SdoServer, BlockAndUnknownRequestsAndStraySegmentsAreRefused) {
  ObjectDictionary od = drive_dictionary();
  SdoServer server(3, od);
  CanFrame f, r;
  SdoFrame d;
  for (std::uint8_t cmd : {0xA4, 0xC0, 0xE0, 0x60 /* upload segment with no upload */}) {
    f = CanFrame{};
    f.id = 0x603;
    f.len = 8;
    f.data[0] = cmd;
    ASSERT_TRUE(server.on_frame(f));
    ASSERT_TRUE(server.take_response(r, 0));
    ASSERT_EQ(decode_sdo(r, 0x583, d), SdoDecodeStatus::kOk);
    EXPECT_EQ(d.kind, SdoFrameKind::kAbort);
    EXPECT_EQ(d.abort_code, SdoAbort::kCommandSpecifier) << int(cmd);
  }
  f.id = 0x604;  // another node's channel
  EXPECT_FALSE(server.on_frame(f));
}

TEST(SdoServer, AClientAbortEndsTheTransferWithoutAnswer) {
  ObjectDictionary od = drive_dictionary();
  SdoServer server(3, od);
  SdoClient client(3);
  std::array<std::uint8_t, 32> buf{};
  client.start_upload({0x1008, 0}, buf, 0);
  CanFrame f;
  client.take_request(f, 0);
  server.on_frame(f);
  server.take_response(f, 0);
  client.on_frame(f);  // segmented: the client now asks for the first segment
  client.cancel(SdoAbort::kGeneral, 0);
  ASSERT_TRUE(client.take_request(f, 0));
  EXPECT_TRUE(server.on_frame(f));
  EXPECT_FALSE(server.take_response(f, 0));
  EXPECT_EQ(server.counters().aborts_received, 1u);
  // The next transfer starts afresh.
  EXPECT_EQ(upload_text(client, server, {0x1008, 0}), "numen emulated drive");
}

TEST(SdoServer, ReadsAndWritesOverTheSimulatedBus) {
  SimBusSettings settings;
  settings.latency_ns = 200'000;
  SimBus bus(settings);
  ObjectDictionary od = drive_dictionary();
  SdoServer server(3, od);
  SdoClient client(3, 50'000'000);
  std::array<std::uint8_t, 32> buf{};
  ASSERT_TRUE(client.start_upload({0x1008, 0}, buf, 0));
  CanFrame f;
  std::int64_t t = 0;
  for (; t < 100'000'000 && client.status() == SdoStatus::kPending; t += 100'000) {
    bus.set_time_ns(t);
    while (client.take_request(f, t)) bus.controller().write(f);
    while (bus.device().read(f) == IoStatus::kOk) server.on_frame(f);
    while (server.take_response(f, t)) bus.device().write(f);
    while (bus.controller().read(f) == IoStatus::kOk) client.on_frame(f);
    client.poll(t);
  }
  ASSERT_EQ(client.status(), SdoStatus::kDone);
  EXPECT_EQ(std::string(buf.begin(), buf.begin() + 20), "numen emulated drive");
  // 4 round trips (initiate + 3 segments), each 2 × 200 µs on the bus plus the 100 µs until
  // the loop takes the next request: 2 ms.
  EXPECT_LE(t, 2'100'000);
}

TEST(SdoServer, NeitherSideAllocatesDuringTransfers) {
  ObjectDictionary od = drive_dictionary();
  SdoServer server(3, od);
  SdoClient client(3);
  std::array<std::uint8_t, 32> buf{};
  const std::string text = "twelve bytes";
  numen::test::AllocationGuard guard;
  for (int k = 0; k < 50; ++k) {
    client.start_download({0x2000, 0}, std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), 0);
    exchange(client, server);
    client.start_upload({0x2000, 0}, buf, 0);
    exchange(client, server);
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(server.counters().downloads, 50u);
  EXPECT_EQ(server.counters().uploads, 50u);
}

}  // namespace
