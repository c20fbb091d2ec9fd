#include <gtest/gtest.h>

#include <cmath>

#include "test_support.hpp"

namespace fl::logic {
namespace {

TEST(OrientCommand, PositiveErrorSpeedsUpTheRightBelt) {
  const LineConfig config = default_line_config();
  const UnitCommand command =
      orient_command(config.multilane, config.limits[index(DriveId::kMultilane1Left)], 0.3F);
  EXPECT_GT(command.right_mps, command.left_mps);
  // Common mode stays the unit's speed so the item keeps its place in the stream.
  EXPECT_NEAR(0.5F * (command.left_mps + command.right_mps), config.multilane.common_speed_mps,
              1e-6F);
}

TEST(OrientCommand, LargeErrorSaturatesAtMaxDifferential) {
  const LineConfig config = default_line_config();
  // Two radians: gain and braking envelope both ask for more than the drives give.
  const UnitCommand command =
      orient_command(config.multilane, config.limits[index(DriveId::kMultilane1Left)], -2.0F);
  EXPECT_NEAR(command.left_mps - command.right_mps, config.multilane.max_differential_mps, 1e-5F);
}

TEST(OrientCommand, SmallErrorFollowsTheBrakingEnvelope) {
  const LineConfig config = default_line_config();
  const DriveLimits& limits = config.limits[index(DriveId::kMultilane1Left)];
  const float error_rad = 0.01F;
  const UnitCommand command = orient_command(config.multilane, limits, error_rad);
  const float track_m = 0.001F * config.multilane.belt_track_mm;
  const float rate_radps = (command.right_mps - command.left_mps) / track_m;
  const float envelope = std::sqrt(2.0F * (2.0F * limits.max_accel_mps2 / track_m) * error_rad);
  const float proportional = config.multilane.angle_gain_per_s * error_rad;
  EXPECT_NEAR(rate_radps, std::min(envelope, proportional), 1e-3F);
}

TEST(OrientCommand, ZeroErrorRunsBothBeltsEqual) {
  const LineConfig config = default_line_config();
  const UnitCommand command =
      orient_command(config.multilane, config.limits[index(DriveId::kMultilane1Left)], 0.0F);
  EXPECT_EQ(command.left_mps, command.right_mps);
}

// The encoders' differential turns the estimate between camera frames: 10 mm of
// differential over an 80 mm track is 0.125 rad.
TEST(MultilaneStation, IntegratesRotationFromEncoders) {
  test::Harness h;
  MultilaneStation station(h.config);
  h.tracker.advance(h.in);
  test::move_belt(h.in, h.config, DriveId::kMultilane1Right, 10.0F);
  h.in.time_ns = 10'000'000;
  h.tracker.advance(h.in);
  station.integrate_rotation(h.context());
  EXPECT_NEAR(station.rotation_since_rad(0, 0), 10.0F / h.config.multilane.belt_track_mm, 1e-4F);
  EXPECT_NEAR(station.rotation_since_rad(1, 0), 0.0F, 1e-6F);
}

TEST(MultilaneStation, SecondItemGoesToTheSecondUnitWhileTheFirstIsBusy) {
  test::Harness h;
  MultilaneStation station(h.config);
  const float unit1_start = h.config.sections[index(DriveId::kMultilane1Left)].start_mm;
  for (float s : {unit1_start + 100.0F, unit1_start - 60.0F}) {
    Item* item = h.tracker.create(0, s, false);
    item->classified = item->passed_plate2 = item->angle_known = true;
    item->angle_rad = 0.0F;
    item->target_angle_rad = h.config.tolerance.target_angle_rad;
  }
  station.update(h.context(), h.out);
  EXPECT_EQ(h.tracker.items()[0].multilane_unit, 0);
  EXPECT_EQ(h.tracker.items()[1].multilane_unit, 1);
  EXPECT_EQ(station.controlled_item(0), h.tracker.items()[0].id);
  // Unit 1 turns its item: right belt faster for the positive target.
  EXPECT_GT(h.out.drives[index(DriveId::kMultilane1Right)].speed_mps,
            h.out.drives[index(DriveId::kMultilane1Left)].speed_mps);
  // Unit 2 has nothing on it yet: equal speeds.
  EXPECT_EQ(h.out.drives[index(DriveId::kMultilane2Right)].speed_mps,
            h.out.drives[index(DriveId::kMultilane2Left)].speed_mps);
}

}  // namespace
}  // namespace fl::logic
