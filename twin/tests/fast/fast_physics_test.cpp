// Physics of the fast plant against analytic answers: friction-limited belt following, drive
// ramps and encoders, multilane rotation, flip plates, reject reversal, centring and the
// squeeze roller. Steps are 1 ms (the internal step) so that events resolve to one step.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "fast_test_support.hpp"

namespace fl::test {
namespace {

constexpr double kPi = std::numbers::pi;

BodySpawn spawn_at(double s_mm, double v_mps, double angle_rad = 0.0, double y_mm = 0.0) {
  BodySpawn spawn;
  spawn.s_mm = s_mm;
  spawn.v_mps = v_mps;
  spawn.angle_rad = angle_rad;
  spawn.y_mm = y_mm;
  spawn.variant = 1;  // 172 x 72 x 32 mm
  return spawn;
}

// ---------------------------------------------------------------- belt following

TEST(FastPhysics, FrictionLimitedAccelerationOntoFasterBelt) {
  // Transition 1 at 0.1 m/s hands over to transition 2 at 1.0 m/s (its limit). The item
  // accelerates at mu g = 0.4 x 9.81 = 3.924 m/s^2: dv = 0.9 m/s takes 0.9 / 3.924 = 0.2294 s
  // over 0.1 t + mu g t^2 / 2 = 22.94 + 103.21 = 126.15 mm.
  Rig rig;
  rig.out.drives[index(DriveId::kTransition1)].speed_mps = 0.1F;
  rig.out.drives[index(DriveId::kTransition2)].speed_mps = 1.0F;
  rig.run(0.5);  // belts at speed
  const auto id = rig.plant->spawn_body(spawn_at(420.0, 0.1));
  ASSERT_TRUE(id);
  const double mu_g = 0.4 * 9.81;
  const double t_analytic = 0.9 / mu_g;
  const double d_analytic_mm = (0.1 * t_analytic + 0.5 * mu_g * t_analytic * t_analytic) * 1000;

  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->s_mm >= 500.0; }, 2.0));
  const double t_cross = rig.time_s();
  const double s_cross = rig.body(*id)->s_mm;
  EXPECT_LT(s_cross - 500.0, 0.1 + 1e-9);  // one step at 0.1 m/s
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->v_mps >= 1.0 - 1e-12; }, 2.0));
  // Time and distance to one internal step (1 ms, at most 1 mm at 1 m/s).
  EXPECT_NEAR(rig.time_s() - t_cross, t_analytic, 1.0e-3 + 1e-9);
  EXPECT_NEAR(rig.body(*id)->s_mm - s_cross, d_analytic_mm, 1.0);
}

TEST(FastPhysics, ItemsSlipWhenTheTaktAcceleratesFasterThanFriction) {
  // The takt accelerates at 6 m/s^2 from its standard speed v0 to 0.6 m/s; an item follows
  // at mu g = 3.924 m/s^2 and reaches 0.6 m/s (0.6 - v0) / 3.924 s later: it slips.
  Rig rig;
  const double standard_mps = rig.line.sections[index(DriveId::kTakt)].nominal_speed_mps;
  rig.run(0.3);
  const auto id = rig.plant->spawn_body(spawn_at(-400.0, standard_mps));
  ASSERT_TRUE(id);
  rig.step();
  auto& takt = rig.out.drives[index(DriveId::kTakt)];
  takt.speed_mps = 0.6F;
  takt.accel_mps2 = 6.0F;
  rig.step();  // command issued at this step's start; the drive follows 5 ms later
  const double t0 = rig.time_s() - 0.001;
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->v_mps >= 0.6 - 1e-12; }, 1.0));
  // Float speeds: the standard speed is a float literal, hence the 1.5 ms (1.5 steps) bound.
  EXPECT_NEAR(rig.time_s() - t0, 0.005 + (0.6 - standard_mps) / (0.4 * 9.81), 1.5e-3);
  // While it slipped the belt ran ahead and reached 0.6 m/s first.
  EXPECT_NEAR(rig.in.drives[index(DriveId::kTakt)].speed_mps, 0.6F, 1e-6);
}

// ---------------------------------------------------------------- drives

TEST(FastPhysics, EncoderCountsAreIntegratedSpeedTimesResolution) {
  // 0.3 m/s at 2 m/s^2 after the 5 ms command delay: after 1 s the belt travelled
  // 0.3 x (1 - 0.005) - 0.3^2 / (2 x 2) = 0.2760 m = 2760.0 counts at 10 counts/mm.
  Rig rig;
  rig.out = OutputImage{};
  auto& command = rig.out.drives[index(DriveId::kTransition1)];
  command.enable = true;
  command.speed_mps = 0.3F;
  command.accel_mps2 = 2.0F;
  rig.run(1.0);
  const auto& feedback = rig.in.drives[index(DriveId::kTransition1)];
  const double counts_per_mm = rig.line.limits[index(DriveId::kTransition1)].counts_per_mm;
  const double travel_mm = (0.3 * (1.0 - 0.005) - 0.3 * 0.3 / 4.0) * 1000.0;
  EXPECT_NEAR(static_cast<double>(feedback.encoder_counts), travel_mm * counts_per_mm, 1.0);
  EXPECT_FLOAT_EQ(feedback.speed_mps, 0.3F);
  EXPECT_TRUE(feedback.ready);
  EXPECT_FALSE(feedback.fault);
  // Reversing: 5 ms more at +0.3 m/s (+1.5 mm), the ramp 0.3 -> -0.3 at 2 m/s^2 is symmetric
  // (no net travel), then 0.7 - 0.005 - 0.3 = 0.395 s at -0.3 m/s (-118.5 mm): -117 mm.
  command.speed_mps = -0.3F;
  const std::int64_t before = feedback.encoder_counts;
  rig.run(0.7);
  const double back_mm = 0.3 * 0.005 * 1000.0 - 0.3 * (0.7 - 0.005 - 0.3) * 1000.0;
  EXPECT_NEAR(static_cast<double>(feedback.encoder_counts - before), back_mm * counts_per_mm, 1.5);
}

TEST(FastPhysics, DriveRespectsItsLimitsAndFaults) {
  Rig rig;
  rig.out = OutputImage{};
  auto& command = rig.out.drives[index(DriveId::kGuide)];
  command.enable = true;
  command.speed_mps = 3.0F;    // beyond the 1 m/s limit
  command.accel_mps2 = 50.0F;  // beyond the 5 m/s^2 limit: 1 m/s takes 0.2 s
  rig.run(0.1);
  const auto& feedback = rig.in.drives[index(DriveId::kGuide)];
  EXPECT_NEAR(feedback.speed_mps, 5.0 * (0.1 - 0.005), 1e-5);
  rig.run(0.2);
  EXPECT_FLOAT_EQ(feedback.speed_mps, 1.0F);
  rig.plant->faults().drive_fault[index(DriveId::kGuide)] = true;
  rig.run(0.1);
  EXPECT_TRUE(feedback.fault);
  EXPECT_FALSE(feedback.ready);
  EXPECT_NEAR(feedback.speed_mps, 1.0 - 5.0 * 0.1, 1e-5);  // quick stop at the limit
  rig.run(0.2);
  EXPECT_FLOAT_EQ(feedback.speed_mps, 0.0F);
  rig.plant->faults().drive_fault[index(DriveId::kGuide)] = false;
  rig.plant->faults().estop_open = true;
  rig.run(0.05);
  EXPECT_FALSE(rig.in.estop_ok);
  EXPECT_FALSE(feedback.ready);
  EXPECT_FLOAT_EQ(feedback.speed_mps, 0.0F);
}

// ---------------------------------------------------------------- multilane

TEST(FastPhysics, MultilaneRotationRateIsDifferentialOverTrack) {
  // Left 0.3, right 0.5 m/s, track 80 mm: omega = 0.2 / 0.080 = 2.5 rad/s, CCW (the angle
  // grows) because the right belt (y < 0) is faster. Forward speed: the mean, 0.4 m/s.
  Rig rig;
  rig.out.drives[index(DriveId::kMultilane1Left)].speed_mps = 0.3F;
  rig.out.drives[index(DriveId::kMultilane1Right)].speed_mps = 0.5F;
  rig.run(0.5);
  const auto id = rig.plant->spawn_body(spawn_at(3450.0, 0.4));
  ASSERT_TRUE(id);
  rig.run(0.2);  // ten lag time constants (20 ms): omega within e^-10 of its target
  const double a0 = rig.body(*id)->angle_rad;
  rig.run(0.1);
  const FilletBody& body = *rig.body(*id);
  EXPECT_EQ(body.zone, BodyZone::kMultilane1);
  EXPECT_NEAR(body.omega_radps, 2.5, 2.5 * 1e-4);
  EXPECT_NEAR(body.angle_rad - a0, 0.25, 1e-4);
  EXPECT_NEAR(body.v_mps, 0.4, 1e-6);  // mean of the float speeds
}

TEST(FastPhysics, MultilaneOffCentreItemGetsAFractionAndRotationSaturates) {
  Rig rig;
  rig.out.drives[index(DriveId::kMultilane1Left)].speed_mps = 0.3F;
  rig.out.drives[index(DriveId::kMultilane1Right)].speed_mps = 0.5F;
  rig.out.drives[index(DriveId::kMultilane2Left)].speed_mps = 0.0F;
  rig.out.drives[index(DriveId::kMultilane2Right)].speed_mps = 0.9F;
  rig.run(0.5);
  // 30 mm off centre (beyond the 15 mm grip limit): 0.3 x 2.5 = 0.75 rad/s.
  const auto off = rig.plant->spawn_body(spawn_at(3450.0, 0.4, 0.0, 30.0));
  // Unit 2 with a 0.9 m/s differential: 0.9 / 0.08 = 11.25 rad/s, saturated at 8 rad/s.
  const auto fast = rig.plant->spawn_body(spawn_at(3850.0, 0.45, 0.0, 0.0));
  ASSERT_TRUE(off && fast);
  rig.run(0.2);
  EXPECT_NEAR(rig.body(*off)->omega_radps, 0.75, 1e-3);
  EXPECT_NEAR(rig.body(*fast)->omega_radps, 8.0, 1e-9);
  // Left faster than right turns the other way.
  rig.out.drives[index(DriveId::kMultilane1Left)].speed_mps = 0.5F;
  rig.out.drives[index(DriveId::kMultilane1Right)].speed_mps = 0.3F;
  rig.run(0.2);
  EXPECT_NEAR(rig.body(*off)->omega_radps, -0.75, 1e-3);
}

// ---------------------------------------------------------------- flip plates

struct FlipCase {
  bool plate1;
  bool plate2;
  SideUp side;
  double angle_rad;
};

TEST(FastPhysics, FlipPlatesProduceTheFourSideDirectionCombinations) {
  // Item skin up at 0.3 rad. Plate 1 (end over end): side toggles, a -> pi - a. Plate 2
  // (sideways): side toggles, a -> -a. Both: side kept, a -> -(pi - a) = a - pi.
  const double a = 0.3;
  const FlipCase cases[] = {
      {false, false, SideUp::kSkin, a},
      {true, false, SideUp::kBone, kPi - a},
      {false, true, SideUp::kBone, -a},
      {true, true, SideUp::kSkin, a - kPi},
  };
  for (const FlipCase& expected : cases) {
    Rig rig;
    rig.out.flip_plate1_flip = expected.plate1;
    rig.out.flip_plate2_flip = expected.plate2;
    rig.run(0.5);  // plates at their ends (0.15 s travel), belts at speed
    EXPECT_EQ(rig.in.flip_plate1_flipping, expected.plate1);
    EXPECT_EQ(rig.in.flip_plate2_flipping, expected.plate2);
    const auto id = rig.plant->spawn_body(spawn_at(2010.0, 0.5, a));
    ASSERT_TRUE(id);
    ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->s_mm > 2160.0; }, 1.0));
    const FilletBody& body = *rig.body(*id);
    EXPECT_EQ(body.members[0].side, expected.side) << expected.plate1 << expected.plate2;
    EXPECT_NEAR(body.angle_rad, expected.angle_rad, 1e-12) << expected.plate1 << expected.plate2;
    EXPECT_EQ(body.plate1_flipped, expected.plate1);
    EXPECT_EQ(body.plate2_flipped, expected.plate2);
    EXPECT_FALSE(body.misflipped);
  }
}

TEST(FastPhysics, PlateInMidTravelMisflips) {
  Rig rig;
  rig.run(0.5);
  const auto id = rig.plant->spawn_body(spawn_at(2040.0, 0.5, 0.0));
  ASSERT_TRUE(id);
  // The centre reaches plate 1 (2050 mm) after 20 ms; the plate needs 150 ms to retract.
  rig.out.flip_plate1_flip = true;
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->s_mm > 2060.0; }, 1.0));
  EXPECT_TRUE(rig.body(*id)->misflipped);
  EXPECT_EQ(rig.plant->counters().misflips, 1U);
}

// ---------------------------------------------------------------- reject belt

TEST(FastPhysics, RejectReversalDropsAfterTheAnalyticTime) {
  // Item at rest at 2400 mm on the stopped reject belt, 172 mm long, heading 0: it falls when
  // its centre is half a length (86 mm) behind the belt's upstream edge at 2200 mm, 286 mm
  // back. Reverse to -0.5 m/s at 2 m/s^2 (below mu g, the item follows the belt exactly):
  // 5 ms delay + 0.25 s ramp (62.5 mm) + (286 - 62.5) / 500 = 0.447 s  ->  0.702 s.
  Rig rig;
  auto& reject = rig.out.drives[index(DriveId::kReject)];
  reject.speed_mps = 0.0F;
  rig.run(0.2);
  const auto id = rig.plant->spawn_body(spawn_at(2400.0, 0.0));
  ASSERT_TRUE(id);
  rig.step();
  (void)rig.plant->drain_exits();
  reject.speed_mps = -0.5F;
  reject.accel_mps2 = 2.0F;
  const double t0 = rig.time_s();
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id) == nullptr; }, 2.0));
  EXPECT_NEAR(rig.time_s() - t0, 0.702, 1.0e-3 + 1e-9);
  const auto exits = rig.plant->drain_exits();
  ASSERT_EQ(exits.size(), 1U);
  EXPECT_EQ(exits[0].exit, TrueExit::kRejectCrate);
}

TEST(FastPhysics, ReversalDragsBackAnItemHalfOnTheRejectBelt) {
  // An item on the plates whose front edge is on the reversing belt is collateral.
  Rig rig;
  rig.run(0.5);
  const auto on_plates = rig.plant->spawn_body(spawn_at(2150.0, 0.5));  // front at 2236
  const auto far_back = rig.plant->spawn_body(spawn_at(1400.0, 0.5));   // on the guide
  ASSERT_TRUE(on_plates && far_back);
  auto& reject = rig.out.drives[index(DriveId::kReject)];
  reject.speed_mps = -0.5F;
  // It first slides on to about 2200 mm while the belt turns round (0.1 s to pass zero,
  // then 1.0 / 3.924 = 0.25 s for the item to follow to -0.5 m/s), then travels back 86 mm
  // at 0.5 m/s: gone after about 0.53 s. The item behind is still 500 mm upstream.
  rig.run(1.0);
  EXPECT_EQ(rig.body(*on_plates), nullptr);
  EXPECT_NE(rig.body(*far_back), nullptr);
  EXPECT_EQ(rig.plant->counters().exits[static_cast<std::size_t>(TrueExit::kRejectCrate)], 1U);
}

// ---------------------------------------------------------------- centring

TEST(FastPhysics, CentringShiftsAnItemOncePerPass) {
  // Pusher stroked to +30 mm before the item arrives: the item at y = -30 mm leaves at 0.
  Rig rig;
  rig.out.centring_shift_mm = 30.0F;
  rig.out.centring_stroke = true;
  rig.run(0.5);
  EXPECT_FLOAT_EQ(rig.in.centring_position_mm, 30.0F);
  const auto id = rig.plant->spawn_body(spawn_at(3100.0, 0.5, 0.0, -30.0));
  ASSERT_TRUE(id);
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->s_mm > 3250.0; }, 1.0));
  EXPECT_NEAR(rig.body(*id)->y_mm, 0.0, 1e-9);
  // Parking the pusher afterwards does not pull it back.
  rig.out.centring_stroke = false;
  rig.run(0.2);
  EXPECT_NEAR(rig.body(*id)->y_mm, 0.0, 1e-9);
  EXPECT_FLOAT_EQ(rig.in.centring_position_mm, 0.0F);
}

TEST(FastPhysics, CentringWithoutStrokeKeepsY) {
  Rig rig;
  rig.out.centring_shift_mm = 30.0F;  // a shift without stroke does nothing
  rig.run(0.5);
  const auto id = rig.plant->spawn_body(spawn_at(3100.0, 0.5, 0.0, -30.0));
  ASSERT_TRUE(id);
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->s_mm > 3250.0; }, 1.0));
  EXPECT_NEAR(rig.body(*id)->y_mm, -30.0, 1e-9);
}

TEST(FastPhysics, CentringShiftIsRateLimitedByTheStroke) {
  // Stroke to 60 mm starts as the centre enters the +-20 mm window: the pusher moves at
  // 60 mm / 0.12 s = 500 mm/s and the item crosses the 40 mm window at 0.5 m/s in 80 ms,
  // so it is shifted by about 500 x 0.08 = 40 mm.
  Rig rig;
  rig.run(0.5);
  const auto id = rig.plant->spawn_body(spawn_at(3100.0, 0.5, 0.0, -50.0));
  ASSERT_TRUE(id);
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->s_mm >= 3180.0; }, 1.0));
  rig.out.centring_shift_mm = 60.0F;
  rig.out.centring_stroke = true;
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->s_mm > 3250.0; }, 1.0));
  EXPECT_NEAR(rig.body(*id)->y_mm, -50.0 + 40.0, 1.0);  // one step of pusher travel: 0.5 mm
}

// ---------------------------------------------------------------- squeeze roller

TEST(FastPhysics, LoweredRollerJamsAFilletWhoseThickestSectionArrives) {
  // Roller down before the item comes: the thick section (0.3 of 172 mm from the trailing
  // thick end, 34.4 mm behind the centre) reaches the roller and the fillet sticks there
  // until the roller lifts.
  Rig rig;
  rig.out.squeeze_roller_down = true;
  rig.run(0.5);
  EXPECT_TRUE(rig.in.squeeze_roller_down);
  const auto id = rig.plant->spawn_body(spawn_at(4250.0, 0.4, 0.0));
  ASSERT_TRUE(id);
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->stuck_at_roller; }, 1.0));
  rig.run(0.5);
  const FilletBody& stuck = *rig.body(*id);
  EXPECT_TRUE(stuck.stuck_at_roller);
  EXPECT_DOUBLE_EQ(stuck.v_mps, 0.0);
  EXPECT_NEAR(thickest_section_s_mm(stuck), 4400.0 - 0.01, 1e-6);
  EXPECT_NEAR(stuck.s_mm, 4400.0 - 0.01 + 0.2 * 172.0, 1e-3);
  rig.out.squeeze_roller_down = false;
  rig.run(0.2);
  EXPECT_FALSE(rig.body(*id)->stuck_at_roller);
  EXPECT_TRUE(rig.body(*id)->was_stuck);
  EXPECT_GT(rig.body(*id)->s_mm, 4440.0);
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id) == nullptr; }, 5.0));
  const auto exits = rig.plant->drain_exits();
  ASSERT_EQ(exits.size(), 1U);
  EXPECT_EQ(exits[0].exit, TrueExit::kOutfeed);
  EXPECT_FALSE(exits[0].squeezed_ok);
}

TEST(FastPhysics, RollerLoweredBehindTheThickestSectionSqueezes) {
  // Lowered as the thickest section passes: the roller touches after half its 80 ms stroke
  // (16 mm of travel at 0.4 m/s), while 0.3 x 172 = 51.6 mm of the fillet is still under it.
  Rig rig;
  rig.run(0.5);
  const auto id = rig.plant->spawn_body(spawn_at(4250.0, 0.4, 0.0));
  ASSERT_TRUE(id);
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->thick_passed_roller; }, 2.0));
  rig.out.squeeze_roller_down = true;
  rig.run(0.2);
  EXPECT_TRUE(rig.body(*id)->squeezed_ok);
  EXPECT_FALSE(rig.body(*id)->was_stuck);
  rig.out.squeeze_roller_down = false;
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id) == nullptr; }, 5.0));
  const auto exits = rig.plant->drain_exits();
  ASSERT_EQ(exits.size(), 1U);
  EXPECT_TRUE(exits[0].squeezed_ok);
}

TEST(FastPhysics, RollerLoweredAfterTheFilletLeftDoesNotSqueeze) {
  Rig rig;
  rig.run(0.5);
  const auto id = rig.plant->spawn_body(spawn_at(4250.0, 0.4, 0.0));
  ASSERT_TRUE(id);
  // Rear edge past the roller: centre beyond 4400 + 86 mm.
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->s_mm > 4490.0; }, 2.0));
  rig.out.squeeze_roller_down = true;
  rig.run(0.2);
  EXPECT_FALSE(rig.body(*id)->squeezed_ok);
}

TEST(FastPhysics, ThickEndLeadingMeetsTheRollerEarly) {
  // Heading pi (tip trailing): the thickest section is 34.4 mm ahead of the centre, so it
  // passes the roller when the centre is at 4365.6 mm.
  Rig rig;
  rig.run(0.5);
  const auto id = rig.plant->spawn_body(spawn_at(4250.0, 0.4, kPi));
  ASSERT_TRUE(id);
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id)->thick_passed_roller; }, 2.0));
  EXPECT_NEAR(rig.body(*id)->s_mm, 4400.0 - 0.2 * 172.0, 0.5);
}

// ---------------------------------------------------------------- stations feedback

TEST(FastPhysics, ActuatorFeedbackFollowsAfterTheActuationTime) {
  Rig rig;
  rig.run(0.1);
  rig.out.squeeze_roller_down = true;
  rig.out.flip_plate1_flip = true;
  // Roller: 80 ms stroke; plate: 150 ms.
  rig.run(0.07);
  EXPECT_FALSE(rig.in.squeeze_roller_down);
  rig.run(0.02);
  EXPECT_TRUE(rig.in.squeeze_roller_down);
  rig.run(0.05);
  EXPECT_FALSE(rig.in.flip_plate1_flipping);
  rig.run(0.02);
  EXPECT_TRUE(rig.in.flip_plate1_flipping);
}

TEST(FastPhysics, GuideRailsAlignHeadingAndCentreBand) {
  // 1000 mm of guide at 0.5 m/s = 2 s: the heading error decays by e^-6 (from 0.4 rad to
  // 1 mrad) and the offset beyond the 40 mm band by e^-8.
  Rig rig;
  rig.run(0.5);
  const auto tip_forward = rig.plant->spawn_body(spawn_at(1000.0, 0.5, 0.4, 120.0));
  const auto tip_back = rig.plant->spawn_body(spawn_at(1000.0, 0.5, kPi - 0.4, -120.0));
  ASSERT_TRUE(tip_forward && tip_back);
  rig.run(1.9);
  EXPECT_NEAR(rig.body(*tip_forward)->angle_rad, 0.0, 0.4 * std::exp(-5.5));
  EXPECT_NEAR(std::abs(rig.body(*tip_back)->angle_rad), kPi, 0.4 * std::exp(-5.5));
  EXPECT_NEAR(rig.body(*tip_forward)->y_mm, 40.0, 80.0 * std::exp(-7.5));
  EXPECT_NEAR(rig.body(*tip_back)->y_mm, -40.0, 80.0 * std::exp(-7.5));
}

TEST(FastPhysics, FinalAirKnifeBlowsOffAnItemPassingIt) {
  Rig rig;
  rig.run(0.5);
  const auto blown = rig.plant->spawn_body(spawn_at(4700.0, 0.4));
  ASSERT_TRUE(blown);
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*blown)->s_mm >= 4840.0; }, 2.0));
  rig.out.final_reject = true;
  rig.run(0.1);
  rig.out.final_reject = false;
  EXPECT_EQ(rig.body(*blown), nullptr);
  auto exits = rig.plant->drain_exits();
  ASSERT_EQ(exits.size(), 1U);
  EXPECT_EQ(exits[0].exit, TrueExit::kFinalReject);
}

TEST(FastPhysics, ItemsPileUpBehindAStuckFillet) {
  Rig rig;
  rig.out.squeeze_roller_down = true;
  rig.run(0.5);
  const auto first = rig.plant->spawn_body(spawn_at(4300.0, 0.4));
  const auto second = rig.plant->spawn_body(spawn_at(4100.0, 0.4));
  ASSERT_TRUE(first && second);
  rig.run(1.5);
  const FilletBody& a = *rig.body(*first);
  const FilletBody& b = *rig.body(*second);
  EXPECT_TRUE(a.stuck_at_roller);
  EXPECT_NEAR(b.s_mm, a.s_mm - a.half_extent_s_mm - b.half_extent_s_mm, 1e-6);
  EXPECT_DOUBLE_EQ(b.v_mps, 0.0);
}

TEST(FastPhysics, ItemBeyondTheBeltWidthFallsOff) {
  Rig rig;
  rig.run(0.5);
  const auto id = rig.plant->spawn_body(spawn_at(3100.0, 0.5, 0.0, -190.0));
  ASSERT_TRUE(id);
  rig.out.centring_shift_mm = -60.0F;  // pushes it further out, past 200 mm
  rig.out.centring_stroke = true;
  ASSERT_TRUE(rig.run_until([&] { return rig.body(*id) == nullptr; }, 1.0));
  const auto exits = rig.plant->drain_exits();
  ASSERT_EQ(exits.size(), 1U);
  EXPECT_EQ(exits[0].exit, TrueExit::kFellOff);
}

}  // namespace
}  // namespace fl::test
