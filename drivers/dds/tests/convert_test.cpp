// The converter between the IDL's C structs and the process image: round trips and the
// validation of incoming samples.
#include "fl/drivers/dds/convert.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "dds_test_support.hpp"

namespace fl::drivers::dds {
namespace {

// Field by field: memcmp would also compare padding bytes, which nobody initialises.
bool same(const FilletEstimate& a, const FilletEstimate& b) {
  return a.x_mm == b.x_mm && a.y_mm == b.y_mm && a.angle_rad == b.angle_rad &&
         a.confidence == b.confidence && a.hand == b.hand && a.side == b.side &&
         a.singulated == b.singulated;
}

bool same(const CameraFrame& a, const CameraFrame& b) {
  if (a.frame_time_ns != b.frame_time_ns || a.sequence != b.sequence || a.count != b.count) {
    return false;
  }
  for (std::size_t i = 0; i < kMaxEstimatesPerFrame; ++i) {
    if (!same(a.estimates[i], b.estimates[i])) return false;
  }
  return true;
}

bool same_actuators(const OutputImage& a, const OutputImage& b) {
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    if (a.drives[d].enable != b.drives[d].enable ||
        a.drives[d].speed_mps != b.drives[d].speed_mps ||
        a.drives[d].accel_mps2 != b.drives[d].accel_mps2) {
      return false;
    }
  }
  return a.hopper_opening_mm == b.hopper_opening_mm &&
         a.leveller_speed_rpm == b.leveller_speed_rpm && a.flip_plate1_flip == b.flip_plate1_flip &&
         a.flip_plate2_flip == b.flip_plate2_flip && a.centring_shift_mm == b.centring_shift_mm &&
         a.centring_stroke == b.centring_stroke && a.squeeze_roller_down == b.squeeze_roller_down &&
         a.final_reject == b.final_reject;
}

TEST(DdsConvert, CameraFrameRoundTripsForEveryFillLevel) {
  // Sequences 1..9 give counts 1..8 and 0: every fill level of a frame.
  for (std::uint32_t sequence = 1; sequence <= kMaxEstimatesPerFrame + 1; ++sequence) {
    const CameraFrame frame = test::make_frame(CameraId::kMultilane2, sequence, 123'456'789);
    fl_CameraEstimates sample{};
    to_idl(CameraId::kMultilane2, frame, sample);
    EXPECT_EQ(sample.camera_id, 3);
    ASSERT_FALSE(validate(sample).has_value());
    CameraFrame back;
    from_idl(sample, back);
    EXPECT_TRUE(same(back, frame)) << "sequence " << sequence;
  }
}

TEST(DdsConvert, FromIdlClearsEntriesBehindCount) {
  CameraFrame frame = test::make_frame(CameraId::kFinal, 8, 0);  // 8 estimates
  fl_CameraEstimates sample{};
  to_idl(CameraId::kFinal, test::make_frame(CameraId::kFinal, 2, 0), sample);  // 2 estimates
  from_idl(sample, frame);
  EXPECT_EQ(frame.count, 2);
  EXPECT_EQ(frame.estimates[2].x_mm, 0.0F);  // not the 8-estimate frame's third entry
}

TEST(DdsConvert, LineCommandRoundTripsTheActuatorPart) {
  OutputImage out;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    out.drives[d] =
        DriveCommand{d % 2 == 0, 0.1F * static_cast<float>(d) - 0.5F, static_cast<float>(d)};
  }
  out.hopper_opening_mm = 60.0F;
  out.leveller_speed_rpm = 120.0F;
  out.flip_plate1_flip = true;
  out.centring_shift_mm = -23.5F;
  out.centring_stroke = true;
  out.final_reject = true;
  out.state = LineState::kRunning;
  out.active_faults = 0x5;
  fl_LineCommand sample{};
  to_idl(42, 7, out, sample);
  EXPECT_EQ(sample.time_ns, 42);
  EXPECT_EQ(sample.scan, 7U);
  OutputImage back;
  from_idl(sample, back);
  EXPECT_TRUE(same_actuators(back, out));
  // State and faults are not part of the command: LineStatus carries them.
  EXPECT_EQ(back.state, LineState::kStopped);
  EXPECT_EQ(back.active_faults, 0U);
}

TEST(DdsConvert, DriveFeedbackRoundTripsAndRefusesUnknownDrive) {
  const DriveFeedback feedback{-0.75F, -123456789012LL, true, false};
  fl_DriveFeedback sample{};
  to_idl(DriveId::kReject, 99, feedback, sample);
  DriveId drive = DriveId::kBulk;
  DriveFeedback back;
  ASSERT_TRUE(from_idl(sample, drive, back));
  EXPECT_EQ(drive, DriveId::kReject);
  EXPECT_EQ(back.speed_mps, feedback.speed_mps);
  EXPECT_EQ(back.encoder_counts, feedback.encoder_counts);
  EXPECT_TRUE(back.ready);
  sample.drive_id = static_cast<std::uint8_t>(kDriveCount);  // one past the last drive
  EXPECT_FALSE(from_idl(sample, drive, back));
}

fl_CameraEstimates valid_sample() {
  fl_CameraEstimates sample{};
  to_idl(CameraId::kOrientation, test::make_frame(CameraId::kOrientation, 4, 1000), sample);
  return sample;
}

TEST(DdsConvert, ValidationNamesEachReason) {
  fl_CameraEstimates s = valid_sample();
  ASSERT_FALSE(validate(s).has_value());

  s.camera_id = static_cast<std::uint8_t>(kCameraCount);  // one past the last camera
  EXPECT_EQ(validate(s), RejectReason::kCameraIdOutOfRange);

  s = valid_sample();
  s.count = static_cast<std::uint8_t>(kMaxEstimatesPerFrame + 1);
  EXPECT_EQ(validate(s), RejectReason::kCountOverCapacity);

  s = valid_sample();
  s.estimates[1].angle_rad = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(validate(s), RejectReason::kNotFinite);

  s = valid_sample();
  s.estimates[0].y_mm = std::numeric_limits<float>::infinity();
  EXPECT_EQ(validate(s), RejectReason::kNotFinite);

  s = valid_sample();
  s.estimates[2].confidence = 1.5F;  // confidence is 0..1
  EXPECT_EQ(validate(s), RejectReason::kValueOutOfRange);

  s = valid_sample();
  s.estimates[3].x_mm = kMaxAbsPositionMm + 1.0F;
  EXPECT_EQ(validate(s), RejectReason::kValueOutOfRange);

  s = valid_sample();
  const int no_such_hand = 7;  // the IDL has three enumerators; a peer may send anything
  std::memcpy(&s.estimates[0].hand, &no_such_hand, sizeof no_such_hand);
  EXPECT_EQ(validate(s), RejectReason::kEnumOutOfRange);

  // A NaN behind `count` is not data: ignored.
  s = valid_sample();
  s.estimates[kMaxEstimatesPerFrame - 1].x_mm = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(validate(s).has_value());
}

}  // namespace
}  // namespace fl::drivers::dds
