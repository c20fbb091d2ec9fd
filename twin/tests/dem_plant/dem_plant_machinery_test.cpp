// The DEM plant's machinery that the controller's models lean on: the multilane units' turn by
// differential belt speed, the guide rails' funnel and the squeeze roller's gap.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "dem_plant_test_support.hpp"

namespace fl::test {
namespace {

constexpr double kMm = 1e-3;

// A fillet on the two belts of a multilane unit slips on both: neither belt can carry it at
// its own speed. For a rigid body on equally loaded point contacts, Coulomb friction at each
// contact points along that contact's slip, (v_belt - v + omega * y, -omega * x) with x along
// the line from the contacts' centre and y across it from the belts' split; the fillet turns
// at the omega where the friction torques balance. Solved here by bisection over the
// fillet's own bottom-layer spheres: the driving torque grows with how far the contacts sit
// from the split, the braking one with the patch's length, so a fillet lying along the line
// turns slowest. (To first order in omega * x against half the differential the balance is
// omega = dv * sum|y| / (2 * sum x^2).)
double rigid_coulomb_turn_radps(const dem::State& s, double v_left_mps, double v_right_mps) {
  double lowest_m = 1e9;
  for (std::size_t k = 0; k < s.position_m.size(); ++k) {
    lowest_m = std::min(lowest_m, s.position_m[k].z() - s.radius_m[k]);
  }
  // The bottom layer: the spheres that rest on the belts (the raster's layers are a sphere
  // diameter, 14 mm, apart).
  std::vector<Eigen::Vector2d> contacts;
  for (std::size_t k = 0; k < s.position_m.size(); ++k) {
    if (s.position_m[k].z() - s.radius_m[k] < lowest_m + 0.003) {
      contacts.emplace_back(s.position_m[k].x(), s.position_m[k].y());
    }
  }
  double centre_x_m = 0.0;
  for (const Eigen::Vector2d& c : contacts) centre_x_m += c.x();
  centre_x_m /= static_cast<double>(contacts.size());
  const double mean_mps = 0.5 * (v_left_mps + v_right_mps);
  // Anticlockwise torque on the fillet turning at omega (per unit friction force).
  const auto torque = [&](double omega_radps) {
    double sum = 0.0;
    for (const Eigen::Vector2d& c : contacts) {
      const double x = c.x() - centre_x_m;
      const double y = c.y();
      const double belt_mps = y > 0.0 ? v_left_mps : v_right_mps;  // the left belt is at +y
      const double slip_x = belt_mps - mean_mps + omega_radps * y;
      const double slip_y = -omega_radps * x;
      const double slip = std::hypot(slip_x, slip_y);
      if (slip > 0.0) sum += (x * slip_y - y * slip_x) / slip;
    }
    return sum;
  };
  double low = 0.0;
  double high = 50.0;  // rad/s: past any balance at these speeds
  const double sign = v_right_mps >= v_left_mps ? 1.0 : -1.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (low + high);
    (torque(sign * mid) * sign > 0.0 ? low : high) = mid;
  }
  return sign * low;
}

// Turn rate of a fillet spawned straddling multilane unit 1 (3400..3800 mm), along the line,
// with the unit's belts at the common speed -+ half the differential, and the rigid-body
// Coulomb rate for its contacts as it started.
struct TurnRun {
  double omega_radps = 0.0;
  double rigid_omega_radps = 0.0;
};
TurnRun turn_on_unit1(double differential_mps) {
  DemRig rig;
  const auto left = index(DriveId::kMultilane1Left);
  const auto right = index(DriveId::kMultilane1Right);
  const double common_mps = rig.line.multilane.common_speed_mps;
  rig.out.drives[left].speed_mps = static_cast<float>(common_mps - 0.5 * differential_mps);
  rig.out.drives[right].speed_mps = static_cast<float>(common_mps + 0.5 * differential_mps);
  rig.run(0.2);  // both belts at their speeds (6 m/s^2: 0.1 m/s in 17 ms)
  DemFilletSpawn spawn;
  spawn.s_mm = 3440.0;  // past the unit's entry gap
  spawn.v_mps = common_mps;
  EXPECT_TRUE(rig.plant->spawn_fillet(spawn));
  rig.run(0.1);  // settled on the belts
  const double angle0 = rig.plant->fillets().at(0).angle_rad;
  const double rigid_radps =
      rigid_coulomb_turn_radps(rig.plant->simulation().state(), rig.out.drives[left].speed_mps,
                               rig.out.drives[right].speed_mps);
  constexpr double kWindowS = 0.25;  // 150 mm at 0.6 m/s: it stays on unit 1
  rig.run(kWindowS);
  const DemFilletView after = rig.plant->fillets().at(0);
  EXPECT_LT(after.max_s_mm, 3800.0);
  return {(after.angle_rad - angle0) / kWindowS, rigid_radps};
}

TEST(DemPlantMultilane, DifferentialSpeedTurnsTheFilletAtMostAtTheRigidCoulombRate) {
  constexpr double kDifferentialMps = 0.2;  // well inside max_differential_mps (0.5)
  const TurnRun ccw = turn_on_unit1(kDifferentialMps);
  const TurnRun cw = turn_on_unit1(-kDifferentialMps);
  const TurnRun straight = turn_on_unit1(0.0);
  std::printf("omega ccw %.3f (rigid %.3f) cw %.3f (rigid %.3f) straight %.3f rad/s\n",
              ccw.omega_radps, ccw.rigid_omega_radps, cw.omega_radps, cw.rigid_omega_radps,
              straight.omega_radps);
  EXPECT_GT(ccw.omega_radps, 0.0);  // a faster right belt turns it anticlockwise
  EXPECT_LT(cw.omega_radps, 0.0);
  // Mirror images: the fillet is not symmetric (thick end, tip, hand), so 25 % between them.
  EXPECT_NEAR(-cw.omega_radps / ccw.omega_radps, 1.0, 0.25);
  // Equal speeds: no turn beyond a tenth of the differential's.
  EXPECT_LT(std::fabs(straight.omega_radps), 0.1 * ccw.omega_radps);
  // The rigid body is the stiff limit: the soft fillet gives in shear, its halves partly
  // follow their belts, and part of the differential goes into deforming it instead of
  // turning it. Measured here: 0.64 of the rigid rate. Not below half of it.
  for (const TurnRun* run : {&ccw, &cw}) {
    const double share = run->omega_radps / run->rigid_omega_radps;
    EXPECT_LE(share, 1.05);
    EXPECT_GE(share, 0.5);
  }
  // The controller's plant model (line.yaml multilane.belt_track_mm, 80 mm, as if the
  // fillet rolled on both belts without slip) turns this fillet several times faster than
  // friction can: docs/twin.md, "Multilane units".
  const double track_mm = kDifferentialMps / ccw.omega_radps / kMm;
  EXPECT_GT(track_mm, 2.0 * static_cast<double>(DemRig().line.multilane.belt_track_mm));
}

// Guide rails: a fillet that comes onto the guide at the belt's edge is funnelled in, and
// past the funnel's end no sphere of it lies beyond the channel's half width (less than a
// millimetre of contact overlap with the rail).
TEST(DemPlantRails, TheFunnelBringsAnEdgeFilletIntoTheChannel) {
  DemRig rig;
  rig.run(0.2);
  const DemMachineryConfig& m = rig.config.machinery;
  const BeltSection& guide = rig.line.sections[index(DriveId::kGuide)];
  DemFilletSpawn spawn;
  spawn.s_mm = guide.start_mm + 60.0;
  spawn.y_mm = m.belt_half_width_mm - 60.0;  // against the side wall, in the funnel's mouth
  spawn.v_mps = guide.nominal_speed_mps;
  ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  const double funnel_end_mm = guide.start_mm + m.rail_funnel_length_mm;
  double outermost_mm = 0.0;  // farthest sphere surface from the line past the funnel
  for (int i = 0; i < 300 && rig.plant->fillets().at(0).s_mm < funnel_end_mm + 200.0; ++i) {
    rig.step();
    if (rig.plant->fillets().at(0).min_s_mm < funnel_end_mm) continue;
    const dem::State& s = rig.plant->simulation().state();
    for (std::size_t k = 0; k < s.position_m.size(); ++k) {
      outermost_mm = std::max(outermost_mm, (std::fabs(s.position_m[k].y()) + s.radius_m[k]) / kMm);
    }
  }
  const DemFilletView after = rig.plant->fillets().at(0);
  ASSERT_GT(after.s_mm, funnel_end_mm + 100.0) << "stuck in the funnel";
  ASSERT_GT(outermost_mm, 0.0);
  std::printf("start y %.1f, outermost past the funnel %.1f, end y %.1f\n", spawn.y_mm,
              outermost_mm, after.y_mm);
  EXPECT_LE(outermost_mm, m.rail_channel_half_width_mm + 1.0);
  // It was moved in, not spawned inside: its outer edge started beyond the channel.
  EXPECT_GT(spawn.y_mm + 36.0, m.rail_channel_half_width_mm + 20.0);
}

// Thickness of what lies right under the squeeze roller's axis (spheres within a radius of
// it along the line), at its largest over a fillet's pass.
double thickest_under_roller_mm(bool roller_down, float down_gap_mm) {
  DemPlantConfig config = test_config();
  config.machinery.roller_down_gap_mm = down_gap_mm;
  DemRig rig(config);
  rig.out.squeeze_roller_down = roller_down;
  rig.run(0.2);  // the roller at its place (0.08 s actuation)
  const double roller_mm = rig.line.squeeze.roller_s_mm;
  DemFilletSpawn spawn;
  spawn.s_mm = roller_mm - 200.0;
  spawn.v_mps = rig.line.sections[index(DriveId::kSqueeze)].nominal_speed_mps;
  EXPECT_TRUE(rig.plant->spawn_fillet(spawn));
  double thickest_mm = 0.0;
  for (int i = 0; i < 200 && rig.plant->fillets().at(0).min_s_mm < roller_mm + 20.0; ++i) {
    rig.step();
    const dem::State& s = rig.plant->simulation().state();
    double top_m = -1e9;
    double bottom_m = 1e9;
    for (std::size_t k = 0; k < s.position_m.size(); ++k) {
      if (std::fabs(s.position_m[k].x() - roller_mm * kMm) > s.radius_m[k]) continue;
      top_m = std::max(top_m, s.position_m[k].z() + s.radius_m[k]);
      bottom_m = std::min(bottom_m, s.position_m[k].z() - s.radius_m[k]);
    }
    if (top_m > bottom_m) thickest_mm = std::max(thickest_mm, (top_m - bottom_m) / kMm);
  }
  EXPECT_GT(rig.plant->fillets().at(0).min_s_mm, roller_mm) << "held behind the roller";
  return thickest_mm;
}

// Lowered, the roller presses what passes under it to its gap and rolls it through with the
// belt; raised (80 mm) it leaves the fillet its own thickness. The 7 mm raster makes a 40 mm
// fillet two sphere layers, 28 mm, which the shipped 25 mm gap presses by only 3 mm: the test
// sets 18 mm, so that the pressing shows beyond the contact overlap.
TEST(DemPlantSqueeze, TheLoweredRollerPressesTheFilletToItsGap) {
  constexpr float kGapMm = 18.0F;
  const double down_mm = thickest_under_roller_mm(true, kGapMm);
  const double up_mm = thickest_under_roller_mm(false, kGapMm);
  std::printf("thickest under the roller: down %.1f mm, up %.1f mm\n", down_mm, up_mm);
  // The gap plus the spheres' contact overlaps with the roller and the belt: pressing 10 mm
  // out of the soft fillet loads each contact to about 1 mm of Hertz overlap (20.2 measured).
  EXPECT_LE(down_mm, kGapMm + 3.0);
  // Raised: two layers of 7 mm spheres, 28 mm, untouched.
  EXPECT_NEAR(up_mm, 28.0, 1.5);
}

}  // namespace
}  // namespace fl::test
