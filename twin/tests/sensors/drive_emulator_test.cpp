// The shared drive emulator on its own: command delay, ramps at the limits, encoder counts,
// trips and the safety chain.
#include "fl/twin/sensors/drive_emulator.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace fl::test {
namespace {

constexpr std::int64_t kMs = 1000000;
constexpr auto kGuide = DriveId::kGuide;

// Reference limits: 1 m/s, 5 m/s^2, 10 counts per mm; 5 ms delay (thesis 5.3).
struct Rig {
  Rig() : emulator(limits(), 0.005) {}
  static std::array<DriveLimits, kDriveCount> limits() {
    std::array<DriveLimits, kDriveCount> l{};
    for (auto& limit : l) limit = {1.0F, 5.0F, 10.0F};
    return l;
  }
  // A 10 ms scan: the command leaves at the scan's start, then 1 ms plant steps.
  void scan() {
    emulator.command(commands, time_ns);
    for (int i = 0; i < 10; ++i) {
      emulator.step(time_ns, 0.001, tripped, powered);
      time_ns += kMs;
    }
  }
  DriveEmulator emulator;
  std::array<DriveCommand, kDriveCount> commands{};
  std::array<bool, kDriveCount> tripped{};
  bool powered = true;
  std::int64_t time_ns = 0;
};

TEST(DriveEmulator, CommandActsAfterTheDelay) {
  Rig rig;
  rig.commands[index(kGuide)] = {true, 0.5F, 0.0F};
  rig.emulator.command(rig.commands, 0);
  for (int ms = 0; ms < 5; ++ms) {  // 5 ms delay: nothing moves yet
    rig.emulator.step(ms * kMs, 0.001, rig.tripped, true);
    EXPECT_EQ(rig.emulator.speed_mps(kGuide), 0.0) << ms;
    EXPECT_FALSE(rig.emulator.drive(kGuide).ready);
  }
  rig.emulator.step(5 * kMs, 0.001, rig.tripped, true);
  EXPECT_NEAR(rig.emulator.speed_mps(kGuide), 0.005, 1e-12);  // 5 m/s^2 x 1 ms
  EXPECT_TRUE(rig.emulator.drive(kGuide).ready);
}

TEST(DriveEmulator, RampsAtTheLimitAndCountsTheTravel) {
  Rig rig;
  rig.commands[index(kGuide)] = {true, 0.5F, 0.0F};  // 0: as fast as allowed
  for (int s = 0; s < 50; ++s) rig.scan();           // 0.5 s
  EXPECT_DOUBLE_EQ(rig.emulator.speed_mps(kGuide), 0.5);
  // Travel = v (T - delay - ramp / 2) = 0.5 (0.5 - 0.005 - 0.05) m = 222.5 mm, 2225 counts at
  // 10 per mm (the trapezoid integrates the ramp exactly; floor may lose the last count).
  EXPECT_NEAR(rig.emulator.drive(kGuide).position_mm, 222.5, 1e-9);
  EXPECT_NEAR(static_cast<double>(rig.emulator.drive(kGuide).encoder_counts), 2225.0, 1.0);
  // A ramp the command asks for is kept when under the limit: 1 m/s^2 from 0.5 to 0 m/s
  // takes 0.5 s, after the 5 ms delay.
  rig.commands[index(kGuide)] = {true, 0.0F, 1.0F};
  for (int s = 0; s < 25; ++s) rig.scan();  // 0.25 s
  EXPECT_NEAR(rig.emulator.speed_mps(kGuide), 0.5 - 1.0 * (0.25 - 0.005), 1e-9);
  // Speed is clamped to the drive's maximum; reversing counts down.
  rig.commands[index(kGuide)] = {true, -3.0F, 0.0F};
  const std::int64_t before = rig.emulator.drive(kGuide).encoder_counts;
  for (int s = 0; s < 100; ++s) rig.scan();
  EXPECT_DOUBLE_EQ(rig.emulator.speed_mps(kGuide), -1.0);
  EXPECT_LT(rig.emulator.drive(kGuide).encoder_counts, before);
}

TEST(DriveEmulator, TripAndSafetyChainQuickStop) {
  Rig rig;
  rig.commands[index(kGuide)] = {true, 0.5F, 0.5F};
  for (int s = 0; s < 200; ++s) rig.scan();  // at speed after 1 s of a 0.5 m/s^2 ramp
  ASSERT_DOUBLE_EQ(rig.emulator.speed_mps(kGuide), 0.5);
  rig.tripped[index(kGuide)] = true;
  rig.scan();
  // Quick stop at the limit (5 m/s^2), not the commanded ramp: 10 ms take 0.05 m/s.
  EXPECT_NEAR(rig.emulator.speed_mps(kGuide), 0.45, 1e-9);
  EXPECT_TRUE(rig.emulator.drive(kGuide).fault);
  EXPECT_FALSE(rig.emulator.drive(kGuide).ready);
  rig.tripped[index(kGuide)] = false;
  for (int s = 0; s < 200; ++s) rig.scan();
  ASSERT_DOUBLE_EQ(rig.emulator.speed_mps(kGuide), 0.5);
  rig.powered = false;  // STO: every drive stops and reports not ready, without a fault
  for (int s = 0; s < 20; ++s) rig.scan();
  EXPECT_EQ(rig.emulator.speed_mps(kGuide), 0.0);
  EXPECT_FALSE(rig.emulator.drive(kGuide).ready);
  EXPECT_FALSE(rig.emulator.drive(kGuide).fault);
  std::array<DriveFeedback, kDriveCount> feedback{};
  rig.emulator.write(feedback);
  EXPECT_EQ(feedback[index(kGuide)].encoder_counts, rig.emulator.drive(kGuide).encoder_counts);
  EXPECT_FALSE(feedback[index(kGuide)].ready);
}

}  // namespace
}  // namespace fl::test
