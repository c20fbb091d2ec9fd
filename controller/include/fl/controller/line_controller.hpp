// The line's logic: one call of update() is one scan. It reads only the input image and
// the configuration, writes only the output image, its own state, and the ledger and event
// rings. No clock, no I/O, no allocation after construction: the same sequence of input
// images gives bit-identical outputs in real time and in lock-step simulation.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>

#include "fl/controller/ledger.hpp"
#include "fl/controller/line_config.hpp"
#include "fl/controller/process_image.hpp"

namespace fl {

enum class FaultCode : std::uint8_t {
  kEstop,
  kDriveFault,
  kLevellerOverload,
  kCycleOverrun,
  kCameraSilent,
  kEstimateFlood,  // more detections than a frame can hold, or a burst of bad estimates
  kTrackerOverflow,
  kCount
};
const char* to_string(FaultCode code);
inline constexpr std::uint32_t fault_bit(FaultCode code) {
  return 1U << static_cast<std::uint32_t>(code);
}

// Counters a commissioning engineer reads to see how the line is doing; monotonic per run.
struct ControllerCounters {
  std::uint64_t scans = 0;
  std::uint64_t overruns = 0;       // scans whose time step was longer than 1.5 periods
  std::uint64_t items_created = 0;  // by the takt
  std::uint64_t items_adopted = 0;  // from detections no tracked item explained
  std::uint64_t items_closed = 0;
  std::uint64_t takt_strokes = 0;
  // Of those, rows struck without a clear beam since the last stroke (takt.rearm_travel_mm):
  // rows that touched the previous fillet. Many of them mean the infeed's layer is too dense.
  std::uint64_t takt_strokes_by_travel = 0;
  std::uint64_t reject_reversals = 0;
  std::uint64_t flip_conflicts = 0;
  std::uint64_t estimates_rejected = 0;  // not finite, out of range, stale, out of order
  std::uint64_t detections_unmatched = 0;
  std::uint64_t detections_duplicate = 0;
  std::uint64_t frames_processed = 0;
  std::array<std::uint64_t, kOutcomeCount> outcomes{};  // indexed by Outcome
};

// A tracked item as the HMI and the DDS status topic show it.
struct TrackedItemView {
  std::uint32_t id = 0;
  float s_mm = 0.0F;
  float y_mm = 0.0F;
  float angle_rad = 0.0F;
  bool angle_known = false;
  bool reject_pending = false;
  std::int8_t multilane_unit = -1;
  Hand hand = Hand::kUnknown;
  SideUp side = SideUp::kUnknown;  // side up after the flips planned so far
  bool classified = false;         // camera 1 has decided hand, side and flips
  bool flip_plate1 = false;        // planned flips
  bool flip_plate2 = false;
  bool orienting_done = false;                  // the multilane unit has turned it
  Outcome reject_reason = Outcome::kInTransit;  // when reject_pending
};

inline constexpr std::size_t kMaxTrackedItems = 64;
using RecordRing = FixedRing<FilletRecord, 256>;
using EventRing = FixedRing<Event, 1024>;

class LineController {
 public:
  explicit LineController(const LineConfig& config);
  ~LineController();
  LineController(const LineController&) = delete;
  LineController& operator=(const LineController&) = delete;

  // Back to the stopped state with an empty tracker; counters restart.
  void reset();

  // One scan.
  void update(const InputImage& in, OutputImage& out);

  // Operator commands outside the input image (HMI, linectl): applied at the next scan.
  void request_start();
  void request_stop();
  void acknowledge_faults();

  [[nodiscard]] LineState state() const;
  [[nodiscard]] std::uint32_t active_faults() const;
  [[nodiscard]] const ControllerCounters& counters() const;
  [[nodiscard]] std::size_t tracked_count() const;
  // Copies up to out.size() tracked items, returns how many.
  std::size_t tracked_items(std::span<TrackedItemView> out) const;

  // Closed ledger records and events, drained by a non-real-time consumer.
  RecordRing& closed_records();
  EventRing& events();
  // Entries lost because the consumer fell behind: a balanced ledger needs zero records lost.
  [[nodiscard]] std::uint64_t records_dropped() const;
  [[nodiscard]] std::uint64_t events_dropped() const;

  // Close every item still in transit as lost with the given reason (end of a run, or the
  // operator clearing the belts after a fault), so the ledger balances.
  void close_all_in_transit(std::int64_t time_ns, LostReason reason);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fl
