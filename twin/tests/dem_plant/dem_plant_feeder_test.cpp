// The levelled-layer feeder of the DEM plant: what it puts on the takt belt stays on it.
#include <gtest/gtest.h>

#include "dem_plant_test_support.hpp"

namespace fl::test {
namespace {

TEST(DemPlantFeeder, TouchingPairsAreFedWhollyOntoTheTaktBelt) {
  // Every feed a touching pair (4 % on the line), the infeed running. The partner lies to the
  // first fillet's left: for a pair heading against the travel that is up to 40 mm upstream and
  // towards the right wall. Placed there it hung over the belt's end, tipped off and held the
  // entry shut for the rest of a run (seed 1 of the closed loop fed nothing after 45 s), or
  // pressed into the wall and stayed put on the moving belt, which shut the entry as well.
  // Each member's rearmost sphere must be on the belt (its upstream end less the sphere
  // radius, 7 mm, that the centroid's placement margin does not cover), and the feed must go
  // on: 15 s move the belt 1.8 m, and a pair takes at most 176 mm of length, 40 mm of partner
  // offset and 40 mm of gap, so six pairs at the least.
  DemPlantConfig config = test_config();
  config.shared.fillet.touching_pair_prob = 1.0F;
  DemRig rig(config);
  rig.out.drives[index(DriveId::kBulk)].speed_mps = 0.1F;  // fills the backlog, 3 fillets a second
  rig.out.hopper_opening_mm = 60.0F;
  rig.out.leveller_speed_rpm = 120.0F;
  const double entry_mm = -static_cast<double>(rig.line.takt_belt_length_mm);
  double rearmost_mm = 0.0;
  std::uint64_t fed_pairs = 0;
  for (int scan = 0; scan < 1500; ++scan) {
    rig.step();
    for (const DemFilletView& fillet : rig.plant->fillets()) {
      rearmost_mm = std::min(rearmost_mm, fillet.min_s_mm);
    }
    fed_pairs = rig.plant->counters().fillets_spawned / 2;
  }
  EXPECT_GE(fed_pairs, 6U);
  EXPECT_GE(rearmost_mm, entry_mm - 7.0);
}

}  // namespace
}  // namespace fl::test
