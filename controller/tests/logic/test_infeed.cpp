#include <gtest/gtest.h>

#include "test_support.hpp"

namespace fl::logic {
namespace {

TEST(BulkFeed, LowLevelSpeedsTheBulkBeltUpAndFullLevelSlowsIt) {
  test::Harness h;
  BulkFeedStation station(h.config);
  h.in.level_mm = 0.0F;  // empty in front of the leveller
  station.update(h.context(), h.out);
  const float empty_speed = h.out.drives[index(DriveId::kBulk)].speed_mps;
  h.in.level_mm = 2.0F * h.config.bulk.level_setpoint_mm;  // overfull
  station.update(h.context(), h.out);
  EXPECT_GT(empty_speed, 0.0F);
  EXPECT_EQ(h.out.drives[index(DriveId::kBulk)].speed_mps, h.config.bulk.min_speed_mps);
}

TEST(BulkFeed, IntegralDoesNotWindUpWhileSaturated) {
  test::Harness h;
  BulkFeedStation station(h.config);
  h.in.level_mm = 0.0F;
  // 100 s starved at full speed; without anti-windup the integral would hold the belt at
  // full speed for a long time after the level recovers.
  for (int scan = 0; scan < 10'000; ++scan) station.update(h.context(), h.out);
  h.in.level_mm = h.config.bulk.level_setpoint_mm + 20.0F;
  station.update(h.context(), h.out);
  EXPECT_LT(h.out.drives[index(DriveId::kBulk)].speed_mps, h.config.bulk.max_speed_mps);
}

TEST(BulkFeed, StarvedHopperIsOpenedWiderForAMoment) {
  test::Harness h;
  BulkFeedStation station(h.config);
  h.in.level_mm = 0.0F;
  const int scans_until_starved = static_cast<int>(h.config.bulk.starved_after_s / 0.01F) + 50;
  bool opened = false;
  for (int scan = 0; scan < scans_until_starved; ++scan) {
    station.update(h.context(), h.out);
    opened = opened || h.out.hopper_opening_mm == h.config.bulk.hopper_unblock_opening_mm;
  }
  EXPECT_TRUE(opened);
  const int unblock_scans = static_cast<int>(h.config.bulk.unblock_duration_s / 0.01F) + 2;
  for (int scan = 0; scan < unblock_scans; ++scan) station.update(h.context(), h.out);
  EXPECT_EQ(h.out.hopper_opening_mm, h.config.bulk.hopper_opening_mm);
}

TEST(Leveller, JamIsDetectedAfterSpinUp) {
  test::Harness h;
  LevellerStation station(h.config);
  h.in.leveller_speed_rpm = 0.0F;  // blades not turning
  const int spin_up_scans = static_cast<int>(h.config.leveller.spin_up_s / 0.01F);
  for (int scan = 0; scan < spin_up_scans - 1; ++scan) {
    EXPECT_FALSE(station.update(h.context(), h.out));
  }
  bool jammed = false;
  for (int scan = 0; scan < 5; ++scan) jammed = station.update(h.context(), h.out);
  EXPECT_TRUE(jammed);
}

TEST(Leveller, OverloadInputIsAFaultAtOnce) {
  test::Harness h;
  LevellerStation station(h.config);
  h.in.leveller_overload = true;
  EXPECT_TRUE(station.update(h.context(), h.out));
}

class TaktTest : public ::testing::Test {
 protected:
  void scan(TaktStation& station, float takt_travel_mm) {
    test::move_belt(h.in, h.config, DriveId::kTakt, takt_travel_mm);
    h.in.time_ns += 10'000'000;
    h.tracker.advance(h.in);
    station.update(h.context(), h.out);
  }
  test::Harness h;
};

TEST_F(TaktTest, BeamBreakCreatesOneItemAndAcceleratesTheTakt) {
  TaktStation station(h.config);
  h.tracker.advance(h.in);
  station.update(h.context(), h.out);
  EXPECT_FLOAT_EQ(h.out.drives[index(DriveId::kTakt)].speed_mps, h.config.takt.standard_speed_mps);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 3; ++i) scan(station, 0.8F);  // 30 ms: past the 20 ms debounce
  EXPECT_EQ(h.tracker.active_count(), 1U);
  EXPECT_EQ(station.phase(), TaktStation::Phase::kPull);
  EXPECT_FLOAT_EQ(h.out.drives[index(DriveId::kTakt)].speed_mps, h.config.takt.takt_speed_mps);
  EXPECT_FLOAT_EQ(h.out.drives[index(DriveId::kTakt)].accel_mps2, h.config.takt.takt_accel_mps2);
  // The stroke ends after the pull distance of belt travel, back to standard speed.
  h.in.takt_beam_broken = false;
  scan(station, h.config.takt.pull_distance_mm);
  EXPECT_EQ(station.phase(), TaktStation::Phase::kIndex);
  EXPECT_EQ(h.tracker.active_count(), 1U);
}

TEST_F(TaktTest, NextRowWaitsUntilThePreviousItemIsClear) {
  TaktStation station(h.config);
  h.tracker.advance(h.in);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 3; ++i) scan(station, 0.0F);
  ASSERT_EQ(h.tracker.active_count(), 1U);
  scan(station, h.config.takt.pull_distance_mm);
  // The pulled fillet leaves the beam, then the next row arrives at once.
  h.in.takt_beam_broken = false;
  for (int i = 0; i < 3; ++i) scan(station, 1.0F);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 3; ++i) scan(station, 0.0F);
  EXPECT_EQ(station.phase(), TaktStation::Phase::kWaitGap);
  EXPECT_EQ(h.out.drives[index(DriveId::kTakt)].speed_mps, 0.0F);  // holds the row
  EXPECT_EQ(h.tracker.active_count(), 1U);
  // Once the previous item is past the minimum gap and the minimum period has passed,
  // the next stroke goes.
  h.tracker.items()[0].s_mm = h.config.takt.min_gap_mm + 1.0F;
  const int period_scans = static_cast<int>(h.config.takt.min_period_s / 0.01F) + 1;
  for (int i = 0; i < period_scans; ++i) scan(station, 0.0F);
  EXPECT_EQ(h.tracker.active_count(), 2U);
}

// The pulled fillet's tail keeps the beam broken after the stroke: that is the same
// fillet, not the next row, however long it lasts.
TEST_F(TaktTest, BeamThatNeverClearsCountsOnce) {
  TaktStation station(h.config);
  h.tracker.advance(h.in);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 500; ++i) {  // 5 s, several minimum periods
    scan(station, 1.0F);
    if (!h.tracker.items()[0].active) continue;
    h.tracker.items()[0].s_mm = h.config.takt.min_gap_mm + 1.0F;  // gap is never the limit
  }
  EXPECT_EQ(h.tracker.active_count(), 1U);
}

// Seen in the DEM twin: the held row settles a few mm back as the takt belt stops, so the
// beam is clear when the stroke starts, and the pulled fillet breaks it again during the
// pull. That clear beam is not the gap behind the pulled fillet: its body over the beam
// after the pull must not start a second stroke (which created an item for the fillet
// behind, still 75 mm short of the barrier, and later a ghost at camera 1).
TEST_F(TaktTest, BeamClearAtTheStartOfThePullDoesNotArmTheNextStroke) {
  TaktStation station(h.config);
  h.tracker.advance(h.in);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 3; ++i) scan(station, 0.0F);
  ASSERT_EQ(h.tracker.active_count(), 1U);
  ASSERT_EQ(station.phase(), TaktStation::Phase::kPull);
  h.in.takt_beam_broken = false;                    // settled 5 mm back off the beam
  for (int i = 0; i < 4; ++i) scan(station, 5.0F);  // 40 ms clear: twice the debounce
  h.in.takt_beam_broken = true;                     // the pulled fillet reaches the beam
  // The rest of the pull, then 2 s with its body over the beam (a slow crossing): well past
  // the minimum period, with the gap never the limit.
  for (int i = 0; i < 200; ++i) {
    scan(station, 5.0F);
    if (h.tracker.items()[0].active) h.tracker.items()[0].s_mm = h.config.takt.min_gap_mm + 1.0F;
  }
  EXPECT_EQ(h.tracker.active_count(), 1U);
  // Its tail leaves the beam, the next row arrives: the next stroke goes.
  h.in.takt_beam_broken = false;
  for (int i = 0; i < 3; ++i) scan(station, 1.0F);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 3; ++i) scan(station, 0.0F);
  EXPECT_EQ(h.tracker.active_count(), 2U);
}

// A row held at the barrier that comes off the beam (settling back, or the beam was broken
// by the previous fillet's tail that the transition belt then pulled away) is not struck at
// a clear beam: the takt creeps on at standard speed until the beam breaks again.
TEST_F(TaktTest, HeldRowThatLeavesTheBeamIsNotStruck) {
  TaktStation station(h.config);
  h.tracker.advance(h.in);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 3; ++i) scan(station, 0.0F);
  scan(station, h.config.takt.pull_distance_mm);
  h.in.takt_beam_broken = false;
  for (int i = 0; i < 3; ++i) scan(station, 1.0F);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 3; ++i) scan(station, 0.0F);
  ASSERT_EQ(station.phase(), TaktStation::Phase::kWaitGap);  // held: minimum period
  h.in.takt_beam_broken = false;
  const int period_scans = static_cast<int>(h.config.takt.min_period_s / 0.01F) + 1;
  for (int i = 0; i < period_scans; ++i) {
    scan(station, 0.0F);
    h.tracker.items()[0].s_mm = h.config.takt.min_gap_mm + 1.0F;
  }
  EXPECT_EQ(station.phase(), TaktStation::Phase::kIndex);
  EXPECT_FLOAT_EQ(h.out.drives[index(DriveId::kTakt)].speed_mps, h.config.takt.standard_speed_mps);
  EXPECT_EQ(h.tracker.active_count(), 1U);
  h.in.takt_beam_broken = true;  // the row is at the barrier again: struck at once
  for (int i = 0; i < 3; ++i) scan(station, 0.0F);
  EXPECT_EQ(h.tracker.active_count(), 2U);
}

// A stop during a stroke lets the stroke finish: the item it created must leave the takt.
TEST_F(TaktTest, StrokeInProgressFinishesWhenTheInfeedStops) {
  TaktStation station(h.config);
  h.tracker.advance(h.in);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 3; ++i) scan(station, 0.0F);
  ASSERT_EQ(station.phase(), TaktStation::Phase::kPull);
  test::move_belt(h.in, h.config, DriveId::kTakt, 10.0F);
  h.tracker.advance(h.in);
  station.update(h.context(0.01F, true, false), h.out);
  EXPECT_FLOAT_EQ(h.out.drives[index(DriveId::kTakt)].speed_mps, h.config.takt.takt_speed_mps);
  test::move_belt(h.in, h.config, DriveId::kTakt, h.config.takt.pull_distance_mm);
  h.tracker.advance(h.in);
  station.update(h.context(0.01F, true, false), h.out);
  EXPECT_EQ(h.out.drives[index(DriveId::kTakt)].speed_mps, 0.0F);
}

TEST_F(TaktTest, NoFeedingWhileTheInfeedIsDisabled) {
  TaktStation station(h.config);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 10; ++i) station.update(h.context(0.01F, true, false), h.out);
  EXPECT_EQ(h.tracker.active_count(), 0U);
  EXPECT_EQ(h.out.drives[index(DriveId::kTakt)].speed_mps, 0.0F);
}

}  // namespace
}  // namespace fl::logic
