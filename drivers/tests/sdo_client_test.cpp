// SDO client: expedited transfers against an emulated device, its abort codes, segmented
// upload, and a scripted server for the failures a real device rarely shows (timeout,
// truncated frames, toggle errors, answers for another object).
#include <gtest/gtest.h>

#include <deque>
#include <functional>
#include <string>

#include "fl/drivers/canopen_emulation.hpp"
#include "fl/drivers/canopen_sdo_client.hpp"
#include "fl/drivers/loopback_bus.hpp"

namespace fl::drivers {
namespace {

using namespace canopen;
constexpr NodeId kNode = 5;
constexpr std::int64_t kTimeoutNs = 100'000'000;  // 100 ms, as config/can.yaml

struct SdoRig {
  std::int64_t now_ns = 0;
  LoopbackHub hub{[this] { return now_ns; }};
  LoopbackBus& client_bus = hub.add_endpoint();
  LoopbackBus& device_bus = hub.add_endpoint();
  // Either an emulated device serves the bus, or `script` answers each request.
  emulation::EmulatedBusNodes devices{device_bus};
  std::function<void(const CanFrame& request)> script;
  BusClock clock{[this] { return now_ns; },
                 [this](std::int64_t duration) {
                   now_ns += duration;
                   if (script) {
                     std::array<CanFrame, 8> frames{};
                     const std::size_t count = device_bus.receive(frames);
                     for (std::size_t i = 0; i < count; ++i) {
                       script(frames[i]);
                     }
                   } else {
                     devices.poll(now_ns);
                   }
                 }};
  SdoClient client{client_bus, clock, kTimeoutNs};
};

TEST(SdoClient, ExpeditedDownloadAndUploadRoundTrip) {
  SdoRig rig;
  auto& drive = rig.devices.add_drive(kNode);
  rig.devices.poll(0);  // boot-up
  const SdoResult written = rig.client.download(kNode, {0x6060, 0}, 3, 1);
  ASSERT_TRUE(written.ok()) << written.describe();
  EXPECT_EQ(drive.state().mode, 3);
  const SdoResult read = rig.client.upload(kNode, {0x6061, 0});  // mode display follows 0x6060
  ASSERT_TRUE(read.ok()) << read.describe();
  EXPECT_EQ(read.value, 3U);
  EXPECT_EQ(read.size_bytes, 1);
  const SdoResult type = rig.client.upload(kNode, {0x1000, 0});
  EXPECT_EQ(type.value & 0xFFFFU, 402U);  // CiA 402 profile number in the low word
}

TEST(SdoClient, DeviceAbortsAreDecoded) {
  SdoRig rig;
  rig.devices.add_drive(kNode);
  rig.devices.poll(0);
  const SdoResult missing = rig.client.upload(kNode, {0x2345, 0});
  EXPECT_EQ(missing.status, SdoStatus::kAborted);
  EXPECT_EQ(missing.abort_code, sdo_abort::kNoObject);
  EXPECT_NE(missing.describe().find("object does not exist"), std::string::npos);
  const SdoResult read_only = rig.client.download(kNode, {0x6041, 0}, 0, 2);
  EXPECT_EQ(read_only.abort_code, sdo_abort::kReadOnly);
  const SdoResult wrong_size = rig.client.download(kNode, {0x6040, 0}, 0, 4);  // 0x6040 is 16 bits
  EXPECT_EQ(wrong_size.abort_code, sdo_abort::kLengthMismatch);
  const SdoResult no_sub = rig.client.upload(kNode, {0x1017, 9});
  EXPECT_EQ(no_sub.abort_code, sdo_abort::kNoSubindex);
  // A mapping may change only while its PDO is invalid (the default RPDO1 is valid).
  const SdoResult mapping = rig.client.download(kNode, {0x1600, 0}, 0, 1);
  EXPECT_EQ(mapping.abort_code, sdo_abort::kDeviceState);
  EXPECT_EQ(rig.client.counters().aborts_received, 5U);
}

TEST(SdoClient, SegmentedUploadReadsTheDeviceName) {
  SdoRig rig;
  rig.devices.add_drive(kNode);
  rig.devices.poll(0);
  const SdoResult name = rig.client.upload(kNode, {0x1008, 0});
  ASSERT_TRUE(name.ok()) << name.describe();
  // 25 characters: four segments of 7, 7, 7 and 4 bytes.
  EXPECT_EQ(std::string(name.bytes.begin(), name.bytes.end()), "FL emulated CiA 402 drive");
}

TEST(SdoClient, SilentServerTimesOutAndIsAborted) {
  SdoRig rig;
  std::deque<CanFrame> seen;
  rig.script = [&](const CanFrame& frame) { seen.push_back(frame); };
  const std::int64_t start = rig.now_ns;
  const SdoResult result = rig.client.download(kNode, {0x1017, 0}, 50, 2);
  EXPECT_EQ(result.status, SdoStatus::kTimeout);
  EXPECT_EQ(result.abort_code, sdo_abort::kTimeout);
  // Gave up after the timeout, not before, and within one poll step after it.
  EXPECT_GE(rig.now_ns - start, kTimeoutNs);
  EXPECT_LE(rig.now_ns - start, kTimeoutNs + SdoClient::kPollStepNs);
  ASSERT_EQ(seen.size(), 1U);  // the request; the abort follows without a wait
  std::array<CanFrame, 4> rest{};
  ASSERT_EQ(rig.device_bus.receive(rest), 1U);
  EXPECT_EQ(decode_sdo_request(rest[0]).kind, SdoRequestKind::kAbort);
  EXPECT_EQ(rig.client.counters().timeouts, 1U);
}

TEST(SdoClient, TruncatedResponseIsAProtocolErrorNotACrash) {
  SdoRig rig;
  rig.script = [&](const CanFrame& request) {
    CanFrame response = make_sdo_download_response(kNode, {0x1017, 0});
    response.dlc = 3;  // truncated
    (void)request;
    rig.device_bus.send(response);
  };
  const SdoResult result = rig.client.download(kNode, {0x1017, 0}, 50, 2);
  EXPECT_EQ(result.status, SdoStatus::kProtocolError);
  EXPECT_EQ(rig.client.counters().malformed_responses, 1U);
}

TEST(SdoClient, ResponseForAnotherObjectIsRefused) {
  SdoRig rig;
  rig.script = [&](const CanFrame&) {
    rig.device_bus.send(make_sdo_download_response(kNode, {0x1018, 0}));
  };
  const SdoResult result = rig.client.download(kNode, {0x1017, 0}, 50, 2);
  EXPECT_EQ(result.status, SdoStatus::kProtocolError);
  EXPECT_EQ(rig.client.counters().unexpected_responses, 1U);
}

TEST(SdoClient, ToggleErrorInSegmentedUploadAborts) {
  SdoRig rig;
  int segment = 0;
  rig.script = [&](const CanFrame& request) {
    const SdoRequest decoded = decode_sdo_request(request);
    if (decoded.kind == SdoRequestKind::kUpload) {
      rig.device_bus.send(make_sdo_upload_segmented_response(kNode, decoded.address, 14));
    } else if (decoded.kind == SdoRequestKind::kUploadSegment) {
      const std::array<std::uint8_t, 7> bytes{'a', 'b', 'c', 'd', 'e', 'f', 'g'};
      // The second segment repeats toggle 0 where 1 is due.
      rig.device_bus.send(make_sdo_upload_segment(kNode, false, bytes, segment == 1));
      ++segment;
    }
  };
  const SdoResult result = rig.client.upload(kNode, {0x1008, 0});
  EXPECT_EQ(result.status, SdoStatus::kProtocolError);
  EXPECT_EQ(result.abort_code, sdo_abort::kToggleBit);
  EXPECT_EQ(rig.client.counters().toggle_errors, 1U);
}

TEST(SdoClient, OtherFramesDuringATransferAreHandedOn) {
  SdoRig rig;
  int heartbeats = 0;
  SdoClient client(rig.client_bus, rig.clock, kTimeoutNs, [&](const CanFrame& frame) {
    heartbeats += frame.id == kHeartbeatBase + 9 ? 1 : 0;
  });
  rig.script = [&](const CanFrame&) {
    rig.device_bus.send(make_heartbeat(9, NmtState::kOperational));
    rig.device_bus.send(make_sdo_download_response(kNode, {0x1017, 0}));
  };
  EXPECT_TRUE(client.download(kNode, {0x1017, 0}, 50, 2).ok());
  EXPECT_EQ(heartbeats, 1);
}

}  // namespace
}  // namespace fl::drivers
