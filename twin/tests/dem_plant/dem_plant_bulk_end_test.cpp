// The bulk end as the DEM plant's infeed (DemInfeedSource::kDemBulkEnd, config/bulk_line.yaml):
// the controller's commands drive the scene and its sensors read it, fillets move from the
// stop plate onto the takt belt as they lay there, and the closed loop runs the line from the
// hopper.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dem_plant_test_support.hpp"
#include "fl/apps/closed_loop.hpp"

namespace fl::test {
namespace {

DemPlantConfig bulk_end_config() {
  DemPlantConfig config = test_config();
  config.feeder.source = DemInfeedSource::kDemBulkEnd;
  return config;
}

OutputImage infeed_running(const LineConfig& line, float bulk_mps) {
  OutputImage out = belts_running(line);
  out.drives[index(DriveId::kBulk)].speed_mps = bulk_mps;
  out.leveller_speed_rpm = line.leveller.speed_rpm;
  out.hopper_opening_mm = line.bulk.hopper_opening_mm;
  return out;
}

TEST(DemPlantBulkEnd, CommandsDriveTheSceneAndItsSensorsAreRead) {
  DemRig rig(bulk_end_config());
  ASSERT_NE(rig.plant->bulk_end(), nullptr);
  const BulkScene& bulk = *rig.plant->bulk_end();
  // At rest: the plant starts the scene still, the gate at plant_fast.yaml's initial opening.
  EXPECT_DOUBLE_EQ(bulk.belt_speed_mps(), 0.0);
  EXPECT_DOUBLE_EQ(bulk.leveller_rpm(), 0.0);
  EXPECT_DOUBLE_EQ(rig.in.hopper_opening_mm, 60.0F);
  // The initial fill is what fits in the hopper's slots; the feeder drops the rest later.
  EXPECT_GT(bulk.counters().fed, 0U);
  EXPECT_LE(bulk.counters().fed, rig.config.bulk_end.feeder.initial_fill);
  // In pictures the scene stands where it feeds: its discharge edge at the takt belt's
  // upstream end (600 mm before the barrier), its belt at the takt belt's level (the guide's
  // start, plant_dem.yaml: 150 - 50 mm over the reject belt).
  const dem::Vec3 offset = rig.plant->bulk_end_offset_m();
  EXPECT_NEAR(offset.x() + rig.config.bulk_end.belt.discharge_mm * 1e-3,
              -rig.line.takt_belt_length_mm * 1e-3, 1e-12);
  EXPECT_DOUBLE_EQ(offset.y(), 0.0);
  EXPECT_NEAR(offset.z(), 0.100, 1e-12);

  rig.out = infeed_running(rig.line, 0.1F);
  rig.out.hopper_opening_mm = 90.0F;  // the controller's unblock opening
  rig.run(1.0);
  // The bulk drive's actual speed moves the belt; the leveller's motor lag (0.4 s) turns the
  // rotor and the leveller's belt with it; the gate runs at the cylinder's 50 mm/s: 0.6 s.
  EXPECT_DOUBLE_EQ(bulk.belt_speed_mps(), rig.plant->drives().speed_mps(DriveId::kBulk));
  EXPECT_NEAR(bulk.belt_speed_mps(), 0.1, 1e-6);
  EXPECT_NEAR(bulk.leveller_rpm(), 120.0 * (1.0 - std::exp(-1.0 / 0.4)), 0.5);
  EXPECT_FLOAT_EQ(rig.in.leveller_speed_rpm, static_cast<float>(bulk.leveller_rpm()));
  EXPECT_NEAR(bulk.gate_opening_mm(), 90.0, 1e-6);
  EXPECT_FLOAT_EQ(rig.in.hopper_opening_mm, static_cast<float>(bulk.gate_opening_mm()));
  // Level: the heap in the sensor's window plus plant_fast.yaml's 1 mm noise (4 sigma).
  const double heap_mm = bulk.heap_height_mm(rig.config.feeder.level_sensor_from_mm,
                                             rig.config.feeder.level_sensor_to_mm);
  EXPECT_NEAR(rig.in.level_mm, heap_mm, 4.0);

  // The safety chain: the drives' torque is cut and the leveller's command ignored.
  rig.plant->faults().estop_open = true;
  rig.run(1.0);
  EXPECT_DOUBLE_EQ(bulk.belt_speed_mps(), 0.0);
  EXPECT_LT(bulk.leveller_rpm(), 120.0 * std::exp(-1.0 / 0.4) + 0.5);
}

// The leveller's motor trips on the rotor's real load. At the rated 29 N m the layer never
// trips it (the thesis' bulk run loaded its rotor with 0.2 to 1.3 N m); at 0.05 N m the
// first fillets the blades sweep back do: the input image says overload and the rotor runs
// down with the motor's lag, and the line's jam check sees it.
TEST(DemPlantBulkEnd, ALoadOverTheTripTorqueTripsTheLeveller) {
  int first_loaded_step = -1;  // of the 29 N m run: its sampled torque first over 0.05 N m
  for (const float trip_nm : {29.0F, 0.05F}) {
    DemPlantConfig config = bulk_end_config();
    config.feeder.leveller_trip_torque_nm = trip_nm;
    DemRig rig(config);
    rig.out = infeed_running(rig.line, 0.15F);
    double most_torque_nm = 0.0;
    bool tripped = false;
    int trip_step = -1;
    for (int k = 0; k < 600 && !tripped; ++k) {  // up to 6 s: the heap reaches the rotor by 4 s
      rig.step();
      const double torque_nm = rig.plant->bulk_end()->leveller_load_mean().torque_nm;
      most_torque_nm = std::max(most_torque_nm, torque_nm);
      if (first_loaded_step < 0 && torque_nm > 0.05) first_loaded_step = k;
      tripped = rig.in.leveller_overload;
      if (tripped) trip_step = k;
    }
    SCOPED_TRACE("trip torque " + std::to_string(trip_nm) + " N m");
    if (trip_nm > 1.0F) {
      EXPECT_GT(most_torque_nm, 0.05);  // the blades met the layer
      EXPECT_FALSE(tripped);
      EXPECT_LT(most_torque_nm, trip_nm);
      continue;
    }
    // Both runs are the same up to the trip (the trip torque changes nothing before it). The
    // motor trips on the load of any of the plant's scene steps, which these 10 ms samples can
    // miss, so it trips no later than the first sample over 0.05 N m of the 29 N m run, and
    // on the same layer: within a quarter second, four blade passes at 120 rpm.
    ASSERT_TRUE(tripped);
    ASSERT_GE(first_loaded_step, 0);
    EXPECT_LE(trip_step, first_loaded_step);
    EXPECT_GE(trip_step, first_loaded_step - 25);
    const double rpm_at_trip = rig.plant->bulk_end()->leveller_rpm();
    rig.run(0.4);  // one motor time constant: down to about 37 %, tripped all along
    const double rpm_after_trip = rig.plant->bulk_end()->leveller_rpm();
    EXPECT_TRUE(rig.in.leveller_overload);
    EXPECT_LT(rpm_after_trip, 0.45 * rpm_at_trip);
    // Commanded off, the protection resets; commanded on again, the motor starts.
    rig.out.leveller_speed_rpm = 0.0F;
    rig.step();
    EXPECT_FALSE(rig.in.leveller_overload);
  }
}

// Every fillet on the takt belt came over the transfer, as the scene handed it on: its
// template's size and hand, its side up, its heading, and its place across the belt.
TEST(DemPlantBulkEnd, HandedOverFilletsKeepVariantSideHeadingAndPlace) {
  DemRig rig(bulk_end_config());
  rig.out = infeed_running(rig.line, 0.15F);
  std::uint64_t checked = 0;
  std::uint64_t seen = 0;
  for (int k = 0; k < 1200 && checked < 3; ++k) {  // up to 12 s, 10 ms at a time
    rig.step();
    const auto& handover = rig.plant->last_handover();
    if (!handover || rig.plant->counters().handed_over == seen) continue;
    seen = rig.plant->counters().handed_over;
    const BulkHandover& from = handover->from_bulk;
    const std::vector<DemFilletView> views = rig.plant->fillets();
    const auto view = std::find_if(views.begin(), views.end(), [&](const DemFilletView& v) {
      return v.plant_id == handover->plant_id;
    });
    ASSERT_NE(view, views.end());
    const dem::FilletTemplate& t = rig.plant->templates()[from.variant];
    EXPECT_EQ(view->hand, t.name.ends_with("_left") ? Hand::kLeft : Hand::kRight);
    EXPECT_EQ(view->size_variant, from.variant / 2);
    EXPECT_EQ(view->side, from.rotation(2, 2) >= 0.0 ? SideUp::kSkin : SideUp::kBone);
    // Up to 10 ms on the takt belt since: the heading is still the one it was placed with
    // (0.01 rad: settling of a rigid-placed fillet), its place across within 2 mm, or on the
    // clamp that keeps it off the side walls.
    const double heading = std::atan2(from.rotation(1, 0), from.rotation(0, 0));
    EXPECT_LT(std::abs(std::remainder(view->angle_rad - heading, 2.0 * std::numbers::pi)), 0.01);
    const double half_w_mm = rig.config.machinery.belt_half_width_mm;
    EXPECT_LE(std::abs(view->y_mm), half_w_mm);
    if (std::abs(from.centroid_m.y() * 1e3) < half_w_mm - 100.0) {
      EXPECT_NEAR(view->y_mm, from.centroid_m.y() * 1e3, 2.0);
    }
    EXPECT_LT(view->s_mm, -rig.line.takt_belt_length_mm + 120.0);  // at the takt belt's start
    ++checked;
  }
  EXPECT_EQ(checked, 3U) << "fewer fillets came over the transfer in 12 s";
  // Every fillet the line holds came over the transfer, and the scene lost none on the way.
  EXPECT_EQ(rig.plant->counters().fillets_spawned, rig.plant->counters().handed_over);
  EXPECT_EQ(rig.plant->bulk_end()->counters().discharged, rig.plant->counters().handed_over);
  EXPECT_EQ(rig.plant->bulk_end()->counters().lost, 0U);
}

// The controller runs the line from the hopper: the level loop moves the bulk belt, fillets
// pass the gate and the leveller, come over the transfer and are fed past the takt barrier,
// and both ledgers balance.
TEST(DemPlantBulkEnd, ClosedLoopFeedsTheLineFromTheHopper) {
  DemRig rig(bulk_end_config());
  apps::RunOptions options;
  options.duration_s = 15.0;
  options.drain_timeout_s = 2.0;
  options.measure_compute = false;
  float lowest_bulk_mps = 1e9F;
  float highest_bulk_mps = -1e9F;
  bool leveller_overload = false;
  options.after_update = [&](const InputImage& in, const OutputImage& out) {
    leveller_overload = leveller_overload || in.leveller_overload;
    if (out.leveller_speed_rpm <= 0.0F) return;  // starting and stopping
    const float bulk_mps = out.drives[index(DriveId::kBulk)].speed_mps;
    lowest_bulk_mps = std::min(lowest_bulk_mps, bulk_mps);
    highest_bulk_mps = std::max(highest_bulk_mps, bulk_mps);
  };
  const apps::Kpis kpis = apps::run_closed_loop(rig.line, *rig.plant, options);
  EXPECT_TRUE(kpis.truth_balanced);
  EXPECT_TRUE(kpis.ledger_balanced);
  // Seed 1 fed 15 in 20 s: the hopper's first fillets come over the transfer after about
  // 7 s, then about one every 0.9 s (the feeder refills at 1.2 per s).
  EXPECT_GE(kpis.truth.fed, 5U);
  EXPECT_EQ(rig.plant->counters().fillets_spawned, rig.plant->counters().handed_over);
  const BulkCounters& bulk = rig.plant->bulk_end()->counters();
  EXPECT_GT(bulk.passed_gate, bulk.discharged);  // a layer stands between gate and transfer
  EXPECT_EQ(bulk.lost, 0U);
  EXPECT_FALSE(leveller_overload);  // the layer is far under the motor's rated torque
  // The level loop regulated: the bulk belt ran at its limit while the heap was low and was
  // slowed when the heap stood over the 60 mm setpoint.
  EXPECT_FLOAT_EQ(highest_bulk_mps, rig.line.bulk.max_speed_mps);
  EXPECT_LT(lowest_bulk_mps, 0.5F * rig.line.bulk.max_speed_mps);
}

}  // namespace
}  // namespace fl::test
