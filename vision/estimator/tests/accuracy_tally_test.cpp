// The accuracy tally behind `linectl vision eval`: matching, angle wrap, confusion matrices
// and singulation precision and recall on hand-made frames whose right answers are known.
#include <gtest/gtest.h>

#include <numbers>
#include <string>

#include "fl/vision/accuracy.hpp"

namespace fl::vision {
namespace {

constexpr double kRadPerDeg = std::numbers::pi / 180.0;

BlobResult fillet_blob(float x_mm, float y_mm, float angle_rad, Hand hand, SideUp side,
                       bool singulated = true) {
  BlobResult blob;
  blob.status = BlobStatus::kFillet;
  blob.estimate.x_mm = x_mm;
  blob.estimate.y_mm = y_mm;
  blob.estimate.angle_rad = angle_rad;
  blob.estimate.hand = hand;
  blob.estimate.side = side;
  blob.estimate.singulated = singulated;
  blob.estimate.confidence = 0.9F;
  return blob;
}

TrueFillet single(double x_mm, double y_mm, double angle_rad, Hand hand, SideUp side) {
  TrueFillet fillet;
  fillet.x_mm = x_mm;
  fillet.y_mm = y_mm;
  fillet.angle_rad = angle_rad;
  fillet.hand = hand;
  fillet.side = side;
  return fillet;
}

TrueFillet member_of(int group, double x_mm, double y_mm) {
  TrueFillet fillet = single(x_mm, y_mm, 0.0, Hand::kLeft, SideUp::kSkin);
  fillet.group_id = group;
  fillet.singulated = false;
  return fillet;
}

TEST(AccuracyTally, AngleErrorWrapsAroundTheHalfTurn) {
  // 179 and -179 degrees are 2 degrees apart, not 358.
  EXPECT_NEAR(angle_between_rad(179.0 * kRadPerDeg, -179.0 * kRadPerDeg), 2.0 * kRadPerDeg, 1e-12);
  EXPECT_NEAR(angle_between_rad(0.0, std::numbers::pi), std::numbers::pi, 1e-12);
}

TEST(AccuracyTally, AMatchedSingleGivesItsErrorsAndConfusionCells) {
  AccuracyTally tally;
  FrameResult frame;
  // 3-4-5: the estimate lies 5 mm from the pose; the angle is 2 degrees off across the wrap.
  frame.blobs.push_back(fillet_blob(3.0F, 4.0F, static_cast<float>(-179.0 * kRadPerDeg),
                                    Hand::kRight, SideUp::kUnknown));
  tally.add_frame(frame, {single(0.0, 0.0, 179.0 * kRadPerDeg, Hand::kRight, SideUp::kBone)});
  const AccuracySummary s = tally.summary();
  EXPECT_EQ(s.singles, 1U);
  EXPECT_EQ(s.detected, 1U);
  EXPECT_NEAR(s.angle_error_max_deg, 2.0, 1e-4);  // float estimate: 1e-4 degrees
  EXPECT_NEAR(s.position_error_max_mm, 5.0, 1e-6);
  EXPECT_EQ(s.thick_end_right, 1U);
  EXPECT_EQ(s.hand[1][1], 1U);  // right called right
  EXPECT_EQ(s.side[1][2], 1U);  // bone called unknown
  EXPECT_DOUBLE_EQ(s.hand_correct_share, 1.0);
  EXPECT_DOUBLE_EQ(s.side_correct_share, 0.0);
}

TEST(AccuracyTally, ABlobBeyondTheGateIsAMissNotAMatch) {
  AccuracyTally tally;  // 30 mm gate
  FrameResult frame;
  frame.blobs.push_back(fillet_blob(40.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin));
  tally.add_frame(frame, {single(0.0, 0.0, 0.0, Hand::kLeft, SideUp::kSkin)});
  const AccuracySummary s = tally.summary();
  EXPECT_EQ(s.singles, 1U);
  EXPECT_EQ(s.detected, 0U);
  EXPECT_EQ(s.phantoms, 0U);  // within 100 mm of a fillet: part of the scene, not made up
}

TEST(AccuracyTally, ABlobFarFromEveryFilletIsAPhantom) {
  AccuracyTally tally;
  FrameResult frame;
  frame.blobs.push_back(fillet_blob(250.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin));
  tally.add_frame(frame, {single(0.0, 0.0, 0.0, Hand::kLeft, SideUp::kSkin)});
  EXPECT_EQ(tally.summary().phantoms, 1U);
}

TEST(AccuracyTally, AFilletCutByTheImageBorderIsNotJudged) {
  AccuracyTally tally;
  TrueFillet cut = single(0.0, 0.0, 0.0, Hand::kLeft, SideUp::kSkin);
  cut.fully_visible = false;
  tally.add_frame(FrameResult{}, {cut});
  EXPECT_EQ(tally.summary().singles, 0U);
}

TEST(AccuracyTally, AMissedSingleIsListedWithItsFrameAndWhatTheEstimatorSawInstead) {
  AccuracyTally tally;
  // Frame 11: the only fillet blob lies 40 mm off, beyond the 30 mm gate, and a second blob
  // touched the image edge.
  FrameResult frame;
  frame.sequence = 11;
  frame.blobs.push_back(fillet_blob(40.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin));
  BlobResult cut;
  cut.status = BlobStatus::kCutByBorder;
  frame.blobs.push_back(cut);
  tally.add_frame(frame, {single(0.0, 0.0, 0.5, Hand::kLeft, SideUp::kSkin)});
  // Frame 12 was refused as a whole.
  FrameResult refused;
  refused.sequence = 12;
  refused.status = FrameStatus::kNoBelt;
  tally.add_frame(refused, {single(5.0, 6.0, 0.0, Hand::kLeft, SideUp::kSkin)});
  // Frame 13: nothing at all was found.
  FrameResult empty;
  empty.sequence = 13;
  tally.add_frame(empty, {single(0.0, 0.0, 0.0, Hand::kLeft, SideUp::kSkin)});

  const std::vector<MissedSingle>& missed = tally.missed_singles();
  ASSERT_EQ(missed.size(), 3U);
  EXPECT_EQ(missed[0].sequence, 11U);
  EXPECT_DOUBLE_EQ(missed[0].angle_rad, 0.5);
  EXPECT_EQ(missed[0].why, "nearest fillet blob 40 mm away; a blob cut by the image border");
  EXPECT_EQ(missed[1].sequence, 12U);
  EXPECT_DOUBLE_EQ(missed[1].x_mm, 5.0);
  EXPECT_EQ(missed[1].why, "frame refused: " + std::string(to_string(FrameStatus::kNoBelt)));
  EXPECT_EQ(missed[2].why, "no blob");
  EXPECT_EQ(tally.summary().detected, 0U);  // a listed miss is still a miss
}

TEST(AccuracyTally, ATouchingGroupCountsOnceAndIsFlaggedOnlyWhenEveryBlobSaysSo) {
  AccuracyTally tally;
  FrameResult flagged;
  flagged.blobs.push_back(fillet_blob(50.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin, false));
  tally.add_frame(flagged, {member_of(7, 0.0, 0.0), member_of(7, 100.0, 0.0)});
  FrameResult half_flagged = flagged;
  half_flagged.blobs.push_back(fillet_blob(110.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin));
  tally.add_frame(half_flagged, {member_of(7, 0.0, 0.0), member_of(7, 100.0, 0.0)});
  const AccuracySummary s = tally.summary();
  EXPECT_EQ(s.groups, 2U);  // one group per frame
  EXPECT_EQ(s.groups_flagged, 1U);
  EXPECT_DOUBLE_EQ(s.singulation_recall, 0.5);
  EXPECT_DOUBLE_EQ(s.singulation_precision, 1.0);
  EXPECT_EQ(s.singles, 0U);
}

TEST(AccuracyTally, AGroupCutByTheBorderIsNotJudged) {
  AccuracyTally tally;
  TrueFillet cut = member_of(3, 100.0, 0.0);
  cut.fully_visible = false;
  tally.add_frame(FrameResult{}, {member_of(3, 0.0, 0.0), cut});
  EXPECT_EQ(tally.summary().groups, 0U);
}

TEST(AccuracyTally, ASingleCalledTouchingLowersPrecision) {
  AccuracyTally tally;
  FrameResult frame;
  frame.blobs.push_back(fillet_blob(0.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin, false));
  frame.blobs.push_back(fillet_blob(300.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin, false));
  tally.add_frame(frame, {single(0.0, 0.0, 0.0, Hand::kLeft, SideUp::kSkin),
                          member_of(1, 300.0, 0.0), member_of(1, 350.0, 0.0)});
  const AccuracySummary s = tally.summary();
  EXPECT_EQ(s.singles_flagged, 1U);
  EXPECT_EQ(s.groups_flagged, 1U);
  EXPECT_DOUBLE_EQ(s.singulation_precision, 0.5);
  EXPECT_DOUBLE_EQ(s.singulation_recall, 1.0);
}

// A single closer to another fillet than the least gap (4 mm, EstimatorParams::min_gap_mm) is
// to be reported not singulated: it is tallied as a near pair, not as a single, and is right
// when no blob near it claims a singulated fillet. Without the option it stays a single.
TEST(AccuracyTally, ASingleWithinTheLeastGapIsANearPair) {
  AccuracyOptions options;
  options.near_gap_mm = 4.0;
  TrueFillet close = single(0.0, 0.0, 0.0, Hand::kLeft, SideUp::kSkin);
  close.gap_mm = 3.0;  // under the least gap
  TrueFillet clear = single(200.0, 0.0, 0.0, Hand::kLeft, SideUp::kSkin);
  clear.gap_mm = 4.0;  // at the least gap: a single
  FrameResult flagged;
  flagged.blobs.push_back(fillet_blob(0.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin, false));
  flagged.blobs.push_back(fillet_blob(200.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin));
  FrameResult called_single;
  called_single.blobs.push_back(fillet_blob(0.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin));
  FrameResult merged;  // one blob with the neighbour, beyond the match gate: no single claimed
  merged.blobs.push_back(fillet_blob(0.0F, 40.0F, 0.0F, Hand::kUnknown, SideUp::kUnknown, false));

  AccuracyTally tally(options);
  tally.add_frame(flagged, {close, clear});
  tally.add_frame(called_single, {close});
  tally.add_frame(merged, {close});
  const AccuracySummary s = tally.summary();
  EXPECT_EQ(s.near_singles, 3U);
  EXPECT_EQ(s.near_reported_not_singulated, 2U);  // flagged and merged; not the one called single
  EXPECT_EQ(s.singles, 1U);                       // only the clear one
  EXPECT_EQ(s.detected, 1U);
  EXPECT_EQ(s.singles_flagged, 0U);

  AccuracyTally without_option;
  without_option.add_frame(flagged, {close, clear});
  EXPECT_EQ(without_option.summary().near_singles, 0U);
  EXPECT_EQ(without_option.summary().singles, 2U);
  EXPECT_EQ(without_option.summary().singles_flagged, 1U);
}

// A single whose gap lies just above the least gap, within the band the estimator measures
// gaps to, is borderline: either answer is right, and it is scored neither as a single nor as
// a near pair.
TEST(AccuracyTally, ASingleJustBeyondTheLeastGapIsBorderline) {
  AccuracyOptions options;
  options.near_gap_mm = 4.0;
  options.near_gap_band_mm = 1.0;
  TrueFillet borderline = single(0.0, 0.0, 0.0, Hand::kLeft, SideUp::kSkin);
  borderline.gap_mm = 4.4;  // in [4, 5): borderline
  TrueFillet clear = single(200.0, 0.0, 0.0, Hand::kLeft, SideUp::kSkin);
  clear.gap_mm = 5.0;  // at the band's end: a single
  FrameResult frame;
  frame.blobs.push_back(fillet_blob(0.0F, 0.0F, 0.0F, Hand::kUnknown, SideUp::kUnknown, false));
  frame.blobs.push_back(fillet_blob(200.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin));
  FrameResult called_single;
  called_single.blobs.push_back(fillet_blob(0.0F, 0.0F, 0.0F, Hand::kLeft, SideUp::kSkin));

  AccuracyTally tally(options);
  tally.add_frame(frame, {borderline, clear});
  tally.add_frame(called_single, {borderline});
  const AccuracySummary s = tally.summary();
  EXPECT_EQ(s.borderline_singles, 2U);
  EXPECT_EQ(s.borderline_reported_not_singulated, 1U);
  EXPECT_EQ(s.near_singles, 0U);
  EXPECT_EQ(s.singles, 1U);  // only the clear one
  EXPECT_EQ(s.singles_flagged, 0U);
  EXPECT_DOUBLE_EQ(s.hand_correct_share, 1.0);
}

// A detected single with the wrong hand or side, or one left unknown, is listed with its frame,
// its true pose and what the estimator said, so that `vision eval` can show the frame; a right
// one is not.
TEST(AccuracyTally, AMisjudgedSingleIsListedWithWhatTheEstimatorSaid) {
  AccuracyTally tally;
  FrameResult frame;
  frame.sequence = 239;
  frame.blobs.push_back(fillet_blob(0.0F, 14.0F, 1.4F, Hand::kLeft, SideUp::kBone));  // both wrong
  frame.blobs.push_back(fillet_blob(200.0F, 0.0F, 0.0F, Hand::kRight, SideUp::kSkin));  // right
  frame.blobs.push_back(fillet_blob(-200.0F, 0.0F, 0.0F, Hand::kRight, SideUp::kUnknown));
  tally.add_frame(frame, {single(0.0, 14.0, 1.4, Hand::kRight, SideUp::kSkin),
                          single(200.0, 0.0, 0.0, Hand::kRight, SideUp::kSkin),
                          single(-200.0, 0.0, 0.0, Hand::kRight, SideUp::kSkin)});
  ASSERT_EQ(tally.misjudged_singles().size(), 2U);
  const MisjudgedSingle& wrong = tally.misjudged_singles()[0];
  EXPECT_EQ(wrong.sequence, 239U);
  EXPECT_DOUBLE_EQ(wrong.y_mm, 14.0);
  EXPECT_EQ(wrong.true_hand, Hand::kRight);
  EXPECT_EQ(wrong.seen_hand, Hand::kLeft);
  EXPECT_EQ(wrong.true_side, SideUp::kSkin);
  EXPECT_EQ(wrong.seen_side, SideUp::kBone);
  EXPECT_FLOAT_EQ(wrong.confidence, 0.9F);
  EXPECT_EQ(tally.misjudged_singles()[1].seen_side, SideUp::kUnknown);
  EXPECT_DOUBLE_EQ(tally.misjudged_singles()[1].x_mm, -200.0);
  EXPECT_EQ(tally.summary().detected, 3U);
}

TEST(AccuracyTally, ARefusedFrameIsCounted) {
  AccuracyTally tally;
  FrameResult frame;
  frame.status = FrameStatus::kWrongResolution;
  tally.add_frame(frame, {});
  EXPECT_EQ(tally.summary().frames_not_ok, 1U);
}

TEST(AccuracyPercentile, IsNearestRank) {
  std::vector<double> values;
  for (int i = 20; i >= 1; --i) values.push_back(i);
  EXPECT_DOUBLE_EQ(percentile(values, 0.95), 19.0);  // rank ceil(0.95 * 20) = 19
  EXPECT_DOUBLE_EQ(percentile(values, 0.5), 10.0);
  EXPECT_DOUBLE_EQ(percentile(values, 1.0), 20.0);
  EXPECT_DOUBLE_EQ(percentile({}, 0.5), 0.0);
}

}  // namespace
}  // namespace fl::vision
