// Belts, drives and the takt barrier of the DEM plant.
#include <gtest/gtest.h>

#include "dem_plant_test_support.hpp"

namespace fl::test {
namespace {

TEST(DemPlantBelt, FilletReachesBeltSpeedAndIsCarriedTheAnalyticDistance) {
  DemRig rig;
  rig.run(0.2);  // guide at 0.5 m/s: 5 ms delay + 0.1 s ramp at 5 m/s^2
  ASSERT_DOUBLE_EQ(rig.plant->drives().speed_mps(DriveId::kGuide), 0.5);
  DemFilletSpawn spawn;
  spawn.s_mm = 1100.0;  // guide belt, between the rails (+-180 mm here)
  spawn.v_mps = 0.0;    // dropped at rest: friction must bring it up to speed
  ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  // Friction accelerates it at up to mu g = 4.9 m/s^2: at speed within about 0.1 s; 0.4 s
  // leaves the soft body's landing bounce time to settle.
  rig.run(0.4);
  const DemFilletView before = rig.plant->fillets().at(0);
  // The bonded body rings at a few per cent of its speed (E = 3.7e5 Pa), so the speed is
  // checked loosely and the distance over 0.5 s, which averages the ringing.
  EXPECT_NEAR(before.v_mps, 0.5, 0.05);
  rig.run(0.5);
  const DemFilletView after = rig.plant->fillets().at(0);
  EXPECT_NEAR(after.s_mm - before.s_mm, 0.5 * 500.0, 10.0);  // 250 mm, within 4 %
  EXPECT_NEAR(after.y_mm, 0.0, 5.0);                         // a straight belt: no drift
  EXPECT_NEAR(after.angle_rad, 0.0, 0.05);
  EXPECT_GT(after.z_mm, 0.0);  // on the belt, not through it
}

TEST(DemPlantBelt, EncodersCountTheRampedTravel) {
  DemRig rig;
  rig.run(0.5);
  // The command arrives at t = 0 and acts after the 5 ms delay; the ramp to 0.5 m/s at
  // 5 m/s^2 takes 0.1 s: travel = v (T - delay - ramp / 2) = 0.5 (0.5 - 0.005 - 0.05) m =
  // 222.5 mm = 2225 counts at 10 counts per mm (the 1 ms steps integrate the ramp exactly).
  const auto counts = rig.in.drives[index(DriveId::kGuide)].encoder_counts;
  EXPECT_NEAR(static_cast<double>(counts), 2225.0, 1.0);
  EXPECT_FLOAT_EQ(rig.in.drives[index(DriveId::kGuide)].speed_mps, 0.5F);
  EXPECT_TRUE(rig.in.drives[index(DriveId::kGuide)].ready);
  // Reversed drive counts down.
  rig.out.drives[index(DriveId::kReject)].speed_mps = -0.5F;
  rig.run(0.5);
  EXPECT_LT(rig.in.drives[index(DriveId::kReject)].encoder_counts, 2225);
}

TEST(DemPlantBelt, LaserBarrierSeesTheFilletCrossing) {
  DemRig rig;
  rig.out.drives[index(DriveId::kTakt)].speed_mps = 0.0F;
  DemFilletSpawn spawn;
  const double half_length_mm = rig.plant->templates()[2].half_extent_m.x() * 1000.0;
  spawn.s_mm = -half_length_mm - 20.0;  // front 20 mm before the beam
  ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  rig.run(0.1);
  EXPECT_FALSE(rig.in.takt_beam_broken);
  EXPECT_EQ(rig.plant->fillets_fed(), 0U);
  // Takt at 0.12 m/s: the 20 mm take 0.17 s (plus delay and ramp).
  rig.out.drives[index(DriveId::kTakt)].speed_mps = 0.12F;
  bool broken = false;
  for (int i = 0; i < 40 && !broken; ++i) {
    rig.step();
    broken = rig.in.takt_beam_broken;
  }
  EXPECT_TRUE(broken);
  // The transition belt pulls it across: centroid past 0 (fed), then the beam clears.
  rig.run(3.0);
  EXPECT_FALSE(rig.in.takt_beam_broken);
  EXPECT_EQ(rig.plant->fillets_fed(), 1U);
  EXPECT_EQ(rig.plant->fillets_on_line(), 1U);
}

}  // namespace
}  // namespace fl::test

namespace fl::test {
namespace {

// A reject-belt reversal drops into the crate only what the reversing belt carries back over
// its upstream edge. The crate test used to take any fillet upstream of the reject belt that
// moved backwards at all while the belt reversed (a fillet settling on the held guide, the
// takt belt's row): in the closed loop 12 of 14 fed fillets vanished into the crate.
TEST(DemPlantBelt, ReversalDropsOnlyTheFilletOnTheRejectBelt) {
  DemRig rig;
  rig.out = OutputImage{};  // the line holds while the reject belt reverses
  rig.out.drives[index(DriveId::kReject)] = {true, -0.5F, 0.0F};
  DemFilletSpawn on_reject;
  on_reject.s_mm = 2300.0;  // rear about 12 mm past the belt's upstream edge at 2200
  ASSERT_TRUE(rig.plant->spawn_fillet(on_reject));
  rig.run(0.1);  // 5 ms delay and a 0.1 s ramp: the reject belt is reversing
  ASSERT_LT(rig.plant->drives().speed_mps(DriveId::kReject), 0.0);
  DemFilletSpawn upstream;
  upstream.s_mm = 1700.0;  // on the held guide belt, 500 mm upstream of the reject belt
  upstream.v_mps = -0.02;  // rocking back as the guide stopped
  ASSERT_TRUE(rig.plant->spawn_fillet(upstream));
  std::array<std::uint64_t, 4> exits{};
  for (int i = 0; i < 100; ++i) {  // 1 s at -0.5 m/s: 500 mm of belt travel back
    rig.step();
    for (const TrueFilletExit& exit : rig.plant->drain_exits()) {
      ++exits[static_cast<std::size_t>(exit.exit)];
    }
  }
  EXPECT_EQ(exits[static_cast<std::size_t>(TrueExit::kRejectCrate)], 1U);
  ASSERT_EQ(rig.plant->fillets().size(), 1U);
  EXPECT_NEAR(rig.plant->fillets()[0].s_mm, 1700.0, 20.0);  // settled where it was put
}

}  // namespace
}  // namespace fl::test

namespace fl::test {
namespace {

std::string construction_error(const DemPlantConfig& config) {
  try {
    const DemPlant plant(default_line_config(), config);
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "";
}

// The line starts empty, so nothing in a run would show that the engine's timestep is too long
// for the model until it blew up: the plant checks it on a probe fillet of each variant when it
// is built, and refuses with the numbers. The shipped configuration passes (every other test).
TEST(DemPlantTimestep, ATimestepTheModelCannotCarryIsRefusedWithItsNumbers) {
  DemPlantConfig long_step = test_config();
  long_step.simulation.rayleigh_fraction = 0.5;  // EDEM's advice ends at 40 %
  const std::string rayleigh = construction_error(long_step);
  EXPECT_NE(rayleigh.find("above 40% of the Rayleigh time"), std::string::npos) << rayleigh;
  EXPECT_NE(rayleigh.find("rayleigh_fraction"), std::string::npos) << rayleigh;

  // Bonds 400 times appendix B's stiffness: a sub-particle held by its bonds oscillates 20
  // times faster, and 15 % of the Rayleigh time is then 2.4 times 2/omega (measured:
  // 0.29 ms against 0.12 ms at 7 mm spheres), where the integration diverges.
  const auto with_bonds_stiffer = [](double factor) {
    DemPlantConfig config = test_config();
    for (dem::InteractionSpec& interaction : config.engine.interactions) {
      if (!interaction.bond_law) continue;
      for (const char* key : {"normal_stiffness_n_per_m3", "shear_stiffness_n_per_m3"}) {
        interaction.bond_law->parameters.at(key) *= factor;
      }
    }
    return config;
  };
  const std::string bonds = construction_error(with_bonds_stiffer(400.0));
  EXPECT_NE(bonds.find("unstable"), std::string::npos) << bonds;
  EXPECT_NE(bonds.find("TOO LARGE for the bonds"), std::string::npos) << bonds;
  // Four times stiffer: 0.29 ms is 0.24 of 2/omega, stable but over the engine's accuracy
  // fifth; a coarse line is allowed to run.
  EXPECT_EQ(construction_error(with_bonds_stiffer(4.0)), "");
}

}  // namespace
}  // namespace fl::test
