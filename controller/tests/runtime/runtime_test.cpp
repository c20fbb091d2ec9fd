#include "fl/controller/runtime.hpp"

#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>
#include <sys/mman.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>

#include "runtime_test_support.hpp"

namespace fl {
namespace {

using test::CopyingIo;
using test::EchoLogic;
using test::monotonic_now_ns;
using test::sleep_for_ns;

constexpr std::int64_t kMs = 1'000'000;
// Timing bounds are generous on purpose: CI machines are loaded, and these tests check the
// schedule's logic, not the machine's latency (bench/jitter measures that).
constexpr double kMeanPeriodToleranceNs = 1.0 * kMs;
// Tests that count overruns exactly ask for SCHED_FIFO, so that other processes on a loaded
// machine cannot add overruns of their own; where it is refused (no root or CAP_SYS_NICE)
// the runtime logs that and runs under SCHED_OTHER.
constexpr int kTestFifoPriority = 10;
// Tests of the schedule, the stop paths and the set-up are not tests of the fault limits: a
// loaded CI machine stalls a 2 ms scan for 20 ms or more (three overruns in a row were seen),
// so they switch both fault sources off and the fault tests below keep them.
constexpr std::uint32_t kNoOverrunFault = 0;
constexpr std::uint32_t kNoWatchdog = 0;

// Sleeps for `sleep_ns` on the chosen scans (0-based) and counts the overruns it is told of.
class SleepyLogic final : public ScanLogic {
 public:
  static constexpr std::size_t kMaxOverruns = 64;

  SleepyLogic(std::int64_t sleep_ns, std::initializer_list<std::uint64_t> sleepy_scans,
              std::uint64_t sleep_from_scan = UINT64_MAX)
      : sleep_ns_(sleep_ns), sleep_from_scan_(sleep_from_scan) {
    for (const std::uint64_t scan : sleepy_scans) sleepy_scans_[sleepy_count_++] = scan;
  }

  void update(const InputImage& /*in*/, OutputImage& out) override {
    const std::uint64_t scan = updates_++;
    scan_thread_ = std::this_thread::get_id();
    bool sleep = scan >= sleep_from_scan_;
    for (std::size_t i = 0; i < sleepy_count_; ++i) sleep = sleep || sleepy_scans_[i] == scan;
    if (sleep) sleep_for_ns(sleep_ns_);
    out.drives[0].enable = true;
  }

  void on_overrun(const OverrunInfo& info) override {
    if (overrun_count_ < kMaxOverruns) {
      overrun_infos_[overrun_count_] = info;
      overrun_scans_[overrun_count_] = updates_ - 1;  // the scan that just overran
    }
    ++overrun_count_;
  }

  std::uint64_t updates_ = 0;
  std::size_t overrun_count_ = 0;
  std::array<OverrunInfo, kMaxOverruns> overrun_infos_{};
  std::array<std::uint64_t, kMaxOverruns> overrun_scans_{};
  std::thread::id scan_thread_;

 private:
  std::int64_t sleep_ns_;
  std::uint64_t sleep_from_scan_;
  std::array<std::uint64_t, 8> sleepy_scans_{};
  std::size_t sleepy_count_ = 0;
};

// What a fault callback saw; the callback may run on another thread.
struct FaultRecord {
  std::atomic<int> calls{0};
  std::atomic<RuntimeFault> fault{RuntimeFault::kNone};
  std::atomic<std::int64_t> at_ns{0};
  std::thread::id thread;
  OutputImage safe_image{};

  std::function<void(RuntimeFault)> callback() {
    return [this](RuntimeFault raised) {
      thread = std::this_thread::get_id();
      safe_image = make_safe_output_image();
      at_ns.store(monotonic_now_ns());
      fault.store(raised);
      calls.fetch_add(1);
    };
  }
};

TEST(ScanRuntime, ScansOnAnAbsoluteGridAndPassesTheScheduledTime) {
  constexpr std::int64_t kPeriodNs = 5 * kMs;
  constexpr std::size_t kScans = 200;
  CopyingIo io;
  EchoLogic logic;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = kPeriodNs,
                                     .max_scans = kScans,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = kNoWatchdog});
  const std::int64_t started_ns = monotonic_now_ns();
  ASSERT_TRUE(runtime.run().started);

  ASSERT_EQ(io.reads(), kScans);
  ASSERT_EQ(io.writes(), kScans);
  EXPECT_EQ(runtime.scans(), kScans);
  EXPECT_EQ(runtime.fault(), RuntimeFault::kNone);
  EXPECT_GE(io.now_ns(0), started_ns + kPeriodNs);  // first scan one period after start
  for (std::size_t scan = 0; scan < kScans; ++scan) {
    EXPECT_EQ(io.preset_time_ns(scan), io.now_ns(scan));  // in.time_ns is the scheduled time
    EXPECT_EQ((io.now_ns(scan) - io.now_ns(0)) % kPeriodNs, 0) << "scan " << scan;
    EXPECT_GE(io.read_at_ns(scan), io.now_ns(scan));  // never wakes before its time
    if (scan > 0) {
      EXPECT_GT(io.now_ns(scan), io.now_ns(scan - 1));
    }
  }

  // Only an overrun may take a scan off consecutive grid points, and then it is counted.
  const CycleStatsSummary stats = runtime.stats().summary();
  const std::int64_t scheduled_span_ns = io.now_ns(kScans - 1) - io.now_ns(0);
  EXPECT_EQ(scheduled_span_ns,
            static_cast<std::int64_t>(kScans - 1 + stats.missed_periods) * kPeriodNs);
  const double measured_mean_period_ns =
      static_cast<double>(io.read_at_ns(kScans - 1) - io.read_at_ns(0)) / (kScans - 1);
  const double scheduled_mean_period_ns = static_cast<double>(scheduled_span_ns) / (kScans - 1);
  EXPECT_NEAR(measured_mean_period_ns, scheduled_mean_period_ns, kMeanPeriodToleranceNs);
  if (stats.missed_periods == 0) {
    EXPECT_EQ(scheduled_mean_period_ns, kPeriodNs);
  }

  EXPECT_EQ(stats.scans, kScans);
  EXPECT_EQ(stats.wakeup_latency.count, kScans);
  EXPECT_EQ(stats.compute.count, kScans);
  EXPECT_GE(stats.wakeup_latency.min_ns, 0);
  EXPECT_LE(stats.wakeup_latency.p50_ns, stats.wakeup_latency.p99_ns);
  EXPECT_LE(stats.wakeup_latency.p99_ns, stats.wakeup_latency.max_ns);
  EXPECT_TRUE(io.activated());
  EXPECT_TRUE(io.deactivated());
  EXPECT_FALSE(runtime.running());
}

// With a relative sleep the period would grow by the compute time (5 + 2 ms); on the
// absolute schedule it stays at 5 ms.
TEST(ScanRuntime, ComputeTimeDoesNotStretchThePeriod) {
  constexpr std::int64_t kPeriodNs = 5 * kMs;
  constexpr std::size_t kScans = 100;
  CopyingIo io;
  SleepyLogic logic(2 * kMs, {}, 0);
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = kPeriodNs,
                                     .max_scans = kScans,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = kNoWatchdog});
  ASSERT_TRUE(runtime.run().started);

  ASSERT_EQ(io.reads(), kScans);
  const CycleStatsSummary stats = runtime.stats().summary();
  EXPECT_GE(stats.compute.min_ns, 2 * kMs);
  const double measured_mean_period_ns =
      static_cast<double>(io.read_at_ns(kScans - 1) - io.read_at_ns(0)) / (kScans - 1);
  const double expected_mean_period_ns =
      static_cast<double>(kScans - 1 + stats.missed_periods) * kPeriodNs / (kScans - 1);
  EXPECT_NEAR(measured_mean_period_ns, expected_mean_period_ns, kMeanPeriodToleranceNs);
  EXPECT_LE(stats.missed_periods, kScans / 10) << "machine too loaded for this test";
}

// Scans 9, 19 and 29 take 1.25 periods: exactly three overruns, each skipping one period
// without a catch-up scan, and the logic told of each.
TEST(ScanRuntime, CountsOverrunsExactlyAndSkipsMissedPeriods) {
  constexpr std::int64_t kPeriodNs = 20 * kMs;
  constexpr std::size_t kScans = 40;
  // A virtual machine's host can stall a scan by a period by itself (seen once in a CI
  // rehearsal on a loaded 2-core VM: a fourth overrun). Such a run says nothing about the
  // counting, so the scenario runs again, at most three times, and the checks below hold for
  // the first run in which only the sleepy scans overran (or for the last).
  constexpr int kAttempts = 3;
  std::unique_ptr<CopyingIo> io_owner;
  std::unique_ptr<SleepyLogic> logic_owner;
  std::unique_ptr<FaultRecord> faults_owner;
  std::unique_ptr<ScanRuntime> runtime_owner;
  for (int attempt = 1; attempt <= kAttempts; ++attempt) {
    runtime_owner.reset();
    io_owner = std::make_unique<CopyingIo>();
    logic_owner =
        std::make_unique<SleepyLogic>(25 * kMs, std::initializer_list<std::uint64_t>{9, 19, 29});
    faults_owner = std::make_unique<FaultRecord>();
    runtime_owner =
        std::make_unique<ScanRuntime>(*io_owner, *logic_owner,
                                      RuntimeOptions{.period_ns = kPeriodNs,
                                                     .fifo_priority = kTestFifoPriority,
                                                     .max_scans = kScans,
                                                     .overrun_fault_consecutive = 2,
                                                     .on_fault = faults_owner->callback()});
    ASSERT_TRUE(runtime_owner->run().started);
    const SleepyLogic& finished = *logic_owner;
    const bool only_the_sleepy_scans =
        finished.overrun_count_ == 3U && finished.overrun_scans_[0] == 9U &&
        finished.overrun_scans_[1] == 19U && finished.overrun_scans_[2] == 29U;
    if (only_the_sleepy_scans) break;
    std::cerr << "attempt " << attempt << ": " << finished.overrun_count_
              << " overruns where scans 9, 19 and 29 made 3"
              << (attempt < kAttempts ? "; trying again\n" : "\n");
  }
  CopyingIo& io = *io_owner;
  SleepyLogic& logic = *logic_owner;
  FaultRecord& faults = *faults_owner;
  ScanRuntime& runtime = *runtime_owner;

  ASSERT_EQ(io.reads(), kScans);
  EXPECT_EQ(runtime.overruns(), 3U);
  EXPECT_EQ(runtime.stats().overruns(), 3U);
  EXPECT_EQ(runtime.stats().missed_periods(), 3U);
  EXPECT_EQ(runtime.stats().summary().max_consecutive_overruns, 1U);
  EXPECT_EQ(runtime.fault(), RuntimeFault::kNone);  // never two in a row
  EXPECT_EQ(faults.calls.load(), 0);
  ASSERT_EQ(logic.overrun_count_, 3U);
  for (std::size_t i = 0; i < 3; ++i) {
    const std::uint64_t overrun_scan = 9 + 10 * i;
    EXPECT_EQ(logic.overrun_scans_[i], overrun_scan);
    const OverrunInfo& info = logic.overrun_infos_[i];
    EXPECT_EQ(info.scheduled_ns, io.now_ns(overrun_scan));
    EXPECT_GT(info.finished_ns, info.scheduled_ns + kPeriodNs);
    EXPECT_EQ(info.missed_periods, 1U);
    EXPECT_EQ(info.consecutive, 1U);
    EXPECT_EQ(info.total_overruns, i + 1);
  }
  // The logic's clock jumps by two periods after an overrun and by one otherwise.
  for (std::size_t scan = 1; scan < kScans; ++scan) {
    const bool after_overrun = scan == 10 || scan == 20 || scan == 30;
    EXPECT_EQ(io.now_ns(scan) - io.now_ns(scan - 1), (after_overrun ? 2 : 1) * kPeriodNs)
        << "scan " << scan;
  }
}

TEST(ScanRuntime, ConsecutiveOverrunsRaiseTheFaultOnceAndStop) {
  constexpr std::int64_t kPeriodNs = 10 * kMs;
  CopyingIo io;
  SleepyLogic logic(kPeriodNs + kPeriodNs / 4, {}, 4);  // every scan from the fifth overruns
  FaultRecord faults;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = kPeriodNs,
                                     .fifo_priority = kTestFifoPriority,
                                     .max_scans = 100,
                                     .overrun_fault_consecutive = 3,
                                     .on_fault = faults.callback()});
  ASSERT_TRUE(runtime.run().started);

  EXPECT_EQ(runtime.fault(), RuntimeFault::kConsecutiveOverruns);
  EXPECT_EQ(faults.calls.load(), 1);
  EXPECT_EQ(faults.fault.load(), RuntimeFault::kConsecutiveOverruns);
  EXPECT_EQ(faults.thread, logic.scan_thread_);  // raised by the scan thread itself
  EXPECT_EQ(runtime.scans(), 7U);                // 4 on time, then 3 overruns
  EXPECT_EQ(io.writes(), 7U);
  EXPECT_EQ(runtime.overruns(), 3U);
  EXPECT_EQ(runtime.stats().summary().max_consecutive_overruns, 3U);
  EXPECT_EQ(faults.safe_image.state, LineState::kFault);
  EXPECT_FALSE(runtime.running());
}

// The tenth scan blocks for 60 periods; the watchdog must act long before it returns, from
// its own thread, and the scan must not write its outputs afterwards. The 50 ms limit stays
// above the scheduling stalls a loaded 2-core CI machine shows (up to ~22 ms in the soak).
TEST(ScanRuntime, WatchdogCatchesAStalledScan) {
  constexpr std::int64_t kPeriodNs = 5 * kMs;
  constexpr std::uint32_t kWatchdogPeriods = 10;
  constexpr std::int64_t kBlockNs = 60 * kPeriodNs;

  class BlockingLogic final : public ScanLogic {
   public:
    void update(const InputImage& /*in*/, OutputImage& /*out*/) override {
      scan_thread = std::this_thread::get_id();
      if (updates++ == 9) {
        blocked_at_ns = monotonic_now_ns();
        sleep_for_ns(kBlockNs);
        unblocked_at_ns = monotonic_now_ns();
      }
    }
    std::uint64_t updates = 0;
    std::int64_t blocked_at_ns = 0;
    std::int64_t unblocked_at_ns = 0;
    std::thread::id scan_thread;
  } logic;

  CopyingIo io;
  FaultRecord faults;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = kPeriodNs,
                                     .fifo_priority = kTestFifoPriority,
                                     .watchdog_periods = kWatchdogPeriods,
                                     .on_fault = faults.callback()});
  ASSERT_TRUE(runtime.run().started);  // no scan limit: only the fault ends this run

  EXPECT_EQ(runtime.fault(), RuntimeFault::kScanStalled);
  EXPECT_EQ(faults.calls.load(), 1);
  EXPECT_NE(faults.thread, logic.scan_thread);
  // The heartbeat is taken at wake-up, a little before the logic blocked.
  EXPECT_GE(faults.at_ns.load() - logic.blocked_at_ns, (kWatchdogPeriods - 1) * kPeriodNs);
  EXPECT_LT(faults.at_ns.load(), logic.unblocked_at_ns);
  EXPECT_EQ(logic.updates, 10U);
  EXPECT_EQ(io.writes(), 9U);  // the stalled scan wrote nothing after the safe state
  EXPECT_EQ(runtime.scans(), 9U);
  EXPECT_TRUE(io.deactivated());
}

TEST(ScanRuntime, WatchdogStaysQuietWhileScansRunAndAfterTheEnd) {
  CopyingIo io;
  EchoLogic logic;
  FaultRecord faults;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 2 * kMs,
                                     .max_scans = 50,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = 25,  // 50 ms: above CI load stalls
                                     .on_fault = faults.callback()});
  ASSERT_TRUE(runtime.start().started);
  // Leave wait() late, three watchdog limits: a finished scan thread is not a stalled one.
  while (runtime.running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  runtime.wait();
  EXPECT_EQ(runtime.fault(), RuntimeFault::kNone);
  EXPECT_EQ(faults.calls.load(), 0);
}

// A log sink that stalls on the start-up line, as a slow journal or a machine under qemu does:
// the time start() spends before it releases the scan thread.
class SlowStartSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  explicit SlowStartSink(std::int64_t stall_ns) : stall_ns_(stall_ns) {}

 protected:
  void sink_it_(const spdlog::details::log_msg& message) override {
    const std::string_view text(message.payload.data(), message.payload.size());
    if (text.find("scan runtime started") != std::string_view::npos) sleep_for_ns(stall_ns_);
  }
  void flush_() override {}

 private:
  std::int64_t stall_ns_;
};

TEST(ScanRuntime, WatchdogDoesNotCountASlowStartUpAsAStall) {
  // 50 ms at 2 ms periods: above the scheduling stalls of a loaded 2-core CI machine, which
  // made a 6 ms limit fault this test mid-run once.
  constexpr int kWatchdogPeriods = 25;
  // start() stalls 4 watchdog limits before it releases the scan: before the fix the
  // watchdog, already running, faulted the runtime "after 0 scans" (seen under qemu at boot).
  const std::shared_ptr<spdlog::logger> previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>(
      "slow_start", std::make_shared<SlowStartSink>(4 * kWatchdogPeriods * 2 * kMs)));
  CopyingIo io;
  EchoLogic logic;
  FaultRecord faults;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 2 * kMs,
                                     .max_scans = 20,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = kWatchdogPeriods,
                                     .on_fault = faults.callback()});
  const RealtimeSetup setup = runtime.start();
  spdlog::set_default_logger(previous);
  ASSERT_TRUE(setup.started);
  runtime.wait();
  EXPECT_EQ(runtime.fault(), RuntimeFault::kNone);
  EXPECT_EQ(faults.calls.load(), 0);
  EXPECT_EQ(runtime.stats().summary().scans, 20U);
}

TEST(ScanRuntime, StopRequestEndsTheRun) {
  CopyingIo io;
  EchoLogic logic;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 2 * kMs,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = kNoWatchdog});
  ASSERT_TRUE(runtime.start().started);
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (runtime.scans() < 5 && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_GE(runtime.scans(), 5U);
  runtime.request_stop();
  runtime.wait();
  EXPECT_FALSE(runtime.running());
  EXPECT_EQ(runtime.fault(), RuntimeFault::kNone);
  const std::uint64_t scans_at_stop = runtime.scans();
  std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(runtime.scans(), scans_at_stop);
  EXPECT_EQ(io.writes(), scans_at_stop);
  EXPECT_TRUE(io.deactivated());
}

TEST(ScanRuntime, StopRequestedBeforeStartRunsNoScan) {
  CopyingIo io;
  EchoLogic logic;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 2 * kMs,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = kNoWatchdog});
  runtime.request_stop();
  ASSERT_TRUE(runtime.run().started);
  EXPECT_EQ(runtime.scans(), 0U);
  EXPECT_EQ(io.reads(), 0U);
}

TEST(ScanRuntime, DestructorStopsARunningRuntime) {
  CopyingIo io;
  EchoLogic logic;
  {
    ScanRuntime runtime(io, logic,
                        RuntimeOptions{.period_ns = 2 * kMs,
                                       .overrun_fault_consecutive = kNoOverrunFault,
                                       .watchdog_periods = kNoWatchdog});
    ASSERT_TRUE(runtime.start().started);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_TRUE(io.deactivated());
}

// Scans scheduled before start + duration run: 100 ms at 10 ms is ten grid points.
TEST(ScanRuntime, DurationBoundsTheSchedule) {
  CopyingIo io;
  EchoLogic logic;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 10 * kMs,
                                     .duration_ns = 100 * kMs,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = kNoWatchdog});
  ASSERT_TRUE(runtime.run().started);
  EXPECT_EQ(runtime.scans() + runtime.stats().missed_periods(), 10U);
  EXPECT_LT(io.now_ns(io.recorded() - 1) - io.now_ns(0), 100 * kMs);
}

TEST(ScanRuntime, ExceptionInTheScanFaultsTheRuntime) {
  class ThrowingLogic final : public ScanLogic {
   public:
    void update(const InputImage& /*in*/, OutputImage& /*out*/) override {
      if (++updates == 3) throw std::runtime_error("logic bug");
    }
    int updates = 0;
  } logic;
  CopyingIo io;
  FaultRecord faults;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 2 * kMs,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = kNoWatchdog,
                                     .on_fault = faults.callback()});
  ASSERT_TRUE(runtime.run().started);
  EXPECT_EQ(runtime.fault(), RuntimeFault::kScanException);
  EXPECT_EQ(faults.calls.load(), 1);
  EXPECT_EQ(io.writes(), 2U);
  EXPECT_TRUE(io.deactivated());
}

TEST(ScanRuntime, RequiredRealtimeSetupThatFailsDoesNotStart) {
  CopyingIo io;
  EchoLogic logic;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.cpu = CPU_SETSIZE - 1,  // no machine here has it
                                     .realtime_required = true,
                                     .max_scans = 3});
  const RealtimeSetup setup = runtime.run();
  EXPECT_FALSE(setup.started);
  EXPECT_FALSE(setup.affinity_applied);
  EXPECT_NE(setup.error.find("CPU " + std::to_string(CPU_SETSIZE - 1)), std::string::npos)
      << setup.error;
  EXPECT_FALSE(io.activated());
  EXPECT_EQ(io.reads(), 0U);
  EXPECT_FALSE(runtime.running());
}

TEST(ScanRuntime, OptionalRealtimeSetupThatFailsRunsAnyway) {
  CopyingIo io;
  EchoLogic logic;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 2 * kMs,
                                     .cpu = CPU_SETSIZE - 1,
                                     .max_scans = 3,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = kNoWatchdog});
  const RealtimeSetup setup = runtime.run();
  EXPECT_TRUE(setup.started);
  EXPECT_FALSE(setup.affinity_applied);
  EXPECT_FALSE(setup.error.empty());
  EXPECT_EQ(runtime.scans(), 3U);
}

// Needs root or CAP_SYS_NICE and CAP_IPC_LOCK; skipped where the setup is refused.
TEST(ScanRuntime, AppliesFifoPriorityMemoryLockAndAffinityWhenPermitted) {
  class PolicyProbe final : public ScanLogic {
   public:
    void update(const InputImage& /*in*/, OutputImage& /*out*/) override {
      sched_param param{};
      pthread_getschedparam(pthread_self(), &policy, &param);
      priority = param.sched_priority;
      cpu = sched_getcpu();
    }
    int policy = -1;
    int priority = -1;
    int cpu = -1;
  } logic;
  CopyingIo io;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 2 * kMs,
                                     .fifo_priority = 10,
                                     .lock_memory = true,
                                     .cpu = 0,
                                     .cpu_dma_latency_us = 0,
                                     .max_scans = 5});
  const RealtimeSetup setup = runtime.run();
  munlockall();  // leave the rest of the test binary as it was
  ASSERT_TRUE(setup.started);
  if (!setup.error.empty()) GTEST_SKIP() << "real-time setup refused here: " << setup.error;
  EXPECT_TRUE(setup.fifo_applied);
  EXPECT_TRUE(setup.memory_locked);
  EXPECT_TRUE(setup.affinity_applied);
  EXPECT_TRUE(setup.dma_latency_applied);
  EXPECT_EQ(logic.policy, SCHED_FIFO);
  EXPECT_EQ(logic.priority, 10);
  EXPECT_EQ(logic.cpu, 0);
  EXPECT_EQ(runtime.scans(), 5U);
}

// The kernel's count of this process's locked memory (VmLck in /proc/self/status), in kB.
long locked_kib() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmLck:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

// A caller that brings devices up between prepare() and start() (linectl control's CANopen
// start-up) finds memory already locked when it starts, and start() keeps that result
// instead of locking again.
TEST(ScanRuntime, PrepareLocksMemoryBeforeTheScanStarts) {
#if defined(__SANITIZE_ADDRESS__)
  // The sanitizer runtime intercepts mlockall as a no-op that reports success (locking its
  // shadow memory would take the machine's RAM), so the kernel shows nothing to check.
  GTEST_SKIP() << "mlockall is a no-op under AddressSanitizer";
#endif
  CopyingIo io;
  EchoLogic logic;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 2 * kMs, .lock_memory = true, .max_scans = 3});
  const RealtimeSetup prepared = runtime.prepare();
  const long locked_before_start_kib = locked_kib();
  if (!prepared.memory_locked) {
    munlockall();
    GTEST_SKIP() << "mlockall refused here: " << prepared.error;
  }
  EXPECT_GT(locked_before_start_kib, 0) << "prepare() reported a lock the kernel does not show";
  EXPECT_EQ(runtime.scans(), 0U) << "prepare() must not start scanning";
  EXPECT_TRUE(runtime.prepare().memory_locked);  // a second call returns the first result
  const RealtimeSetup setup = runtime.run();
  munlockall();  // leave the rest of the test binary as it was
  EXPECT_TRUE(setup.started);
  EXPECT_TRUE(setup.memory_locked);
  EXPECT_EQ(runtime.scans(), 3U);
}

TEST(ScanRuntime, RejectsInvalidOptions) {
  CopyingIo io;
  EchoLogic logic;
  EXPECT_THROW(ScanRuntime(io, logic, RuntimeOptions{.period_ns = 0}), std::invalid_argument);
  EXPECT_THROW(ScanRuntime(io, logic, RuntimeOptions{.fifo_priority = 100}), std::invalid_argument);
  EXPECT_THROW(ScanRuntime(io, logic, RuntimeOptions{.cpu = -2}), std::invalid_argument);
  EXPECT_THROW(ScanRuntime(io, logic, RuntimeOptions{.cpu_dma_latency_us = -2}),
               std::invalid_argument);
  EXPECT_THROW(ScanRuntime(io, logic, RuntimeOptions{.duration_ns = -1}), std::invalid_argument);
  EXPECT_THROW(ScanRuntime(io, logic, RuntimeOptions{.stats_bin_width_ns = 0}),
               std::invalid_argument);
}

TEST(ScanRuntime, StartsOnlyOnce) {
  CopyingIo io;
  EchoLogic logic;
  ScanRuntime runtime(io, logic,
                      RuntimeOptions{.period_ns = 2 * kMs,
                                     .max_scans = 2,
                                     .overrun_fault_consecutive = kNoOverrunFault,
                                     .watchdog_periods = kNoWatchdog});
  ASSERT_TRUE(runtime.run().started);
  EXPECT_THROW(runtime.start(), std::logic_error);
}

TEST(SafeOutputImage, DisablesEveryDriveAndParksTheActuators) {
  const OutputImage safe = make_safe_output_image();
  for (const DriveCommand& drive : safe.drives) {
    EXPECT_FALSE(drive.enable);
    EXPECT_EQ(drive.speed_mps, 0.0F);
  }
  EXPECT_EQ(safe.hopper_opening_mm, 0.0F);
  EXPECT_EQ(safe.leveller_speed_rpm, 0.0F);
  EXPECT_FALSE(safe.flip_plate1_flip);
  EXPECT_FALSE(safe.flip_plate2_flip);
  EXPECT_FALSE(safe.centring_stroke);
  EXPECT_FALSE(safe.squeeze_roller_down);
  EXPECT_FALSE(safe.final_reject);
  EXPECT_EQ(safe.state, LineState::kFault);
}

}  // namespace
}  // namespace fl
