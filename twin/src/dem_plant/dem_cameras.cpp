// Cameras of the DEM plant: the fast plant's camera model (fast_cameras.cpp: exposure at the
// mount's period with jitter, noise, misses, misclassification, confidences, faults, delivery
// after the latency) applied to each fillet's ground-truth rigid pose. The logic is the fast
// plant's, copied because it is private to FastPlant; the detections differ: one estimate per
// fillet, not singulated while any of its spheres touches another fillet's.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include "fl/twin/dem_plant/dem_plant.hpp"

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

template <typename T>
void copy_bytes(T& to, const T& from) {
  std::memcpy(static_cast<void*>(&to), static_cast<const void*>(&from), sizeof(T));
}

}  // namespace

void DemPlant::schedule_exposure(CameraId camera, bool first) {
  CameraState& state = cameras_[index(camera)];
  FastRng& rng = camera_rngs_[index(camera)];
  const std::int64_t period_ns = std::max(step_ns_, to_ns(line_.cameras[index(camera)].period_s));
  if (first) {
    state.next_nominal_ns =
        time_ns_ + static_cast<std::int64_t>(rng.uniform() * static_cast<double>(period_ns));
  } else {
    state.next_nominal_ns += period_ns;
  }
  const double quarter_s = 0.25 * static_cast<double>(period_ns) * 1e-9;
  const double jitter_s =
      std::clamp(static_cast<double>(config_.shared.cameras[index(camera)].jitter_s) * rng.normal(),
                 -quarter_s, quarter_s);
  state.next_exposure_ns = state.next_nominal_ns + to_ns(jitter_s);
}

void DemPlant::capture_frames() {
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    if (time_ns_ < cameras_[c].next_exposure_ns) continue;
    capture(static_cast<CameraId>(c));
    schedule_exposure(static_cast<CameraId>(c), false);
  }
}

void DemPlant::capture(CameraId camera) {
  const std::size_t c = index(camera);
  CameraState& state = cameras_[c];
  FastRng& rng = camera_rngs_[c];
  const FastCameraConfig& config = config_.shared.cameras[c];
  const FastCameraFaults& faults = faults_.cameras[c];
  const CameraMount& mount = line_.cameras[c];
  ++counters_.frames_captured[c];
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
    for (std::size_t k = 1; k < kPendingFrames; ++k) {
      copy_bytes(state.pending[k - 1], state.pending[k]);
    }
    --state.pending_count;
    ++counters_.frames_superseded[c];
  }
  PendingFrame& pending = state.pending[state.pending_count++];
  std::memset(static_cast<void*>(&pending.frame), 0, sizeof(CameraFrame));
  CameraFrame& frame = pending.frame;
  frame.frame_time_ns = time_ns_;
  pending.publish_ns = time_ns_ + to_ns(config.latency_s);
  pending.out_of_order = order_draw < faults.out_of_order_prob;

  const double half_view_mm = 0.5 * static_cast<double>(mount.field_of_view_mm);
  std::uint8_t count = 0;
  for (std::size_t f = 0; f < fillets_.size(); ++f) {
    const Fillet& fillet = fillets_[f];
    if (fillet.particles.empty()) continue;
    const double x_mm = fillet.centroid_m.x() * 1000.0 - mount.s_mm;
    if (std::abs(x_mm) > half_view_mm) continue;
    if (rng.bernoulli(config.miss_prob)) continue;
    if (count == kMaxEstimatesPerFrame) {
      ++counters_.detections_truncated[c];
      continue;
    }
    const Pose pose = fit_pose(fillet);
    FilletEstimate& estimate = frame.estimates[count++];
    estimate.x_mm = static_cast<float>(x_mm + config.position_sigma_mm * rng.normal());
    estimate.y_mm = static_cast<float>(fillet.centroid_m.y() * 1000.0 +
                                       config.position_sigma_mm * rng.normal());
    estimate.angle_rad =
        static_cast<float>(wrap_angle_rad(pose.angle_rad + config.angle_sigma_rad * rng.normal()));
    if (estimate.angle_rad <= -std::numbers::pi_v<float>) {
      estimate.angle_rad = std::numbers::pi_v<float>;
    }
    const bool is_touching = touching(f);
    estimate.singulated = rng.bernoulli(config.singulation_error_prob) ? is_touching : !is_touching;
    bool doubtful = is_touching;
    if (config.classifies) {
      estimate.hand =
          templates_[fillet.variant].name.ends_with("_left") ? Hand::kLeft : Hand::kRight;
      estimate.side = pose.side;
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

void DemPlant::publish_frames() {
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    CameraState& state = cameras_[c];
    std::size_t ready = 0;
    while (ready < state.pending_count && state.pending[ready].publish_ns <= time_ns_) ++ready;
    if (ready == 0) continue;
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
      copy_bytes(image_.cameras[c], frame);
      ++counters_.frames_published[c];
    }
    for (std::size_t k = ready; k < state.pending_count; ++k) {
      copy_bytes(state.pending[k - ready], state.pending[k]);
    }
    state.pending_count -= ready;
  }
}

}  // namespace fl
