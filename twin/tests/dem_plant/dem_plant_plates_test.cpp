// The flip plates of the DEM plant (thesis 5.2, figure 5.13: "functioning as a slide, it
// prevented the fillets from overturning, whereas when it moved out of the way, it resulted in
// the fillets flipping over"). Plate 1 is physical: the outcome is the contact's, not a rule.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dem_plant_test_support.hpp"

namespace fl::test {
namespace {

struct PlatesPass {
  SideUp side = SideUp::kUnknown;
  double angle_rad = 0.0;
  double s_mm = 0.0;
  std::uint64_t flips = 0;
};

double wrapped(double angle_rad) { return std::remainder(angle_rad, 2.0 * std::numbers::pi); }

// One fillet fed onto the guide's raised end, skin up, with the plates set before it comes;
// its pose once it is on the reject belt.
PlatesPass pass_plates(std::uint8_t variant, double angle_rad, bool open_plate1, bool flip_plate2) {
  DemRig rig;
  rig.out.flip_plate1_flip = open_plate1;
  rig.out.flip_plate2_flip = flip_plate2;
  rig.run(0.3);  // belts at speed, plates at the end of their 0.15 s travel
  DemFilletSpawn spawn;
  spawn.s_mm = 1880.0;  // on the guide, its front 30..60 mm before the end at 2000
  spawn.angle_rad = angle_rad;
  spawn.v_mps = 0.5;  // the guide's speed
  spawn.variant = variant;
  spawn.side = SideUp::kSkin;
  EXPECT_TRUE(rig.plant->spawn_fillet(spawn));
  PlatesPass pass;
  // 600 mm to the reject belt's middle at 0.5 m/s: 1.2 s, and time to settle after a fall.
  for (int i = 0; i < 300; ++i) {
    rig.step();
    const auto fillets = rig.plant->fillets();
    if (fillets.empty()) break;
    pass.side = fillets[0].side;
    pass.angle_rad = fillets[0].angle_rad;
    pass.s_mm = fillets[0].s_mm;
    if (pass.s_mm > 2600.0) break;
  }
  pass.flips = rig.plant->counters().flips;
  return pass;
}

// What the controller's plan (orienting.cpp: plan_flips) relies on is which end leads: a
// slide keeps it, plate 1 swaps it. So the heading must stay within a quarter turn of the
// planned one. Measured on the 7 mm twin: a slide turns a fillet by up to 0.6 rad, a fall
// leaves it up to 0.8 rad from pi - a.
constexpr double kTurnBoundRad = std::numbers::pi / 2.0;
constexpr double kHeadingRad = 0.3;  // as the rails leave a fillet, turned a little

// Every variant of table 3.1 (three sizes, each hand): the thin 172 x 32 mm one and the thick
// 40 mm ones. Closed plates are a slide: the fillet arrives skin up, its heading kept.
TEST(DemPlantPlates, ClosedPlatesAreASlide) {
  for (std::uint8_t variant = 0; variant < 6; ++variant) {
    const PlatesPass pass = pass_plates(variant, kHeadingRad, false, false);
    EXPECT_GT(pass.s_mm, 2450.0) << "variant " << int{variant} << " did not reach the reject belt";
    EXPECT_EQ(pass.side, SideUp::kSkin) << "variant " << int{variant};
    EXPECT_LT(std::abs(wrapped(pass.angle_rad - kHeadingRad)), kTurnBoundRad)
        << "variant " << int{variant} << " heading " << pass.angle_rad;
    EXPECT_EQ(pass.flips, 0U);
  }
}

// Plate 1 swung out of the way: the fillet falls the 150 mm drop and turns end over end, its
// thick end now at the other side. The controller's model (orienting.cpp) and the fast plant
// turn it about the line's lateral axis, heading a to pi - a; the fall here turns some about
// their own lateral axis instead (a to pi + a), so either is accepted.
TEST(DemPlantPlates, OpenPlate1TurnsEveryVariantEndOverEnd) {
  for (std::uint8_t variant = 0; variant < 6; ++variant) {
    const PlatesPass pass = pass_plates(variant, kHeadingRad, true, false);
    EXPECT_GT(pass.s_mm, 2450.0) << "variant " << int{variant} << " did not reach the reject belt";
    EXPECT_EQ(pass.side, SideUp::kBone) << "variant " << int{variant};
    const double off_rad =
        std::min(std::abs(wrapped(pass.angle_rad - (std::numbers::pi - kHeadingRad))),
                 std::abs(wrapped(pass.angle_rad - (std::numbers::pi + kHeadingRad))));
    EXPECT_LT(off_rad, kTurnBoundRad)
        << "variant " << int{variant} << " heading " << pass.angle_rad;
    EXPECT_EQ(pass.flips, 1U);
  }
}

// Plate 2 (scripted, see dem_plant.hpp) turns the fillet sideways on its slope: heading -a.
TEST(DemPlantPlates, Plate2TurnsTheFilletSideways) {
  const PlatesPass pass = pass_plates(2, kHeadingRad, false, true);
  EXPECT_GT(pass.s_mm, 2450.0);
  EXPECT_EQ(pass.side, SideUp::kBone);
  EXPECT_LT(std::abs(wrapped(pass.angle_rad + kHeadingRad)), kTurnBoundRad) << pass.angle_rad;
  EXPECT_EQ(pass.flips, 1U);
}

// Both: end over end, then sideways: the side is back, the heading reversed (a + pi).
TEST(DemPlantPlates, BothPlatesReverseTheFilletSkinStillUp) {
  const PlatesPass pass = pass_plates(2, kHeadingRad, true, true);
  EXPECT_GT(pass.s_mm, 2450.0);
  EXPECT_EQ(pass.side, SideUp::kSkin);
  EXPECT_LT(std::abs(wrapped(pass.angle_rad - (kHeadingRad + std::numbers::pi))), kTurnBoundRad)
      << pass.angle_rad;
  EXPECT_EQ(pass.flips, 0U);  // turned over twice: the same side up as on the guide
}

}  // namespace
}  // namespace fl::test
