// Interop with a peer that shares none of the project's DDS code (tests/idl_only_peer.c: C,
// Cyclone's C API, the idlc types and the topic names and QoS from docs/dds.md). A camera node
// written from the docs is read by the controller's DdsCameraInput; an MES written from the
// docs reads the ledger the controller's DdsTelemetryPublisher writes.
#include <gtest/gtest.h>

#include <chrono>
#include <sstream>
#include <string>

#include "dds_test_support.hpp"
#include "fl/drivers/dds/camera_input.hpp"
#include "fl/drivers/dds/telemetry.hpp"

namespace fl::drivers::dds {
namespace {

using namespace std::chrono_literals;
using test::loopback_uri;
using test::PeerProcess;
using test::wait_until;

TEST(DdsInterop, CameraNodeWrittenFromTheDocsIsRead) {
  constexpr int kDomain = 46;  // its own: the dds tests use 11-45, the two-process ones 50-58
  constexpr int kFrames = 20;  // 5 ms apart: 0.1 s
  Participant controller(kDomain);
  DdsCameraInput input(controller);
  PeerProcess peer(FL_DDS_IDL_PEER,
                   {"publish-estimates", std::to_string(kDomain), "2", std::to_string(kFrames)},
                   loopback_uri());
  InputImage in;
  ASSERT_TRUE(wait_until(
      [&] {
        input.read(in);
        return in.cameras[index(CameraId::kMultilane1)].sequence == kFrames;
      },
      15s))
      << "last sequence " << in.cameras[index(CameraId::kMultilane1)].sequence
      << ", peer: " << peer.output();
  EXPECT_EQ(peer.wait_exit(5s), 0);
  // The last frame as the peer wrote it (idl_only_peer.c): one fillet at x = 20 mm.
  const CameraFrame& frame = in.cameras[index(CameraId::kMultilane1)];
  ASSERT_EQ(frame.count, 1U);
  EXPECT_FLOAT_EQ(frame.estimates[0].x_mm, static_cast<float>(kFrames));
  EXPECT_FLOAT_EQ(frame.estimates[0].y_mm, -5.0F);
  EXPECT_FLOAT_EQ(frame.estimates[0].angle_rad, 0.25F);
  EXPECT_FLOAT_EQ(frame.estimates[0].confidence, 0.9F);
  EXPECT_EQ(frame.estimates[0].hand, Hand::kLeft);
  EXPECT_EQ(frame.estimates[0].side, SideUp::kBone);
  EXPECT_TRUE(frame.estimates[0].singulated);
  // QoS as documented: matched, and nothing refused by the converter.
  EXPECT_EQ(input.counters().rejected_total(), 0U);
}

TEST(DdsInterop, LedgerReachesASubscriberWrittenFromTheDocs) {
  constexpr int kDomain = 47;
  constexpr int kRecords = 3;
  PeerProcess mes(FL_DDS_IDL_PEER,
                  {"read-ledger", std::to_string(kDomain), std::to_string(kRecords), "10000"},
                  loopback_uri());
  Participant controller(kDomain);
  DdsTelemetryPublisher telemetry(controller);
  ASSERT_TRUE(wait_until([&] { return telemetry.matched_ledger_readers() > 0; }, 10s))
      << "the MES reader never matched; peer: " << mes.output();
  for (std::uint32_t id = 1; id <= kRecords; ++id) {
    FilletRecord record;
    record.id = id;
    record.outcome = Outcome::kPlaced;
    record.hand = Hand::kRight;
    telemetry.publish(record);
  }
  ASSERT_EQ(mes.wait_exit(15s), 0) << mes.output();
  // "record ID OUTCOME HAND", one line per record in order (reliable, one writer).
  std::istringstream lines(mes.output());
  std::string line;
  std::uint32_t expected_id = 1;
  while (std::getline(lines, line)) {
    if (line == "ready") continue;
    std::ostringstream want;
    want << "record " << expected_id << " " << static_cast<int>(Outcome::kPlaced) << " "
         << static_cast<int>(Hand::kRight);
    EXPECT_EQ(line, want.str());
    ++expected_id;
  }
  EXPECT_EQ(expected_id, kRecords + 1U);
  EXPECT_EQ(telemetry.counters().write_failures, 0U);
}

}  // namespace
}  // namespace fl::drivers::dds
