#include <gtest/gtest.h>

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

// No fillet is on the line, so nothing downstream of the tripped reject belt has to drain:
// every belt stops in the scan that reads the fault. (With fillets downstream those belts run
// on until they are clear: closed_loop_tests FaultScenarios.DriveTrip*.)
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

// A frame that claims more detections than it holds raises the flood fault in the scan that
// reads it; the line keeps running (it only degrades), the fault clears with the next sane
// frame, and after an acknowledge the line can be started again.
TEST_F(LineControllerTest, EstimateFloodIsShownInTheSameScanAndClearsWhenFramesAreSane) {
  controller.request_start();
  scans(3);
  ASSERT_EQ(controller.state(), LineState::kRunning);
  const float camera_s = config.cameras[index(CameraId::kOrientation)].s_mm;
  in.time_ns += 10'000'000;
  test::publish(in, config, CameraId::kOrientation, camera_s,
                test::good_estimate(Hand::kLeft, SideUp::kSkin, 0.0F));
  in.cameras[index(CameraId::kOrientation)].count = 255;  // the most a corrupt count can claim
  controller.update(in, out);
  EXPECT_NE(out.active_faults & fault_bit(FaultCode::kEstimateFlood), 0U);
  EXPECT_EQ(out.state, LineState::kRunning);
  // Exactly the 8 estimates the frame holds were judged (each one refused, unmatched or a
  // duplicate: they all lie on one spot with no tracked item), none of the 247 it only claims.
  const ControllerCounters& counters = controller.counters();
  EXPECT_EQ(
      counters.estimates_rejected + counters.detections_unmatched + counters.detections_duplicate,
      kMaxEstimatesPerFrame);

  in.time_ns += 10'000'000;
  test::publish(in, config, CameraId::kOrientation, camera_s,
                test::good_estimate(Hand::kLeft, SideUp::kSkin, 0.0F));
  controller.update(in, out);
  // Cause gone: still shown (latched) until the operator acknowledges.
  EXPECT_NE(out.active_faults & fault_bit(FaultCode::kEstimateFlood), 0U);
  controller.acknowledge_faults();
  scans(1);
  EXPECT_EQ(out.active_faults & fault_bit(FaultCode::kEstimateFlood), 0U);

  // A stopped line starts again: nothing latched is left to refuse the start.
  controller.request_stop();
  scans(1);
  for (int i = 0; i < 3500 && controller.state() != LineState::kStopped; ++i) scans(1);
  ASSERT_EQ(controller.state(), LineState::kStopped);
  controller.acknowledge_faults();  // the camera fell silent meanwhile; nothing is running
  scans(1);
  controller.request_start();
  scans(2);
  EXPECT_EQ(controller.state(), LineState::kRunning);
}

// Fillets that camera 1 sees but the tracker never created (as if the takt's beam were
// blind) pile up where the belts stand still, until the tracker's 64 slots are full: the next
// one cannot be tracked, and the line stops rather than run with a fillet it does not know.
TEST_F(LineControllerTest, TrackerOverflowStopsTheLine) {
  controller.request_start();
  scans(3);
  const CameraMount& camera = config.cameras[index(CameraId::kOrientation)];
  const float half_view_mm = 0.5F * camera.field_of_view_mm - 10.0F;  // inside the view
  constexpr float kSpeedMmPerScan = 10.0F;                            // 1 m/s on the guide belt
  constexpr int kScansApart = 15;  // fillets 150 mm apart: beyond the 80 mm gate
  bool overflowed = false;
  // A fillet every 150 ms; 65 need under 10000 scans, 20000 leaves room for adoption delays.
  for (int i = 0; i < 20000 && !overflowed; ++i) {
    in.time_ns += 10'000'000;
    test::move_belt(in, config, DriveId::kGuide, kSpeedMmPerScan);
    if (i % 4 == 0) {  // camera 1's 40 ms frame period
      CameraFrame& frame = in.cameras[index(CameraId::kOrientation)];
      ++frame.sequence;
      frame.frame_time_ns = in.time_ns;
      frame.count = 0;
      // Every fillet that entered the view at its own time and has moved with the belt since.
      for (int entered = i - i % kScansApart; entered >= 0 && frame.count < kMaxEstimatesPerFrame;
           entered -= kScansApart) {
        const float x_mm = -half_view_mm + kSpeedMmPerScan * static_cast<float>(i - entered);
        if (x_mm > half_view_mm) break;
        FilletEstimate estimate = test::good_estimate(Hand::kLeft, SideUp::kSkin, 0.0F);
        estimate.x_mm = x_mm;
        frame.estimates[frame.count++] = estimate;
      }
    }
    controller.update(in, out);
    overflowed = (out.active_faults & fault_bit(FaultCode::kTrackerOverflow)) != 0;
  }
  ASSERT_TRUE(overflowed) << "tracked " << controller.tracked_count() << ", adopted "
                          << controller.counters().items_adopted << ", closed "
                          << controller.counters().items_closed;
  // The scan that shows the fault already stops every belt; the 64 tracked stay tracked.
  EXPECT_EQ(out.state, LineState::kFault);
  for (const DriveCommand& drive : out.drives) EXPECT_EQ(drive.speed_mps, 0.0F);
  EXPECT_EQ(controller.tracked_count(), kMaxTrackedItems);
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
    for (std::size_t d = 0; d < kDriveCount; ++d) {
      image.drives[d].encoder_counts += 40 + static_cast<std::int64_t>(d);
    }
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
  EXPECT_TRUE(first == second);  // member by member, not the padding bytes
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
