// Fillet tracking: items move along the line by the encoder travel of the belt under them,
// camera detections are validated and matched to items, and every item ends in the ledger.
// Internal to the logic library; stations read and annotate the items.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>

#include "fl/controller/ledger.hpp"
#include "fl/controller/line_config.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/process_image.hpp"

namespace fl::logic {

inline float wrap_angle(float angle_rad) {
  constexpr float kPi = std::numbers::pi_v<float>;
  constexpr float kTwoPi = 2.0F * kPi;
  angle_rad = std::fmod(angle_rad, kTwoPi);
  if (angle_rad > kPi) angle_rad -= kTwoPi;
  if (angle_rad <= -kPi) angle_rad += kTwoPi;
  return angle_rad;
}

// Confidence-weighted votes and running means over the frames in which a camera saw an item.
struct CameraEvidence {
  std::uint16_t frames = 0;
  float hand_vote = 0.0F;  // + right, - left
  float side_vote = 0.0F;  // + skin, - bone
  float not_singulated_weight = 0.0F;
  float singulated_weight = 0.0F;
  float confidence_sum = 0.0F;
  float y_sum_mm = 0.0F;
  float cos_sum = 0.0F;  // circular mean of the angle
  float sin_sum = 0.0F;

  void add(const FilletEstimate& estimate);
  [[nodiscard]] float mean_y_mm() const {
    return frames ? y_sum_mm / static_cast<float>(frames) : 0.0F;
  }
  [[nodiscard]] float mean_angle_rad() const { return std::atan2(sin_sum, cos_sum); }
  [[nodiscard]] float mean_confidence() const {
    return frames ? confidence_sum / static_cast<float>(frames) : 0.0F;
  }
  [[nodiscard]] Hand hand() const;
  [[nodiscard]] SideUp side() const;
  [[nodiscard]] bool singulated() const { return singulated_weight >= not_singulated_weight; }
};

struct Item {
  bool active = false;
  std::uint32_t id = 0;
  float s_mm = 0.0F;
  float y_mm = 0.0F;
  float length_mm = 170.0F;
  // Best knowledge of the heading; valid once camera 1 has seen the item.
  float angle_rad = 0.0F;
  bool angle_known = false;
  Hand hand = Hand::kUnknown;
  SideUp side = SideUp::kUnknown;  // current side up (after planned flips)
  bool adopted = false;            // created from an unmatched detection, not by the takt
  bool classified = false;
  bool reject_pending = false;
  Outcome reject_reason = Outcome::kInTransit;
  bool flip1 = false;
  bool flip2 = false;
  bool passed_plate1 = false;
  bool passed_plate2 = false;
  // Running back over the reject belt's upstream edge into the crate: the tracker stops
  // moving it and the reject station counts the belt travel until it has surely fallen.
  bool dropping = false;
  float drop_travel_mm = 0.0F;
  bool centring_done = false;
  float centring_shift_mm = 0.0F;
  bool centring_stroke_started = false;  // the pusher left home for this item
  std::int8_t multilane_unit = -1;
  bool orienting_done = false;
  float target_angle_rad = 0.0F;
  // The multilane angle loop's estimate of how much of the encoders' rotation the item
  // really turns (friction, slip, heading), learnt from successive frames on a unit: a
  // recursive least-squares fit of measured over encoder rotation. 0 weight: nothing
  // learnt yet, the loop starts from the model (gain 1).
  float turn_gain = 1.0F;
  float turn_gain_weight_rad2 = 0.0F;  // sum of squared encoder rotations (with forgetting)
  float turn_gain_sum_rad2 = 0.0F;     // sum of encoder times measured rotation
  // The previous multilane frame (angle, exposure, unit), the start of the next gain sample.
  float gain_frame_angle_rad = 0.0F;
  std::int64_t gain_frame_ns = 0;
  std::int8_t gain_frame_unit = -1;
  // The heading the units left it at (estimate on unit 2), until the final camera has
  // compared it with what it sees: the rotation on the way there.
  float exit_angle_rad = 0.0F;
  bool exit_angle_known = false;
  // Newest angle measurement, for the multilane loop (latency compensated there).
  float measured_angle_rad = 0.0F;
  std::int64_t measured_angle_ns = 0;
  bool measured_angle_new = false;
  bool final_checked = false;
  bool final_reject = false;
  std::array<CameraEvidence, kCameraCount> evidence{};
  FilletRecord record{};
};

// Results of reading one camera frame, for the fault logic.
struct FrameIntake {
  bool new_frame = false;
  std::uint16_t rejected = 0;  // estimates refused (not finite, out of range, stale, order)
  std::uint16_t unmatched = 0;
  bool flooded = false;
};

// An unmatched detection waiting for confirmation: a fillet the tracker missed shows up
// frame after frame where the belt carries it, a phantom (glare, a scrap) does not.
struct Tentative {
  bool active = false;
  float s_mm = 0.0F;
  std::uint8_t hits = 0;            // frames that saw it, at most one per frame
  std::int64_t last_seen_ns = 0;    // scan time of the frame that last saw it
  std::uint32_t last_sequence = 0;  // that frame's sequence number
};

class Tracker {
 public:
  // Frames in which an unmatched detection must reappear before it becomes an item.
  static constexpr std::uint8_t kConfirmFrames = 3;
  // Tentatives per camera: more unexplained blobs than this at once is a flood.
  static constexpr std::size_t kMaxTentatives = 8;

  explicit Tracker(const LineConfig& config);
  void reset();

  // Advance every item by the travel of the belt under it since the last scan.
  void advance(const InputImage& in);

  // Belt travel of one drive over the last scan in mm (signed).
  [[nodiscard]] float travel_mm(DriveId drive) const { return travel_mm_[index(drive)]; }
  // Travel of the product under line position s over the last scan.
  [[nodiscard]] float travel_at_mm(float s_mm) const;
  // Speed of the belt under s from drive feedback.
  [[nodiscard]] float speed_at_mps(const InputImage& in, float s_mm) const;

  // Create an item at the takt barrier; returns nullptr (and counts) when the table is full.
  Item* create(std::int64_t time_ns, float s_mm, bool adopted);

  // Validate the camera's newest frame if it is new, match detections to items and add the
  // evidence. Unmatched detections on the orientation, position and final cameras are
  // adopted as items flagged for rejection: a fillet on the belts is never untracked.
  FrameIntake ingest(const InputImage& in, CameraId camera, EventRing& events);

  // Close an item with an outcome: writes the record to the ring and frees the slot.
  void close(Item& item, std::int64_t time_ns, Outcome outcome, LostReason reason,
             RecordRing& records, EventRing& events);

  std::array<Item, kMaxTrackedItems>& items() { return items_; }
  [[nodiscard]] const std::array<Item, kMaxTrackedItems>& items() const { return items_; }
  [[nodiscard]] std::size_t active_count() const { return active_count_; }
  [[nodiscard]] std::uint64_t overflows() const { return overflows_; }
  [[nodiscard]] std::uint64_t rejected_estimates() const { return rejected_estimates_; }
  [[nodiscard]] std::uint64_t unmatched_detections() const { return unmatched_; }
  [[nodiscard]] std::uint64_t duplicate_detections() const { return duplicates_; }
  [[nodiscard]] std::uint64_t frames_processed() const { return frames_; }
  [[nodiscard]] std::uint64_t adopted() const { return adopted_; }
  [[nodiscard]] const std::array<std::uint64_t, kOutcomeCount>& outcome_counts() const {
    return outcome_counts_;
  }
  [[nodiscard]] std::int64_t last_frame_time_ns(CameraId camera) const {
    return last_frame_time_ns_[index(camera)];
  }
  [[nodiscard]] bool camera_has_delivered(CameraId camera) const {
    return has_frame_[index(camera)];
  }

 private:
  Item* nearest_item(float s_mm, float gate_mm);
  // Counts an unmatched detection of frame `sequence`; returns true once it is confirmed by
  // kConfirmFrames different frames.
  bool confirm_unmatched(CameraId camera, float s_mm, std::int64_t time_ns, std::uint32_t sequence);

  const LineConfig& config_;
  std::array<Item, kMaxTrackedItems> items_{};
  std::array<std::array<Tentative, kMaxTentatives>, kCameraCount> tentatives_{};
  std::array<std::int64_t, kDriveCount> last_counts_{};
  std::array<float, kDriveCount> travel_mm_{};
  std::array<std::uint32_t, kCameraCount> last_sequence_{};
  std::array<std::int64_t, kCameraCount> last_frame_time_ns_{};
  std::array<bool, kCameraCount> has_frame_{};
  bool first_advance_ = true;
  std::uint32_t next_id_ = 1;
  std::size_t active_count_ = 0;
  std::uint64_t overflows_ = 0;
  std::uint64_t rejected_estimates_ = 0;
  std::uint64_t unmatched_ = 0;
  std::uint64_t duplicates_ = 0;
  std::uint64_t frames_ = 0;
  std::uint64_t adopted_ = 0;
  std::array<std::uint64_t, kOutcomeCount> outcome_counts_{};
};

}  // namespace fl::logic
