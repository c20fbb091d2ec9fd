// The real-time scan runtime: a dedicated thread runs one scan (read inputs, update the
// logic, write outputs) per period on an absolute CLOCK_MONOTONIC schedule, measures wake-up
// latency and compute time, detects overruns, and a watchdog thread takes the outputs to a
// safe state when the scan thread stalls. The interfaces follow ros2_control: hardware
// (drivers, plants) implements ProcessIo, the controller implements ScanLogic.
//
// Inside the cycle (ProcessIo::read/write, ScanLogic::update/on_overrun/after_scan and the
// runtime's own bookkeeping) nothing allocates, locks or blocks; controller/tests/runtime
// checks it by counting operator new and mutex locks on the scan thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <latch>
#include <optional>
#include <stop_token>
#include <string>
#include <thread>

#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/process_image.hpp"

namespace fl {

class LineController;
class LineStatusPublisher;

// The hardware side of a scan: field bus drivers, the DDS bridge, or a plant in simulation.
class ProcessIo {
 public:
  ProcessIo() = default;
  ProcessIo(const ProcessIo&) = delete;
  ProcessIo& operator=(const ProcessIo&) = delete;
  virtual ~ProcessIo() = default;

  // Called on the scan thread before the first scan and after the last one, outside the
  // cycle: may allocate, lock and block (open a bus, bind thread-local state).
  virtual void activate() {}
  virtual void deactivate() {}

  // Real-time: no allocation, lock or blocking I/O. `now_ns` is the scan's scheduled time
  // on CLOCK_MONOTONIC (not the measured wake-up, so the logic's time is deterministic);
  // in.time_ns already holds it when read() is called.
  virtual void read(std::int64_t now_ns, InputImage& in) = 0;
  virtual void write(const OutputImage& out) = 0;

  // When the previous write()'s commands took effect at the devices, on CLOCK_MONOTONIC, as
  // far as the transport can tell once read() has run (a field bus: its SYNC on the wire);
  // nullopt where it cannot. Real-time.
  [[nodiscard]] virtual std::optional<std::int64_t> last_write_applied_ns() const {
    return std::nullopt;
  }
};

// One overrunning scan, as ScanLogic::on_overrun sees it.
struct OverrunInfo {
  std::int64_t scheduled_ns = 0;     // scheduled wake-up of the scan that overran
  std::int64_t finished_ns = 0;      // when its write() returned
  std::uint64_t missed_periods = 0;  // wake-ups skipped to get back on the schedule
  std::uint32_t consecutive = 0;     // overrunning scans in a row, this one included
  std::uint64_t total_overruns = 0;  // since start
};

// The logic side of a scan.
class ScanLogic {
 public:
  ScanLogic() = default;
  ScanLogic(const ScanLogic&) = delete;
  ScanLogic& operator=(const ScanLogic&) = delete;
  virtual ~ScanLogic() = default;

  // Real-time: no allocation, lock or blocking I/O.
  virtual void update(const InputImage& in, OutputImage& out) = 0;

  // Called on the scan thread right after a scan that finished after the next deadline and
  // before the next update(). Real-time. The skipped periods also show in in.time_ns, which
  // jumps by (missed_periods + 1) periods.
  virtual void on_overrun(const OverrunInfo& /*info*/) {}

  // Called on the scan thread after every scan's write() with the images and the scan's
  // measured timing (for status snapshots). Real-time.
  virtual void after_scan(const InputImage& /*in*/, const OutputImage& /*out*/,
                          const ScanTimingSample& /*timing*/) {}
};

// Receives every scan's images as the line's logic saw them, the operator's requests
// included, on the scan thread after the scan: real-time, so an implementation copies into
// preallocated memory and writes elsewhere (linectl control --record).
class ScanRecorder {
 public:
  ScanRecorder() = default;
  ScanRecorder(const ScanRecorder&) = delete;
  ScanRecorder& operator=(const ScanRecorder&) = delete;
  virtual ~ScanRecorder() = default;
  virtual void on_scan(std::uint64_t scan, const InputImage& in, const OutputImage& out) = 0;
};

// Adapter from the line's logic to the runtime. LineController has no overrun input of its
// own; it sees the skipped periods as a jump of in.time_ns, and the count is kept here.
// LineController's operator commands are not thread-safe; the ones here are: they set a flag
// that the scan thread puts into the next scan's input image (start_request, stop_request,
// fault_reset_request, as the line's buttons would), so a recording of the images alone
// replays the operator's actions too.
class LineControllerLogic final : public ScanLogic {
 public:
  explicit LineControllerLogic(LineController& controller) : controller_(controller) {}

  void update(const InputImage& in, OutputImage& out) override;
  void on_overrun(const OverrunInfo& info) override;
  void after_scan(const InputImage& in, const OutputImage& out,
                  const ScanTimingSample& timing) override;

  // Publish a LineStatus snapshot after every scan (the HMI reads them). Call before the
  // runtime starts; the publisher must outlive the runtime.
  void attach_status(LineStatusPublisher* publisher) noexcept { status_ = publisher; }
  // Hand every scan's images to `recorder` (same rules as attach_status).
  void attach_recorder(ScanRecorder* recorder) noexcept { recorder_ = recorder; }

  // Any thread.
  void request_start() noexcept { start_requested_.store(true, std::memory_order_release); }
  void request_stop() noexcept { stop_requested_.store(true, std::memory_order_release); }
  void acknowledge_faults() noexcept { ack_requested_.store(true, std::memory_order_release); }
  [[nodiscard]] std::uint64_t overruns_seen() const noexcept {
    return overruns_seen_.load(std::memory_order_relaxed);
  }

  // The controller itself: touch it only while the runtime is not running.
  [[nodiscard]] LineController& controller() noexcept { return controller_; }

 private:
  LineController& controller_;
  LineStatusPublisher* status_ = nullptr;
  ScanRecorder* recorder_ = nullptr;
  InputImage applied_{};  // the last scan's input with the operator's requests in it
  std::uint64_t scans_ = 0;
  std::atomic<bool> start_requested_{false};
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> ack_requested_{false};
  std::atomic<std::uint64_t> overruns_seen_{0};
};

enum class RuntimeFault : std::uint8_t {
  kNone,
  kConsecutiveOverruns,  // RuntimeOptions::overrun_fault_consecutive overruns in a row
  kScanStalled,          // no scan started for RuntimeOptions::watchdog_periods periods
  kScanException,        // activate, read, update or write threw
};
const char* to_string(RuntimeFault fault);

// The output image a fault callback should write: every drive disabled at zero speed, all
// actuators released or parked, hopper closed, state kFault.
OutputImage make_safe_output_image();

struct RuntimeOptions {
  std::int64_t period_ns = 10'000'000;  // 10 ms
  int fifo_priority = 0;                // 1..99: SCHED_FIFO for the scan thread; 0: SCHED_OTHER
  bool lock_memory = false;             // mlockall(MCL_CURRENT | MCL_FUTURE)
  int cpu = -1;                         // pin the scan thread to this CPU; -1: no pinning
  // >= 0: hold /dev/cpu_dma_latency at this many us while the runtime exists, which keeps
  // the CPUs out of deep idle states (cyclictest does the same with 0); -1: leave it alone.
  int cpu_dma_latency_us = -1;
  // When true, start() refuses to run if the priority, memory lock, affinity or DMA latency
  // asked for cannot be applied; when false it logs the error and runs without it.
  bool realtime_required = false;

  std::int64_t duration_ns = 0;  // run scans scheduled before start + duration; 0: no limit
  std::uint64_t max_scans = 0;   // stop after this many scans; 0: no limit

  // Consecutive overrunning scans that raise RuntimeFault::kConsecutiveOverruns; 0: never.
  std::uint32_t overrun_fault_consecutive = 3;
  // Periods without a scan starting before the watchdog raises kScanStalled; 0: no watchdog.
  std::uint32_t watchdog_periods = 10;
  // Called once, on the first fault, from the thread that detected it: the scan thread
  // after it left the cycle (kConsecutiveOverruns, kScanException), or the watchdog thread while
  // the scan thread may still be stuck inside read/update/write (kScanStalled), so it must use a
  // path that is safe against that (e.g. a driver's own safe-stop). The runtime writes no
  // further outputs after a fault and stops scanning.
  std::function<void(RuntimeFault)> on_fault{};

  // Histogram resolution and range of the wake-up latency and compute-time statistics.
  std::int64_t stats_bin_width_ns = DurationHistogram::kDefaultBinWidthNs;
  std::int64_t stats_range_ns = DurationHistogram::kDefaultRangeNs;
};

// What start() could apply of the real-time setup.
struct RealtimeSetup {
  bool started = false;
  bool fifo_applied = false;
  bool memory_locked = false;
  bool affinity_applied = false;
  bool dma_latency_applied = false;
  std::string error;  // what was asked for and could not be applied, and why; empty if none
};

class ScanRuntime {
 public:
  // Throws std::invalid_argument on invalid options. Allocates everything the cycle needs.
  ScanRuntime(ProcessIo& io, ScanLogic& logic, RuntimeOptions options = {});
  ~ScanRuntime();  // requests a stop and joins both threads
  ScanRuntime(const ScanRuntime&) = delete;
  ScanRuntime& operator=(const ScanRuntime&) = delete;

  // The process-wide part of the real-time setup, once: locks memory and holds the CPU
  // latency request. Locking a large process can take long (0.7 s for 400 MB in an emulated
  // guest), so a caller that brings devices up before the first scan (a CANopen start-up
  // that enables drives, whose command timeout then runs) prepares first. Later calls return
  // the first call's result.
  RealtimeSetup prepare();
  // Prepares (if not done), starts the scan and watchdog threads and returns the whole setup.
  // The first scan is scheduled one period after the call. A runtime starts once
  // (std::logic_error on a second call).
  RealtimeSetup start();
  // Async-signal-safe. The scan thread finishes its current scan and does not start another
  // (a request that arrives while it sleeps takes effect when it wakes, within a period).
  void request_stop() noexcept;
  // Blocks until the scan thread has finished (stop request, duration, scan count or fault).
  void wait();
  // start() and, if it started, wait().
  RealtimeSetup run();

  // Live, readable from any thread.
  [[nodiscard]] bool running() const noexcept { return running_.load(std::memory_order_acquire); }
  [[nodiscard]] std::uint64_t scans() const noexcept {
    return scans_.load(std::memory_order_relaxed);
  }
  [[nodiscard]] std::uint64_t overruns() const noexcept {
    return overruns_.load(std::memory_order_relaxed);
  }
  [[nodiscard]] RuntimeFault fault() const noexcept {
    return fault_.load(std::memory_order_acquire);
  }

  // Written by the scan thread: read them after wait().
  [[nodiscard]] const CycleStats& stats() const noexcept { return stats_; }
  [[nodiscard]] const OutputImage& last_output() const noexcept { return output_; }
  [[nodiscard]] const RuntimeOptions& options() const noexcept { return options_; }

 private:
  void scan_thread_main();
  RuntimeFault scan_loop();  // returns the fault that ended it, if any
  void watchdog_main(const std::stop_token& stop);
  void raise_fault(RuntimeFault fault);

  ProcessIo& io_;
  ScanLogic& logic_;
  const RuntimeOptions options_;

  CycleStats stats_;
  InputImage input_{};
  OutputImage output_{};

  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> running_{false};
  std::atomic<bool> abort_start_{false};
  std::atomic<std::uint64_t> scans_{0};
  std::atomic<std::uint64_t> overruns_{0};
  std::atomic<RuntimeFault> fault_{RuntimeFault::kNone};
  std::atomic<std::int64_t> heartbeat_ns_{0};  // wake-up time of the newest scan started
  std::int64_t first_wakeup_ns_ = 0;
  int dma_latency_fd_ = -1;  // the request lasts as long as the file stays open

  bool prepared_ = false;
  RealtimeSetup prepared_setup_;
  bool started_ = false;
  std::latch start_gate_{1};
  std::thread scan_thread_;
  std::jthread watchdog_thread_;
  std::stop_source watchdog_stop_;  // the scan thread ends the watchdog when it finishes
};

}  // namespace fl
