#include <gtest/gtest.h>

#include "test_support.hpp"

namespace fl::logic {
namespace {

Item& item_at(test::Harness& h, float s_mm, float angle_rad) {
  Item* item = h.tracker.create(0, s_mm, false);
  item->angle_known = true;
  item->angle_rad = angle_rad;
  return *item;
}

// Tip leading along the belt (heading 0): the thickest section is 0.2 lengths behind the
// centre (thickest at 0.3 of the length from the rear).
TEST(Squeeze, ThickestSectionPositionFromHeading) {
  test::Harness h;
  Item& item = item_at(h, 1000.0F, 0.0F);
  EXPECT_FLOAT_EQ(thickest_section_s_mm(item, 0.3F), 1000.0F - 0.2F * item.length_mm);
  EXPECT_FLOAT_EQ(rear_s_mm(item), 1000.0F - 0.5F * item.length_mm);
}

TEST(Squeeze, RollerStaysUpUntilTheThickestSectionHasPassed) {
  test::Harness h;
  SqueezeStation station(h.config);
  const float roller = h.config.squeeze.roller_s_mm;
  Item& item = item_at(h, roller, 0.0F);  // centre under the roller, thickest still before it
  station.update(h.context(), h.out);
  EXPECT_FALSE(h.out.squeeze_roller_down);
  item.s_mm = roller + 0.2F * item.length_mm + 20.0F;  // thickest 20 mm past, rear still before
  station.update(h.context(), h.out);
  EXPECT_TRUE(h.out.squeeze_roller_down);
  item.s_mm = roller + 0.5F * item.length_mm + 10.0F;  // whole fillet past: lift
  station.update(h.context(), h.out);
  EXPECT_FALSE(h.out.squeeze_roller_down);
}

TEST(Squeeze, ApproachingThickSectionOverridesAnItemBehindWhichItCouldPress) {
  test::Harness h;
  SqueezeStation station(h.config);
  const float roller = h.config.squeeze.roller_s_mm;
  Item& first = item_at(h, roller + 0.2F * 170.0F + 20.0F, 0.0F);  // would want it down
  Item& second = item_at(h, roller + 0.2F * 170.0F - 2.0F, 0.0F);  // thickest just arriving
  (void)first;
  (void)second;
  station.update(h.context(), h.out);
  EXPECT_FALSE(h.out.squeeze_roller_down);
}

class FinalTest : public ::testing::Test {
 protected:
  Item& seen_item(float angle_rad, float y_mm, SideUp side) {
    Item& item = item_at(h, station.decision_s_mm() + 1.0F, angle_rad);
    item.hand = Hand::kRight;
    item.classified = true;
    item.target_angle_rad = h.config.tolerance.target_angle_rad;
    FilletEstimate estimate = test::good_estimate(Hand::kRight, side, angle_rad);
    estimate.y_mm = y_mm;
    item.evidence[index(CameraId::kFinal)].add(estimate);
    return item;
  }
  void pass_to(Item& item, float s_mm) {
    item.s_mm = s_mm;
    station.update(h.context(), h.out);
  }
  test::Harness h;
  FinalStation station{h.config};
};

TEST_F(FinalTest, InToleranceIsPlacedAtTheEnd) {
  Item& item =
      seen_item(h.config.tolerance.target_angle_rad + 0.5F * h.config.tolerance.angle_tol_rad, 5.0F,
                h.config.flip.target_side);
  station.update(h.context(), h.out);
  EXPECT_FALSE(item.final_reject);
  pass_to(item, h.config.tolerance.final_reject_s_mm);
  EXPECT_FALSE(h.out.final_reject);
  pass_to(item, h.config.placed_at_s_mm);
  EXPECT_EQ(h.records.pop()->outcome, Outcome::kPlaced);
}

TEST_F(FinalTest, AngleOutOfToleranceIsBlownOff) {
  Item& item =
      seen_item(h.config.tolerance.target_angle_rad + 2.0F * h.config.tolerance.angle_tol_rad, 0.0F,
                h.config.flip.target_side);
  station.update(h.context(), h.out);
  EXPECT_TRUE(item.final_reject);
  pass_to(item, h.config.tolerance.final_reject_s_mm);
  EXPECT_TRUE(h.out.final_reject);
  pass_to(item, h.config.tolerance.final_reject_s_mm + 41.0F);  // past the 40 mm knife window
  EXPECT_EQ(h.records.pop()->outcome, Outcome::kRejectedMisaligned);
}

TEST_F(FinalTest, WrongSideIsBlownOff) {
  const SideUp wrong = h.config.flip.target_side == SideUp::kSkin ? SideUp::kBone : SideUp::kSkin;
  Item& item = seen_item(h.config.tolerance.target_angle_rad, 0.0F, wrong);
  station.update(h.context(), h.out);
  EXPECT_TRUE(item.final_reject);
}

TEST_F(FinalTest, LateralOffsetIsBlownOff) {
  Item& item = seen_item(h.config.tolerance.target_angle_rad,
                         h.config.tolerance.lateral_tol_mm + 1.0F, h.config.flip.target_side);
  station.update(h.context(), h.out);
  EXPECT_TRUE(item.final_reject);
}

TEST_F(FinalTest, UnseenItemIsNotPlacedBlind) {
  Item& item = item_at(h, station.decision_s_mm() + 1.0F, 0.0F);
  item.evidence[index(CameraId::kOrientation)].frames = 3;  // it was seen upstream
  station.update(h.context(), h.out);
  EXPECT_TRUE(item.final_reject);
  pass_to(item, h.config.tolerance.final_reject_s_mm + 41.0F);
  EXPECT_EQ(h.records.pop()->outcome, Outcome::kRejectedUnverified);
}

TEST(Reject, FlaggedItemIsReversedIntoTheCrateAndClosedWithItsReason) {
  test::Harness h;
  RejectStation station(h.config);
  const BeltSection& belt = h.config.sections[index(DriveId::kReject)];
  h.tracker.advance(h.in);
  Item* item = h.tracker.create(0, belt.start_mm + 100.0F, false);
  item->passed_plate1 = item->passed_plate2 = true;
  item->reject_pending = true;
  item->reject_reason = Outcome::kRejectedNotSingulated;
  bool hold = false;
  station.update(h.context(), h.out, hold);
  EXPECT_TRUE(station.reversing());
  EXPECT_FLOAT_EQ(h.out.drives[index(DriveId::kReject)].speed_mps,
                  -h.config.reject.reverse_speed_mps);
  // Run the belt back 10 mm a scan until the item is closed; it must have travelled past
  // the belt's upstream edge plus half its length plus the drop margin.
  int scans = 0;
  while (h.tracker.active_count() > 0 && scans < 1000) {
    test::move_belt(h.in, h.config, DriveId::kReject, -10.0F);
    h.tracker.advance(h.in);
    station.update(h.context(), h.out, hold);
    ++scans;
  }
  const float expected_travel = 100.0F + 0.5F * 170.0F + h.config.reject.drop_margin_mm;
  EXPECT_NEAR(10.0F * static_cast<float>(scans), expected_travel,
              10.0F);  // one scan's travel of resolution
  EXPECT_EQ(h.records.pop()->outcome, Outcome::kRejectedNotSingulated);
  station.update(h.context(), h.out, hold);
  EXPECT_FALSE(station.reversing());
  EXPECT_GT(h.out.drives[index(DriveId::kReject)].speed_mps, 0.0F);
}

TEST(Reject, GoodItemCarriedIntoTheCrateIsCollateral) {
  test::Harness h;
  RejectStation station(h.config);
  const BeltSection& belt = h.config.sections[index(DriveId::kReject)];
  h.tracker.advance(h.in);
  Item* flagged = h.tracker.create(0, belt.start_mm + 200.0F, false);
  flagged->passed_plate1 = flagged->passed_plate2 = flagged->reject_pending = true;
  flagged->reject_reason = Outcome::kRejectedNotSingulated;
  Item* good = h.tracker.create(0, belt.start_mm + 10.0F, false);
  good->passed_plate1 = good->passed_plate2 = true;
  bool hold = false;
  for (int scan = 0; scan < 200 && h.tracker.active_count() > 0; ++scan) {
    station.update(h.context(), h.out, hold);
    test::move_belt(h.in, h.config, DriveId::kReject, -10.0F);
    h.tracker.advance(h.in);
  }
  std::array<int, kOutcomeCount> seen{};
  while (auto record = h.records.pop()) ++seen[static_cast<std::size_t>(record->outcome)];
  EXPECT_EQ(seen[static_cast<std::size_t>(Outcome::kRejectedCollateral)], 1);
  EXPECT_EQ(seen[static_cast<std::size_t>(Outcome::kRejectedNotSingulated)], 1);
}

TEST(Centring, StrokeShiftsTheMeasuredOffsetToTheCentre) {
  test::Harness h;
  CentringStation station(h.config);
  Item* item = h.tracker.create(0, h.config.centring.s_mm - 100.0F, false);
  FilletEstimate estimate = test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F);
  estimate.y_mm = 25.0F;
  item->evidence[index(CameraId::kPosition)].add(estimate);
  station.update(h.context(), h.out);
  EXPECT_FLOAT_EQ(h.out.centring_shift_mm, -25.0F);  // pre-positioned
  EXPECT_FALSE(h.out.centring_stroke);               // not yet at the unit
  item->s_mm = h.config.centring.s_mm;
  station.update(h.context(), h.out);
  EXPECT_TRUE(h.out.centring_stroke);
  h.in.centring_position_mm = -25.0F;  // the pusher reports the stroke done
  item->s_mm = h.config.centring.s_mm + 21.0F;
  station.update(h.context(), h.out);
  EXPECT_TRUE(item->centring_done);
  EXPECT_FLOAT_EQ(item->y_mm, 0.0F);
}

// The item crosses the 40 mm stroke window in 80 ms at 0.5 m/s; a 50 mm stroke takes the
// pusher 0.1 s at its top speed (0.12 s for 60 mm) and longer on a profile gentle enough
// not to throw the fillet (the DEM twin: 0.21 s). Dropping the stroke when the item left
// the window retracted the plate mid-stroke at full speed, and the fillet slid on to 40 mm
// on the other side. The stroke is held until the pusher reports the shift.
TEST(Centring, StrokeIsHeldUntilThePusherReportsTheShift) {
  test::Harness h;
  CentringStation station(h.config);
  Item* item = h.tracker.create(0, h.config.centring.s_mm, false);
  FilletEstimate estimate = test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F);
  estimate.y_mm = 50.0F;
  item->evidence[index(CameraId::kPosition)].add(estimate);
  station.update(h.context(), h.out);
  ASSERT_TRUE(h.out.centring_stroke);
  h.in.centring_position_mm = -40.0F;  // 80 ms at 0.5 m/s: 40 of the 50 mm
  item->s_mm = h.config.centring.s_mm + 40.0F;
  station.update(h.context(), h.out);
  EXPECT_TRUE(h.out.centring_stroke);
  EXPECT_FLOAT_EQ(h.out.centring_shift_mm, -50.0F);
  EXPECT_FALSE(item->centring_done);
  h.in.centring_position_mm = -50.0F;
  item->s_mm = h.config.centring.s_mm + 50.0F;
  station.update(h.context(), h.out);
  EXPECT_FALSE(h.out.centring_stroke);
  EXPECT_TRUE(item->centring_done);
  EXPECT_FLOAT_EQ(item->y_mm, 0.0F);
}

// A pusher that never arrives (jammed, or the item was not there) does not hold the unit
// for the next item: the stroke ends 150 mm past the unit, 350 mm before the next item at
// the nominal 500 mm spacing reaches the approach zone.
TEST(Centring, HeldStrokeEndsWhenTheItemIsWellPastTheUnit) {
  test::Harness h;
  CentringStation station(h.config);
  Item* item = h.tracker.create(0, h.config.centring.s_mm, false);
  FilletEstimate estimate = test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F);
  estimate.y_mm = 50.0F;
  item->evidence[index(CameraId::kPosition)].add(estimate);
  station.update(h.context(), h.out);
  item->s_mm = h.config.centring.s_mm + 151.0F;
  station.update(h.context(), h.out);
  EXPECT_FALSE(h.out.centring_stroke);
  EXPECT_TRUE(item->centring_done);
}

// Two items close together: the first one's stroke ends as it leaves the window, and the
// pusher retracts from its 50 mm. The second item's stroke waits until the pusher reports
// home; passing 20 mm on the way back (the second item's shift) is not its stroke done. A
// second item that leaves the window before the pusher is home keeps the camera's offset.
TEST(Centring, NextStrokeStartsOnlyWithThePusherHome) {
  test::Harness h;
  CentringStation station(h.config);
  const float unit_mm = h.config.centring.s_mm;
  auto measured = [&](Item* item, float y_mm) {
    FilletEstimate estimate = test::good_estimate(Hand::kLeft, SideUp::kBone, 0.0F);
    estimate.y_mm = y_mm;
    item->evidence[index(CameraId::kPosition)].add(estimate);
  };
  Item* first = h.tracker.create(0, unit_mm + 21.0F, false);
  first->y_mm = 50.0F;  // as camera 2 saw it when its stroke began
  first->centring_shift_mm = -50.0F;
  first->centring_stroke_started = true;
  Item* second = h.tracker.create(0, unit_mm - 10.0F, false);  // in the window
  measured(second, 20.0F);
  h.in.centring_position_mm = -50.0F;  // the first stroke is done
  station.update(h.context(), h.out);
  EXPECT_TRUE(first->centring_done);
  EXPECT_FLOAT_EQ(first->y_mm, 0.0F);
  EXPECT_FALSE(h.out.centring_stroke) << "the pusher is out at -50 mm";
  EXPECT_FLOAT_EQ(h.out.centring_shift_mm, -20.0F);  // pre-positioned only
  h.in.centring_position_mm = -20.0F;                // retracting through the second item's shift
  station.update(h.context(), h.out);
  EXPECT_FALSE(h.out.centring_stroke);
  EXPECT_FALSE(second->centring_stroke_started);
  h.in.centring_position_mm = 0.0F;  // home
  station.update(h.context(), h.out);
  EXPECT_TRUE(h.out.centring_stroke);
  EXPECT_TRUE(second->centring_stroke_started);
  // A third item reaches the window with the pusher out and leaves it before it is home.
  h.in.centring_position_mm = -20.0F;
  second->s_mm = unit_mm + 21.0F;
  Item* third = h.tracker.create(0, unit_mm - 10.0F, false);
  measured(third, 30.0F);
  station.update(h.context(), h.out);
  EXPECT_TRUE(second->centring_done);
  EXPECT_FALSE(h.out.centring_stroke);
  h.in.centring_position_mm = -5.0F;
  third->s_mm = unit_mm + 21.0F;
  station.update(h.context(), h.out);
  EXPECT_TRUE(third->centring_done);
  EXPECT_FALSE(third->centring_stroke_started);
  EXPECT_FLOAT_EQ(third->y_mm, 30.0F) << "no stroke: where camera 2 saw it";
}

}  // namespace
}  // namespace fl::logic
