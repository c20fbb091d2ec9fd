#include "fl/controller/runtime.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <spdlog/spdlog.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <utility>

#include "fl/controller/monotonic_clock.hpp"

namespace fl {

namespace {

// The cycle may only use lock-free atomics: a lock-based fallback would be a hidden mutex.
static_assert(std::atomic<std::int64_t>::is_always_lock_free);
static_assert(std::atomic<std::uint64_t>::is_always_lock_free);
static_assert(std::atomic<RuntimeFault>::is_always_lock_free);

// Touch the stack the cycle will use, so that its first page faults happen before the first
// scan (with mlockall(MCL_FUTURE) the touched pages then stay resident).
[[gnu::noinline]] void prefault_stack() noexcept {
  constexpr std::size_t kPrefaultBytes = std::size_t{256} * 1024;
  constexpr std::size_t kPageBytes = 4096;
  volatile unsigned char stack_pages[kPrefaultBytes];
  for (std::size_t offset = 0; offset < kPrefaultBytes; offset += kPageBytes) {
    stack_pages[offset] = 0;
  }
  static_cast<void>(stack_pages[0]);  // a volatile read: the writes above stay
}

std::string errno_text(int error_number) { return std::strerror(error_number); }

void append_error(std::string& errors, const std::string& error) {
  if (!errors.empty()) errors += "; ";
  errors += error;
}

void validate(const RuntimeOptions& options) {
  if (options.period_ns <= 0) throw std::invalid_argument("RuntimeOptions: period_ns must be > 0");
  if (options.fifo_priority != 0) {
    const int min_priority = sched_get_priority_min(SCHED_FIFO);
    const int max_priority = sched_get_priority_max(SCHED_FIFO);
    if (options.fifo_priority < min_priority || options.fifo_priority > max_priority) {
      throw std::invalid_argument("RuntimeOptions: fifo_priority must be 0 (off) or " +
                                  std::to_string(min_priority) + ".." +
                                  std::to_string(max_priority));
    }
  }
  if (options.cpu < -1 || options.cpu >= CPU_SETSIZE) {
    throw std::invalid_argument("RuntimeOptions: cpu must be -1 (no pinning) or 0.." +
                                std::to_string(CPU_SETSIZE - 1));
  }
  if (options.duration_ns < 0) throw std::invalid_argument("RuntimeOptions: duration_ns < 0");
  if (options.cpu_dma_latency_us < -1) {
    throw std::invalid_argument("RuntimeOptions: cpu_dma_latency_us must be -1 (off) or >= 0");
  }
}

// Returns 0 or the pthread error number.
int set_fifo_priority(pthread_t thread, int priority) {
  sched_param param{};
  param.sched_priority = priority;
  return pthread_setschedparam(thread, SCHED_FIFO, &param);
}

int set_affinity(pthread_t thread, int cpu) {
  cpu_set_t cpus;
  CPU_ZERO(&cpus);
  CPU_SET(static_cast<std::size_t>(cpu), &cpus);
  return pthread_setaffinity_np(thread, sizeof(cpus), &cpus);
}

}  // namespace

const char* to_string(RuntimeFault fault) {
  switch (fault) {
    case RuntimeFault::kNone:
      return "none";
    case RuntimeFault::kConsecutiveOverruns:
      return "consecutive cycle overruns";
    case RuntimeFault::kScanStalled:
      return "scan thread stalled";
    case RuntimeFault::kScanException:
      return "exception in the scan";
  }
  return "unknown";
}

OutputImage make_safe_output_image() {
  OutputImage safe{};  // value-initialised: drives disabled at 0 m/s, actuators released
  safe.hopper_opening_mm = 0.0F;
  safe.leveller_speed_rpm = 0.0F;
  safe.state = LineState::kFault;
  return safe;
}

ScanRuntime::ScanRuntime(ProcessIo& io, ScanLogic& logic, RuntimeOptions options)
    : io_(io),
      logic_(logic),
      options_((validate(options), std::move(options))),
      stats_(options_.stats_bin_width_ns, options_.stats_range_ns) {}

ScanRuntime::~ScanRuntime() {
  request_stop();
  wait();
  if (dma_latency_fd_ >= 0) close(dma_latency_fd_);
}

void ScanRuntime::request_stop() noexcept {
  stop_requested_.store(true, std::memory_order_relaxed);
}

RealtimeSetup ScanRuntime::prepare() {
  if (prepared_) return prepared_setup_;
  prepared_ = true;
  RealtimeSetup& setup = prepared_setup_;

  if (options_.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      setup.memory_locked = true;
    } else {
      const int error_number = errno;
      append_error(setup.error,
                   "mlockall(MCL_CURRENT | MCL_FUTURE) failed: " + errno_text(error_number) +
                       (error_number == EPERM || error_number == ENOMEM
                            ? " (needs CAP_IPC_LOCK or a larger RLIMIT_MEMLOCK)"
                            : ""));
    }
  }

  if (options_.cpu_dma_latency_us >= 0) {
    // The PM QoS interface takes a binary 32-bit value.
    const std::int32_t latency_us = options_.cpu_dma_latency_us;
    dma_latency_fd_ = open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
    if (dma_latency_fd_ >= 0 && write(dma_latency_fd_, &latency_us, sizeof(latency_us)) ==
                                    static_cast<ssize_t>(sizeof(latency_us))) {
      setup.dma_latency_applied = true;
    } else {
      const int error_number = errno;
      if (dma_latency_fd_ >= 0) close(dma_latency_fd_);
      dma_latency_fd_ = -1;
      append_error(setup.error,
                   "/dev/cpu_dma_latency " + std::to_string(latency_us) +
                       " us failed: " + errno_text(error_number) +
                       (error_number == EACCES || error_number == EPERM ? " (needs root)" : ""));
    }
  }
  return setup;
}

RealtimeSetup ScanRuntime::start() {
  if (started_) throw std::logic_error("ScanRuntime::start: a runtime starts once");
  started_ = true;
  RealtimeSetup setup = prepare();

  // The thread waits at the gate until its priority and affinity are set, so that no scan
  // runs with the wrong ones.
  scan_thread_ = std::thread([this] { scan_thread_main(); });

  if (options_.fifo_priority != 0) {
    const int error_number =
        set_fifo_priority(scan_thread_.native_handle(), options_.fifo_priority);
    if (error_number == 0) {
      setup.fifo_applied = true;
    } else {
      append_error(
          setup.error,
          "SCHED_FIFO priority " + std::to_string(options_.fifo_priority) +
              " failed: " + errno_text(error_number) +
              (error_number == EPERM ? " (needs root, CAP_SYS_NICE or RLIMIT_RTPRIO)" : ""));
    }
  }
  if (options_.cpu >= 0) {
    const int error_number = set_affinity(scan_thread_.native_handle(), options_.cpu);
    if (error_number == 0) {
      setup.affinity_applied = true;
    } else {
      append_error(setup.error,
                   "pinning to CPU " + std::to_string(options_.cpu) +
                       " failed: " + errno_text(error_number) +
                       (error_number == EINVAL ? " (no such CPU in this cpuset)" : ""));
    }
  }

  const auto abort = [this] {
    abort_start_.store(true, std::memory_order_relaxed);
    start_gate_.count_down();
    scan_thread_.join();
    if (dma_latency_fd_ >= 0) close(dma_latency_fd_);
    dma_latency_fd_ = -1;
  };

  if (!setup.error.empty()) {
    if (options_.realtime_required) {
      spdlog::error("scan runtime not started: {}", setup.error);
      abort();
      return setup;
    }
    spdlog::warn("scan runtime runs without part of its real-time setup: {}", setup.error);
  }

  // Until the scan thread is released the watchdog has nothing to judge: the time start()
  // takes below (the watchdog thread, its priority, the log line) is not a stalled scan. On a
  // slow machine (qemu at boot) that time alone exceeded the watchdog's limit.
  heartbeat_ns_.store(std::numeric_limits<std::int64_t>::max(), std::memory_order_relaxed);
  running_.store(true, std::memory_order_release);

  if (options_.watchdog_periods > 0) {
    try {
      watchdog_thread_ = std::jthread([this](const std::stop_token& stop) { watchdog_main(stop); });
    } catch (...) {
      running_.store(false, std::memory_order_release);
      abort();
      throw;
    }
    watchdog_stop_ = watchdog_thread_.get_stop_source();
    if (setup.fifo_applied) {
      // Above the scan thread, so that a scan thread spinning at its FIFO priority cannot
      // starve the watchdog that is meant to catch it.
      const int watchdog_priority =
          std::min(options_.fifo_priority + 1, sched_get_priority_max(SCHED_FIFO));
      const int error_number =
          set_fifo_priority(watchdog_thread_.native_handle(), watchdog_priority);
      if (error_number != 0) {
        spdlog::warn("scan runtime: watchdog SCHED_FIFO priority {} failed: {}", watchdog_priority,
                     errno_text(error_number));
      }
    }
  }

  spdlog::info(
      "scan runtime started: period {} us, {}, memory {}, {}, {}, watchdog {}, overrun fault {}",
      options_.period_ns / 1000,
      setup.fifo_applied ? "SCHED_FIFO " + std::to_string(options_.fifo_priority) : "SCHED_OTHER",
      setup.memory_locked ? "locked" : "not locked",
      setup.affinity_applied ? "CPU " + std::to_string(options_.cpu) : "no CPU pinning",
      setup.dma_latency_applied
          ? "cpu_dma_latency " + std::to_string(options_.cpu_dma_latency_us) + " us"
          : "no cpu_dma_latency request",
      options_.watchdog_periods > 0 ? std::to_string(options_.watchdog_periods) + " periods"
                                    : "off",
      options_.overrun_fault_consecutive > 0
          ? "after " + std::to_string(options_.overrun_fault_consecutive) + " in a row"
          : "off");

  setup.started = true;
  // The schedule and the watchdog's clock start at the release (the latch orders these
  // stores before the scan thread's reads).
  first_wakeup_ns_ = monotonic_now_ns() + options_.period_ns;
  heartbeat_ns_.store(first_wakeup_ns_, std::memory_order_relaxed);
  start_gate_.count_down();
  return setup;
}

void ScanRuntime::wait() {
  if (scan_thread_.joinable()) scan_thread_.join();
  if (watchdog_thread_.joinable()) {
    watchdog_thread_.request_stop();
    watchdog_thread_.join();
  }
}

RealtimeSetup ScanRuntime::run() {
  RealtimeSetup setup = start();
  if (setup.started) wait();
  return setup;
}

void ScanRuntime::scan_thread_main() {
  prefault_stack();
  start_gate_.wait();
  if (abort_start_.load(std::memory_order_relaxed)) return;

  RuntimeFault fault = RuntimeFault::kNone;
  try {
    io_.activate();
    fault = scan_loop();
  } catch (const std::exception& error) {
    spdlog::error("scan runtime: exception in the scan: {}", error.what());
    fault = RuntimeFault::kScanException;
  } catch (...) {
    spdlog::error("scan runtime: unknown exception in the scan");
    fault = RuntimeFault::kScanException;
  }
  if (fault != RuntimeFault::kNone) raise_fault(fault);

  try {
    io_.deactivate();
  } catch (const std::exception& error) {
    spdlog::error("scan runtime: exception in ProcessIo::deactivate: {}", error.what());
  }
  running_.store(false, std::memory_order_release);
  watchdog_stop_.request_stop();
}

RuntimeFault ScanRuntime::scan_loop() {
  const std::int64_t period_ns = options_.period_ns;
  const std::int64_t end_ns = options_.duration_ns > 0 ? first_wakeup_ns_ + options_.duration_ns
                                                       : std::numeric_limits<std::int64_t>::max();
  std::int64_t scheduled_ns = first_wakeup_ns_;
  std::uint32_t consecutive_overruns = 0;
  std::uint64_t scan_count = 0;
  std::uint64_t overrun_count = 0;

  while (!stop_requested_.load(std::memory_order_relaxed) && scheduled_ns < end_ns) {
    sleep_until_ns(scheduled_ns);
    if (stop_requested_.load(std::memory_order_relaxed)) break;
    const std::int64_t woke_ns = monotonic_now_ns();
    heartbeat_ns_.store(woke_ns, std::memory_order_relaxed);

    input_.time_ns = scheduled_ns;
    io_.read(scheduled_ns, input_);
    logic_.update(input_, output_);
    // After a watchdog fault the outputs belong to the safe state: write nothing more.
    if (fault_.load(std::memory_order_acquire) != RuntimeFault::kNone) return RuntimeFault::kNone;
    io_.write(output_);
    const std::int64_t finished_ns = monotonic_now_ns();

    stats_.record_scan(woke_ns - scheduled_ns, finished_ns - woke_ns);
    scans_.store(++scan_count, std::memory_order_relaxed);

    std::int64_t next_ns = scheduled_ns + period_ns;
    if (finished_ns > next_ns) {
      // Skip the deadlines already past instead of running catch-up scans back to back: the
      // next scan starts on the first period boundary after this one finished.
      const std::int64_t elapsed_periods = (finished_ns - scheduled_ns) / period_ns;
      next_ns = scheduled_ns + (elapsed_periods + 1) * period_ns;
      ++consecutive_overruns;
      overruns_.store(++overrun_count, std::memory_order_relaxed);
      const auto missed_periods = static_cast<std::uint64_t>(elapsed_periods);
      stats_.record_overrun(missed_periods, consecutive_overruns);
      logic_.on_overrun(OverrunInfo{scheduled_ns, finished_ns, missed_periods, consecutive_overruns,
                                    overrun_count});
    } else {
      consecutive_overruns = 0;
    }
    logic_.after_scan(input_, output_,
                      ScanTimingSample{period_ns, woke_ns - scheduled_ns, finished_ns - woke_ns,
                                       scan_count, overrun_count});
    if (options_.overrun_fault_consecutive > 0 &&
        consecutive_overruns >= options_.overrun_fault_consecutive) {
      return RuntimeFault::kConsecutiveOverruns;
    }
    scheduled_ns = next_ns;
    if (options_.max_scans > 0 && scan_count >= options_.max_scans) break;
  }
  return RuntimeFault::kNone;
}

void ScanRuntime::watchdog_main(const std::stop_token& stop) {
  const auto check_interval = std::chrono::nanoseconds(options_.period_ns);
  const std::int64_t stall_ns =
      static_cast<std::int64_t>(options_.watchdog_periods) * options_.period_ns;
  std::mutex mutex;  // only for the interruptible wait; the scan thread never touches it
  std::condition_variable_any wake;
  std::unique_lock lock(mutex);
  while (!wake.wait_for(lock, stop, check_interval, [] { return false; }) &&
         !stop.stop_requested()) {
    const std::int64_t silent_ns =
        monotonic_now_ns() - heartbeat_ns_.load(std::memory_order_relaxed);
    if (silent_ns > stall_ns) {
      request_stop();
      raise_fault(RuntimeFault::kScanStalled);
      spdlog::error("scan runtime: no scan started for {} us (limit {} periods of {} us)",
                    silent_ns / 1000, options_.watchdog_periods, options_.period_ns / 1000);
      return;
    }
  }
}

void ScanRuntime::raise_fault(RuntimeFault fault) {
  RuntimeFault expected = RuntimeFault::kNone;
  if (!fault_.compare_exchange_strong(expected, fault, std::memory_order_acq_rel)) return;
  // Safe state first, the log line after it.
  if (options_.on_fault) {
    try {
      options_.on_fault(fault);
    } catch (const std::exception& error) {
      spdlog::error("scan runtime: fault callback threw: {}", error.what());
    } catch (...) {
      spdlog::error("scan runtime: fault callback threw");
    }
  }
  spdlog::error("scan runtime fault: {} after {} scans, {} overruns", to_string(fault),
                scans_.load(std::memory_order_relaxed), overruns_.load(std::memory_order_relaxed));
}

}  // namespace fl
