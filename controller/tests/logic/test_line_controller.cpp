#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "fl/controller/line_controller.hpp"
#include "test_support.hpp"

namespace fl {
namespace {

class LineControllerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    in.estop_ok = true;
    test::all_drives_ready(in);
  }
  void scans(int count) {
    for (int i = 0; i < count; ++i) {
      in.time_ns += 10'000'000;
      controller.update(in, out);
    }
  }
  LineConfig config = default_line_config();
  LineController controller{config};
  InputImage in;
  OutputImage out;
};

TEST_F(LineControllerTest, StartsIntoRunningWhenDrivesAreReady) {
  scans(1);
  EXPECT_EQ(controller.state(), LineState::kStopped);
  for (const DriveCommand& drive : out.drives) EXPECT_EQ(drive.speed_mps, 0.0F);
  controller.request_start();
  scans(2);
  EXPECT_EQ(controller.state(), LineState::kRunning);
  EXPECT_EQ(out.state, LineState::kRunning);
  EXPECT_FLOAT_EQ(out.drives[index(DriveId::kGuide)].speed_mps,
                  config.sections[index(DriveId::kGuide)].nominal_speed_mps);
}

TEST_F(LineControllerTest, StartRequestFromTheInputImageWorksToo) {
  in.start_request = true;
  scans(1);
  in.start_request = false;
  scans(1);
  EXPECT_EQ(controller.state(), LineState::kRunning);
}

TEST_F(LineControllerTest, EstopDisablesEveryDriveInTheSameScan) {
  controller.request_start();
  scans(3);
  in.estop_ok = false;
  scans(1);
  EXPECT_EQ(controller.state(), LineState::kFault);
  for (const DriveCommand& drive : out.drives) {
    EXPECT_FALSE(drive.enable);
    EXPECT_EQ(drive.speed_mps, 0.0F);
  }
  EXPECT_NE(out.active_faults & fault_bit(FaultCode::kEstop), 0U);
  // Acknowledge does nothing while the chain is open; once closed, it clears to stopped.
  controller.acknowledge_faults();
  scans(1);
  EXPECT_EQ(controller.state(), LineState::kFault);
  in.estop_ok = true;
  controller.acknowledge_faults();
  scans(1);
  EXPECT_EQ(controller.state(), LineState::kStopped);
  EXPECT_EQ(controller.active_faults(), 0U);
}

TEST_F(LineControllerTest, DriveFaultStopsTheLine) {
  controller.request_start();
  scans(3);
  in.drives[index(DriveId::kReject)].fault = true;
  scans(1);
  EXPECT_EQ(controller.state(), LineState::kFault);
  for (const DriveCommand& drive : out.drives) EXPECT_EQ(drive.speed_mps, 0.0F);
}

TEST_F(LineControllerTest, LevellerOverloadStopsOnlyTheInfeed) {
  controller.request_start();
  scans(3);
  in.leveller_overload = true;
  scans(1);
  EXPECT_EQ(controller.state(), LineState::kRunning);
  EXPECT_EQ(out.drives[index(DriveId::kBulk)].speed_mps, 0.0F);
  EXPECT_EQ(out.drives[index(DriveId::kTakt)].speed_mps, 0.0F);
  EXPECT_GT(out.drives[index(DriveId::kGuide)].speed_mps, 0.0F);  // downstream drains
}

// Three consecutive scans whose time steps show skipped periods (the runtime's overruns)
// fault the line; isolated ones are only counted.
TEST_F(LineControllerTest, ConsecutiveOverrunsFaultTheLine) {
  controller.request_start();
  scans(3);
  in.time_ns += 20'000'000;  // one skipped period
  controller.update(in, out);
  scans(1);
  EXPECT_EQ(controller.counters().overruns, 1U);
  EXPECT_EQ(controller.state(), LineState::kRunning);
  for (int i = 0; i < config.watchdog.overrun_fault_cycles; ++i) {
    in.time_ns += 30'000'000;
    controller.update(in, out);
  }
  EXPECT_EQ(controller.state(), LineState::kFault);
  EXPECT_NE(controller.active_faults() & fault_bit(FaultCode::kCycleOverrun), 0U);
}

TEST_F(LineControllerTest, SilentCameraIsAFault) {
  controller.request_start();
  // No frame at all for a second of running: longer than any camera's silence limit.
  scans(100);
  EXPECT_NE(controller.active_faults() & fault_bit(FaultCode::kCameraSilent), 0U);
}

// Time and inputs are everything the logic reads: replaying the same input images gives
// bit-identical output images.
TEST_F(LineControllerTest, SameInputsGiveBitIdenticalOutputs) {
  std::vector<InputImage> inputs;
  InputImage image = in;
  image.start_request = true;
  for (int i = 0; i < 3000; ++i) {
    image.time_ns += 10'000'000;
    image.takt_beam_broken = (i / 37) % 3 == 0;  // rows arriving irregularly
    image.level_mm = static_cast<float>(i % 90);
    for (std::size_t d = 0; d < kDriveCount; ++d) image.drives[d].encoder_counts += 40 + d;
    if (i % 4 == 0) {
      test::publish(image, config, CameraId::kOrientation,
                    config.cameras[index(CameraId::kOrientation)].s_mm + static_cast<float>(i % 50),
                    test::good_estimate(Hand::kLeft, SideUp::kSkin, 0.1F));
    }
    inputs.push_back(image);
    image.start_request = false;
  }
  auto run = [&](std::vector<OutputImage>& outputs) {
    LineController fresh(config);
    OutputImage output;
    for (const InputImage& input : inputs) {
      fresh.update(input, output);
      outputs.push_back(output);
    }
  };
  std::vector<OutputImage> first;
  std::vector<OutputImage> second;
  run(first);
  run(second);
  ASSERT_EQ(first.size(), second.size());
  EXPECT_EQ(std::memcmp(first.data(), second.data(), first.size() * sizeof(OutputImage)), 0);
}

TEST_F(LineControllerTest, CloseAllInTransitBalancesTheLedger) {
  controller.request_start();
  scans(3);
  in.takt_beam_broken = true;
  scans(5);
  ASSERT_EQ(controller.tracked_count(), 1U);
  controller.close_all_in_transit(in.time_ns, LostReason::kLineStopped);
  EXPECT_EQ(controller.tracked_count(), 0U);
  auto record = controller.closed_records().pop();
  ASSERT_TRUE(record.has_value());
  EXPECT_EQ(record->outcome, Outcome::kLost);
  EXPECT_EQ(record->lost_reason, LostReason::kLineStopped);
}

}  // namespace
}  // namespace fl
