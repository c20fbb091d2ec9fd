// The fault matrix's "the loop keeps its period" (docs/fault_matrix.md): the real scan runtime
// (10 ms absolute schedule, SCHED_OTHER as in CI) runs the line's logic against the fast plant
// behind PlantIo, as `linectl run --realtime` does, while a drive trips and is reset from
// another thread through PlantIo::set_twin_fault, as the HMI's twin panel does.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <thread>

#include "fl/apps/closed_loop.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/runtime.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/line_devices.hpp"
#include "fl/twin/fast_plant.hpp"
#include "fl/twin/fast_plant_config.hpp"
#include "plant_io.hpp"

namespace fl {
namespace {

const std::filesystem::path kConfigDir = std::filesystem::path(FL_SOURCE_DIR) / "config";
constexpr std::int64_t kPeriodNs = 10'000'000;  // line.yaml's scan period
constexpr std::int64_t kMs = 1'000'000;

// The line's logic, with a check of each scan's images on the scan thread: scans that read
// a drive fault, and those among them that did not stop, in the same scan, the faulted
// drive and every drive upstream of it (lower in DriveId's flow order; belts downstream may
// run on to carry their fillets off).
class CheckedLogic final : public ScanLogic {
 public:
  explicit CheckedLogic(LineControllerLogic& logic) : logic_(logic) {}
  void update(const InputImage& in, OutputImage& out) override {
    logic_.update(in, out);
    std::size_t last_faulted = kDriveCount;
    for (std::size_t d = 0; d < kDriveCount; ++d) {
      if (in.drives[d].fault) last_faulted = d;
    }
    if (last_faulted == kDriveCount) return;
    fault_scans_.fetch_add(1, std::memory_order_relaxed);
    bool at_rest = out.state == LineState::kFault;
    for (std::size_t d = 0; d <= last_faulted; ++d) {
      at_rest = at_rest && out.drives[d].speed_mps == 0.0F;
    }
    if (!at_rest) missed_scans_.fetch_add(1, std::memory_order_relaxed);
  }
  void on_overrun(const OverrunInfo& info) override { logic_.on_overrun(info); }
  void after_scan(const InputImage& in, const OutputImage& out,
                  const ScanTimingSample& timing) override {
    logic_.after_scan(in, out, timing);
  }
  std::atomic<std::uint64_t> fault_scans_{0};
  std::atomic<std::uint64_t> missed_scans_{0};

 private:
  LineControllerLogic& logic_;
};

// The HMI's twin panel behind the bus (`linectl run --realtime --fieldbus canopen --hmi`):
// PlantIo drives the inner fast plant's switches while the controller sees the plant only
// through the CANopen master, so a drive trip arrives as the drive's EMCY and a lost camera
// as frames that stop. Stepped here by hand in simulated time (no runtime: the bus path,
// not the timing, is under test).
TEST(RealtimeFaults, TwinSwitchesReachTheControllerThroughTheBus) {
  const LineConfig line = load_line_config(kConfigDir / "line.yaml");
  FastPlant fast(line, load_fast_plant_config(kConfigDir / "plant_fast.yaml"));
  drivers::CanopenPlant bus_plant(fast, drivers::load_can_config(kConfigDir / "can.yaml", line));
  apps::PlantIo io(bus_plant, 3, &fast);
  InputImage in;
  OutputImage out = make_safe_output_image();
  std::int64_t now_ns = 1'000 * kMs;
  const auto scan = [&] {
    now_ns += kPeriodNs;
    io.read(now_ns, in);
    io.write(out);
  };
  scan();
  constexpr std::size_t kDrive = index(DriveId::kCentring);
  ASSERT_FALSE(in.drives[kDrive].fault);
  io.set_twin_fault(apps::TwinFault::kDriveLost, kDrive, true);
  // The plant trips in the next step; its drive sends the EMCY at the following SYNC and the
  // master reads it one scan later: within 3 scans.
  for (int s = 0; s < 3 && !in.drives[kDrive].fault; ++s) scan();
  EXPECT_TRUE(in.drives[kDrive].fault);
  EXPECT_EQ(bus_plant.master().drive_status(DriveId::kCentring).emcy_code,
            drivers::emulation::LineDevices::kPlantDriveFaultCode);

  // A camera switched silent: its frames (not on the bus) stop advancing.
  constexpr std::size_t kCamera = index(CameraId::kOrientation);
  const std::uint32_t before = in.cameras[kCamera].sequence;
  for (int s = 0; s < 20; ++s) scan();
  ASSERT_GT(in.cameras[kCamera].sequence, before);  // delivering before the switch
  io.set_twin_fault(apps::TwinFault::kCameraSilent, kCamera, true);
  scan();
  const std::uint32_t frozen = in.cameras[kCamera].sequence;
  for (int s = 0; s < 20; ++s) scan();  // 200 ms: five frames of a 40 ms camera
  EXPECT_EQ(in.cameras[kCamera].sequence, frozen);
}

TEST(RealtimeFaults, DriveTripAndResetKeepTheScanPeriodAndTheBooks) {
  const LineConfig line = load_line_config(kConfigDir / "line.yaml");
  FastPlant plant(line, load_fast_plant_config(kConfigDir / "plant_fast.yaml"));
  LineController controller(line);
  LineControllerLogic logic(controller);
  CheckedLogic checked(logic);
  apps::PlantIo io(plant, 3);
  io.request_line_start();

  // 8 s: the first fillet crosses the takt barrier about 4 s after the start (seed 3), so
  // the trip at 5 s stops belts that carry fillets; short enough for the default suite.
  constexpr std::int64_t kRunNs = 8'000 * kMs;
  RuntimeOptions options;
  options.period_ns = kPeriodNs;
  options.duration_ns = kRunNs;
  std::atomic<int> runtime_faults{0};
  options.on_fault = [&](RuntimeFault) { runtime_faults.fetch_add(1); };
  ScanRuntime runtime(io, checked, options);

  apps::KpiCollector collector(line);
  std::uint64_t records = 0;
  const auto drain = [&] {
    while (auto exit = io.exits().pop()) collector.add_exit(*exit);
    while (controller.closed_records().pop()) ++records;
    while (auto event = controller.events().pop()) collector.add_event(*event);
  };

  const auto wall_start = std::chrono::steady_clock::now();
  ASSERT_TRUE(runtime.start().started);
  const auto since_start = [&] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() -
                                                                wall_start)
        .count();
  };
  // The operator's timeline, from this (non-real-time) thread: trip at 5 s, reset at 6 s,
  // acknowledge and start again at 6.2 s and 6.4 s.
  constexpr std::size_t kDrive = index(DriveId::kCentring);
  int step = 0;
  while (runtime.running()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // two scans
    drain();
    const std::int64_t now_ns = since_start();
    if (step == 0 && now_ns >= 5'000 * kMs) {
      io.set_twin_fault(apps::TwinFault::kDriveLost, kDrive, true);
      ++step;
    } else if (step == 1 && now_ns >= 6'000 * kMs) {
      io.set_twin_fault(apps::TwinFault::kDriveLost, kDrive, false);
      ++step;
    } else if (step == 2 && now_ns >= 6'200 * kMs) {
      logic.acknowledge_faults();
      ++step;
    } else if (step == 3 && now_ns >= 6'400 * kMs) {
      logic.request_start();
      ++step;
    }
  }
  runtime.wait();
  const double wall_s = static_cast<double>(since_start()) / 1e9;
  drain();

  // The period held: no runtime fault (three overruns in a row would raise one), and the
  // scans fill the run's schedule (a period skipped after an overrun is a scan missing). 5 %
  // slack on the 800 scans and the 8 s: a loaded 2-core CI machine, SCHED_OTHER.
  EXPECT_EQ(runtime.fault(), RuntimeFault::kNone);
  EXPECT_EQ(runtime_faults.load(), 0);
  const std::uint64_t scheduled = static_cast<std::uint64_t>(kRunNs / kPeriodNs);
  EXPECT_GE(runtime.scans(), scheduled * 95 / 100) << "overruns " << runtime.overruns();
  EXPECT_LE(runtime.scans(), scheduled);
  EXPECT_NEAR(wall_s, 8.0, 0.4);

  // The fault was seen, reacted to in each scan that read it, and cleared: the line ran again.
  EXPECT_GT(checked.fault_scans_.load(), 50U);  // the 1 s trip: about 100 scans
  EXPECT_EQ(checked.missed_scans_.load(), 0U);
  EXPECT_EQ(step, 4);
  EXPECT_EQ(controller.state(), LineState::kRunning);
  EXPECT_EQ(controller.active_faults() & fault_bit(FaultCode::kDriveFault), 0U);

  // Every fillet accounted for on both sides of the books.
  controller.close_all_in_transit(io.last_scan_time_ns(), LostReason::kRunEnded);
  drain();
  apps::Kpis kpis;
  collector.finish(controller, io.fillets_fed(), io.fillets_on_line(), wall_s, wall_s, wall_s,
                   kpis);
  SCOPED_TRACE(apps::format_kpis(kpis));
  EXPECT_NE(kpis.faults_seen & fault_bit(FaultCode::kDriveFault), 0U);
  EXPECT_GT(kpis.truth.fed, 0U);
  EXPECT_TRUE(kpis.truth_balanced);
  EXPECT_TRUE(kpis.ledger_balanced);
  EXPECT_EQ(records, kpis.items_closed);
}

}  // namespace
}  // namespace fl
