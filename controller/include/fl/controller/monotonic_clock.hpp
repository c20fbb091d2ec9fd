// CLOCK_MONOTONIC in nanoseconds, and an absolute sleep on it: what every periodic thread of
// the line (the scan runtime, the soak's latency probe) schedules by.
#pragma once

#include <time.h>

#include <cerrno>
#include <cstdint>

namespace fl {

inline std::int64_t monotonic_now_ns() noexcept {
  constexpr std::int64_t kNsPerSecond = 1'000'000'000;
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<std::int64_t>(now.tv_sec) * kNsPerSecond + now.tv_nsec;
}

// Absolute sleep: a late wake-up does not shift later deadlines, and a signal only restarts
// the wait for the same instant.
inline void sleep_until_ns(std::int64_t wakeup_ns) noexcept {
  constexpr std::int64_t kNsPerSecond = 1'000'000'000;
  timespec wakeup{};
  wakeup.tv_sec = static_cast<time_t>(wakeup_ns / kNsPerSecond);
  wakeup.tv_nsec = static_cast<long>(wakeup_ns % kNsPerSecond);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wakeup, nullptr) == EINTR) {
  }
}

}  // namespace fl
