// Cameras: exposure scheduling, detections with noise and misclassification, delivery after
// the latency, and the injectable faults.
#include "fl/twin/sensors/camera_emulator.hpp"

#include <algorithm>
#include <cstring>
#include <limits>

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

// Byte copy, padding included: frames end up in the image, which is compared byte for byte.
template <typename T>
void copy_bytes(T& to, const T& from) {
  std::memcpy(static_cast<void*>(&to), static_cast<const void*>(&from), sizeof(T));
}

}  // namespace

CameraEmulator::CameraEmulator(const std::array<CameraMount, kCameraCount>& mounts,
                               const std::array<CameraModelConfig, kCameraCount>& models,
                               std::int64_t step_ns)
    : mounts_(mounts), models_(models), step_ns_(std::max<std::int64_t>(1, step_ns)) {
  reset(0, 0);
}

void CameraEmulator::reset(std::uint64_t seed, std::int64_t time_ns) {
  counters_ = CameraCounters{};
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    rngs_[c].seed_with(stream_seed(seed, kCameraStreamBase + c));
    CameraState& state = cameras_[c];
    state.sequence = 0;
    state.pending_count = 0;
    state.last_frame_time_ns = 0;
    schedule_exposure(c, time_ns, true);
  }
}

void CameraEmulator::schedule_exposure(std::size_t c, std::int64_t time_ns, bool first) {
  CameraState& state = cameras_[c];
  TwinRng& rng = rngs_[c];
  const std::int64_t period_ns = std::max(step_ns_, to_ns(mounts_[c].period_s));
  if (first) {
    // Free-running cameras: a random phase each, not synchronised with each other.
    state.next_nominal_ns =
        time_ns + static_cast<std::int64_t>(rng.uniform() * static_cast<double>(period_ns));
  } else {
    state.next_nominal_ns += period_ns;
  }
  const double quarter_s = 0.25 * static_cast<double>(period_ns) * 1e-9;
  const double jitter_s =
      std::clamp(static_cast<double>(models_[c].jitter_s) * rng.normal(), -quarter_s, quarter_s);
  state.next_exposure_ns = state.next_nominal_ns + to_ns(jitter_s);
}

void CameraEmulator::capture_due(std::int64_t time_ns, const CameraScene& scene,
                                 const CameraFaultSet& faults) {
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    if (time_ns < cameras_[c].next_exposure_ns) continue;
    capture(c, time_ns, scene, faults[c]);
    schedule_exposure(c, time_ns, false);
  }
}

void CameraEmulator::capture(std::size_t c, std::int64_t time_ns, const CameraScene& scene,
                             const CameraFaults& faults) {
  CameraState& state = cameras_[c];
  TwinRng& rng = rngs_[c];
  const CameraModelConfig& config = models_[c];
  const CameraMount& mount = mounts_[c];
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
      copy_bytes(state.pending[k - 1], state.pending[k]);
    }
    --state.pending_count;
    ++counters_.frames_superseded[c];
  }
  PendingFrame& pending = state.pending[state.pending_count++];
  std::memset(static_cast<void*>(&pending.frame), 0, sizeof(CameraFrame));
  CameraFrame& frame = pending.frame;
  frame.frame_time_ns = time_ns;
  pending.publish_ns = time_ns + to_ns(config.latency_s);
  pending.out_of_order = order_draw < faults.out_of_order_prob;

  const double half_view_mm = 0.5 * static_cast<double>(mount.field_of_view_mm);
  std::uint8_t count = 0;
  for (std::size_t item = 0; item < scene.size(); ++item) {
    const double x_mm = scene.s_mm(item) - mount.s_mm;
    if (std::abs(x_mm) > half_view_mm) continue;
    if (rng.bernoulli(config.miss_prob)) continue;
    if (count == kMaxEstimatesPerFrame) {
      ++counters_.detections_truncated[c];
      continue;
    }
    const CameraTruth truth = scene.truth(item);
    FilletEstimate& estimate = frame.estimates[count++];
    estimate.x_mm = static_cast<float>(x_mm + config.position_sigma_mm * rng.normal());
    estimate.y_mm = static_cast<float>(truth.y_mm + config.position_sigma_mm * rng.normal());
    estimate.angle_rad =
        static_cast<float>(wrap_angle_rad(truth.angle_rad + config.angle_sigma_rad * rng.normal()));
    // A float rounding of pi must stay inside (-pi, pi].
    if (estimate.angle_rad <= -std::numbers::pi_v<float>) {
      estimate.angle_rad = std::numbers::pi_v<float>;
    }
    estimate.singulated =
        rng.bernoulli(config.singulation_error_prob) ? truth.touching : !truth.touching;
    bool doubtful = truth.touching;  // a blob of two is classified with less confidence
    if (config.classifies) {
      estimate.hand = truth.hand;
      estimate.side = truth.side;
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

void CameraEmulator::publish(std::int64_t time_ns, const CameraFaultSet& faults,
                             std::array<CameraFrame, kCameraCount>& frames) {
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    CameraState& state = cameras_[c];
    std::size_t ready = 0;
    while (ready < state.pending_count && state.pending[ready].publish_ns <= time_ns) ++ready;
    if (ready == 0) continue;
    // Only the newest frame reaches the image; an older one ready in the same step is lost.
    counters_.frames_superseded[c] += ready - 1;
    PendingFrame& newest = state.pending[ready - 1];
    if (faults[c].stale) {
      counters_.frames_dropped[c] += 1;
    } else {
      CameraFrame& frame = newest.frame;
      if (newest.out_of_order && state.sequence > 0) {
        const std::int64_t period_ns = to_ns(mounts_[c].period_s);
        frame.frame_time_ns = state.last_frame_time_ns - std::max<std::int64_t>(period_ns, 1);
      }
      frame.sequence = ++state.sequence;
      state.last_frame_time_ns = frame.frame_time_ns;
      copy_bytes(frames[c], frame);
      // A corrupt camera node: the count claims more detections than a frame can hold; the
      // entries beyond the real ones are whatever the buffer held. No draw, so the random
      // sequence (and every recorded golden run) stays the same with the fault off.
      if (faults[c].flood) frames[c].count = std::numeric_limits<std::uint8_t>::max();
      ++counters_.frames_published[c];
    }
    for (std::size_t k = ready; k < state.pending_count; ++k) {
      copy_bytes(state.pending[k - ready], state.pending[k]);
    }
    state.pending_count -= ready;
  }
}

}  // namespace fl
