// Exits and the balance, determinism, and the closed loop through apps' run_closed_loop.
#include <gtest/gtest.h>

#include <cmath>

#include "dem_plant_test_support.hpp"
#include "fl/apps/closed_loop.hpp"

namespace fl::test {
namespace {

TEST(DemPlantRun, FedEqualsExitsPlusOnLine) {
  DemRig rig;
  rig.run(0.2);  // belts at speed
  DemFilletSpawn spawn;
  spawn.v_mps = 0.5;
  spawn.s_mm = 5350.0;  // outfeed: 150 mm to the hand-off at 0.5 m/s
  ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  spawn.s_mm = 4850.0;  // under the air knife
  ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  spawn.s_mm = 3000.0;  // centring belt: still on the line after the run
  ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  rig.out.final_reject = true;
  rig.step();
  rig.out.final_reject = false;
  std::array<std::uint64_t, 4> exits{};
  for (int i = 0; i < 100; ++i) {  // 1 s
    rig.step();
    for (const TrueFilletExit& exit : rig.plant->drain_exits()) {
      ++exits[static_cast<std::size_t>(exit.exit)];
    }
  }
  EXPECT_EQ(rig.plant->fillets_fed(), 3U);
  EXPECT_EQ(exits[static_cast<std::size_t>(TrueExit::kOutfeed)], 1U);
  EXPECT_EQ(exits[static_cast<std::size_t>(TrueExit::kFinalReject)], 1U);
  EXPECT_EQ(rig.plant->fillets_on_line(), 1U);
  EXPECT_EQ(rig.plant->fillets_fed(),
            exits[0] + exits[1] + exits[2] + exits[3] + rig.plant->fillets_on_line());
  EXPECT_EQ(rig.plant->fillets().size(), 1U);  // the engine really lost the two
}

// The camera renderer draws each DEM fillet at its view's size_variant: the view must name
// the table 3.1 row of the template the fillet was made from, for all six templates.
TEST(DemPlantRun, ViewsCarryTheTableSizeOfTheirTemplate) {
  DemRig rig;
  const auto& templates = rig.plant->templates();
  ASSERT_EQ(templates.size(), 6U);  // three sizes, each left and right
  // The renderer's rows, in its order (fillet_renderer.hpp, FilletInstance::size_variant).
  constexpr const char* kRowPrefix[] = {"s144x72x40", "s172x72x32", "s176x72x40"};
  for (std::uint8_t variant = 0; variant < 6; ++variant) {
    DemFilletSpawn spawn;
    spawn.variant = variant;
    spawn.s_mm = 1900.0 + 250.0 * variant;  // one per 250 mm on the stopped line: no contact
    ASSERT_TRUE(rig.plant->spawn_fillet(spawn)) << int{variant};
  }
  const auto views = rig.plant->fillets();
  ASSERT_EQ(views.size(), 6U);
  for (const DemFilletView& view : views) {
    const int variant = static_cast<int>(std::lround((view.s_mm - 1900.0) / 250.0));
    ASSERT_TRUE(variant >= 0 && variant < 6) << view.s_mm;
    const auto& name = templates[static_cast<std::size_t>(variant)].name;
    EXPECT_TRUE(name.starts_with(kRowPrefix[view.size_variant])) << name;
    EXPECT_EQ(view.hand, name.ends_with("_left") ? Hand::kLeft : Hand::kRight) << name;
  }
}

// A fillet as spawned is its template placed rigidly: no bend, at any heading and either side
// up. The fit pairs each sphere with its own template position; a wrong pairing reads a bend.
TEST(DemPlantRun, ASpawnedFilletIsNotBent) {
  DemRig rig;
  const double headings[] = {0.0, 0.9, 2.8, -1.7};
  for (int k = 0; k < 4; ++k) {
    DemFilletSpawn spawn;
    spawn.variant = static_cast<std::uint8_t>(k);
    spawn.angle_rad = headings[k];
    spawn.side = k % 2 == 0 ? SideUp::kSkin : SideUp::kBone;
    spawn.s_mm = 1900.0 + 300.0 * k;  // apart on the stopped line
    ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  }
  const auto views = rig.plant->fillets();
  ASSERT_EQ(views.size(), 4U);
  for (const DemFilletView& view : views) {
    // 1e-9 / mm: a radius of 1000 km, rounding in a fit over 100 mm coordinates.
    EXPECT_NEAR(view.bend_per_mm, 0.0, 1e-9) << view.s_mm;
  }
}

// The shipped line takes a second engine thread from twice min_particles_per_thread spheres:
// one fillet stays on one thread, ten (a part-filled line) share two.
TEST(DemPlantRun, ALineOfFilletsTakesTheSecondThread) {
  DemRig rig(test_config(2));
  const int per_thread = rig.config.simulation.min_particles_per_thread;
  ASSERT_EQ(per_thread, 256);  // config/plant_dem.yaml
  DemFilletSpawn spawn;
  spawn.s_mm = 1900.0;
  ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  rig.step();
  ASSERT_LT(rig.plant->simulation().state().size(), 2U * 256U);
  EXPECT_EQ(rig.plant->simulation().active_thread_count(), 1);
  for (int k = 1; k < 10; ++k) {      // the smallest variant: about 60 spheres at 7 mm
    spawn.s_mm = 1900.0 + 300.0 * k;  // apart on the stopped line
    ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  }
  rig.step();
  ASSERT_GE(rig.plant->simulation().state().size(), 2U * 256U);
  EXPECT_EQ(rig.plant->simulation().active_thread_count(), 2);
}

TEST(DemPlantRun, SameSeedAndThreadsGiveIdenticalImages) {
  // Feeder on (bulk and leveller run): fillets enter the takt belt from the seeded draws.
  auto make = [] {
    auto rig = std::make_unique<DemRig>(test_config(2), default_line_config(), 7);
    rig->out.drives[index(DriveId::kBulk)].speed_mps = 0.1F;
    rig->out.leveller_speed_rpm = 120.0F;
    rig->out.hopper_opening_mm = 60.0F;
    return rig;
  };
  auto a = make();
  auto b = make();
  for (int i = 0; i < 60; ++i) {  // 0.6 s: the leveller spins up and places fillets
    a->step();
    b->step();
    ASSERT_TRUE(a->in == b->in) << "differs at step " << i;
  }
  EXPECT_GT(a->plant->counters().fillets_spawned, 0U);
  EXPECT_EQ(a->plant->simulation().state().position_m, b->plant->simulation().state().position_m);
}

TEST(DemPlantRun, ClosedLoopSmokeRunBalances) {
  DemRig rig;
  apps::RunOptions options;
  // 4 s of feeding put the first items past the takt and the transitions; 2 s of drain, then
  // what is still on the belts is closed as run ended: both ledgers must balance anyway.
  options.duration_s = 4.0;
  options.drain_timeout_s = 2.0;
  options.measure_compute = false;
  const apps::Kpis kpis = apps::run_closed_loop(rig.line, *rig.plant, options);
  EXPECT_EQ(kpis.plant, "dem");
  EXPECT_TRUE(kpis.truth_balanced);
  EXPECT_TRUE(kpis.ledger_balanced);
  EXPECT_GT(kpis.truth.fed, 0U);  // the feeder kept the takt supplied
  EXPECT_GT(kpis.items_created, 0U);
  EXPECT_EQ(kpis.records_dropped, 0U);
}

}  // namespace
}  // namespace fl::test
