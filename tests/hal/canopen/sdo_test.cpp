// Tests of numen/hal/canopen/sdo.hpp: the frames byte for byte as CiA 301 §7.2.4.3 lays them
// out, the abort code names, and SdoClient against scripted server frames: expedited and
// segmented transfers, server aborts, every protocol error the client detects, the timeout,
// frames it must ignore, and no allocation.
#include "numen/hal/canopen/sdo.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <initializer_list>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "can_test_frames.hpp"

namespace {

using namespace numen::hal;

using numen::test::raw_frame;

std::vector<std::uint8_t> bytes_of(const CanFrame& f) {
  return std::vector<std::uint8_t>(f.data.begin(), f.data.begin() + f.len);
}

/// The client's next request, which must exist.
CanFrame request(SdoClient& c, std::int64_t now = 0) {
  CanFrame f;
  EXPECT_TRUE(c.take_request(f, now));
  return f;
}

TEST(SdoFrames, RequestsAreByteExact) {
  // Read 0x1018:01 (identity, vendor id) of node 5.
  SdoFrame f;
  f.kind = SdoFrameKind::kInitiateUploadRequest;
  f.address = {0x1018, 0x01};
  CanFrame c;
  ASSERT_TRUE(encode_sdo(f, sdo_request_cob_id(5), 7, c));
  EXPECT_EQ(c.id, 0x605u);
  EXPECT_EQ(c.timestamp_ns, 7);
  EXPECT_EQ(bytes_of(c), (std::vector<std::uint8_t>{0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}));
  // Expedited download of 1, 2 and 4 bytes: 2F, 2B, 23 (n = 3, 2, 0; e = s = 1).
  f.kind = SdoFrameKind::kInitiateDownloadRequest;
  f.address = {0x6060, 0x00};
  f.expedited = true;
  f.data_len = 1;
  f.data[0] = 0x0A;  // modes of operation: cyclic synchronous torque
  ASSERT_TRUE(encode_sdo(f, 0x601, 0, c));
  EXPECT_EQ(bytes_of(c), (std::vector<std::uint8_t>{0x2F, 0x60, 0x60, 0x00, 0x0A, 0, 0, 0}));
  f.data_len = 2;
  f.data[1] = 0x01;
  ASSERT_TRUE(encode_sdo(f, 0x601, 0, c));
  EXPECT_EQ(c.data[0], 0x2B);
  f.data_len = 4;
  ASSERT_TRUE(encode_sdo(f, 0x601, 0, c));
  EXPECT_EQ(c.data[0], 0x23);
  // Segmented download initiate with the size: 21 idx sub size.
  f = SdoFrame{};
  f.kind = SdoFrameKind::kInitiateDownloadRequest;
  f.address = {0x1008, 0x00};
  f.size_indicated = true;
  f.size = 11;
  ASSERT_TRUE(encode_sdo(f, 0x601, 0, c));
  EXPECT_EQ(bytes_of(c), (std::vector<std::uint8_t>{0x21, 0x08, 0x10, 0x00, 11, 0, 0, 0}));
  // Download segment, toggle 1, 2 bytes, last: 0x10 | (7 − 2) << 1 | 1 = 0x1B.
  f = SdoFrame{};
  f.kind = SdoFrameKind::kDownloadSegmentRequest;
  f.toggle = true;
  f.last = true;
  f.data_len = 2;
  f.data[0] = 'a';
  f.data[1] = 'b';
  ASSERT_TRUE(encode_sdo(f, 0x601, 0, c));
  EXPECT_EQ(bytes_of(c), (std::vector<std::uint8_t>{0x1B, 'a', 'b', 0, 0, 0, 0, 0}));
  // Upload segment requests: 60, 70.
  f = SdoFrame{};
  f.kind = SdoFrameKind::kUploadSegmentRequest;
  ASSERT_TRUE(encode_sdo(f, 0x601, 0, c));
  EXPECT_EQ(c.data[0], 0x60);
  f.toggle = true;
  ASSERT_TRUE(encode_sdo(f, 0x601, 0, c));
  EXPECT_EQ(c.data[0], 0x70);
  // Abort: 80 idx sub code (little endian).
  f = SdoFrame{};
  f.kind = SdoFrameKind::kAbort;
  f.address = {0x1018, 0x02};
  f.abort_code = SdoAbort::kNoObject;
  ASSERT_TRUE(encode_sdo(f, 0x601, 0, c));
  EXPECT_EQ(bytes_of(c), (std::vector<std::uint8_t>{0x80, 0x18, 0x10, 0x02, 0x00, 0x00, 0x02, 0x06}));
  // Block transfers and out-of-range lengths are not encoded.
  f.kind = SdoFrameKind::kBlock;
  EXPECT_FALSE(encode_sdo(f, 0x601, 0, c));
  f.kind = SdoFrameKind::kInitiateDownloadRequest;
  f.expedited = true;
  f.data_len = 5;
  EXPECT_FALSE(encode_sdo(f, 0x601, 0, c));
}

TEST(SdoFrames, ResponsesDecodeAsCiA301LaysThemOut) {
  SdoFrame f;
  // Expedited upload response, 2 bytes (n = 2): 4B.
  ASSERT_EQ(
      decode_sdo(raw_frame(0x585, {0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0xAA, 0xAA}), 0x585, f),
      SdoDecodeStatus::kOk);
  EXPECT_EQ(f.kind, SdoFrameKind::kInitiateUploadResponse);
  EXPECT_EQ(f.address, (SdoAddress{0x1017, 0x00}));
  EXPECT_TRUE(f.expedited);
  ASSERT_EQ(f.data_len, 2);
  EXPECT_EQ(f.data[0] | f.data[1] << 8, 1000);  // heartbeat producer time 1000 ms
  // Expedited without the size: all 4 bytes.
  ASSERT_EQ(decode_sdo(raw_frame(0x585, {0x42, 0x00, 0x10, 0x00, 1, 2, 3, 4}), 0x585, f),
            SdoDecodeStatus::kOk);
  EXPECT_EQ(f.data_len, 4);
  // Segmented with the size.
  ASSERT_EQ(decode_sdo(raw_frame(0x585, {0x41, 0x08, 0x10, 0x00, 20, 0, 0, 0}), 0x585, f),
            SdoDecodeStatus::kOk);
  EXPECT_FALSE(f.expedited);
  EXPECT_TRUE(f.size_indicated);
  EXPECT_EQ(f.size, 20u);
  // Upload segment, toggle 1, 3 bytes (n = 4), last: 0x19.
  ASSERT_EQ(decode_sdo(raw_frame(0x585, {0x19, 'x', 'y', 'z', 0, 0, 0, 0}), 0x585, f),
            SdoDecodeStatus::kOk);
  EXPECT_EQ(f.kind, SdoFrameKind::kUploadSegmentResponse);
  EXPECT_TRUE(f.toggle);
  EXPECT_TRUE(f.last);
  EXPECT_EQ(f.data_len, 3);
  EXPECT_EQ(f.data[2], 'z');
  // Download responses: 60 (initiate), 20 / 30 (segment, toggle).
  ASSERT_EQ(decode_sdo(raw_frame(0x585, {0x60, 0x60, 0x60, 0x00, 0, 0, 0, 0}), 0x585, f),
            SdoDecodeStatus::kOk);
  EXPECT_EQ(f.kind, SdoFrameKind::kInitiateDownloadResponse);
  ASSERT_EQ(decode_sdo(raw_frame(0x585, {0x30, 0, 0, 0, 0, 0, 0, 0}), 0x585, f),
            SdoDecodeStatus::kOk);
  EXPECT_EQ(f.kind, SdoFrameKind::kDownloadSegmentResponse);
  EXPECT_TRUE(f.toggle);
  // Abort.
  ASSERT_EQ(
      decode_sdo(raw_frame(0x585, {0x80, 0x00, 0x20, 0x01, 0x11, 0x00, 0x09, 0x06}), 0x585, f),
      SdoDecodeStatus::kOk);
  EXPECT_EQ(f.kind, SdoFrameKind::kAbort);
  EXPECT_EQ(f.abort_code, SdoAbort::kNoSubIndex);
  // The same command byte on the request channel reads as the client's service.
  ASSERT_EQ(decode_sdo(raw_frame(0x605, {0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}), 0x605, f),
            SdoDecodeStatus::kOk);
  EXPECT_EQ(f.kind, SdoFrameKind::kInitiateUploadRequest);
  ASSERT_EQ(decode_sdo(raw_frame(0x605, {0xA0, 0, 0, 0, 0, 0, 0, 0}), 0x605, f),
            SdoDecodeStatus::kOk);
  EXPECT_EQ(f.kind, SdoFrameKind::kBlock);
}

TEST(SdoFrames, FramesOffTheChannelOrOfTheWrongKindAreRefused) {
  SdoFrame f;
  EXPECT_EQ(decode_sdo(raw_frame(0x586, {0x60, 0, 0, 0, 0, 0, 0, 0}), 0x585, f),
            SdoDecodeStatus::kWrongId);
  CanFrame ext = raw_frame(0x585, {0x60, 0, 0, 0, 0, 0, 0, 0});
  ext.flags = CanFlag::kExtendedId;
  EXPECT_EQ(decode_sdo(ext, 0x585, f), SdoDecodeStatus::kWrongId);
  CanFrame err = ext;
  err.flags = CanFlag::kErrorFrame;
  EXPECT_EQ(decode_sdo(err, 0x585, f), SdoDecodeStatus::kWrongId);
  CanFrame fd = raw_frame(0x585, {0x60, 0, 0, 0, 0, 0, 0, 0});
  fd.flags = CanFlag::kFd;
  EXPECT_EQ(decode_sdo(fd, 0x585, f), SdoDecodeStatus::kNotDataFrame);
  CanFrame rtr = raw_frame(0x585, {});
  rtr.flags = CanFlag::kRemote;
  EXPECT_EQ(decode_sdo(rtr, 0x585, f), SdoDecodeStatus::kNotDataFrame);
  EXPECT_EQ(decode_sdo(raw_frame(0x585, {0x60, 0, 0}), 0x585, f), SdoDecodeStatus::kWrongLength);
}

TEST(SdoAbortNames, TheStandardTableByCode) {
  EXPECT_STREQ(sdo_abort_name(0x06020000), "object does not exist in the object dictionary");
  EXPECT_STREQ(sdo_abort_name(0x05040000), "SDO protocol timed out");
  EXPECT_STREQ(sdo_abort_name(0x06010002), "attempt to write a read only object");
  EXPECT_STREQ(sdo_abort_name(0x08000022),
               "data cannot be transferred or stored to the application because of the present "
               "device state");
  EXPECT_STREQ(sdo_abort_name(0x12345678), "unknown abort code");
}

TEST(SdoClient, ExpeditedUpload) {
  SdoClient c(5);
  std::array<std::uint8_t, 4> buf{};
  ASSERT_TRUE(c.start_upload({0x1000, 0}, buf, 0));
  EXPECT_EQ(c.status(), SdoStatus::kPending);
  EXPECT_EQ(bytes_of(request(c)), (std::vector<std::uint8_t>{0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}));
  CanFrame none;
  EXPECT_FALSE(c.take_request(none, 0));  // one request per response
  EXPECT_TRUE(c.on_frame(raw_frame(0x585, {0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00})));
  EXPECT_EQ(c.status(), SdoStatus::kDone);
  EXPECT_EQ(c.transferred(), 4u);
  EXPECT_EQ(buf[0] | buf[1] << 8 | buf[2] << 16 | buf[3] << 24, 0x00020192);  // CiA 402 drive
  EXPECT_EQ(c.counters().completed, 1u);
}

TEST(SdoClient, SegmentedUploadAlternatesTheToggle) {
  SdoClient c(5);
  std::array<std::uint8_t, 32> buf{};
  const std::string name = "numen drive 3";  // 13 bytes: 7 + 6
  ASSERT_TRUE(c.start_upload({0x1008, 0}, buf, 0));
  request(c);
  c.on_frame(raw_frame(0x585, {0x41, 0x08, 0x10, 0x00, 13, 0, 0, 0}));
  EXPECT_EQ(c.announced_size(), 13u);
  EXPECT_EQ(request(c).data[0], 0x60);  // toggle 0
  CanFrame seg = raw_frame(0x585, {0x00, 0, 0, 0, 0, 0, 0, 0});
  std::memcpy(&seg.data[1], name.data(), 7);
  c.on_frame(seg);
  EXPECT_EQ(request(c).data[0], 0x70);  // toggle 1
  seg = raw_frame(0x585, {0x10 | (1 << 1) | 1, 0, 0, 0, 0, 0, 0, 0});  // toggle 1, 6 bytes, last
  std::memcpy(&seg.data[1], name.data() + 7, 6);
  c.on_frame(seg);
  EXPECT_EQ(c.status(), SdoStatus::kDone);
  EXPECT_EQ(std::string(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(c.transferred())), name);
}

TEST(SdoClient, ExpeditedAndSegmentedDownloads) {
  SdoClient c(1);
  const std::array<std::uint8_t, 2> hb{0xE8, 0x03};
  ASSERT_TRUE(c.start_download({0x1017, 0}, hb, 0));
  EXPECT_EQ(bytes_of(request(c)), (std::vector<std::uint8_t>{0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0}));
  c.on_frame(raw_frame(0x581, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(c.status(), SdoStatus::kDone);

  const std::string text = "left pivot encoder";  // 18 bytes: 7 + 7 + 4
  const std::span<const std::uint8_t> data(reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
  ASSERT_TRUE(c.start_download({0x1008, 0}, data, 0));
  EXPECT_EQ(bytes_of(request(c)), (std::vector<std::uint8_t>{0x21, 0x08, 0x10, 0x00, 18, 0, 0, 0}));
  c.on_frame(raw_frame(0x581, {0x60, 0x08, 0x10, 0x00, 0, 0, 0, 0}));
  CanFrame s1 = request(c);
  EXPECT_EQ(s1.data[0], 0x00);  // toggle 0, 7 bytes, more
  EXPECT_EQ(std::memcmp(&s1.data[1], text.data(), 7), 0);
  c.on_frame(raw_frame(0x581, {0x20, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(request(c).data[0], 0x10);  // toggle 1, 7 bytes, more
  c.on_frame(raw_frame(0x581, {0x30, 0, 0, 0, 0, 0, 0, 0}));
  CanFrame s3 = request(c);
  EXPECT_EQ(s3.data[0], 0x00 | (3 << 1) | 1);  // toggle 0, 4 bytes, last
  EXPECT_EQ(c.status(), SdoStatus::kPending);   // until the server confirms
  c.on_frame(raw_frame(0x581, {0x20, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(c.status(), SdoStatus::kDone);
  EXPECT_EQ(c.counters().completed, 2u);
}

TEST(SdoClient, AServerAbortIsReportedWithItsCode) {
  SdoClient c(5);
  std::array<std::uint8_t, 4> buf{};
  c.start_upload({0x2000, 1}, buf, 0);
  request(c);
  c.on_frame(raw_frame(0x585, {0x80, 0x00, 0x20, 0x01, 0x00, 0x00, 0x02, 0x06}));
  EXPECT_EQ(c.status(), SdoStatus::kAborted);
  EXPECT_TRUE(c.aborted_by_server());
  EXPECT_EQ(c.abort_code(), SdoAbort::kNoObject);
  EXPECT_STREQ(sdo_abort_name(c.abort_code()), "object does not exist in the object dictionary");
  CanFrame none;
  EXPECT_FALSE(c.take_request(none, 0));  // a server abort is not answered
  EXPECT_EQ(c.counters().server_aborts, 1u);
}

/// A client mid-way through a segmented upload of node 5 (toggle 0 requested).
void into_segments(SdoClient& c, std::span<std::uint8_t> buf, std::uint8_t size) {
  c.start_upload({0x1008, 0}, buf, 0);
  request(c);
  c.on_frame(raw_frame(0x585, {0x41, 0x08, 0x10, 0x00, size, 0, 0, 0}));
  request(c);
}

/// The abort request the client queued, with its code.
std::uint32_t queued_abort(SdoClient& c) {
  CanFrame f;
  if (!c.take_request(f, 0)) return 0;
  SdoFrame d;
  EXPECT_EQ(decode_sdo(f, 0x605, d), SdoDecodeStatus::kOk);
  EXPECT_EQ(d.kind, SdoFrameKind::kAbort);
  return d.abort_code;
}

TEST(SdoClient, ProtocolErrorsAbortWithTheStandardCode) {
  std::array<std::uint8_t, 16> buf{};
  {  // the toggle bit not alternated
    SdoClient c(5);
    into_segments(c, buf, 10);
    c.on_frame(raw_frame(0x585, {0x10, 1, 2, 3, 4, 5, 6, 7}));  // toggle 1 where 0 was asked
    EXPECT_EQ(c.status(), SdoStatus::kAborted);
    EXPECT_FALSE(c.aborted_by_server());
    EXPECT_EQ(queued_abort(c), SdoAbort::kToggleBit);
  }
  {  // a response of the wrong service
    SdoClient c(5);
    c.start_upload({0x1000, 0}, buf, 0);
    request(c);
    c.on_frame(raw_frame(0x585, {0x60, 0x00, 0x10, 0x00, 0, 0, 0, 0}));  // a download response
    EXPECT_EQ(queued_abort(c), SdoAbort::kCommandSpecifier);
  }
  {  // a response for another entry
    SdoClient c(5);
    c.start_upload({0x1000, 0}, buf, 0);
    request(c);
    c.on_frame(raw_frame(0x585, {0x43, 0x01, 0x10, 0x00, 0, 0, 0, 0}));
    EXPECT_EQ(queued_abort(c), SdoAbort::kGeneral);
  }
  {  // more than the buffer holds, announced
    SdoClient c(5);
    std::array<std::uint8_t, 8> small{};
    c.start_upload({0x1008, 0}, small, 0);
    request(c);
    c.on_frame(raw_frame(0x585, {0x41, 0x08, 0x10, 0x00, 9, 0, 0, 0}));
    EXPECT_EQ(queued_abort(c), SdoAbort::kOutOfMemory);
  }
  {  // more than announced
    SdoClient c(5);
    into_segments(c, buf, 5);
    c.on_frame(raw_frame(0x585, {0x00, 1, 2, 3, 4, 5, 6, 7}));
    EXPECT_EQ(queued_abort(c), SdoAbort::kLengthTooHigh);
  }
  {  // less than announced
    SdoClient c(5);
    into_segments(c, buf, 10);
    c.on_frame(raw_frame(0x585, {0x00 | (4 << 1) | 1, 1, 2, 3, 0, 0, 0, 0}));
    EXPECT_EQ(queued_abort(c), SdoAbort::kLengthTooLow);
  }
}

TEST(SdoClient, ASilentServerTimesOutAndIsToldSo) {
  SdoClient c(5, 100'000'000);
  std::array<std::uint8_t, 4> buf{};
  c.start_upload({0x1000, 0}, buf, 0);
  request(c, 1'000'000);
  c.poll(101'000'000);  // 100 ms after the request: not yet
  EXPECT_EQ(c.status(), SdoStatus::kPending);
  c.poll(101'000'001);
  EXPECT_EQ(c.status(), SdoStatus::kAborted);
  EXPECT_EQ(c.abort_code(), SdoAbort::kTimeout);
  EXPECT_EQ(queued_abort(c), SdoAbort::kTimeout);
  EXPECT_EQ(c.counters().timeouts, 1u);
  EXPECT_EQ(c.counters().client_aborts, 0u);
  // A late response is ignored, and the channel is free again.
  EXPECT_TRUE(c.on_frame(raw_frame(0x585, {0x43, 0x00, 0x10, 0x00, 1, 0, 0, 0})));
  EXPECT_EQ(c.counters().frames_ignored, 1u);
  EXPECT_TRUE(c.start_upload({0x1000, 0}, buf, 0));
}

TEST(SdoClient, OneTransferAtATimeAndOnlyItsOwnChannel) {
  SdoClient c(5);
  std::array<std::uint8_t, 4> buf{};
  ASSERT_TRUE(c.start_upload({0x1000, 0}, buf, 0));
  EXPECT_FALSE(c.start_upload({0x1001, 0}, buf, 0));
  EXPECT_FALSE(c.start_download({0x1017, 0}, std::span<const std::uint8_t>(buf.data(), 2), 0));
  request(c);
  EXPECT_FALSE(c.on_frame(raw_frame(0x586, {0x43, 0x00, 0x10, 0x00, 1, 0, 0, 0})));  // node 6
  EXPECT_FALSE(c.on_frame(raw_frame(0x185, {0x43, 0x00, 0x10, 0x00, 1, 0, 0, 0})));  // a TPDO
  CanFrame fd = raw_frame(0x585, {0x43, 0x00, 0x10, 0x00, 1, 0, 0, 0});
  fd.flags = CanFlag::kFd;
  EXPECT_TRUE(c.on_frame(fd));
  EXPECT_EQ(c.counters().frames_malformed, 1u);
  EXPECT_EQ(c.status(), SdoStatus::kPending);
  // Invalid nodes and empty data start nothing.
  SdoClient none(0);
  EXPECT_FALSE(none.start_upload({0x1000, 0}, buf, 0));
  SdoClient other(5);
  EXPECT_FALSE(other.start_download({0x1017, 0}, {}, 0));
  // cancel() queues an abort with the caller's code.
  c.cancel(SdoAbort::kGeneral, 0);
  EXPECT_EQ(queued_abort(c), SdoAbort::kGeneral);
}

TEST(SdoClient, ATransferDoesNotAllocate) {
  SdoClient c(5);
  std::array<std::uint8_t, 32> buf{};
  numen::test::AllocationGuard guard;
  for (int k = 0; k < 100; ++k) {
    c.start_upload({0x1008, 0}, buf, k);
    request(c, k);
    c.on_frame(raw_frame(0x585, {0x41, 0x08, 0x10, 0x00, 10, 0, 0, 0}));
    request(c, k);
    c.on_frame(raw_frame(0x585, {0x00, 1, 2, 3, 4, 5, 6, 7}));
    request(c, k);
    c.on_frame(raw_frame(0x585, {0x10 | (4 << 1) | 1, 8, 9, 10, 0, 0, 0, 0}));
    c.poll(k);
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(c.counters().completed, 100u);
}

}  // namespace
