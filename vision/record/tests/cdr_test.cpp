#include "fl/vision/record/cdr.hpp"

#include <gtest/gtest.h>

namespace fl::vision::record {
namespace {

CameraEstimatesSample example_estimates() {
  CameraEstimatesSample sample;
  sample.camera_id = 2;
  sample.frame.frame_time_ns = 40'000'000;  // the second frame of a 25 Hz camera
  sample.frame.sequence = 2;
  sample.frame.count = 1;
  sample.frame.estimates[0] = {12.5F, -3.25F, 1.0F, 0.9F, Hand::kLeft, SideUp::kSkin, true};
  return sample;
}

TEST(Cdr, CameraEstimatesLayoutFollowsXcdr1) {
  const Bytes bytes = encode(example_estimates());
  // Header 4 + camera_id 1 + pad 7 (int64 aligns to 8) + time 8 + sequence 4 + count 1 + pad 3
  // + 8 estimates of 4 floats, 2 enums and a boolean (25 bytes, 28 with the padding between
  // them), the sample padded to a multiple of 4: 4 + 24 + 8 * 28, the last 3 bytes padding.
  EXPECT_EQ(bytes.size(), 4U + 24U + 8U * 28U);
  EXPECT_EQ(bytes[0], 0x00);
  EXPECT_EQ(bytes[1], 0x01);   // CDR_LE
  EXPECT_EQ(bytes[3], 3);      // options: 3 bytes of padding at the end
  EXPECT_EQ(bytes[4], 2);      // camera_id
  EXPECT_EQ(bytes[12], 0x00);  // 40 000 000 = 0x02625A00, little endian from offset 12
  EXPECT_EQ(bytes[13], 0x5A);
  EXPECT_EQ(bytes[14], 0x62);
  EXPECT_EQ(bytes[15], 0x02);
}

TEST(Cdr, EveryTypeRoundTrips) {
  const CameraEstimatesSample estimates = decode_camera_estimates(encode(example_estimates()));
  EXPECT_EQ(estimates.camera_id, 2);
  EXPECT_EQ(estimates.frame.estimates[0].y_mm, -3.25F);
  EXPECT_EQ(estimates.frame.estimates[0].hand, Hand::kLeft);

  LineCommandSample command{30'000'000, 3, {}};
  command.output.drives[4] = {true, 0.5F, 5.0F};
  command.output.flip_plate2_flip = true;
  const LineCommandSample command_back = decode_line_command(encode(command));
  EXPECT_EQ(command_back.scan, 3U);
  EXPECT_EQ(command_back.output.drives[4].speed_mps, 0.5F);
  EXPECT_TRUE(command_back.output.flip_plate2_flip);

  const LineStatusSample status_back =
      decode_line_status(encode(LineStatusSample{1, LineState::kRunning, 0x5, 9, 9, 0, 0, 0}));
  EXPECT_EQ(status_back.state, LineState::kRunning);
  EXPECT_EQ(status_back.active_faults, 0x5U);

  const DriveFeedbackSample drive_back =
      decode_drive_feedback(encode(DriveFeedbackSample{3, 7, {0.45F, -99, true, true}}));
  EXPECT_EQ(drive_back.feedback.encoder_counts, -99);
  EXPECT_TRUE(drive_back.feedback.fault);

  LineSensorsSample sensors;
  sensors.scan = 11;
  sensors.input.time_ns = 110'000'000;
  sensors.input.level_mm = 61.0F;
  sensors.input.fault_reset_request = true;
  const LineSensorsSample sensors_back = decode_line_sensors(encode(sensors));
  EXPECT_EQ(sensors_back.scan, 11U);
  EXPECT_EQ(sensors_back.input.level_mm, 61.0F);
  EXPECT_TRUE(sensors_back.input.fault_reset_request);

  const CompressedImageSample image{1, 500, "orientation", "png", {1, 2, 3}};
  const CompressedImageSample image_back = decode_compressed_image(encode(image));
  EXPECT_EQ(image_back.frame_id, "orientation");
  EXPECT_EQ(image_back.data, (Bytes{1, 2, 3}));
}

TEST(Cdr, TruncatedSampleNamesTypeMemberAndOffset) {
  Bytes bytes = encode(example_estimates());
  bytes.resize(20);  // ends inside frame_time_ns (bytes 12..19 hold it, 20 cuts sequence)
  try {
    decode_camera_estimates(bytes);
    FAIL() << "a truncated sample decoded";
  } catch (const CdrError& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find("fl::CameraEstimates.frame_sequence"), std::string::npos) << what;
    EXPECT_NE(what.find("truncated"), std::string::npos) << what;
  }
}

TEST(Cdr, OutOfRangeValuesAreErrors) {
  Bytes bytes = encode(example_estimates());
  bytes[24] = 9;  // count (offset 4 + 20) above MAX_ESTIMATES_PER_FRAME 8
  EXPECT_THROW(decode_camera_estimates(bytes), CdrError);
  bytes = encode(example_estimates());
  bytes[4 + 24 + 16] = 7;  // estimates[0].hand: Hand has 3 values
  EXPECT_THROW(decode_camera_estimates(bytes), CdrError);
  bytes = encode(example_estimates());
  bytes[4 + 24 + 24] = 2;  // estimates[0].singulated: a boolean is 0 or 1
  EXPECT_THROW(decode_camera_estimates(bytes), CdrError);
  bytes = encode(example_estimates());
  bytes[1] = 0x00;  // CDR_BE: big-endian samples are not read
  EXPECT_THROW(decode_camera_estimates(bytes), CdrError);
  bytes = encode(example_estimates());
  bytes.insert(bytes.end(), 4, 0);  // 7 trailing bytes: more than the 3 a writer may pad
  EXPECT_THROW(decode_camera_estimates(bytes), CdrError);
  EXPECT_THROW(decode_compressed_image(Bytes{0, 1, 0, 0, 5, 0, 0, 0}), CdrError);
}

}  // namespace
}  // namespace fl::vision::record
