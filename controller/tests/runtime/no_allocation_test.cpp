// The cycle's real-time contract: from the first read to the last write, the scan thread
// neither allocates nor locks a mutex. The probe (scan_thread_probe.hpp) is armed by the
// I/O's activate() and disarmed by its deactivate(), so it covers every scan, the sleeps
// between them and the runtime's own bookkeeping, not just the logic.
#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "fl/controller/line_config.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/line_status.hpp"
#include "fl/controller/runtime.hpp"
#include "runtime_test_support.hpp"
#include "scan_thread_probe.hpp"

namespace fl {
namespace {

using test::CopyingIo;
using test::EchoLogic;
using test::probe_counts;
using test::reset_probe_counts;

constexpr std::int64_t kPeriodNs = 1'000'000;  // 1 ms: a few hundred scans in well under a second
constexpr std::uint64_t kScans = 300;

// Where an allocation's address goes, so that the compiler cannot elide new/delete pairs.
void* volatile g_sink = nullptr;

// The probe must see what it is meant to catch, or a zero count proves nothing.
TEST(ScanThreadProbe, CountsAllocationsAndLocksOnArmedThreadsOnly) {
  reset_probe_counts();
  std::mutex mutex;
  {
    test::ArmedProbeScope armed;
    auto block = std::make_unique<std::uint64_t[]>(64);
    g_sink = block.get();
    const std::lock_guard lock(mutex);
  }
  std::thread([&] {
    auto block = std::make_unique<std::uint64_t[]>(64);
    g_sink = block.get();
    const std::lock_guard lock(mutex);
  }).join();
  EXPECT_EQ(probe_counts().allocations, 1U);
  EXPECT_EQ(probe_counts().deallocations, 1U);
  EXPECT_EQ(probe_counts().mutex_locks, 1U);
}

// Allocates and locks once on a chosen scan: the probe armed through the runtime sees it.
class MisbehavingLogic final : public ScanLogic {
 public:
  void update(const InputImage& /*in*/, OutputImage& /*out*/) override {
    if (++updates_ == 50) {
      auto block = std::make_unique<std::uint64_t[]>(16);
      g_sink = block.get();
      const std::lock_guard lock(mutex_);
    }
  }

 private:
  std::uint64_t updates_ = 0;
  std::mutex mutex_;
};

TEST(ScanThreadProbe, SeesAnAllocationInsideTheScan) {
  CopyingIo io(/*arm_probe=*/true);
  MisbehavingLogic logic;
  ScanRuntime runtime(io, logic, RuntimeOptions{.period_ns = kPeriodNs, .max_scans = 100});
  reset_probe_counts();
  ASSERT_TRUE(runtime.run().started);
  EXPECT_EQ(probe_counts().allocations, 1U);
  EXPECT_EQ(probe_counts().mutex_locks, 1U);
}

TEST(RealTimeCycle, RuntimeAndTrivialLogicNeitherAllocateNorLock) {
  CopyingIo io(/*arm_probe=*/true);
  io.next_input.estop_ok = true;
  EchoLogic logic;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = kPeriodNs,
                                     .max_scans = kScans,
                                     .overrun_fault_consecutive = 0,  // a loaded CI must not
                                     .watchdog_periods = 0});         // end the run early
  reset_probe_counts();
  ASSERT_TRUE(runtime.run().started);
  ASSERT_TRUE(io.activated());
  EXPECT_EQ(io.writes(), kScans);
  EXPECT_EQ(probe_counts().allocations, 0U);
  EXPECT_EQ(probe_counts().deallocations, 0U);
  EXPECT_EQ(probe_counts().mutex_locks, 0U);
  EXPECT_TRUE(io.last_output.drives[0].enable);
}

// Overrun handling is part of the cycle too.
TEST(RealTimeCycle, OverrunPathNeitherAllocatesNorLocks) {
  class SlowLogic final : public ScanLogic {
   public:
    void update(const InputImage& /*in*/, OutputImage& /*out*/) override {
      if (++updates % 10 == 0) test::sleep_for_ns(kPeriodNs + kPeriodNs / 2);
    }
    std::uint64_t updates = 0;
  } logic;
  CopyingIo io(/*arm_probe=*/true);
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = kPeriodNs,
                                     .max_scans = 100,
                                     .overrun_fault_consecutive = 0,
                                     .watchdog_periods = 0});
  reset_probe_counts();
  ASSERT_TRUE(runtime.run().started);
  EXPECT_GE(runtime.overruns(), 10U);
  EXPECT_EQ(probe_counts().allocations, 0U);
  EXPECT_EQ(probe_counts().mutex_locks, 0U);
}

// A loop-back plant in the I/O: drives follow their commands, the takt barrier is broken by
// a passing fillet now and then, and camera 1 reports it. Crude, but it takes the real
// controller through starting, running, tracking and its stations.
class LoopbackIo final : public ProcessIo {
 public:
  explicit LoopbackIo(const LineConfig& config) : config_(config) {}

  void activate() override { test::arm_probe_on_this_thread(true); }
  void deactivate() override { test::arm_probe_on_this_thread(false); }

  void read(std::int64_t now_ns, InputImage& in) override {
    const float dt_s = previous_ns_ == 0 ? 0.0F : static_cast<float>(now_ns - previous_ns_) * 1e-9F;
    previous_ns_ = now_ns;
    ++scan_;
    in.time_ns = now_ns;
    in.estop_ok = true;
    in.start_request = scan_ == 2;
    in.level_mm = 60.0F;
    in.leveller_speed_rpm = commands_.leveller_speed_rpm;
    for (std::size_t d = 0; d < kDriveCount; ++d) {
      DriveFeedback& drive = in.drives[d];
      drive.ready = true;
      drive.speed_mps = commands_.drives[d].enable ? commands_.drives[d].speed_mps : 0.0F;
      drive.encoder_counts += static_cast<std::int64_t>(drive.speed_mps * 1000.0F * dt_s *
                                                        config_.limits[d].counts_per_mm);
    }
    in.takt_beam_broken = scan_ % 150 >= 50;  // a fillet waits at the barrier
    if (scan_ % 4 == 0) {
      CameraFrame& frame = in.cameras[index(CameraId::kOrientation)];
      ++frame.sequence;
      frame.frame_time_ns = now_ns;
      frame.count = 1;
      frame.estimates[0] = FilletEstimate{0.0F, 5.0F, 0.3F, 0.9F, Hand::kLeft, SideUp::kSkin, true};
    }
  }

  void write(const OutputImage& out) override {
    commands_ = out;
    saw_running_ = saw_running_ || out.state == LineState::kRunning;
  }

  [[nodiscard]] bool saw_running() const { return saw_running_; }

 private:
  const LineConfig& config_;
  OutputImage commands_{};
  std::int64_t previous_ns_ = 0;
  std::uint64_t scan_ = 0;
  bool saw_running_ = false;
};

TEST(RealTimeCycle, RuntimeWithTheLineControllerNeitherAllocatesNorLocks) {
  const LineConfig config = default_line_config();
  LineController controller(config);
  LineControllerLogic logic(controller);
  LineStatusPublisher status;  // the HMI's snapshots are published in the cycle too
  logic.attach_status(&status);
  LoopbackIo io(config);
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = kPeriodNs,
                                     .max_scans = kScans,
                                     .overrun_fault_consecutive = 0,
                                     .watchdog_periods = 0});
  reset_probe_counts();
  ASSERT_TRUE(runtime.run().started);
  EXPECT_EQ(runtime.scans(), kScans);
  EXPECT_EQ(controller.counters().scans, kScans);
  EXPECT_TRUE(io.saw_running());
  EXPECT_GT(controller.counters().frames_processed, 0U);
  ASSERT_TRUE(status.buffer().take());
  EXPECT_EQ(status.buffer().front().timing.scans, kScans);
  EXPECT_EQ(status.buffer().front().counters.scans, kScans);
  EXPECT_EQ(probe_counts().allocations, 0U);
  EXPECT_EQ(probe_counts().deallocations, 0U);
  EXPECT_EQ(probe_counts().mutex_locks, 0U);
}

// Operator commands from another thread reach the controller on the scan thread.
TEST(LineControllerLogic, HandsOperatorCommandsToTheScanThread) {
  const LineConfig config = default_line_config();
  LineController controller(config);
  LineControllerLogic logic(controller);
  InputImage in{};
  in.estop_ok = true;
  for (DriveFeedback& drive : in.drives) drive.ready = true;
  OutputImage out{};
  std::thread([&] { logic.request_start(); }).join();
  in.time_ns = 10'000'000;
  logic.update(in, out);
  in.time_ns += 10'000'000;
  logic.update(in, out);
  EXPECT_EQ(controller.state(), LineState::kRunning);
  std::thread([&] { logic.request_stop(); }).join();
  in.time_ns += 10'000'000;
  logic.update(in, out);
  EXPECT_NE(controller.state(), LineState::kRunning);
}

// What a recorder keeps of each scan; the requests are what matter here.
class RequestLog final : public ScanRecorder {
 public:
  void on_scan(std::uint64_t scan, const InputImage& in, const OutputImage& out) override {
    scans.push_back(scan);
    starts.push_back(in.start_request);
    stops.push_back(in.stop_request);
    states.push_back(out.state);
  }
  std::vector<std::uint64_t> scans;
  std::vector<bool> starts;
  std::vector<bool> stops;
  std::vector<LineState> states;
};

// The operator's requests ride in the scan's input image, so a recorder that keeps only the
// images (linectl control --record) has them for the replay: the start in the first scan
// after it was asked for, then no more, and the stop likewise.
TEST(LineControllerLogic, RecordedImagesCarryTheOperatorsRequests) {
  const LineConfig config = default_line_config();
  LineController controller(config);
  LineControllerLogic logic(controller);
  RequestLog log;
  logic.attach_recorder(&log);
  InputImage in{};
  in.estop_ok = true;
  for (DriveFeedback& drive : in.drives) drive.ready = true;
  OutputImage out{};
  const auto scan = [&] {
    in.time_ns += 10'000'000;
    logic.update(in, out);
    logic.after_scan(in, out, ScanTimingSample{});
  };
  logic.request_start();
  scan();
  scan();
  logic.request_stop();
  scan();
  EXPECT_EQ(log.scans, (std::vector<std::uint64_t>{0, 1, 2}));
  EXPECT_EQ(log.starts, (std::vector<bool>{true, false, false}));
  EXPECT_EQ(log.stops, (std::vector<bool>{false, false, true}));
  EXPECT_EQ(log.states[1], LineState::kRunning);
  EXPECT_FALSE(in.start_request);  // the caller's image is left as it was
  // The same images without the logic's flags, straight into a fresh controller, decide the
  // same: the replay's situation.
  LineController replayed(config);
  InputImage again{};
  again.estop_ok = true;
  for (DriveFeedback& drive : again.drives) drive.ready = true;
  for (std::size_t i = 0; i < log.scans.size(); ++i) {
    again.time_ns = static_cast<std::int64_t>(i + 1) * 10'000'000;
    again.start_request = log.starts[i];
    again.stop_request = log.stops[i];
    OutputImage replayed_out{};
    replayed.update(again, replayed_out);
    EXPECT_EQ(replayed_out.state, log.states[i]) << "scan " << i;
  }
}

}  // namespace
}  // namespace fl
