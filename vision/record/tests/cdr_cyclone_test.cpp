// The CDR coder against Cyclone DDS 0.10's own serializer: a sample of the idlc-generated C
// type is written through a Cyclone writer, its serialized form taken raw with dds_takecdr
// (what goes on the wire, encapsulation header included), and compared byte for byte with
// the coder's encoding of the same values; the coder then decodes Cyclone's bytes.
#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "fillet_line.h"
#include "fl/vision/record/cdr.hpp"

namespace fl::vision::record {
namespace {

// Serializes `sample` with Cyclone: writer and reader on one topic in one participant, so the
// sample is delivered locally and synchronously.
Bytes cyclone_cdr(const dds_topic_descriptor_t* descriptor, const void* sample,
                  const char* topic_name) {
  const dds_entity_t participant = dds_create_participant(DDS_DOMAIN_DEFAULT, nullptr, nullptr);
  EXPECT_GT(participant, 0) << dds_strretcode(participant);
  const dds_entity_t topic =
      dds_create_topic(participant, descriptor, topic_name, nullptr, nullptr);
  EXPECT_GT(topic, 0) << dds_strretcode(topic);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
  const dds_entity_t reader = dds_create_reader(participant, topic, qos, nullptr);
  const dds_entity_t writer = dds_create_writer(participant, topic, qos, nullptr);
  dds_delete_qos(qos);
  EXPECT_GT(reader, 0);
  EXPECT_GT(writer, 0);
  EXPECT_EQ(dds_write(writer, sample), DDS_RETCODE_OK);
  Bytes bytes;
  ddsi_serdata* serdata = nullptr;
  dds_sample_info_t info{};
  // Local delivery is synchronous; the retries only guard against a slow machine.
  for (int attempt = 0; attempt < 100 && bytes.empty(); ++attempt) {
    if (dds_takecdr(reader, &serdata, 1, &info, DDS_ANY_STATE) == 1) {
      bytes.resize(ddsi_serdata_size(serdata));
      ddsi_serdata_to_ser(serdata, 0, bytes.size(), bytes.data());
      ddsi_serdata_unref(serdata);
    } else {
      dds_sleepfor(DDS_MSECS(10));
    }
  }
  dds_delete(participant);
  return bytes;
}

std::string hex(const Bytes& bytes) {
  std::string text;
  char byte[4];
  for (std::uint8_t b : bytes) {
    std::snprintf(byte, sizeof byte, "%02x ", b);
    text += byte;
  }
  return text;
}

TEST(CdrCyclone, CameraEstimatesMatchCycloneBytes) {
  fl_CameraEstimates sample{};
  sample.camera_id = 4;                      // the final camera: a non-zero key
  sample.frame_time_ns = 1'234'567'890'123;  // needs all of the 8 bytes' low half
  sample.frame_sequence = 0x01020304;        // distinct bytes expose byte order
  sample.count = 2;
  for (int i = 0; i < 8; ++i) {
    sample.estimates[i].x_mm = 1.5F * static_cast<float>(i);
    sample.estimates[i].y_mm = -2.25F;
    sample.estimates[i].angle_rad = 3.0F;
    sample.estimates[i].confidence = 0.75F;
    sample.estimates[i].hand = fl_HAND_RIGHT;
    sample.estimates[i].side = fl_SIDE_BONE;
    sample.estimates[i].singulated = (i % 2) == 0;
  }
  CameraEstimatesSample ours;
  ours.camera_id = 4;
  ours.frame.frame_time_ns = sample.frame_time_ns;
  ours.frame.sequence = sample.frame_sequence;
  ours.frame.count = 2;
  for (std::size_t i = 0; i < 8; ++i) {
    ours.frame.estimates[i] = {1.5F * static_cast<float>(i),
                               -2.25F,
                               3.0F,
                               0.75F,
                               Hand::kRight,
                               SideUp::kBone,
                               (i % 2) == 0};
  }
  const Bytes cyclone = cyclone_cdr(&fl_CameraEstimates_desc, &sample, "cdr_test_estimates");
  const Bytes encoded = encode(ours);
  ASSERT_FALSE(cyclone.empty());
  EXPECT_EQ(encoded, cyclone) << "ours    " << hex(encoded) << "\ncyclone " << hex(cyclone);
  const CameraEstimatesSample decoded = decode_camera_estimates(cyclone);
  EXPECT_EQ(decoded.camera_id, 4);
  EXPECT_EQ(decoded.frame.sequence, 0x01020304U);
  EXPECT_EQ(decoded.frame.estimates[7].x_mm, 10.5F);
  EXPECT_FALSE(decoded.frame.estimates[7].singulated);
}

TEST(CdrCyclone, LineCommandMatchesCycloneBytes) {
  fl_LineCommand sample{};
  sample.time_ns = 5'000'000'000;
  sample.scan = 500;
  OutputImage out;
  for (int d = 0; d < 13; ++d) {
    sample.drives[d] = {d % 3 == 0, 0.1F * static_cast<float>(d), 5.0F};
    out.drives[static_cast<std::size_t>(d)] = {d % 3 == 0, 0.1F * static_cast<float>(d), 5.0F};
  }
  sample.hopper_opening_mm = out.hopper_opening_mm = 60.0F;
  sample.leveller_speed_rpm = out.leveller_speed_rpm = 120.0F;
  sample.flip_plate1_flip = out.flip_plate1_flip = true;
  sample.centring_shift_mm = out.centring_shift_mm = -12.5F;
  sample.squeeze_roller_down = out.squeeze_roller_down = true;
  sample.final_reject = out.final_reject = true;
  const Bytes cyclone = cyclone_cdr(&fl_LineCommand_desc, &sample, "cdr_test_command");
  const Bytes encoded = encode(LineCommandSample{5'000'000'000, 500, out});
  ASSERT_FALSE(cyclone.empty());
  EXPECT_EQ(encoded, cyclone) << "ours    " << hex(encoded) << "\ncyclone " << hex(cyclone);
  EXPECT_EQ(decode_line_command(cyclone).output.centring_shift_mm, -12.5F);
}

TEST(CdrCyclone, LineStatusMatchesCycloneBytes) {
  fl_LineStatus sample{};
  sample.time_ns = 7;
  sample.state = fl_LINE_FAULT;
  sample.active_faults = 0x11;
  sample.scans = 1'000'000;
  sample.commands_published = 999'999;
  sample.commands_dropped = 1;
  sample.camera_stale_mask = 0x4;
  sample.estimates_rejected_transport = 3;
  LineStatusSample ours{7, LineState::kFault, 0x11, 1'000'000, 999'999, 1, 0x4, 3};
  const Bytes cyclone = cyclone_cdr(&fl_LineStatus_desc, &sample, "cdr_test_status");
  ASSERT_FALSE(cyclone.empty());
  EXPECT_EQ(encode(ours), cyclone)
      << "ours    " << hex(encode(ours)) << "\ncyclone " << hex(cyclone);
  EXPECT_EQ(decode_line_status(cyclone).state, LineState::kFault);
}

TEST(CdrCyclone, DriveFeedbackMatchesCycloneBytes) {
  fl_DriveFeedback sample{};
  sample.drive_id = 12;
  sample.time_ns = 10'000'000;
  sample.speed_mps = 0.5F;
  sample.encoder_counts = -123'456'789'012;  // negative: sign follows direction
  sample.ready = true;
  sample.fault = false;
  DriveFeedbackSample ours{12, 10'000'000, {0.5F, -123'456'789'012, true, false}};
  const Bytes cyclone = cyclone_cdr(&fl_DriveFeedback_desc, &sample, "cdr_test_drive");
  ASSERT_FALSE(cyclone.empty());
  EXPECT_EQ(encode(ours), cyclone)
      << "ours    " << hex(encode(ours)) << "\ncyclone " << hex(cyclone);
  EXPECT_EQ(decode_drive_feedback(cyclone).feedback.encoder_counts, -123'456'789'012);
}

TEST(CdrCyclone, LineSensorsMatchCycloneBytes) {
  fl_LineSensors sample{};
  sample.time_ns = 20'000'000;
  sample.scan = 2;
  sample.takt_beam_broken = true;
  sample.level_mm = 58.5F;
  sample.hopper_opening_mm = 60.0F;
  sample.leveller_speed_rpm = 119.0F;
  sample.flip_plate2_flipping = true;
  sample.centring_position_mm = -3.0F;
  sample.estop_ok = true;
  sample.start_request = true;
  LineSensorsSample ours;
  ours.scan = 2;
  ours.input.time_ns = 20'000'000;
  ours.input.takt_beam_broken = true;
  ours.input.level_mm = 58.5F;
  ours.input.hopper_opening_mm = 60.0F;
  ours.input.leveller_speed_rpm = 119.0F;
  ours.input.flip_plate2_flipping = true;
  ours.input.centring_position_mm = -3.0F;
  ours.input.estop_ok = true;
  ours.input.start_request = true;
  const Bytes cyclone = cyclone_cdr(&fl_LineSensors_desc, &sample, "cdr_test_sensors");
  ASSERT_FALSE(cyclone.empty());
  EXPECT_EQ(encode(ours), cyclone)
      << "ours    " << hex(encode(ours)) << "\ncyclone " << hex(cyclone);
  EXPECT_EQ(decode_line_sensors(cyclone).input.level_mm, 58.5F);
}

}  // namespace
}  // namespace fl::vision::record
