// Counts heap allocations and mutex locks made on threads that armed the probe. The test
// binary replaces the global operator new/delete (every variant) and interposes
// pthread_mutex_lock/trylock (scan_thread_probe.cpp); only a thread that armed itself
// through its thread_local flag is counted, so other threads (gtest, spdlog, the watchdog)
// cannot disturb the count.
#pragma once

#include <cstdint>

namespace fl::test {

struct ProbeCounts {
  std::uint64_t allocations = 0;
  std::uint64_t deallocations = 0;
  std::uint64_t mutex_locks = 0;
};

// Sum over every thread since the last reset.
ProbeCounts probe_counts();
void reset_probe_counts();

// Arms or disarms counting on the calling thread.
void arm_probe_on_this_thread(bool armed);

// Arms the calling thread for its lifetime.
class ArmedProbeScope {
 public:
  ArmedProbeScope() { arm_probe_on_this_thread(true); }
  ~ArmedProbeScope() { arm_probe_on_this_thread(false); }
  ArmedProbeScope(const ArmedProbeScope&) = delete;
  ArmedProbeScope& operator=(const ArmedProbeScope&) = delete;
};

}  // namespace fl::test
