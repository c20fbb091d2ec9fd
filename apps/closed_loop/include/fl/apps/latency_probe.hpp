// The machine's own wake-up latency, measured beside the scan the way cyclictest does: a
// thread that does nothing but sleep to the next absolute period on SCHED_FIFO (one priority
// below the scan, so it never delays it). When the scan wakes late and the probe does too in
// the same minutes, the hypervisor, firmware or kernel is to blame, not the controller; a
// soak on the line PC then tells "fix the box" from "fix the code" by itself.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <thread>

#include "fl/controller/cycle_stats.hpp"

namespace fl::apps {

class LatencyProbe {
 public:
  // fifo_priority 0: SCHED_OTHER. Histogram: 1 us bins up to 100 ms (a VM's worst).
  LatencyProbe(std::int64_t period_ns, int fifo_priority);
  ~LatencyProbe();
  LatencyProbe(const LatencyProbe&) = delete;
  LatencyProbe& operator=(const LatencyProbe&) = delete;

  // Starts the thread; returns an empty string, or why SCHED_FIFO could not be applied (the
  // probe then runs on SCHED_OTHER and says so).
  std::string start();
  // Stops and joins; the histogram is complete after it. Idempotent.
  void stop();

  // The worst wake-up latency since the previous call, from any thread (for a timeline).
  std::int64_t take_interval_max_ns() noexcept {
    return interval_max_ns_.exchange(0, std::memory_order_relaxed);
  }
  // After stop(): every wake-up of the run.
  [[nodiscard]] const DurationHistogram& histogram() const noexcept { return histogram_; }
  [[nodiscard]] bool fifo_applied() const noexcept { return fifo_applied_; }

 private:
  void run() noexcept;

  std::int64_t period_ns_;
  int fifo_priority_;
  bool fifo_applied_ = false;
  DurationHistogram histogram_;
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> interval_max_ns_{0};
  std::thread thread_;
};

}  // namespace fl::apps
