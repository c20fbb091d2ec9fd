#include "fl/apps/latency_probe.hpp"

#include <pthread.h>
#include <sched.h>

#include <cstring>

#include "fl/controller/monotonic_clock.hpp"

namespace fl::apps {
namespace {

constexpr std::int64_t kProbeRangeNs = 100'000'000;  // 100 ms: beyond any VM tail seen here

}  // namespace

LatencyProbe::LatencyProbe(std::int64_t period_ns, int fifo_priority)
    : period_ns_(period_ns),
      fifo_priority_(fifo_priority),
      histogram_(DurationHistogram::kDefaultBinWidthNs, kProbeRangeNs) {}

LatencyProbe::~LatencyProbe() { stop(); }

std::string LatencyProbe::start() {
  thread_ = std::thread([this] { run(); });
  if (fifo_priority_ <= 0) return {};
  sched_param param{};
  param.sched_priority = fifo_priority_;
  const int error = pthread_setschedparam(thread_.native_handle(), SCHED_FIFO, &param);
  fifo_applied_ = error == 0;
  return error == 0 ? std::string()
                    : "latency probe: SCHED_FIFO " + std::to_string(fifo_priority_) + " refused (" +
                          std::strerror(error) + "); it runs on SCHED_OTHER";
}

void LatencyProbe::stop() {
  stop_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
}

void LatencyProbe::run() noexcept {
  std::int64_t next_ns = monotonic_now_ns() + period_ns_;
  while (!stop_.load(std::memory_order_relaxed)) {
    sleep_until_ns(next_ns);
    const std::int64_t latency_ns = monotonic_now_ns() - next_ns;
    histogram_.record(latency_ns);
    std::int64_t seen = interval_max_ns_.load(std::memory_order_relaxed);
    while (latency_ns > seen &&
           !interval_max_ns_.compare_exchange_weak(seen, latency_ns, std::memory_order_relaxed)) {
    }
    // Like cyclictest: the next period follows the schedule, not the late wake-up; periods
    // slept through entirely are skipped rather than measured as a burst.
    next_ns += period_ns_;
    const std::int64_t now = monotonic_now_ns();
    if (next_ns <= now) next_ns += ((now - next_ns) / period_ns_ + 1) * period_ns_;
  }
}

}  // namespace fl::apps
