// Tests of numen/hal/transport/serial_bus.hpp over a real pseudo-terminal pair (openpty): the bus owns
// the slave side; the test plays the instrument on the master side with raw bytes, encoded
// and decoded by serial_frame.hpp. Round trips both ways, damage on the line, partial frames,
// filters, back-pressure with partial writes, hang-up, open errors, no allocation.
#include "numen/hal/transport/serial_bus.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "pseudo_terminal.hpp"

#include "serial_test_frames.hpp"

namespace numen::hal {
namespace {

using test::Bytes;
using test::encode;
using test::make;

using numen::test::expect_identical;

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

bool wait_readable(int fd, int timeout_ms) {
  pollfd p{fd, POLLIN, 0};
  return ::poll(&p, 1, timeout_ms) > 0 && (p.revents & POLLIN) != 0;
}

std::vector<CanFrame> all_kinds() {
  std::vector<CanFrame> v;
  v.push_back(make(0x000, 0, {}));
  // Bytes a cooked tty would eat or rewrite: LF, CR, XON, XOFF, ^C, ^Z, DEL, 0x00, 0xFF.
  v.push_back(make(0x7FF, 0, {0x0A, 0x0D, 0x11, 0x13, 0x03, 0x1A, 0x7F, 0x00}));
  v.push_back(make(0x1FFFFFFF, CanFlag::kExtendedId, {0xFF, 0x04, 0x1C}));
  CanFrame rtr = make(0x601, CanFlag::kRemote, {});
  rtr.len = 4;
  v.push_back(rtr);
  Bytes fd64(64);
  for (std::size_t i = 0; i < 64; ++i) fd64[i] = static_cast<std::uint8_t>(i * 37);
  v.push_back(make(0x123, CanFlag::kFd | CanFlag::kBitRateSwitch, fd64));
  v.push_back(make(0x18DA00F1, CanFlag::kExtendedId | CanFlag::kFd, Bytes(24, 0x00)));
  v.push_back(make(0x004, CanFlag::kErrorFrame, {0, 0x10, 0, 0, 0, 0, 0, 0}));
  return v;
}

// A pseudo-terminal whose slave is driven by a SerialBus; the master is the far end.
class SerialBusPty : public ::testing::Test {
 protected:
  void SetUp() override { open_pty(); }
  void TearDown() override {
    bus_.reset();
    if (master_ >= 0) ::close(master_);
  }

  void open_pty(std::span<const CanFilter> filters = {}, std::uint32_t baud = 115200) {
    int slave = -1;
    ASSERT_EQ(::openpty(&master_, &slave, nullptr, nullptr, nullptr), 0) << std::strerror(errno);
    char name[256];
    ASSERT_EQ(::ttyname_r(slave, name, sizeof(name)), 0);
    path_ = name;
    bus_ = std::make_unique<SerialBus>(path_, baud, filters);
    ::close(slave);  // the bus has its own descriptor
    const int fl = ::fcntl(master_, F_GETFL);
    ASSERT_EQ(::fcntl(master_, F_SETFL, fl | O_NONBLOCK), 0);
  }

  void reopen_with(std::span<const CanFilter> filters) {
    bus_.reset();
    ::close(master_);
    open_pty(filters);
  }

  // Writes all of `bytes` to the master side.
  void put(std::span<const std::uint8_t> bytes) {
    ASSERT_TRUE(numen::test::write_all(master_, bytes)) << std::strerror(errno);
  }


  // Reads from the master what is there now, after waiting up to `timeout_ms` for a first
  // byte.
  Bytes take(int timeout_ms) {
    Bytes out;
    std::array<std::uint8_t, 4096> buf{};
    while (wait_readable(master_, out.empty() ? timeout_ms : 0)) {
      const ssize_t n = ::read(master_, buf.data(), buf.size());
      if (n <= 0) break;
      out.insert(out.end(), buf.begin(), buf.begin() + n);
    }
    return out;
  }

  // Reads from the master until `n` bytes came (or 2 s passed).
  Bytes take_n(std::size_t n) {
    Bytes out;
    const std::int64_t deadline = now_ns() + 2'000'000'000;
    while (out.size() < n && now_ns() < deadline) {
      const Bytes more = take(10);
      out.insert(out.end(), more.begin(), more.end());
    }
    return out;
  }

  // Waits until the bus's descriptor has at least `n` unread bytes (a pseudo-terminal moves
  // bytes through a kernel worker, so they are not there the moment put() returns).
  bool wait_at_bus(std::size_t n) {
    const std::int64_t deadline = now_ns() + 2'000'000'000;
    for (;;) {
      int queued = 0;
      if (::ioctl(bus_->native_handle(), FIONREAD, &queued) != 0) return false;
      if (static_cast<std::size_t>(queued) >= n) return true;
      if (now_ns() > deadline) return false;
      ::usleep(1000);
    }
  }

  // Writes `line` to the master, waits until all of it reached the bus, then reads frames
  // until the bus has none.
  std::vector<CanFrame> deliver(const Bytes& line) {
    put(line);
    EXPECT_TRUE(wait_at_bus(line.size()));
    std::vector<CanFrame> got;
    CanFrame f;
    IoStatus s;
    while ((s = bus_->read(f)) == IoStatus::kOk) got.push_back(f);
    EXPECT_EQ(s, IoStatus::kWouldBlock);
    return got;
  }

  // bus_->read() until a frame comes (waiting on the descriptor), or a timeout.
  IoStatus read_frame(CanFrame& f, int timeout_ms = 1000) {
    for (;;) {
      const IoStatus s = bus_->read(f);
      if (s != IoStatus::kWouldBlock) return s;
      if (!wait_readable(bus_->native_handle(), timeout_ms)) return IoStatus::kWouldBlock;
    }
  }

  static std::vector<CanFrame> decode(const Bytes& line, SerialFrameDecoder& dec) {
    std::vector<CanFrame> frames;
    std::span<const std::uint8_t> rest(line);
    while (!rest.empty()) {
      CanFrame f;
      const SerialFrameDecoder::Result r = dec.feed(rest, f);
      if (r.frame_ready) frames.push_back(f);
      rest = rest.subspan(r.consumed);
    }
    return frames;
  }

  int master_ = -1;
  std::string path_;
  std::unique_ptr<SerialBus> bus_;
};

TEST_F(SerialBusPty, OpensRawAndReportsOk) {
  EXPECT_EQ(bus_->state(), BusState::kOk);
  EXPECT_EQ(bus_->path(), path_);
  EXPECT_EQ(bus_->baud(), 115200u);
  EXPECT_GE(bus_->native_handle(), 0);
  EXPECT_EQ(bus_->tx_pending(), 0u);
  CanFrame f;
  EXPECT_EQ(bus_->read(f), IoStatus::kWouldBlock);
}

TEST_F(SerialBusPty, FramesRoundTripFromTheLineWithReceiveTimestamps) {
  for (const CanFrame& sent : all_kinds()) {
    const std::int64_t before = now_ns();
    put(encode(sent));
    CanFrame got;
    ASSERT_EQ(read_frame(got), IoStatus::kOk);
    const std::int64_t after = now_ns();
    expect_identical(got, sent);
    EXPECT_GE(got.timestamp_ns, before);
    EXPECT_LE(got.timestamp_ns, after);
  }
  const std::size_t n = all_kinds().size();
  EXPECT_EQ(bus_->counters().frames_rx, n);
  EXPECT_EQ(bus_->serial_counters().frames, n);
  EXPECT_EQ(bus_->serial_counters().rejected(), 0u);
  EXPECT_EQ(bus_->counters().dropped, 0u);
}

TEST_F(SerialBusPty, FramesRoundTripOntoTheLine) {
  Bytes expected;
  for (const CanFrame& f : all_kinds()) {
    ASSERT_EQ(bus_->write(f), IoStatus::kOk);
    const Bytes e = encode(f);
    expected.insert(expected.end(), e.begin(), e.end());
  }
  EXPECT_EQ(bus_->tx_pending(), 0u);
  const Bytes line = take_n(expected.size());
  EXPECT_EQ(line, expected);  // byte exact: no CR/LF or XON/XOFF processing
  SerialFrameDecoder dec;
  const std::vector<CanFrame> got = decode(line, dec);
  const std::vector<CanFrame> sent = all_kinds();
  ASSERT_EQ(got.size(), sent.size());
  for (std::size_t i = 0; i < sent.size(); ++i) expect_identical(got[i], sent[i]);
  EXPECT_EQ(bus_->counters().frames_tx, sent.size());
}

TEST_F(SerialBusPty, WorkedExampleGoesOnTheLineByteForByte) {
  ASSERT_EQ(bus_->write(make(0x181, 0, {0x34, 0x12, 0x00, 0x00})), IoStatus::kOk);
  EXPECT_EQ(take_n(14), (Bytes{0x01, 0x03, 0x81, 0x01, 0x01, 0x04, 0x04, 0x34, 0x12, 0x01, 0x03,
                               0xB0, 0x66, 0x00}));
}

// The line of the resynchronisation test: good frames with garbage, a torn frame and a
// flipped bit between them.
struct DamagedLine {
  Bytes bytes;
  std::vector<CanFrame> survivors;
  std::size_t garbage_bytes = 0;
};

DamagedLine damaged_line() {
  DamagedLine d;
  std::vector<CanFrame> good;
  for (std::uint8_t i = 0; i < 8; ++i) {
    good.push_back(make(0x181 + i, i % 2 ? CanFlag::kFd : 0, Bytes(i % 2 ? 12 : 8, i)));
  }
  auto add = [&](const Bytes& b) { d.bytes.insert(d.bytes.end(), b.begin(), b.end()); };
  add(encode(good[0]));
  add(encode(good[1]));
  Bytes garbage(150);  // no delimiter for 150 bytes: over-long, then skipped to the 0x00
  for (std::size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<std::uint8_t>(0x80 | i);
  add(garbage);
  add({0x00});
  add(encode(good[2]));
  const Bytes torn = encode(good[3]);  // only its first 6 bytes, then a delimiter
  add(Bytes(torn.begin(), torn.begin() + 6));
  add({0x00});
  add(encode(good[4]));
  Bytes flipped = encode(good[5]);
  flipped[10] ^= 0x20;  // one bit of the FD payload
  add(flipped);
  add(encode(good[6]));
  add(encode(good[7]));
  d.survivors = {good[0], good[1], good[2], good[4], good[6], good[7]};
  d.garbage_bytes = 150 + 6 + (flipped.size() - 1);
  return d;
}

void expect_damage_counters(const SerialBus& bus, const DamagedLine& d) {
  const SerialCounters c = bus.serial_counters();
  EXPECT_EQ(c.frames, d.survivors.size());
  EXPECT_EQ(c.torn_frames, 2u);  // the over-long garbage and the 6-byte stub
  EXPECT_EQ(c.crc_errors, 1u);
  EXPECT_EQ(c.cobs_errors, 0u);
  EXPECT_EQ(c.malformed_frames, 0u);
  EXPECT_EQ(c.filtered, 0u);
  EXPECT_EQ(c.garbage_bytes, d.garbage_bytes);
  EXPECT_EQ(c.resyncs, 3u);
  EXPECT_EQ(bus.counters().dropped, 3u);
  EXPECT_EQ(bus.counters().frames_rx, d.survivors.size());
}

TEST_F(SerialBusPty, DamageOnTheLineCostsOnlyTheDamagedFrames) {
  const DamagedLine d = damaged_line();
  const std::vector<CanFrame> got = deliver(d.bytes);
  // 8 frames sent, 2 damaged (torn, flipped bit): exactly the other 6 arrive, in order.
  ASSERT_EQ(got.size(), d.survivors.size());
  for (std::size_t i = 0; i < got.size(); ++i) expect_identical(got[i], d.survivors[i]);
  expect_damage_counters(*bus_, d);
  EXPECT_EQ(bus_->state(), BusState::kOk);
}

TEST_F(SerialBusPty, ByteAtATimeOnTheLineGivesTheSameResult) {
  const DamagedLine d = damaged_line();
  std::vector<CanFrame> got;
  for (std::uint8_t b : d.bytes) {
    put(std::span<const std::uint8_t>(&b, 1));
    ASSERT_TRUE(wait_readable(bus_->native_handle(), 1000));
    CanFrame f;
    const IoStatus s = bus_->read(f);  // one byte read: at most one frame completes
    ASSERT_NE(s, IoStatus::kError);
    if (s == IoStatus::kOk) got.push_back(f);
  }
  CanFrame f;
  EXPECT_EQ(bus_->read(f), IoStatus::kWouldBlock);
  ASSERT_EQ(got.size(), d.survivors.size());
  for (std::size_t i = 0; i < got.size(); ++i) expect_identical(got[i], d.survivors[i]);
  expect_damage_counters(*bus_, d);
}

TEST_F(SerialBusPty, PartialFrameGivesWouldBlockAndIsKeptForTheNextRead) {
  const CanFrame sent = make(0x1ABCDEF1, CanFlag::kExtendedId | CanFlag::kFd, Bytes(48, 0x5C));
  const Bytes e = encode(sent);
  const std::size_t half = e.size() / 2;
  put(std::span<const std::uint8_t>(e).first(half));
  ASSERT_TRUE(wait_readable(bus_->native_handle(), 1000));
  CanFrame f = make(0x7AA, 0, {1});
  EXPECT_EQ(bus_->read(f), IoStatus::kWouldBlock);
  EXPECT_EQ(f.id, 0x7AAu);  // untouched
  EXPECT_EQ(bus_->read(f), IoStatus::kWouldBlock);
  const SerialCounters c = bus_->serial_counters();
  EXPECT_EQ(c.rejected(), 0u);
  EXPECT_EQ(c.garbage_bytes, 0u);
  EXPECT_EQ(bus_->counters().errors, 0u);
  put(std::span<const std::uint8_t>(e).subspan(half));
  ASSERT_EQ(read_frame(f), IoStatus::kOk);
  expect_identical(f, sent);
  EXPECT_EQ(bus_->serial_counters().frames, 1u);
}

TEST_F(SerialBusPty, FiltersDropFramesInUserSpaceAndCountThem) {
  const std::array<CanFilter, 2> filters{exact_standard_filter(0x181),
                                         exact_standard_filter(0x701)};
  reopen_with(filters);
  const std::vector<CanFrame> line{
      make(0x181, 0, {1}),
      make(0x182, 0, {2}),                     // other id
      make(0x181, CanFlag::kExtendedId, {3}),  // 29-bit with the same number
      make(0x701, 0, {0x05}),
      make(0x004, CanFlag::kErrorFrame, {0, 1}),  // error reports always pass
      make(0x181, CanFlag::kRemote, {}),          // remote request of 0x181
  };
  Bytes bytes;
  for (const CanFrame& f : line) {
    const Bytes e = encode(f);
    bytes.insert(bytes.end(), e.begin(), e.end());
  }
  const std::vector<CanFrame> got = deliver(bytes);
  ASSERT_EQ(got.size(), 3u);
  expect_identical(got[0], line[0]);
  expect_identical(got[1], line[3]);
  expect_identical(got[2], line[4]);
  EXPECT_EQ(bus_->serial_counters().filtered, 3u);
  EXPECT_EQ(bus_->serial_counters().frames, 6u);
  EXPECT_EQ(bus_->counters().frames_rx, 3u);
  EXPECT_EQ(bus_->counters().dropped, 0u);
}

TEST_F(SerialBusPty, FullDriverQueueKeepsPartialWritesPendingAndRefusesWhatDoesNotFit) {
  // Nobody reads the master: the kernel queue fills, writes go partial, then the bus buffer.
  std::vector<CanFrame> accepted;
  IoStatus s = IoStatus::kOk;
  for (std::uint32_t i = 0; i < 100000 && s == IoStatus::kOk; ++i) {
    const CanFrame f =
        make(0x100 + (i % 0x600), CanFlag::kFd, Bytes(64, static_cast<std::uint8_t>(i)));
    s = bus_->write(f);
    if (s == IoStatus::kOk) accepted.push_back(f);
  }
  ASSERT_EQ(s, IoStatus::kWouldBlock);
  const std::size_t max_line = kSerialMaxFrameOnLine;
  EXPECT_GT(bus_->tx_pending() + max_line, SerialBus::kTxBufferSize);  // really full
  EXPECT_LE(bus_->tx_pending(), SerialBus::kTxBufferSize);
  EXPECT_EQ(bus_->counters().tx_would_block, 1u);
  // The same frame again: refused again and counted — unless the kernel made room in
  // between, which it may do with nobody reading: the pty hands queued bytes on to the
  // master's side asynchronously, from a kernel worker (seen once in CI: the second write
  // was taken, counted and delivered). Either way nothing is lost or counted twice.
  const IoStatus again = bus_->write(accepted.back());
  ASSERT_NE(again, IoStatus::kError);
  if (again == IoStatus::kOk) accepted.push_back(accepted.back());
  EXPECT_EQ(bus_->counters().tx_would_block, again == IoStatus::kWouldBlock ? 2u : 1u);
  EXPECT_EQ(bus_->counters().frames_tx, accepted.size());

  // Drain the far end while flushing: every accepted frame arrives once, intact, in order.
  const std::size_t expected = accepted.size() * kSerialMaxFrameOnLine;  // 74 bytes each
  const std::int64_t deadline = now_ns() + 5'000'000'000;
  Bytes line;
  while (line.size() < expected && now_ns() < deadline) {
    const Bytes got = take(5);
    line.insert(line.end(), got.begin(), got.end());
    ASSERT_NE(bus_->flush(), IoStatus::kError);
  }
  EXPECT_EQ(bus_->tx_pending(), 0u);
  EXPECT_EQ(line.size(), expected);
  SerialFrameDecoder dec;
  const std::vector<CanFrame> got = decode(line, dec);
  EXPECT_EQ(dec.counters().rejected(), 0u);
  EXPECT_EQ(dec.buffered(), 0u);
  ASSERT_EQ(got.size(), accepted.size());
  for (std::size_t i = 0; i < got.size(); ++i) expect_identical(got[i], accepted[i]);
  // And the port writes again.
  EXPECT_EQ(bus_->write(make(0x42, 0, {})), IoStatus::kOk);
}

TEST_F(SerialBusPty, PendingBytesGoOutBeforeTheNextFrame) {
  // Fill the driver until a write leaves bytes pending, then write one more frame after the
  // far end made room: the line shows the pending tail before the new frame.
  std::uint32_t i = 0;
  while (bus_->tx_pending() == 0 && i < 100000) {
    ASSERT_EQ(bus_->write(make(0x100, CanFlag::kFd, Bytes(64, static_cast<std::uint8_t>(i)))),
              IoStatus::kOk);
    ++i;
  }
  ASSERT_GT(bus_->tx_pending(), 0u);
  Bytes line = take(5);  // room in the driver again
  ASSERT_EQ(bus_->write(make(0x7FF, 0, {0xEE})), IoStatus::kOk);
  const std::size_t expected = i * kSerialMaxFrameOnLine + 11;
  const std::int64_t deadline = now_ns() + 5'000'000'000;
  while (line.size() < expected && now_ns() < deadline) {
    const Bytes more = take(5);
    line.insert(line.end(), more.begin(), more.end());
    ASSERT_NE(bus_->flush(), IoStatus::kError);
  }
  EXPECT_EQ(line.size(), expected);
  SerialFrameDecoder dec;
  const std::vector<CanFrame> got = decode(line, dec);
  EXPECT_EQ(dec.counters().rejected(), 0u);
  ASSERT_EQ(got.size(), i + 1);
  for (std::uint32_t k = 0; k < i; ++k) EXPECT_EQ(got[k].data[0], static_cast<std::uint8_t>(k));
  EXPECT_EQ(got.back().id, 0x7FFu);
}

TEST_F(SerialBusPty, MalformedFrameIsAnErrorAndNothingIsSent) {
  CanFrame bad = make(0x100, 0, Bytes(8, 1));
  bad.len = 9;
  EXPECT_EQ(bus_->write(bad), IoStatus::kError);
  EXPECT_EQ(bus_->write(make(0x100, 0x80, {})), IoStatus::kError);  // reserved flag
  EXPECT_EQ(bus_->counters().errors, 2u);
  EXPECT_EQ(bus_->counters().frames_tx, 0u);
  EXPECT_EQ(bus_->state(), BusState::kOk);  // the line is fine
  // The next good frame is the first thing on the line.
  const Bytes good = encode(make(0x100, 0, {1}));
  ASSERT_EQ(bus_->write(make(0x100, 0, {1})), IoStatus::kOk);
  EXPECT_EQ(take_n(good.size()), good);
  EXPECT_TRUE(take(20).empty());
}

TEST_F(SerialBusPty, HangUpOnReadIsBusOffAndSticky) {
  ::close(master_);
  master_ = -1;
  CanFrame f;
  EXPECT_EQ(bus_->read(f), IoStatus::kError);
  EXPECT_EQ(bus_->state(), BusState::kBusOff);
  EXPECT_EQ(bus_->last_error(), 0);  // read(2) returned 0: hang-up
  EXPECT_EQ(bus_->read(f), IoStatus::kError);
  EXPECT_EQ(bus_->write(make(1, 0, {})), IoStatus::kError);
  EXPECT_EQ(bus_->flush(), IoStatus::kError);
  EXPECT_EQ(bus_->counters().errors, 4u);
}

TEST_F(SerialBusPty, EioOnWriteIsBusOff) {
  ::close(master_);
  master_ = -1;
  EXPECT_EQ(bus_->write(make(1, 0, {})), IoStatus::kError);
  EXPECT_EQ(bus_->state(), BusState::kBusOff);
  EXPECT_EQ(bus_->last_error(), EIO);
  EXPECT_EQ(bus_->counters().frames_tx, 0u);
  EXPECT_EQ(bus_->counters().errors, 1u);
}

TEST_F(SerialBusPty, ReadAndWriteLoopsDoNotAllocate) {
  const std::array<CanFilter, 1> filters{CanFilter{0x100, 0x700}};
  reopen_with(filters);
  const CanFrame out = make(0x181, CanFlag::kFd, Bytes(64, 0x3C));
  const Bytes in_pass = encode(make(0x123, 0, {1, 2, 3, 4}));
  const Bytes in_filtered = encode(make(0x281, 0, {1}));
  std::array<std::uint8_t, 512> buf{};
  SerialFrameDecoder far_end;
  std::size_t received = 0;
  std::size_t echoed = 0;
  {
    numen::test::AllocationGuard guard;
    for (int i = 0; i < 200; ++i) {
      ASSERT_EQ(bus_->write(out), IoStatus::kOk);
      ASSERT_EQ(::write(master_, in_filtered.data(), in_filtered.size()),
                static_cast<ssize_t>(in_filtered.size()));
      ASSERT_EQ(::write(master_, in_pass.data(), in_pass.size()),
                static_cast<ssize_t>(in_pass.size()));
      CanFrame f;
      IoStatus s = IoStatus::kWouldBlock;
      while (s == IoStatus::kWouldBlock) {
        s = bus_->read(f);
        if (s == IoStatus::kWouldBlock) {
          ASSERT_TRUE(wait_readable(bus_->native_handle(), 1000));
        }
      }
      ASSERT_EQ(s, IoStatus::kOk);
      received += f.id == 0x123u;
      // The far end reads what the bus wrote.
      while (wait_readable(master_, 0)) {
        const ssize_t n = ::read(master_, buf.data(), buf.size());
        std::span<const std::uint8_t> rest(buf.data(), n > 0 ? static_cast<std::size_t>(n) : 0);
        while (!rest.empty()) {
          const SerialFrameDecoder::Result r = far_end.feed(rest, f);
          echoed += r.frame_ready;
          rest = rest.subspan(r.consumed);
        }
      }
    }
    EXPECT_EQ(guard.count(), 0);
  }
  const std::int64_t deadline = now_ns() + 2'000'000'000;
  while (echoed < 200 && now_ns() < deadline) echoed += decode(take(10), far_end).size();
  EXPECT_EQ(received, 200u);
  EXPECT_EQ(echoed, 200u);
  EXPECT_EQ(bus_->serial_counters().filtered, 200u);
}

TEST(SerialBus, EverySupportedBaudOpens) {
  const std::span<const std::uint32_t> bauds = serial_supported_bauds();
  ASSERT_EQ(bauds.size(), 18u);
  EXPECT_EQ(bauds.front(), 9600u);
  EXPECT_EQ(bauds.back(), 4000000u);
  for (std::size_t i = 1; i < bauds.size(); ++i) EXPECT_LT(bauds[i - 1], bauds[i]);
  for (std::uint32_t baud : bauds) {
    int master = -1;
    int slave = -1;
    ASSERT_EQ(::openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
    char name[256];
    ASSERT_EQ(::ttyname_r(slave, name, sizeof(name)), 0);
    {
      SerialBus bus(name, baud);
      EXPECT_EQ(bus.state(), BusState::kOk) << baud;
    }
    ::close(slave);
    ::close(master);
  }
}

template <typename E>
std::string what_of(auto&& fn) {
  try {
    fn();
  } catch (const E& e) {
    return e.what();
  }
  return "(no exception)";
}

TEST(SerialBus, OpenErrorsNameThePathAndTheCause) {
  const std::string missing =
      what_of<std::runtime_error>([] { SerialBus bus("/nonexistent/ttyUSB9", 115200); });
  EXPECT_NE(missing.find("/nonexistent/ttyUSB9"), std::string::npos) << missing;
  EXPECT_NE(missing.find("open"), std::string::npos) << missing;
  EXPECT_NE(missing.find(std::strerror(ENOENT)), std::string::npos) << missing;

  const std::string not_tty = what_of<std::runtime_error>([] { SerialBus bus("/dev/null", 9600); });
  EXPECT_NE(not_tty.find("/dev/null"), std::string::npos) << not_tty;
  EXPECT_NE(not_tty.find(std::strerror(ENOTTY)), std::string::npos) << not_tty;

  const std::string baud =
      what_of<std::invalid_argument>([] { SerialBus bus("/dev/ttyS0", 12345); });
  EXPECT_NE(baud.find("12345"), std::string::npos) << baud;
  EXPECT_NE(baud.find("/dev/ttyS0"), std::string::npos) << baud;
  EXPECT_NE(baud.find("115200"), std::string::npos) << baud;  // lists what is supported
}

}  // namespace
}  // namespace numen::hal
