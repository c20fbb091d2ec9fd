// The line's live status for operator screens: a fixed-size, trivially copyable snapshot that
// the scan thread publishes once per scan through a triple buffer, without locks or
// allocation, and one reader (the HMI's broadcaster thread) takes when it likes. The reader
// always gets the newest complete snapshot; the scan never waits for it.
//
// Nothing here knows about sockets or JSON: the HMI component (hmi/) turns snapshots into its
// wire format.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <type_traits>

#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/process_image.hpp"

namespace fl {

// ---------------------------------------------------------------- triple buffer

// Single producer, single consumer. The producer fills back(), then publish() swaps it with
// the shared middle slot; the consumer's take() swaps the middle slot with its front slot when
// a new one is there. Both sides only touch their own slot and one atomic byte, so neither
// ever blocks the other (unlike a seqlock, no torn read is possible and no retry loop runs).
template <typename T>
class TripleBuffer {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  // Producer side.
  [[nodiscard]] T& back() noexcept { return slots_[back_]; }
  void publish() noexcept {
    const std::uint8_t previous =
        middle_.exchange(static_cast<std::uint8_t>(back_ | kFreshBit), std::memory_order_acq_rel);
    back_ = static_cast<std::uint8_t>(previous & kIndexMask);
  }

  // Consumer side: true when a snapshot newer than the last one taken was published; `front()`
  // then holds it (and keeps holding the last one otherwise).
  bool take() noexcept {
    if ((middle_.load(std::memory_order_relaxed) & kFreshBit) == 0) return false;
    const std::uint8_t previous = middle_.exchange(front_, std::memory_order_acq_rel);
    front_ = static_cast<std::uint8_t>(previous & kIndexMask);
    return true;
  }
  [[nodiscard]] const T& front() const noexcept { return slots_[front_]; }

 private:
  static constexpr std::uint8_t kIndexMask = 0x3;
  static constexpr std::uint8_t kFreshBit = 0x4;
  static_assert(std::atomic<std::uint8_t>::is_always_lock_free);

  std::array<T, 3> slots_{};
  std::uint8_t back_ = 0;                // producer's slot
  std::atomic<std::uint8_t> middle_{1};  // shared slot index, plus kFreshBit when unread
  std::uint8_t front_ = 2;               // consumer's slot
};

// ---------------------------------------------------------------- snapshot

struct DriveStatus {
  float command_mps = 0.0F;  // commanded surface speed, negative reverses
  float speed_mps = 0.0F;    // measured
  bool enabled = false;
  bool ready = false;
  bool fault = false;
};

// Scan timing as the runtime measured it. Wake-up latency (actual minus scheduled wake-up) is
// the loop's jitter; compute is read + update + write.
struct ScanTimingStatus {
  std::int64_t period_ns = 0;
  std::int64_t last_wakeup_latency_ns = 0;
  std::int64_t last_compute_ns = 0;
  // Maxima over the last completed window of `kTimingWindowScans` scans (1 s at 10 ms), and
  // since the start.
  std::int64_t window_max_wakeup_latency_ns = 0;
  std::int64_t window_max_compute_ns = 0;
  std::int64_t max_wakeup_latency_ns = 0;
  std::int64_t max_compute_ns = 0;
  std::uint64_t scans = 0;
  std::uint64_t overruns = 0;
};

struct LineStatus {
  std::uint64_t sequence = 0;  // increments per published snapshot
  std::int64_t time_ns = 0;    // the scan's time (CLOCK_MONOTONIC)
  LineState state = LineState::kStopped;
  std::uint32_t active_faults = 0;  // bit set of FaultCode, latched ones included
  bool estop_ok = false;

  std::array<DriveStatus, kDriveCount> drives{};
  bool flip_plate1_flip = false;  // commanded: retract plate 1
  bool flip_plate2_flip = false;
  bool flip_plate1_flipping = false;  // end switches
  bool flip_plate2_flipping = false;
  bool reject_reversing = false;  // the reject belt runs backwards into the crate
  bool final_reject = false;      // air knife blowing
  bool centring_stroke = false;
  float centring_shift_mm = 0.0F;
  bool squeeze_roller_down = false;
  float level_mm = 0.0F;
  float hopper_opening_mm = 0.0F;
  float leveller_speed_rpm = 0.0F;

  ControllerCounters counters{};
  std::uint64_t records_dropped = 0;
  std::uint64_t events_dropped = 0;

  std::uint32_t tracked_count = 0;  // valid entries of `tracked`
  std::array<TrackedItemView, kMaxTrackedItems> tracked{};

  ScanTimingStatus timing{};
};
static_assert(std::is_trivially_copyable_v<LineStatus>);

inline constexpr std::uint64_t kTimingWindowScans = 100;

// Fills and publishes LineStatus snapshots on the scan thread. Real-time: publish() copies
// fixed-size data only.
class LineStatusPublisher {
 public:
  void publish(const LineController& controller, const InputImage& in, const OutputImage& out,
               const ScanTimingSample& timing) noexcept;

  // The consumer's side (one thread).
  [[nodiscard]] TripleBuffer<LineStatus>& buffer() noexcept { return buffer_; }

 private:
  TripleBuffer<LineStatus> buffer_;
  std::uint64_t sequence_ = 0;
  // Running maxima of the current timing window and the last completed one.
  std::int64_t window_latency_ns_ = 0;
  std::int64_t window_compute_ns_ = 0;
  std::int64_t last_window_latency_ns_ = 0;
  std::int64_t last_window_compute_ns_ = 0;
  std::int64_t max_latency_ns_ = 0;
  std::int64_t max_compute_ns_ = 0;
  std::uint64_t window_scans_ = 0;
};

}  // namespace fl
