#include "tracker.hpp"

#include <algorithm>
#include <cmath>

namespace fl::logic {
namespace {

constexpr float kNsPerS = 1e9F;
// Detections this far outside the nominal field of view are refused: a calibrated camera
// cannot see there, so the number is corrupt.
constexpr float kFieldOfViewMarginMm = 50.0F;
// Belts are narrower than this; a lateral position beyond it is not on the belt.
constexpr float kMaxLateralMm = 400.0F;
// Angles are wrapped to (-pi, pi]; a little slack for the float rounding of the sender.
constexpr float kAngleSlackRad = 0.01F;

bool finite(const FilletEstimate& e) {
  return std::isfinite(e.x_mm) && std::isfinite(e.y_mm) && std::isfinite(e.angle_rad) &&
         std::isfinite(e.confidence);
}

void emit(EventRing& events, std::int64_t time_ns, EventCode code, std::uint32_t item_id,
          std::uint8_t source, float value) {
  events.push(Event{time_ns, code, item_id, source, value});
}

}  // namespace

void CameraEvidence::add(const FilletEstimate& estimate) {
  const float weight = std::clamp(estimate.confidence, 0.0F, 1.0F);
  ++frames;
  if (estimate.hand == Hand::kRight) hand_vote += weight;
  if (estimate.hand == Hand::kLeft) hand_vote -= weight;
  if (estimate.side == SideUp::kSkin) side_vote += weight;
  if (estimate.side == SideUp::kBone) side_vote -= weight;
  (estimate.singulated ? singulated_weight : not_singulated_weight) += weight;
  confidence_sum += weight;
  y_sum_mm += estimate.y_mm;
  cos_sum += std::cos(estimate.angle_rad);
  sin_sum += std::sin(estimate.angle_rad);
}

Hand CameraEvidence::hand() const {
  if (hand_vote > 0.0F) return Hand::kRight;
  if (hand_vote < 0.0F) return Hand::kLeft;
  return Hand::kUnknown;
}

SideUp CameraEvidence::side() const {
  if (side_vote > 0.0F) return SideUp::kSkin;
  if (side_vote < 0.0F) return SideUp::kBone;
  return SideUp::kUnknown;
}

Tracker::Tracker(const LineConfig& config) : config_(config) { reset(); }

void Tracker::reset() {
  for (Item& item : items_) item = Item{};
  for (auto& camera : tentatives_) camera.fill(Tentative{});
  last_counts_.fill(0);
  travel_mm_.fill(0.0F);
  last_sequence_.fill(0);
  last_frame_time_ns_.fill(0);
  has_frame_.fill(false);
  first_advance_ = true;
  next_id_ = 1;
  active_count_ = 0;
  overflows_ = rejected_estimates_ = unmatched_ = duplicates_ = frames_ = adopted_ = 0;
  outcome_counts_.fill(0);
}

void Tracker::advance(const InputImage& in) {
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const std::int64_t counts = in.drives[d].encoder_counts;
    // Modulo 2^64, as a counter wraps: a corrupt or reset counter (from a DDS sample, found
    // by fuzzing) makes a wild jump, never a signed overflow.
    const auto delta = first_advance_
                           ? std::int64_t{0}
                           : static_cast<std::int64_t>(static_cast<std::uint64_t>(counts) -
                                                       static_cast<std::uint64_t>(last_counts_[d]));
    last_counts_[d] = counts;
    travel_mm_[d] = static_cast<float>(delta) / config_.limits[d].counts_per_mm;
  }
  first_advance_ = false;
  for (Item& item : items_) {
    if (item.active && !item.dropping) item.s_mm += travel_at_mm(item.s_mm);
  }
  for (auto& camera : tentatives_) {
    for (Tentative& tentative : camera) {
      if (tentative.active) tentative.s_mm += travel_at_mm(tentative.s_mm);
    }
  }
}

bool Tracker::confirm_unmatched(CameraId camera, float s_mm, std::int64_t time_ns,
                                std::uint32_t sequence) {
  auto& tentatives = tentatives_[index(camera)];
  // A tentative not seen for this many frame periods was a phantom.
  constexpr float kExpiryPeriods = 3.0F;
  const auto expiry_ns =
      static_cast<std::int64_t>(kExpiryPeriods * config_.cameras[index(camera)].period_s * 1e9F);
  Tentative* match = nullptr;
  Tentative* free_slot = nullptr;
  for (Tentative& tentative : tentatives) {
    if (tentative.active && time_ns - tentative.last_seen_ns > expiry_ns) tentative.active = false;
    if (!tentative.active) {
      if (free_slot == nullptr) free_slot = &tentative;
      continue;
    }
    if (std::fabs(tentative.s_mm - s_mm) <= config_.tracking.match_gate_mm) match = &tentative;
  }
  if (match == nullptr) {
    if (free_slot == nullptr) return false;  // flooded with phantoms: counted, not adopted
    *free_slot = Tentative{true, s_mm, 1, time_ns, sequence};
    return kConfirmFrames <= 1;
  }
  match->s_mm = s_mm;
  match->last_seen_ns = time_ns;
  // Several blobs of one frame at one place are one sighting: a flooding or glitching camera
  // repeating a detection must not confirm it within a single frame.
  if (match->last_sequence == sequence) return false;
  match->last_sequence = sequence;
  if (++match->hits < kConfirmFrames) return false;
  match->active = false;
  return true;
}

float Tracker::travel_at_mm(float s_mm) const {
  return carrying_speed(config_, s_mm, [this](DriveId drive) { return travel_mm(drive); });
}

float Tracker::speed_at_mps(const InputImage& in, float s_mm) const {
  return carrying_speed(config_, s_mm,
                        [&in](DriveId drive) { return in.drives[index(drive)].speed_mps; });
}

Item* Tracker::create(std::int64_t time_ns, float s_mm, bool adopted) {
  for (Item& item : items_) {
    if (item.active) continue;
    item = Item{};
    item.active = true;
    item.id = next_id_++;
    item.s_mm = s_mm;
    item.adopted = adopted;
    item.length_mm = config_.tracking.nominal_length_mm;
    item.record.id = item.id;
    item.record.created_ns = time_ns;
    ++active_count_;
    return &item;
  }
  ++overflows_;
  return nullptr;
}

Item* Tracker::nearest_item(float s_mm, float gate_mm) {
  Item* best = nullptr;
  float best_distance = gate_mm;
  for (Item& item : items_) {
    if (!item.active) continue;
    const float distance = std::fabs(item.s_mm - s_mm);
    if (distance <= best_distance) {
      best_distance = distance;
      best = &item;
    }
  }
  return best;
}

FrameIntake Tracker::ingest(const InputImage& in, CameraId camera, EventRing& events) {
  FrameIntake intake;
  const std::size_t c = index(camera);
  const CameraFrame& frame = in.cameras[c];
  if (frame.sequence == last_sequence_[c]) return intake;
  last_sequence_[c] = frame.sequence;
  intake.new_frame = true;
  ++frames_;
  const auto source = static_cast<std::uint8_t>(c);
  const CameraMount& mount = config_.cameras[c];

  const auto refuse_frame = [&](EventCode code, float value) {
    intake.rejected = static_cast<std::uint16_t>(std::max<int>(frame.count, 1));
    rejected_estimates_ += intake.rejected;
    emit(events, in.time_ns, code, 0, source, value);
    return intake;
  };
  if (has_frame_[c] && frame.frame_time_ns < last_frame_time_ns_[c]) {
    return refuse_frame(EventCode::kFrameOutOfOrder,
                        static_cast<float>(last_frame_time_ns_[c] - frame.frame_time_ns) / kNsPerS);
  }
  const float age_s = static_cast<float>(in.time_ns - frame.frame_time_ns) / kNsPerS;
  if (age_s < 0.0F) return refuse_frame(EventCode::kEstimateOutOfRange, age_s);  // from the future
  last_frame_time_ns_[c] = frame.frame_time_ns;
  has_frame_[c] = true;
  if (age_s > mount.max_age_s) return refuse_frame(EventCode::kEstimateStale, age_s);

  std::size_t count = frame.count;
  if (count > kMaxEstimatesPerFrame) {
    intake.flooded = true;
    emit(events, in.time_ns, EventCode::kEstimateFlood, 0, source, static_cast<float>(count));
    count = kMaxEstimatesPerFrame;
  }

  std::array<std::uint32_t, kMaxEstimatesPerFrame> matched_ids{};
  std::size_t matched_count = 0;
  for (std::size_t e = 0; e < count; ++e) {
    const FilletEstimate& estimate = frame.estimates[e];
    if (!finite(estimate)) {
      ++intake.rejected;
      emit(events, in.time_ns, EventCode::kEstimateNotFinite, 0, source, 0.0F);
      continue;
    }
    const bool in_range =
        std::fabs(estimate.x_mm) <= 0.5F * mount.field_of_view_mm + kFieldOfViewMarginMm &&
        std::fabs(estimate.y_mm) <= kMaxLateralMm && estimate.confidence >= 0.0F &&
        estimate.confidence <= 1.0F &&
        std::fabs(estimate.angle_rad) <= std::numbers::pi_v<float> + kAngleSlackRad;
    if (!in_range) {
      ++intake.rejected;
      emit(events, in.time_ns, EventCode::kEstimateOutOfRange, 0, source, estimate.x_mm);
      continue;
    }
    // Where the detected item is now: the frame is age_s old and the belt kept moving.
    float s_now = mount.s_mm + estimate.x_mm;
    s_now += 1000.0F * speed_at_mps(in, s_now) * age_s;

    Item* item =
        nearest_item(s_now, camera == CameraId::kPosition ? config_.tracking.plates_gate_mm
                                                          : config_.tracking.match_gate_mm);
    if (item != nullptr && std::find(matched_ids.begin(), matched_ids.begin() + matched_count,
                                     item->id) != matched_ids.begin() + matched_count) {
      ++duplicates_;
      emit(events, in.time_ns, EventCode::kDuplicateDetection, item->id, source, estimate.x_mm);
      // A second blob on one item means the camera saw two fillets there.
      item->evidence[c].not_singulated_weight += 1.0F;
      continue;
    }
    if (item == nullptr) {
      ++intake.unmatched;
      ++unmatched_;
      emit(events, in.time_ns, EventCode::kDetectionUnmatched, 0, source, estimate.x_mm);
      const bool must_adopt = camera == CameraId::kOrientation || camera == CameraId::kPosition ||
                              camera == CameraId::kFinal;
      if (!must_adopt || !confirm_unmatched(camera, s_now, in.time_ns, frame.sequence)) continue;
      item = create(in.time_ns, s_now, true);
      if (item == nullptr) continue;
      ++adopted_;
      item->reject_pending = true;
      item->reject_reason = Outcome::kRejectedUntracked;
      emit(events, in.time_ns, EventCode::kItemAdopted, item->id, source, s_now);
    }
    matched_ids[matched_count++] = item->id;
    item->s_mm = s_now;  // the camera is the better position sensor: belts slip
    item->evidence[c].add(estimate);
    item->measured_angle_rad = estimate.angle_rad;
    item->measured_angle_ns = frame.frame_time_ns;
    item->measured_angle_new = true;
  }
  rejected_estimates_ += intake.rejected;
  return intake;
}

void Tracker::close(Item& item, std::int64_t time_ns, Outcome outcome, LostReason reason,
                    RecordRing& records, EventRing& events) {
  if (!item.active) return;
  item.record.closed_ns = time_ns;
  item.record.outcome = outcome;
  item.record.lost_reason = reason;
  item.record.hand = item.hand;
  item.record.multilane_unit = item.multilane_unit;
  item.record.flip_plate1 = item.flip1;
  item.record.flip_plate2 = item.flip2;
  records.push(item.record);
  ++outcome_counts_[static_cast<std::size_t>(outcome)];
  emit(events, time_ns, EventCode::kItemClosed, item.id, static_cast<std::uint8_t>(outcome),
       item.s_mm);
  item.active = false;
  --active_count_;
}

}  // namespace fl::logic
