// run_line_tracks: the DEM plant replaying a line's command log, fillets placed where a camera
// first saw them.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "dem_plant_test_support.hpp"
#include "fl/twin/dem_plant/line_tracks.hpp"

namespace fl::test {
namespace {

// Every belt of the path at one speed: a fillet crosses the seams without a change of pace.
LineTracksRun even_line(float speed_mps) {
  LineTracksRun run;
  run.line = default_line_config();
  run.plant = test_config();
  run.commands = [speed_mps](double /*time_s*/) {
    OutputImage out{};
    for (DriveCommand& drive : out.drives) drive.speed_mps = speed_mps;
    return out;
  };
  return run;
}

TEST(LineTracks, AFilletRidesTheBeltsAtTheirSpeedAcrossASeam) {
  // Placed on transition 1 (0..500 mm) at 150 mm, it crosses onto transition 2 within the
  // second. At 0.3 m/s on every belt it ends 300 mm on; the 2 mm drop onto the belt and the
  // seam's 2 mm gap cost it a few millimetres at most, and nothing turns or shifts it.
  LineTracksRun run = even_line(0.3F);
  run.first = {{0.1, 150.0, 20.0, 0.3}};
  run.samples = {{0, 0.1}, {0, 0.6}, {0, 1.1}};
  const LineTracksResult result = run_line_tracks(run);
  ASSERT_EQ(result.poses.size(), 3U);
  EXPECT_NEAR(result.poses[0].s_mm, 150.0, 1.0);  // answered where it was placed
  EXPECT_NEAR(result.poses[1].s_mm, 300.0, 5.0);
  EXPECT_NEAR(result.poses[2].s_mm, 450.0, 5.0);
  EXPECT_NEAR(result.poses[2].y_mm, 20.0, 3.0);
  EXPECT_NEAR(result.poses[2].angle_rad, 0.3, 0.05);
  EXPECT_TRUE(result.poses[2].on_line);
  EXPECT_EQ(result.rows_after_leaving, 0U);
}

TEST(LineTracks, TheCommandLogsMultilaneDifferentialTurnsTheFillet) {
  // Multilane unit 1 (3400..3800 mm): the left belt (+y) faster than the right carries the
  // fillet's left half ahead, a clockwise turn seen from above, the angle falls; the mirror
  // command turns it the other way. 0.1 m/s of differential over the unit's 80 mm lever is
  // 1.25 rad/s of belt rate; a fillet turns at a fraction of it (machinery tests), so 0.6 s
  // turns it by a tenth of a radian or more.
  const auto turn_rad = [](float left_mps, float right_mps) {
    LineTracksRun run = even_line(0.3F);
    run.commands = [left_mps, right_mps](double /*time_s*/) {
      OutputImage out{};
      for (DriveCommand& drive : out.drives) drive.speed_mps = 0.3F;
      out.drives[index(DriveId::kMultilane1Left)].speed_mps = left_mps;
      out.drives[index(DriveId::kMultilane1Right)].speed_mps = right_mps;
      return out;
    };
    run.first = {{0.0, 3550.0, 0.0, 0.0}};
    run.samples = {{0, 0.0}, {0, 0.6}};
    const LineTracksResult result = run_line_tracks(run);
    return result.poses[1].angle_rad - result.poses[0].angle_rad;
  };
  EXPECT_LT(turn_rad(0.35F, 0.25F), -0.1);
  EXPECT_GT(turn_rad(0.25F, 0.35F), 0.1);
}

TEST(LineTracks, RowsAfterTheFilletLeftTheLineSayItAndKeepItsLastPose) {
  // The outfeed ends at 5500 mm: from 5400 mm at 0.4 m/s the fillet is placed (taken off the
  // line) within half a second, so the row at 1 s has no fillet to answer.
  LineTracksRun run = even_line(0.4F);
  run.first = {{0.0, 5400.0, 0.0, 0.0}};
  run.samples = {{0, 0.0}, {0, 0.1}, {0, 1.0}};
  const LineTracksResult result = run_line_tracks(run);
  ASSERT_EQ(result.poses.size(), 3U);
  EXPECT_TRUE(result.poses[1].on_line);
  EXPECT_FALSE(result.poses[2].on_line);
  EXPECT_EQ(result.rows_after_leaving, 1U);
  EXPECT_GT(result.poses[2].s_mm, 5400.0);
}

TEST(LineTracks, RefusesRowsItCannotAnswer) {
  LineTracksRun run = even_line(0.3F);
  run.first = {{0.5, 150.0, 0.0, 0.0}};
  run.samples = {{0, 0.2}};  // before the fillet appeared
  EXPECT_THROW(run_line_tracks(run), std::invalid_argument);
  run.samples = {{1, 0.6}};  // a fillet with no start
  EXPECT_THROW(run_line_tracks(run), std::invalid_argument);
  run.samples = {{0, 0.6}, {0, 0.55}};  // out of time order
  EXPECT_THROW(run_line_tracks(run), std::invalid_argument);
  run.samples = {{0, 0.6}};
  run.first = {{0.5, 9000.0, 0.0, 0.0}};  // past the outfeed's end
  EXPECT_THROW(run_line_tracks(run), std::invalid_argument);
  run.first = {{0.5, 150.0, 0.0, 0.0}};
  run.commands = nullptr;
  EXPECT_THROW(run_line_tracks(run), std::invalid_argument);
}

}  // namespace
}  // namespace fl::test
