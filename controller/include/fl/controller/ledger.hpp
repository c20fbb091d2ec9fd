// The fillet ledger: every item the takt pulls out gets an id and ends with exactly one
// outcome. The logic writes ledger records and events into fixed-capacity rings; a
// non-real-time consumer (the simulation loop, the DDS publisher, the log writer) drains
// them outside the cycle.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "fl/controller/process_image.hpp"

namespace fl {

enum class Outcome : std::uint8_t {
  kInTransit,
  kPlaced,
  kRejectedNotSingulated,  // camera 1 saw touching or overlapping fillets
  kRejectedUnclassified,   // camera 1 could not tell hand or side with enough confidence
  kRejectedCollateral,     // on the reject belt while it reversed for another item
  kRejectedMisaligned,     // final camera: angle, side or position out of tolerance
  kRejectedUnverified,     // the final camera did not see it, so it is not placed blind
  kRejectedUntracked,      // a camera saw an item the tracker did not know: never placed
  kLost,
  kCount
};
inline constexpr std::size_t kOutcomeCount = static_cast<std::size_t>(Outcome::kCount);

enum class LostReason : std::uint8_t {
  kNone,
  kNotSeenByCamera,  // passed a camera's field of view without a matching detection
  kStaleEstimates,   // the camera stopped delivering while the item was in view
  kTrackerOverflow,  // more items on the line than the tracker holds
  kLineStopped,      // on the belts when the line was faulted and cleared by hand
  kRunEnded,         // still on the belts when a simulated run ended
};

const char* to_string(Outcome outcome);
const char* to_string(LostReason reason);

// What the controller knows and decided about one item.
struct FilletRecord {
  std::uint32_t id = 0;
  std::int64_t created_ns = 0;
  std::int64_t closed_ns = 0;
  Outcome outcome = Outcome::kInTransit;
  LostReason lost_reason = LostReason::kNone;
  Hand hand = Hand::kUnknown;
  SideUp side_seen = SideUp::kUnknown;  // at camera 1, before flipping
  bool singulated = true;
  bool flip_plate1 = false;
  bool flip_plate2 = false;
  std::int8_t multilane_unit = -1;  // 0 or 1, -1 if none assigned
  float angle_at_camera1_rad = 0.0F;
  float final_angle_rad = 0.0F;  // as seen by the final camera
  float final_y_mm = 0.0F;
};

// Anomalies and decisions worth a log line. Raised in the cycle, logged outside it.
enum class EventCode : std::uint8_t {
  kItemCreated,
  kItemClosed,
  kEstimateNotFinite,   // NaN or infinite field in an estimate
  kEstimateOutOfRange,  // position outside the field of view, confidence outside 0..1
  kEstimateStale,       // frame older than the camera's max age
  kFrameOutOfOrder,     // frame time earlier than the previous frame of that camera
  kDetectionUnmatched,  // no tracked item near the detection
  kDuplicateDetection,  // two detections in one frame claim the same item
  kFlipConflict,        // the plates could not be set in time for an item
  kCameraSilent,        // no new frame for longer than the camera's max age
  kEstimateFlood,       // a frame claims more detections than it can hold
  kItemAdopted,         // an unmatched detection became a tracked item (to reject it)
  kRejectReversal,
  kFaultRaised,
  kFaultCleared,
  kStateChanged,
};

const char* to_string(EventCode code);

struct Event {
  std::int64_t time_ns = 0;
  EventCode code = EventCode::kItemCreated;
  std::uint32_t item_id = 0;  // 0 when not about an item
  std::uint8_t source = 0;    // camera or drive index, meaning depends on the code
  float value = 0.0F;         // the offending number, when there is one
};

// Single-producer single-consumer ring with fixed capacity, safe across one producer thread
// (the scan) and one consumer thread. The producer never blocks or allocates: when the
// consumer falls behind, new entries are counted as dropped rather than overwriting unread
// ones, so the consumer can report the loss.
template <typename T, std::size_t Capacity>
class FixedRing {
  static_assert((Capacity & (Capacity - 1)) == 0, "capacity must be a power of two");

 public:
  bool push(const T& value) {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) == Capacity) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    slots_[head & (Capacity - 1)] = value;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }
  std::optional<T> pop() {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return std::nullopt;
    T value = slots_[tail & (Capacity - 1)];
    tail_.store(tail + 1, std::memory_order_release);
    return value;
  }
  [[nodiscard]] std::size_t size() const {
    return static_cast<std::size_t>(head_.load(std::memory_order_acquire) -
                                    tail_.load(std::memory_order_acquire));
  }
  [[nodiscard]] std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  std::array<T, Capacity> slots_{};
  std::atomic<std::uint64_t> head_{0};
  std::atomic<std::uint64_t> tail_{0};
  std::atomic<std::uint64_t> dropped_{0};
};

}  // namespace fl
