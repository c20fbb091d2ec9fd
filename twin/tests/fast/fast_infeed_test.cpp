// Infeed of the fast plant: hopper cylinder and blockage, the heap and level sensor, the
// leveller rotor and its overload, the levelled fillets on the takt conveyor, the barrier.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "fast_test_support.hpp"

namespace fl::test {
namespace {

// Belts stopped except what a test switches on; hopper at its stable opening.
OutputImage infeed_idle() {
  OutputImage out{};
  out.hopper_opening_mm = 60.0F;
  return out;
}

void run_bulk(OutputImage& out, float speed_mps) {
  out.drives[index(DriveId::kBulk)].enable = true;
  out.drives[index(DriveId::kBulk)].speed_mps = speed_mps;
}

TEST(FastInfeed, HopperCylinderMovesAtItsSpeed) {
  // 50 mm/s: 60 -> 90 mm takes 0.6 s; after 0.3 s it is at 75 mm.
  Rig rig;
  rig.out = infeed_idle();
  rig.run(0.1);
  EXPECT_FLOAT_EQ(rig.in.hopper_opening_mm, 60.0F);
  rig.out.hopper_opening_mm = 90.0F;
  rig.run(0.3);
  EXPECT_NEAR(rig.in.hopper_opening_mm, 75.0F, 1e-3);
  rig.run(0.4);
  EXPECT_FLOAT_EQ(rig.in.hopper_opening_mm, 90.0F);
}

TEST(FastInfeed, HeapGrowsWithBulkSpeedTimesOpening) {
  // 0.5 fillets/(m mm) x 0.1 m/s x 60 mm = 3 fillets/s, 8 mm of heap each: 24 mm/s. After the
  // drive's 5 ms delay and 20 ms ramp, 2 s give about 5.9 fillets, 5 whole ones: 40 mm
  // (level noise 1 mm sigma: 5 sigma bound).
  Rig rig;
  rig.out = infeed_idle();
  run_bulk(rig.out, 0.1F);
  rig.run(2.0);
  EXPECT_DOUBLE_EQ(rig.plant->state().infeed.layer_fillets, 5.0);
  EXPECT_NEAR(rig.in.level_mm, 40.0F, 5.0F);
  EXPECT_EQ(rig.plant->state().infeed.hopper_fillets,
            rig.config.infeed.hopper_initial_fillets - 5U);
  EXPECT_TRUE(rig.plant->bodies().empty());  // leveller stopped: nothing passes
}

TEST(FastInfeed, LevellerSpinsUpWithItsTimeConstant) {
  // First-order lag of 0.4 s: 120 x (1 - e^-1) = 75.85 rpm after 0.4 s.
  Rig rig;
  rig.out = infeed_idle();
  rig.out.leveller_speed_rpm = 120.0F;
  rig.run(0.4);
  EXPECT_NEAR(rig.in.leveller_speed_rpm, 120.0 * (1.0 - std::exp(-1.0)), 0.1);
  rig.run(3.0);
  EXPECT_NEAR(rig.in.leveller_speed_rpm, 120.0F, 0.1F);
  EXPECT_FALSE(rig.in.leveller_overload);
}

TEST(FastInfeed, HighHeapStallsAStoppedLeveller) {
  // Bulk at 0.15 m/s with the leveller stopped: 4.5 fillets/s, 36 mm/s of heap; beyond
  // 150 mm (about 4.2 s) the rotor cannot start against it.
  Rig rig;
  rig.out = infeed_idle();
  run_bulk(rig.out, 0.15F);
  rig.run(3.5);
  EXPECT_FALSE(rig.in.leveller_overload);
  rig.run(1.5);
  EXPECT_TRUE(rig.in.leveller_overload);
  rig.out.leveller_speed_rpm = 120.0F;
  rig.run(1.0);
  EXPECT_TRUE(rig.in.leveller_overload);
  EXPECT_FLOAT_EQ(rig.in.leveller_speed_rpm, 0.0F);
}

TEST(FastInfeed, InjectedLevellerOverloadStopsTheRotor) {
  Rig rig;
  rig.out = infeed_idle();
  rig.out.leveller_speed_rpm = 120.0F;
  rig.run(3.0);
  rig.plant->faults().leveller_overload = true;
  rig.run(0.01);
  EXPECT_TRUE(rig.in.leveller_overload);
  rig.run(3.0);
  EXPECT_LT(rig.in.leveller_speed_rpm, 1.0F);
  rig.plant->faults().leveller_overload = false;
  rig.run(3.0);
  EXPECT_FALSE(rig.in.leveller_overload);
  EXPECT_GT(rig.in.leveller_speed_rpm, 110.0F);
}

TEST(FastInfeed, SmallOpeningBlocksAndOpeningFurtherFreesIt) {
  // Thesis 6.1: at 45 mm the flow stalls (0.3 blockages/s while the belt runs: P(none in
  // 30 s) = e^-9); at 60 mm it flows (no blockage in 60 s). Opening 15 mm beyond where it
  // blocked frees it.
  Rig stable;
  stable.out = infeed_idle();
  stable.out.leveller_speed_rpm = 120.0F;
  stable.out.drives[index(DriveId::kTakt)] = DriveCommand{true, 0.2F, 0.0F};
  run_bulk(stable.out, 0.05F);
  stable.run(60.0, 10 * kMs);
  EXPECT_EQ(stable.plant->counters().hopper_blockages, 0U);

  FastPlantConfig config = quiet_config();
  config.infeed.unblock_hazard_per_s = 0.0F;  // only opening further frees it here
  Rig rig(config);
  rig.out = infeed_idle();
  rig.out.hopper_opening_mm = 45.0F;
  run_bulk(rig.out, 0.05F);
  ASSERT_TRUE(
      rig.run_until([&] { return rig.plant->state().infeed.hopper_blocked; }, 30.0, 10 * kMs));
  const double layer = rig.plant->state().infeed.layer_fillets;
  rig.run(0.5, 10 * kMs);
  EXPECT_EQ(rig.plant->state().infeed.layer_fillets, layer);  // nothing comes out
  rig.out.hopper_opening_mm = 90.0F;
  rig.run(1.0, 10 * kMs);
  EXPECT_FALSE(rig.plant->state().infeed.hopper_blocked);
}

TEST(FastInfeed, InjectedHopperBlockageStopsTheOutflow) {
  Rig rig;
  rig.out = infeed_idle();
  run_bulk(rig.out, 0.1F);
  rig.plant->faults().hopper_blocked = true;
  rig.run(2.0);
  EXPECT_EQ(rig.plant->state().infeed.layer_fillets, 0.0);
}

TEST(FastInfeed, LevellerFeedsTheTaktConveyorWithSmallGaps) {
  // Heap filled first, then the leveller and a takt belt at standard speed: levelled
  // fillets enter at the takt belt's upstream end (-600 mm), 5..40 mm apart, roughly aligned.
  Rig rig;
  rig.out = infeed_idle();
  run_bulk(rig.out, 0.1F);
  rig.out.leveller_speed_rpm = 120.0F;
  rig.out.drives[index(DriveId::kTakt)] = DriveCommand{true, 0.08F, 0.0F};
  rig.run(6.0);  // three fillets; the first is still short of the barrier
  const auto bodies = rig.plant->bodies();
  ASSERT_GE(bodies.size(), 2U);
  for (std::size_t i = 1; i < bodies.size(); ++i) {
    const FilletBody& leader = bodies[i - 1];
    const FilletBody& follower = bodies[i];
    const double gap_mm =
        (leader.s_mm - leader.half_extent_s_mm) - (follower.s_mm + follower.half_extent_s_mm);
    EXPECT_GE(gap_mm, 5.0 - 1e-6);
    EXPECT_LE(gap_mm, 40.0 + 0.1);  // plus one step of travel at 0.08 m/s
  }
  for (const FilletBody& body : bodies) {
    EXPECT_LT(body.s_mm, 0.0);
    EXPECT_FALSE(body.fed);
    // 0 or pi with 0.35 rad sigma: within 5 sigma.
    const double off_axis =
        std::min(std::abs(body.angle_rad), std::numbers::pi - std::abs(body.angle_rad));
    EXPECT_LT(off_axis, 5 * 0.35);
    EXPECT_LE(std::abs(body.y_mm), 100.0);
  }
  EXPECT_EQ(rig.plant->fillets_fed(), 0U);
}

TEST(FastInfeed, TaktBarrierSeesBodiesAtItsEdgeAndFeedCounts) {
  Rig rig;
  rig.out = infeed_idle();
  BodySpawn spawn;
  spawn.s_mm = -200.0;  // 172 mm long: covers -286 .. -114, clear of [-5, 0]
  const auto id = rig.plant->spawn_body(spawn);
  ASSERT_TRUE(id);
  rig.step();
  EXPECT_FALSE(rig.in.takt_beam_broken);
  rig.out.drives[index(DriveId::kTakt)] = DriveCommand{true, 0.1F, 0.0F};
  rig.out.drives[index(DriveId::kTransition1)] = DriveCommand{true, 0.3F, 0.0F};
  // The front edge reaches -5 mm after 109 mm at 0.1 m/s: about 1.1 s.
  ASSERT_TRUE(rig.run_until([&] { return rig.in.takt_beam_broken; }, 2.0));
  EXPECT_NEAR(rig.body(*id)->s_mm + 86.0, -5.0, 0.5);
  EXPECT_EQ(rig.plant->fillets_fed(), 0U);
  ASSERT_TRUE(rig.run_until([&] { return rig.plant->fillets_fed() == 1U; }, 3.0));
  EXPECT_NEAR(rig.body(*id)->s_mm, 0.0, 0.5);
  EXPECT_EQ(rig.plant->fillets_on_line(), 1U);
  ASSERT_TRUE(rig.run_until([&] { return !rig.in.takt_beam_broken; }, 3.0));
  EXPECT_NEAR(rig.body(*id)->s_mm - 86.0, 0.0, 1.0);
}

TEST(FastInfeed, FullPoolStopsFeedingAndCounts) {
  FastPlantConfig config = quiet_config();
  config.max_bodies = 3;
  Rig rig(config);
  rig.out = infeed_idle();
  run_bulk(rig.out, 0.1F);
  rig.out.leveller_speed_rpm = 120.0F;
  // Transition 1 carries the fillets off the takt belt (room at its upstream end) and they
  // stop at its end, where transition 2 stands still: the pool, not the room, limits.
  rig.out.drives[index(DriveId::kTakt)] = DriveCommand{true, 0.3F, 0.0F};
  rig.out.drives[index(DriveId::kTransition1)] = DriveCommand{true, 0.3F, 0.0F};
  rig.run(10.0, 10 * kMs);
  EXPECT_EQ(rig.plant->bodies().size(), 3U);
  EXPECT_GE(rig.plant->counters().pool_full_refusals, 1U);
}

}  // namespace
}  // namespace fl::test
