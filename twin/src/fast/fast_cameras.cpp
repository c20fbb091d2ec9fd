// Cameras: exposures at the mount's period with jitter, detections of the bodies in view in
// camera-local coordinates with noise and misclassification, delivery after the latency,
// and the injectable faults (dropped frames, NaN fields, stale camera, duplicates,
// out-of-order timestamps, phantom detections).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include "fl/twin/fast_plant.hpp"

namespace fl {
namespace {

std::int64_t to_ns(double seconds) { return std::llround(seconds * 1e9); }

Hand other_hand(Hand hand) {
  if (hand == Hand::kLeft) return Hand::kRight;
  if (hand == Hand::kRight) return Hand::kLeft;
  return hand;
}

SideUp other_side(SideUp side) {
  if (side == SideUp::kSkin) return SideUp::kBone;
  if (side == SideUp::kBone) return SideUp::kSkin;
  return side;
}

}  // namespace

// Byte copy, padding included: frames end up in the image, which is compared byte for byte.
void FastPlant::copy_pending(PendingFrame& to, const PendingFrame& from) {
  std::memcpy(static_cast<void*>(&to), static_cast<const void*>(&from), sizeof(PendingFrame));
}

void FastPlant::schedule_exposure(CameraId camera, bool first) {
  CameraState& state = cameras_[index(camera)];
  FastRng& rng = camera_rngs_[index(camera)];
  const std::int64_t period_ns = std::max(step_ns_, to_ns(line_.cameras[index(camera)].period_s));
  if (first) {
    // Free-running cameras: a random phase each, not synchronised with each other.
    state.next_nominal_ns =
        state_.time_ns + static_cast<std::int64_t>(rng.uniform() * static_cast<double>(period_ns));
  } else {
    state.next_nominal_ns += period_ns;
  }
  const double quarter_s = 0.25 * static_cast<double>(period_ns) * 1e-9;
  const double jitter_s =
      std::clamp(static_cast<double>(config_.cameras[index(camera)].jitter_s) * rng.normal(),
                 -quarter_s, quarter_s);
  state.next_exposure_ns = state.next_nominal_ns + to_ns(jitter_s);
}

void FastPlant::capture_frames() {
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    if (state_.time_ns < cameras_[c].next_exposure_ns) continue;
    capture(static_cast<CameraId>(c));
    schedule_exposure(static_cast<CameraId>(c), false);
  }
}

void FastPlant::capture(CameraId camera) {
  const std::size_t c = index(camera);
  CameraState& state = cameras_[c];
  FastRng& rng = camera_rngs_[c];
  const FastCameraConfig& config = config_.cameras[c];
  const FastCameraFaults& faults = faults_.cameras[c];
  const CameraMount& mount = line_.cameras[c];
  ++counters_.frames_captured[c];

  // Fault draws happen for every frame, so that switching a fault on changes its outcomes
  // but not the rest of the camera's random sequence.
  const double drop_draw = rng.uniform();
  const double duplicate_draw = rng.uniform();
  const double phantom_draw = rng.uniform();
  const double nan_draw = rng.uniform();
  const double order_draw = rng.uniform();
  if (faults.stale || drop_draw < faults.drop_frame_prob) {
    ++counters_.frames_dropped[c];
    return;
  }

  if (state.pending_count == kPendingFrames) {
    // Never with sane latencies: the oldest undelivered frame gives way.
    for (std::size_t k = 1; k < kPendingFrames; ++k) {
      copy_pending(state.pending[k - 1], state.pending[k]);
    }
    --state.pending_count;
    ++counters_.frames_superseded[c];
  }
  PendingFrame& pending = state.pending[state.pending_count++];
  std::memset(static_cast<void*>(&pending.frame), 0, sizeof(CameraFrame));
  CameraFrame& frame = pending.frame;
  frame.frame_time_ns = state_.time_ns;
  pending.publish_ns = state_.time_ns + to_ns(config.latency_s);
  pending.out_of_order = order_draw < faults.out_of_order_prob;

  const double half_view_mm = 0.5 * static_cast<double>(mount.field_of_view_mm);
  std::uint8_t count = 0;
  for (const FilletBody& body : bodies_) {
    const double x_mm = body.s_mm - mount.s_mm;
    if (std::abs(x_mm) > half_view_mm) continue;
    if (rng.bernoulli(config.miss_prob)) continue;
    if (count == kMaxEstimatesPerFrame) {
      ++counters_.detections_truncated[c];
      continue;
    }
    FilletEstimate& estimate = frame.estimates[count++];
    estimate.x_mm = static_cast<float>(x_mm + config.position_sigma_mm * rng.normal());
    estimate.y_mm = static_cast<float>(body.y_mm + config.position_sigma_mm * rng.normal());
    estimate.angle_rad =
        static_cast<float>(wrap_angle_rad(body.angle_rad + config.angle_sigma_rad * rng.normal()));
    // A float rounding of pi must stay inside (-pi, pi].
    if (estimate.angle_rad <= -std::numbers::pi_v<float>) {
      estimate.angle_rad = std::numbers::pi_v<float>;
    }
    const bool touching = body.member_count > 1;
    estimate.singulated = rng.bernoulli(config.singulation_error_prob) ? touching : !touching;
    bool doubtful = touching;  // a blob of two is classified with less confidence
    if (config.classifies) {
      estimate.hand = body.members[0].hand;
      estimate.side = body.members[0].side;
      if (rng.bernoulli(config.hand_flip_prob)) {
        estimate.hand = other_hand(estimate.hand);
        doubtful = true;
      }
      if (rng.bernoulli(config.side_flip_prob)) {
        estimate.side = other_side(estimate.side);
        doubtful = true;
      }
    } else {
      estimate.hand = Hand::kUnknown;
      estimate.side = SideUp::kUnknown;
    }
    estimate.confidence = static_cast<float>(
        doubtful
            ? rng.uniform(config.confidence_bad_min, static_cast<double>(config.confidence_bad_max))
            : rng.uniform(config.confidence_ok_min, static_cast<double>(config.confidence_ok_max)));
  }

  // Faults inside the frame.
  if (duplicate_draw < faults.duplicate_prob && count > 0 && count < kMaxEstimatesPerFrame) {
    FilletEstimate copy = frame.estimates[rng.below(count)];
    copy.x_mm += static_cast<float>(rng.normal());
    copy.y_mm += static_cast<float>(rng.normal());
    frame.estimates[count++] = copy;
  }
  if (phantom_draw < faults.phantom_prob && count < kMaxEstimatesPerFrame) {
    FilletEstimate& ghost = frame.estimates[count++];
    ghost.x_mm = static_cast<float>(rng.uniform(-half_view_mm, half_view_mm));
    ghost.y_mm = static_cast<float>(rng.uniform(-100.0, 100.0));
    ghost.angle_rad = static_cast<float>(rng.uniform(-std::numbers::pi, std::numbers::pi));
    ghost.confidence = static_cast<float>(rng.uniform(0.3, 0.9));
    ghost.singulated = true;
    ghost.hand =
        config.classifies ? (rng.bernoulli(0.5) ? Hand::kLeft : Hand::kRight) : Hand::kUnknown;
    ghost.side =
        config.classifies ? (rng.bernoulli(0.5) ? SideUp::kSkin : SideUp::kBone) : SideUp::kUnknown;
  }
  if (nan_draw < faults.nan_prob && count > 0) {
    FilletEstimate& bad = frame.estimates[rng.below(count)];
    constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
    switch (rng.below(4)) {
      case 0:
        bad.x_mm = kNan;
        break;
      case 1:
        bad.y_mm = kNan;
        break;
      case 2:
        bad.angle_rad = kNan;
        break;
      default:
        bad.confidence = kNan;
        break;
    }
  }
  frame.count = count;
}

void FastPlant::publish_frames() {
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    CameraState& state = cameras_[c];
    std::size_t ready = 0;
    while (ready < state.pending_count && state.pending[ready].publish_ns <= state_.time_ns) {
      ++ready;
    }
    if (ready == 0) continue;
    // Only the newest frame reaches the image; an older one ready in the same step is lost.
    counters_.frames_superseded[c] += ready - 1;
    PendingFrame& newest = state.pending[ready - 1];
    if (faults_.cameras[c].stale) {
      counters_.frames_dropped[c] += 1;
    } else {
      CameraFrame& frame = newest.frame;
      if (newest.out_of_order && state.sequence > 0) {
        const std::int64_t period_ns = to_ns(line_.cameras[c].period_s);
        frame.frame_time_ns = state.last_frame_time_ns - std::max<std::int64_t>(period_ns, 1);
      }
      frame.sequence = ++state.sequence;
      state.last_frame_time_ns = frame.frame_time_ns;
      std::memcpy(static_cast<void*>(&image_.cameras[c]), static_cast<const void*>(&frame),
                  sizeof(CameraFrame));
      ++counters_.frames_published[c];
    }
    for (std::size_t k = ready; k < state.pending_count; ++k) {
      copy_pending(state.pending[k - ready], state.pending[k]);
    }
    state.pending_count -= ready;
  }
}

}  // namespace fl
