#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>

#include "test_support.hpp"

namespace fl::logic {
namespace {

class TrackerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    h.tracker.advance(h.in);  // first scan only takes the encoders' starting counts
    h.in.time_ns = 1'000'000'000;
  }
  test::Harness h;
};

TEST_F(TrackerTest, ItemsMoveWithTheEncoderOfTheBeltUnderThem) {
  Item* on_transition = h.tracker.create(0, 100.0F, false);
  Item* on_guide = h.tracker.create(0, 1500.0F, false);
  test::move_belt(h.in, h.config, DriveId::kTransition1, 3.0F);
  test::move_belt(h.in, h.config, DriveId::kGuide, 5.0F);
  h.tracker.advance(h.in);
  EXPECT_FLOAT_EQ(on_transition->s_mm, 103.0F);
  EXPECT_FLOAT_EQ(on_guide->s_mm, 1505.0F);
}

// Found by fuzz/fuzz_dds_samples: encoder counts from a corrupt DriveFeedback sample, one
// scan at the most negative and the next at the most positive count, overflowed the signed
// difference (undefined behaviour, reported by UBSan). The difference now wraps as a counter
// does; the tracker stays usable.
TEST_F(TrackerTest, EncoderJumpAcrossTheWholeRangeDoesNotOverflow) {
  h.tracker.create(0, 100.0F, false);
  h.in.drives[index(DriveId::kTransition1)].encoder_counts = -7289967886237117241;
  h.tracker.advance(h.in);
  h.in.drives[index(DriveId::kTransition1)].encoder_counts = 7545419121571575478;
  h.tracker.advance(h.in);
  h.in.drives[index(DriveId::kTransition1)].encoder_counts =
      std::numeric_limits<std::int64_t>::min();
  h.tracker.advance(h.in);
  EXPECT_TRUE(std::isfinite(h.tracker.create(0, 10.0F, false)->s_mm));
}

TEST_F(TrackerTest, MultilaneItemMovesAtTheMeanOfBothBelts) {
  const float s = h.config.sections[index(DriveId::kMultilane1Left)].start_mm + 50.0F;
  Item* item = h.tracker.create(0, s, false);
  test::move_belt(h.in, h.config, DriveId::kMultilane1Left, 2.0F);
  test::move_belt(h.in, h.config, DriveId::kMultilane1Right, 6.0F);
  h.tracker.advance(h.in);
  EXPECT_FLOAT_EQ(item->s_mm, s + 4.0F);
}

TEST_F(TrackerTest, DetectionCorrectsThePositionAndAddsEvidence) {
  const float camera_s = h.config.cameras[index(CameraId::kOrientation)].s_mm;
  Item* item = h.tracker.create(0, camera_s + 10.0F, false);
  // Seen 30 mm further than dead reckoning says: belts slip, the camera is right.
  test::publish(h.in, h.config, CameraId::kOrientation, camera_s + 40.0F,
                test::good_estimate(Hand::kLeft, SideUp::kBone, 0.1F));
  const FrameIntake intake = h.tracker.ingest(h.in, CameraId::kOrientation, h.events);
  EXPECT_TRUE(intake.new_frame);
  EXPECT_EQ(intake.rejected, 0);
  EXPECT_FLOAT_EQ(item->s_mm, camera_s + 40.0F);
  EXPECT_EQ(item->evidence[index(CameraId::kOrientation)].frames, 1);
  // The same frame again is not new.
  EXPECT_FALSE(h.tracker.ingest(h.in, CameraId::kOrientation, h.events).new_frame);
}

// Over the flip plates an item does not move with the guide belt's encoder: on the DEM twin a
// fillet reached camera 2 up to 90 mm ahead. Camera 2 matches within tracking.plates_gate_mm
// (170), the other cameras within match_gate_mm (80): a detection 100 mm off is the item at
// camera 2 and nothing at camera 1.
TEST_F(TrackerTest, CameraAfterThePlatesMatchesWithinItsWiderGate) {
  constexpr float kOffMm = 100.0F;  // between the two gates
  ASSERT_GT(kOffMm, h.config.tracking.match_gate_mm);
  ASSERT_LT(kOffMm, h.config.tracking.plates_gate_mm);
  const float camera2_s = h.config.cameras[index(CameraId::kPosition)].s_mm;
  Item* after_plates = h.tracker.create(0, camera2_s, false);
  test::publish(h.in, h.config, CameraId::kPosition, camera2_s + kOffMm,
                test::good_estimate(Hand::kLeft, SideUp::kBone, 0.1F));
  EXPECT_EQ(h.tracker.ingest(h.in, CameraId::kPosition, h.events).unmatched, 0);
  EXPECT_FLOAT_EQ(after_plates->s_mm, camera2_s + kOffMm);

  const float camera1_s = h.config.cameras[index(CameraId::kOrientation)].s_mm;
  Item* on_guide = h.tracker.create(0, camera1_s, false);
  test::publish(h.in, h.config, CameraId::kOrientation, camera1_s + kOffMm,
                test::good_estimate(Hand::kLeft, SideUp::kBone, 0.1F));
  EXPECT_EQ(h.tracker.ingest(h.in, CameraId::kOrientation, h.events).unmatched, 1);
  EXPECT_FLOAT_EQ(on_guide->s_mm, camera1_s);
}

TEST_F(TrackerTest, NotFiniteEstimateIsRefusedAndReported) {
  const float camera_s = h.config.cameras[index(CameraId::kPosition)].s_mm;
  Item* item = h.tracker.create(0, camera_s, false);
  FilletEstimate bad = test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F);
  test::publish(h.in, h.config, CameraId::kPosition, camera_s, bad);
  h.in.cameras[index(CameraId::kPosition)].estimates[0].angle_rad =
      std::numeric_limits<float>::quiet_NaN();
  const FrameIntake intake = h.tracker.ingest(h.in, CameraId::kPosition, h.events);
  EXPECT_EQ(intake.rejected, 1);
  EXPECT_EQ(item->evidence[index(CameraId::kPosition)].frames, 0);
  auto event = h.events.pop();
  ASSERT_TRUE(event.has_value());
  EXPECT_EQ(event->code, EventCode::kEstimateNotFinite);
}

TEST_F(TrackerTest, OutOfRangeConfidenceIsRefused) {
  const float camera_s = h.config.cameras[index(CameraId::kPosition)].s_mm;
  h.tracker.create(0, camera_s, false);
  FilletEstimate bad = test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F);
  bad.confidence = 1.5F;  // a probability above one is corrupt
  test::publish(h.in, h.config, CameraId::kPosition, camera_s, bad);
  EXPECT_EQ(h.tracker.ingest(h.in, CameraId::kPosition, h.events).rejected, 1);
}

TEST_F(TrackerTest, StaleFrameIsRefused) {
  const CameraMount& mount = h.config.cameras[index(CameraId::kPosition)];
  h.tracker.create(0, mount.s_mm, false);
  test::publish(h.in, h.config, CameraId::kPosition, mount.s_mm,
                test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F));
  // Exposed twice the allowed age ago.
  h.in.cameras[index(CameraId::kPosition)].frame_time_ns =
      h.in.time_ns - static_cast<std::int64_t>(2.0F * mount.max_age_s * 1e9F);
  EXPECT_EQ(h.tracker.ingest(h.in, CameraId::kPosition, h.events).rejected, 1);
  EXPECT_EQ(h.events.pop()->code, EventCode::kEstimateStale);
}

TEST_F(TrackerTest, OutOfOrderFrameIsRefused) {
  const float camera_s = h.config.cameras[index(CameraId::kPosition)].s_mm;
  h.tracker.create(0, camera_s, false);
  test::publish(h.in, h.config, CameraId::kPosition, camera_s,
                test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F));
  h.tracker.ingest(h.in, CameraId::kPosition, h.events);
  test::publish(h.in, h.config, CameraId::kPosition, camera_s,
                test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F));
  h.in.cameras[index(CameraId::kPosition)].frame_time_ns -= 5'000'000;  // 5 ms before the last
  EXPECT_EQ(h.tracker.ingest(h.in, CameraId::kPosition, h.events).rejected, 1);
}

TEST_F(TrackerTest, RepeatedUnmatchedDetectionAtCameraOneIsAdoptedForRejection) {
  const float camera_s = h.config.cameras[index(CameraId::kOrientation)].s_mm;
  for (int frame = 0; frame < Tracker::kConfirmFrames; ++frame) {
    EXPECT_EQ(h.tracker.active_count(), 0U) << "adopted before confirmation, frame " << frame;
    h.in.time_ns += 40'000'000;  // the camera's 25 frames per second
    test::publish(h.in, h.config, CameraId::kOrientation, camera_s,
                  test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F));
    EXPECT_EQ(h.tracker.ingest(h.in, CameraId::kOrientation, h.events).unmatched, 1);
  }
  ASSERT_EQ(h.tracker.active_count(), 1U);
  const Item& adopted = h.tracker.items()[0];
  EXPECT_TRUE(adopted.adopted);
  EXPECT_TRUE(adopted.reject_pending);
  EXPECT_EQ(adopted.reject_reason, Outcome::kRejectedUntracked);
}

// A camera that repeats one detection across its frame (a flood, a glitch) has seen it once:
// eight identical blobs in one frame, the most a frame holds, confirm nothing; adoption still
// takes kConfirmFrames separate frames.
TEST_F(TrackerTest, IdenticalDetectionsInOneFrameAreOneSighting) {
  const float camera_s = h.config.cameras[index(CameraId::kOrientation)].s_mm;
  CameraFrame& frame = h.in.cameras[index(CameraId::kOrientation)];
  for (int sighting = 1; sighting <= Tracker::kConfirmFrames; ++sighting) {
    EXPECT_EQ(h.tracker.active_count(), 0U) << "adopted after " << sighting - 1 << " frames";
    h.in.time_ns += 40'000'000;  // the camera's 25 frames per second
    test::publish(h.in, h.config, CameraId::kOrientation, camera_s,
                  test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F));
    frame.count = static_cast<std::uint8_t>(kMaxEstimatesPerFrame);
    for (std::size_t e = 1; e < kMaxEstimatesPerFrame; ++e) frame.estimates[e] = frame.estimates[0];
    h.tracker.ingest(h.in, CameraId::kOrientation, h.events);
  }
  ASSERT_EQ(h.tracker.active_count(), 1U);
  EXPECT_TRUE(h.tracker.items()[0].adopted);
}

// Phantoms (glare, a scrap of skin) appear once at random places: never adopted.
TEST_F(TrackerTest, PhantomDetectionsAreNotAdopted) {
  const float camera_s = h.config.cameras[index(CameraId::kOrientation)].s_mm;
  for (int frame = 0; frame < 20; ++frame) {
    h.in.time_ns += 40'000'000;
    // Four spots 100 mm apart (farther than the 80 mm match gate); a spot comes back only
    // after four frames, later than a tentative's three-period expiry.
    const float s = camera_s - 150.0F + 100.0F * static_cast<float>(frame % 4);
    test::publish(h.in, h.config, CameraId::kOrientation, s,
                  test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F));
    h.tracker.ingest(h.in, CameraId::kOrientation, h.events);
  }
  EXPECT_EQ(h.tracker.active_count(), 0U);
  EXPECT_EQ(h.tracker.unmatched_detections(), 20U);
}

TEST_F(TrackerTest, UnmatchedDetectionOnTheMultilaneIsOnlyCounted) {
  const float camera_s = h.config.cameras[index(CameraId::kMultilane1)].s_mm;
  test::publish(h.in, h.config, CameraId::kMultilane1, camera_s,
                test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F));
  EXPECT_EQ(h.tracker.ingest(h.in, CameraId::kMultilane1, h.events).unmatched, 1);
  EXPECT_EQ(h.tracker.active_count(), 0U);
}

TEST_F(TrackerTest, SecondBlobOnOneItemIsADuplicateAndCountsAgainstSingulation) {
  const float camera_s = h.config.cameras[index(CameraId::kOrientation)].s_mm;
  Item* item = h.tracker.create(0, camera_s, false);
  test::publish(h.in, h.config, CameraId::kOrientation, camera_s,
                test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F));
  CameraFrame& frame = h.in.cameras[index(CameraId::kOrientation)];
  frame.count = 2;
  frame.estimates[1] = frame.estimates[0];
  frame.estimates[1].x_mm += 20.0F;  // inside the gate of the same item
  h.tracker.ingest(h.in, CameraId::kOrientation, h.events);
  EXPECT_EQ(h.tracker.duplicate_detections(), 1U);
  EXPECT_FALSE(item->evidence[index(CameraId::kOrientation)].singulated());
}

TEST_F(TrackerTest, FloodedFrameIsClampedAndFlagged) {
  const float camera_s = h.config.cameras[index(CameraId::kFinal)].s_mm;
  test::publish(h.in, h.config, CameraId::kFinal, camera_s,
                test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F));
  h.in.cameras[index(CameraId::kFinal)].count = 200;  // more than a frame can hold
  const FrameIntake intake = h.tracker.ingest(h.in, CameraId::kFinal, h.events);
  EXPECT_TRUE(intake.flooded);
}

TEST_F(TrackerTest, FullTableCountsOverflowInsteadOfCrashing) {
  for (std::size_t i = 0; i < kMaxTrackedItems; ++i) {
    ASSERT_NE(h.tracker.create(0, 0.0F, false), nullptr);
  }
  EXPECT_EQ(h.tracker.create(0, 0.0F, false), nullptr);
  EXPECT_EQ(h.tracker.overflows(), 1U);
}

TEST_F(TrackerTest, ClosingWritesOneRecordWithTheOutcome) {
  Item* item = h.tracker.create(0, 10.0F, false);
  const std::uint32_t id = item->id;
  h.tracker.close(*item, 5, Outcome::kPlaced, LostReason::kNone, h.records, h.events);
  auto record = h.records.pop();
  ASSERT_TRUE(record.has_value());
  EXPECT_EQ(record->id, id);
  EXPECT_EQ(record->outcome, Outcome::kPlaced);
  EXPECT_EQ(h.tracker.active_count(), 0U);
  EXPECT_EQ(h.tracker.outcome_counts()[static_cast<std::size_t>(Outcome::kPlaced)], 1U);
}

}  // namespace
}  // namespace fl::logic
