// DdsProcessIo's safe reaction with the line's logic on top (fault matrix, DDS participant
// gone): the line's I/O side publishes sensors and drive feedback, the controller runs scans
// on it, then the I/O side's participant is deleted. Within sensors_stale_ns the scan reads
// the safety chain open and the controller disables every drive in that same scan.
#include "fl/drivers/dds/process_io.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <thread>

#include "dds_test_support.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/monotonic_clock.hpp"
#include "fl/drivers/dds/camera_input.hpp"
#include "fl/drivers/dds/line_io.hpp"
#include "fl/drivers/dds/line_output.hpp"

namespace fl::drivers::dds {
namespace {

using namespace std::chrono_literals;
using test::wait_until;

constexpr std::int64_t kPeriodNs = 10'000'000;  // the line's scan period

TEST(DdsProcessIo, LineIoParticipantGoneOpensTheChainAndTheLineStopsInThatScan) {
  Participant controller_side(18);
  DdsCameraInput cameras(controller_side);
  DdsSensorInput sensors(controller_side);
  DdsLineOutput output(controller_side);
  DdsProcessIo io(cameras, sensors, output);
  const LineConfig line = default_line_config();
  LineController controller(line);

  std::optional<Participant> io_side(std::in_place, 18);
  std::optional<DdsSensorPublisher> publisher(std::in_place, *io_side);
  ASSERT_TRUE(wait_until([&] { return publisher->matched_readers() == 1; }, 5s));
  InputImage published;
  published.estop_ok = true;
  for (DriveFeedback& drive : published.drives) drive.ready = true;

  InputImage in;
  OutputImage out;
  std::uint64_t scan = 0;
  // One scan as the runtime runs it, on CLOCK_MONOTONIC (the clock the arrival stamps use).
  const auto run_scan = [&] {
    const std::int64_t now_ns = monotonic_now_ns();
    in.time_ns = now_ns;
    io.read(now_ns, in);
    controller.update(in, out);
    io.write(out);
    ++scan;
  };
  publisher->publish(0, published);
  ASSERT_TRUE(wait_until([&] { return sensors.delivered(); }, 2s));
  controller.request_start();
  // 50 scans (0.5 s) with the I/O side alive: the line starts and runs.
  for (int i = 0; i < 50; ++i) {
    publisher->publish(scan, published);
    run_scan();
    std::this_thread::sleep_for(std::chrono::nanoseconds(kPeriodNs));
  }
  ASSERT_EQ(controller.state(), LineState::kRunning);
  ASSERT_TRUE(in.estop_ok);

  // The I/O process dies: its participant disappears without another sample.
  publisher.reset();
  io_side.reset();
  const std::int64_t last_arrival_ns = sensors.last_sensors_arrival_ns();
  std::int64_t opened_at_ns = 0;
  // At most 1 s of scans: five times the 200 ms the chain may stay closed without sensors.
  for (int i = 0; i < 100 && opened_at_ns == 0; ++i) {
    run_scan();
    if (!in.estop_ok) {
      opened_at_ns = in.time_ns;
      // The same scan: state fault, every drive disabled at standstill.
      EXPECT_EQ(out.state, LineState::kFault);
      EXPECT_NE(out.active_faults & fault_bit(FaultCode::kEstop), 0U);
      for (const DriveCommand& drive : out.drives) {
        EXPECT_FALSE(drive.enable);
        EXPECT_EQ(drive.speed_mps, 0.0F);
      }
    }
    std::this_thread::sleep_for(std::chrono::nanoseconds(kPeriodNs));
  }
  ASSERT_NE(opened_at_ns, 0) << "the chain stayed closed for 1 s without sensors";
  const std::int64_t silence_ns = opened_at_ns - last_arrival_ns;
  const std::int64_t stale_ns = DdsProcessIoOptions{}.sensors_stale_ns;
  // Never before the 200 ms; after it within a scan, plus scheduling slack on 2 loaded cores.
  EXPECT_GT(silence_ns, stale_ns);
  EXPECT_LT(silence_ns, stale_ns + kPeriodNs + 100'000'000);
  EXPECT_GT(io.sensors_stale_scans(), 0U);
}

// The line's devices behind a field bus that stamps its writes: each one takes effect
// kApplyDelayNs after the write (a SYNC that waits for the bus).
class StampingDevices final : public ProcessIo {
 public:
  static constexpr std::int64_t kApplyDelayNs = 2'000'000;
  void read(std::int64_t /*now_ns*/, InputImage& in) override {
    in.estop_ok = true;
    applied_ = written_;
    written_.reset();
  }
  void write(const OutputImage& /*out*/) override { written_ = monotonic_now_ns() + kApplyDelayNs; }
  [[nodiscard]] std::optional<std::int64_t> last_write_applied_ns() const override {
    return applied_;
  }

 private:
  std::optional<std::int64_t> written_;
  std::optional<std::int64_t> applied_;
};

// Estimate to the devices: from a frame's publication to its scan's command taking effect at
// the devices, as the devices' transport stamps it; one sample per frame a scan read.
TEST(DdsProcessIo, EstimateToDevicesIsMeasuredToTheDevicesOwnStamp) {
  Participant controller_side(19);
  DdsCameraInput cameras(controller_side);
  DdsLineOutput output(controller_side);
  StampingDevices devices;
  DdsProcessIo io(cameras, devices, output);
  Participant camera_side(19);
  DdsCameraPublisher camera(camera_side, kPeriodNs);
  ASSERT_TRUE(wait_until([&] { return camera.matched_readers() == 1; }, 5s));

  InputImage in;
  OutputImage out;
  constexpr int kFrames = 10;
  for (int frame = 1; frame <= kFrames; ++frame) {
    CameraFrame estimates;
    estimates.sequence = static_cast<std::uint32_t>(frame);
    estimates.frame_time_ns = monotonic_now_ns();
    camera.publish(CameraId::kOrientation, estimates);
    ASSERT_TRUE(wait_until(
        [&] { return cameras.counters().samples_accepted == static_cast<std::uint64_t>(frame); },
        2s));
    io.read(monotonic_now_ns(), in);  // reads the frame (and stamps the previous write)
    io.write(out);
  }
  io.read(monotonic_now_ns(), in);  // the last frame's command is stamped here
  const DistributionSummary latency = io.estimate_to_devices();
  EXPECT_EQ(latency.count, static_cast<std::uint64_t>(kFrames));
  EXPECT_EQ(io.estimates_unstamped(), 0U);
  // At least the devices' 2 ms after the write; the publish-to-read wait of a loaded machine
  // stays far below the 2 s the loop allows.
  EXPECT_GE(latency.min_ns, StampingDevices::kApplyDelayNs);
  EXPECT_LT(latency.max_ns, 2'000'000'000);
}

}  // namespace
}  // namespace fl::drivers::dds
