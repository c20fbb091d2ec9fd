#include <gtest/gtest.h>

#include <functional>

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
// fillet, not the next row, however long it lasts while the belt has moved less than a
// whole fillet (takt.rearm_travel_mm, 190 mm).
TEST_F(TaktTest, BeamThatNeverClearsWithinAFilletsTravelCountsOnce) {
  TaktStation station(h.config);
  h.tracker.advance(h.in);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 3; ++i) scan(station, 0.0F);
  scan(station, h.config.takt.pull_distance_mm);
  // 5 s, several minimum periods, the fillet held back over the beam while the belt slips
  // under it: 497 x 0.1 = 49.7 mm more, 159.7 mm since the stroke.
  for (int i = 0; i < 497; ++i) {
    scan(station, 0.1F);
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
  // The rest of the pull (18 x 5 = 90 mm), then 1 s with its body over the beam (a slow
  // crossing, 100 x 0.3 = 30 mm): 1.22 s, past the minimum period, with the gap never the
  // limit and 140 mm of travel since the stroke, less than a fillet.
  for (int i = 0; i < 118; ++i) {
    scan(station, i < 18 ? 5.0F : 0.3F);
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

// Seen in the DEM twin (3 of 47 items): the next row touches the pulled fillet, or follows it
// so closely that the beam is clear for less than the debounce, so the beam never re-arms
// the takt and the row crosses without a stroke and without an item. Once the belt has
// moved a whole fillet since the stroke, a broken beam is that row.
class TaktRearmTest : public TaktTest {
 protected:
  // One stroke, its pull, and creeping at standard speed (1.2 mm a scan) with the beam as
  // `beam_at` says, until the row is struck or `max_scans` pass. Returns the travel since
  // the stroke when the second item was created (0 if none was).
  float stroke_then_creep(TaktStation& station, const std::function<bool(int)>& beam_at,
                          int max_scans) {
    h.tracker.advance(h.in);
    h.in.takt_beam_broken = true;
    for (int i = 0; i < 3; ++i) scan(station, 0.0F);
    scan(station, h.config.takt.pull_distance_mm);
    float travel_mm = h.config.takt.pull_distance_mm;
    for (int i = 0; i < max_scans; ++i) {
      h.in.takt_beam_broken = beam_at(i);
      const float step_mm = station.phase() == TaktStation::Phase::kWaitGap ? 0.0F : 1.2F;
      scan(station, step_mm);
      travel_mm += step_mm;
      if (h.tracker.items()[0].active) h.tracker.items()[0].s_mm = h.config.takt.min_gap_mm + 1.0F;
      if (h.tracker.active_count() == 2U) return travel_mm;
    }
    return 0.0F;
  }
  const Item& newest() const {
    const Item* newest = nullptr;
    for (const Item& item : h.tracker.items()) {
      if (item.active && (newest == nullptr || item.id > newest->id)) newest = &item;
    }
    return *newest;
  }
};

TEST_F(TaktRearmTest, TouchingRowIsStruckOnceTheBeltHasMovedAWholeFillet) {
  TaktStation station(h.config);
  const float struck_at_mm = stroke_then_creep(
      station, [](int) { return true; }, 300);
  ASSERT_GT(struck_at_mm, 0.0F);
  // Armed at the first scan past 190 mm (110 + 67 x 1.2 = 190.4), the belt then held.
  EXPECT_NEAR(struck_at_mm, 190.4F, 0.01F);
  // No break after the pull: the row's front is taken as the travel beyond a nominal
  // fillet (190.4 - 170), its centre half a nominal length behind that.
  const float nominal_mm = h.config.tracking.nominal_length_mm;
  EXPECT_NEAR(newest().s_mm, (struck_at_mm - nominal_mm) - 0.5F * nominal_mm, 0.01F);
  // Then the row behind it arrives after a clear beam, as usual: a third stroke.
  for (int i = 0; i < 12; ++i) scan(station, 10.0F);  // its pull
  h.in.takt_beam_broken = false;
  for (int i = 0; i < 3; ++i) scan(station, 1.2F);
  h.in.takt_beam_broken = true;
  for (int i = 0; i < 100; ++i) {
    scan(station, 0.0F);
    for (Item& item : h.tracker.items()) item.s_mm = h.config.takt.min_gap_mm + 1.0F;
  }
  EXPECT_EQ(h.tracker.active_count(), 3U);
}

TEST_F(TaktRearmTest, RowBehindAGapShorterThanTheDebounceIsStruckWithItsFrontWhereItBroke) {
  TaktStation station(h.config);
  // The pulled fillet's tail leaves at scan 40 (110 + 40 x 1.2 = 158 mm): one scan clear,
  // 10 ms, under the 20 ms debounce; the next row breaks the beam at scan 41.
  const float struck_at_mm = stroke_then_creep(
      station, [](int i) { return i != 40; }, 300);
  ASSERT_GT(struck_at_mm, 0.0F);
  // Its front has moved with the belt since the scan that saw it: the scans after scan 41
  // up to the arming at 190.4 mm (110 + 67 x 1.2), 25 x 1.2 = 30 mm.
  const float nominal_mm = h.config.tracking.nominal_length_mm;
  EXPECT_NEAR(newest().s_mm, 25.0F * 1.2F - 0.5F * nominal_mm, 0.01F);
}

// A fillet stuck under the beam while the belt runs: one extra item, not one a period.
TEST_F(TaktRearmTest, BeamBrokenForGoodMakesOneExtraItemAtMost) {
  TaktStation station(h.config);
  ASSERT_GT(stroke_then_creep(
                station, [](int) { return true; }, 300),
            0.0F);
  for (int i = 0; i < 1000; ++i) {  // 10 s more, 1.2 m of belt
    scan(station, station.phase() == TaktStation::Phase::kWaitGap ? 0.0F : 1.2F);
    for (Item& item : h.tracker.items()) item.s_mm = h.config.takt.min_gap_mm + 1.0F;
  }
  EXPECT_EQ(h.tracker.active_count(), 2U);
}

// With the rule off (a line.yaml from before it) only a clear beam re-arms: 10 s of a
// broken beam over 1.2 m of belt make no second item.
TEST_F(TaktRearmTest, WithTheRuleOffOnlyAClearBeamReArms) {
  h.config.takt.rearm_travel_mm = 0.0F;
  TaktStation station(h.config);
  EXPECT_EQ(stroke_then_creep(
                station, [](int) { return true; }, 1000),
            0.0F);
  EXPECT_EQ(h.tracker.active_count(), 1U);
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
