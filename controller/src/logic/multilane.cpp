// The two multilane orienting units: which unit turns which item, and the angle loop.
#include <algorithm>
#include <cmath>

#include "stations.hpp"

namespace fl::logic {
namespace {

constexpr DriveId kLeft[MultilaneStation::kUnits] = {DriveId::kMultilane1Left,
                                                     DriveId::kMultilane2Left};
constexpr DriveId kRight[MultilaneStation::kUnits] = {DriveId::kMultilane1Right,
                                                      DriveId::kMultilane2Right};

// Online estimate of the turn gain (item rotation over the encoders' rotation). A long body
// on two belts turns by Coulomb friction, not by rolling: its rate is a fraction of the
// belts' differential over the track that depends on the heading (DEM twin: about 0.16 of
// it near heading 0, 0.67 at 0.6 rad), and slip or a worn track change it on a real line.
//
// Forgetting per frame pair: five frames of memory (0.125 s at 25 ms), shorter than the
// time the item takes to turn through the heading range where the gain doubles.
constexpr float kGainForgetting = 0.8F;
// Weight of the model's gain 1 in the fit, in squared encoder rotation: one frame at
// 2 rad/s of belt rate (0.05 rad). A turning unit (0.16 rad per frame at full differential)
// outweighs it at once; a unit at rest (camera noise only) falls back to the model.
constexpr float kGainPriorWeightRad2 = 0.05F * 0.05F;
// Bounds of the estimate: under 0.1 the 1/gain scaling would ask for differentials far
// beyond the drives' anyway; over 4 the belts would turn the item faster than four times
// their rolling rate, which no friction contact does. Both only guard against noise.
constexpr float kMinTurnGain = 0.1F;
constexpr float kMaxTurnGain = 4.0F;
// Frame pairs further apart than this (missed frames) are not used: the gain changes with
// the heading, and a long baseline would mix headings.
constexpr std::int64_t kMaxGainSampleNs = 100'000'000;
// Learning rate of the transfer bias, one sample per item: about ten items of memory.
constexpr float kTransferBiasRate = 0.1F;

}  // namespace

UnitCommand orient_command(const MultilaneConfig& config, const DriveLimits& limits,
                           float error_rad, float turn_gain, float blind_s) {
  const float gain = std::clamp(turn_gain, kMinTurnGain, kMaxTurnGain);
  const float track_m = 0.001F * config.belt_track_mm;
  // Rates here are the belts' rate, differential over track; the item turns at gain times it.
  const float max_rate_radps = config.max_differential_mps / track_m;
  // Both belts ramp at the drive limit in opposite senses, so the differential speed, and
  // with it the turn rate, changes at twice the drive's acceleration.
  const float max_turn_accel_radps2 = 2.0F * limits.max_accel_mps2 / track_m;
  // Fastest rate from which the turn can still stop at the target (bang-bang envelope),
  // so the loop arrives without overshoot despite the ramp. The item covers gain times the
  // belts' rotation: from belt rate w it stops after gain * w^2 / (2 a). A low learnt gain
  // does not widen the envelope: a fillet that stuck can free itself and follow the belts
  // fully (the DEM twin shows such jumps), so the envelope assumes the rolling model unless
  // the item turns even faster. And such a jump is seen only with the next frame: the
  // envelope also leaves room for the rotation until then, w * T + w^2 / (2 a') <= |e|
  // with a' = a / max(gain, 1) and T = blind_s.
  const float braking_accel_radps2 = max_turn_accel_radps2 / std::max(gain, 1.0F);
  const float braking_rate_radps =
      braking_accel_radps2 *
      (std::sqrt(blind_s * blind_s + 2.0F * std::fabs(error_rad) / braking_accel_radps2) - blind_s);
  // The proportional part asks for an item rate of gain_per_s * e: the loop keeps its
  // bandwidth whatever share of the belts' rate the item follows.
  const float proportional_radps = config.angle_gain_per_s * std::fabs(error_rad) / gain;
  const float rate_radps =
      std::copysign(std::min({proportional_radps, braking_rate_radps, max_rate_radps}), error_rad);
  // Counter-clockwise (positive) turns need the right belt (y < 0 side) faster.
  const float half_differential_mps = 0.5F * rate_radps * track_m;
  UnitCommand command;
  command.left_mps =
      std::clamp(config.common_speed_mps - half_differential_mps, 0.0F, limits.max_speed_mps);
  command.right_mps =
      std::clamp(config.common_speed_mps + half_differential_mps, 0.0F, limits.max_speed_mps);
  return command;
}

void MultilaneStation::reset() {
  rotation_rad_.fill(0.0F);
  for (auto& history : rotation_history_) history.fill(0.0F);
  time_history_.fill(0);
  history_head_ = 0;
  history_size_ = 0;
  controlled_.fill(0);
  transfer_bias_rad_ = 0.0F;
}

float MultilaneStation::aim_rad(const Item& item) const {
  return item.target_angle_rad - std::copysign(transfer_bias_rad_, item.target_angle_rad);
}

int MultilaneStation::unit_at(float s_mm) const {
  for (std::size_t unit = 0; unit < kUnits; ++unit) {
    const BeltSection& section = config_.sections[index(kLeft[unit])];
    if (s_mm >= section.start_mm && s_mm < section.end_mm) return static_cast<int>(unit);
  }
  return -1;
}

void MultilaneStation::integrate_rotation(const ScanContext& ctx) {
  const float track_mm = config_.multilane.belt_track_mm;
  for (std::size_t unit = 0; unit < kUnits; ++unit) {
    const float differential_mm =
        ctx.tracker.travel_mm(kRight[unit]) - ctx.tracker.travel_mm(kLeft[unit]);
    rotation_history_[unit][history_head_] = rotation_rad_[unit];  // before this scan's travel
    rotation_rad_[unit] += differential_mm / track_mm;
  }
  time_history_[history_head_] = ctx.in.time_ns;
  history_head_ = (history_head_ + 1) % kHistory;
  history_size_ = std::min(history_size_ + 1, kHistory);
}

float MultilaneStation::rotation_since_rad(std::size_t unit, std::int64_t frame_time_ns) const {
  // A scan's encoder travel happened between the previous scan and its own time, so the
  // rotation at the exposure is the value before the first scan after it. Frames older
  // than the history use its oldest entry; they are refused as stale long before.
  float at_frame = rotation_rad_[unit];
  for (std::size_t back = 1; back <= history_size_; ++back) {
    const std::size_t slot = (history_head_ + kHistory - back) % kHistory;
    if (time_history_[slot] <= frame_time_ns) break;
    at_frame = rotation_history_[unit][slot];
  }
  return rotation_rad_[unit] - at_frame;
}

void MultilaneStation::learn_turn_gain(Item& item, std::size_t unit,
                                       float since_exposure_rad) const {
  const int unit_index = static_cast<int>(unit);
  const std::int64_t gap_ns = item.measured_angle_ns - item.gain_frame_ns;
  if (item.gain_frame_unit == unit_index && gap_ns > 0 && gap_ns <= kMaxGainSampleNs) {
    // Encoder rotation between the two exposures, and what the camera saw the item turn.
    const float encoder_rad = rotation_since_rad(unit, item.gain_frame_ns) - since_exposure_rad;
    const float measured_rad = wrap_angle(item.measured_angle_rad - item.gain_frame_angle_rad);
    if (item.turn_gain_weight_rad2 <= 0.0F) {
      item.turn_gain_weight_rad2 = kGainPriorWeightRad2;  // the model: gain 1
      item.turn_gain_sum_rad2 = kGainPriorWeightRad2;
    }
    // Forgetting, with the prior topped up to its weight so that a unit at rest drifts
    // back to the model instead of fitting camera noise.
    item.turn_gain_weight_rad2 = kGainForgetting * item.turn_gain_weight_rad2 +
                                 (1.0F - kGainForgetting) * kGainPriorWeightRad2 +
                                 encoder_rad * encoder_rad;
    item.turn_gain_sum_rad2 = kGainForgetting * item.turn_gain_sum_rad2 +
                              (1.0F - kGainForgetting) * kGainPriorWeightRad2 +
                              encoder_rad * measured_rad;
    item.turn_gain = std::clamp(item.turn_gain_sum_rad2 / item.turn_gain_weight_rad2, kMinTurnGain,
                                kMaxTurnGain);
  }
  item.gain_frame_angle_rad = item.measured_angle_rad;
  item.gain_frame_ns = item.measured_angle_ns;
  item.gain_frame_unit = static_cast<std::int8_t>(unit_index);
}

void MultilaneStation::learn_transfer_bias(Item& item) {
  // The first frame of the final camera against the heading unit 2 left the item at. The
  // DEM twin turns items 0 to 5 degrees further (more turned) on the way, the hand-over
  // onto the squeeze belt and the roller; the units aim short by the mean of it. The bias
  // is signed towards more turned, so it holds for both hands (mirrored targets).
  const CameraMount& final_camera = config_.cameras[index(CameraId::kFinal)];
  if (!item.exit_angle_known ||
      item.s_mm < final_camera.s_mm - 0.5F * final_camera.field_of_view_mm) {
    return;
  }
  item.exit_angle_known = false;
  const float drift_rad = std::copysign(1.0F, item.target_angle_rad) *
                          wrap_angle(item.measured_angle_rad - item.exit_angle_rad);
  // Only half the placement tolerance is ever given to the bias: a larger rotation on the
  // way is a fault of the line, not something to aim around.
  const float limit_rad = 0.5F * config_.tolerance.angle_tol_rad;
  transfer_bias_rad_ +=
      kTransferBiasRate * (std::clamp(drift_rad, -limit_rad, limit_rad) - transfer_bias_rad_);
}

void MultilaneStation::assign(const ScanContext& ctx) {
  const BeltSection& first = config_.sections[index(kLeft[0])];
  for (Item& item : ctx.tracker.items()) {
    if (!item.active || item.multilane_unit >= 0 || item.reject_pending || !item.angle_known) {
      continue;
    }
    if (item.s_mm < first.start_mm - 0.5F * item.length_mm) continue;
    // Unit 1 is busy while an item assigned to it has not finished turning on it.
    bool unit1_busy = false;
    for (const Item& other : ctx.tracker.items()) {
      if (other.active && other.id != item.id && other.multilane_unit == 0 &&
          !other.orienting_done && other.s_mm < first.end_mm + 0.5F * other.length_mm) {
        unit1_busy = true;
      }
    }
    item.multilane_unit = unit1_busy ? 1 : 0;
  }
}

void MultilaneStation::update(const ScanContext& ctx, OutputImage& out) {
  assign(ctx);
  // Bring every item's heading forward: a fresh measurement, latency compensated by the
  // rotation the unit under it made since the exposure, or else the encoders' rotation.
  for (Item& item : ctx.tracker.items()) {
    if (!item.active) continue;
    const int unit = unit_at(item.s_mm);
    if (item.measured_angle_new && item.classified && item.passed_plate2) {
      item.measured_angle_new = false;
      item.angle_rad = item.measured_angle_rad;
      if (unit >= 0) {
        const std::size_t u = static_cast<std::size_t>(unit);
        const float since_exposure_rad = rotation_since_rad(u, item.measured_angle_ns);
        learn_turn_gain(item, u, since_exposure_rad);
        item.angle_rad += item.turn_gain * since_exposure_rad;
      } else {
        item.gain_frame_unit = -1;  // off the units: the next sample starts afresh
        learn_transfer_bias(item);
      }
      item.angle_rad = wrap_angle(item.angle_rad);
      item.angle_known = true;
      if (unit >= 0) {
        // Settled within the done band; reopened only beyond half the placement tolerance.
        // The camera's noise (0.015 rad) is of the order of the band (0.02 rad): without
        // the hysteresis a settled item flickers back into control and holds its unit,
        // so that the next item has to share a unit with it.
        const float error_rad = std::fabs(wrap_angle(aim_rad(item) - item.angle_rad));
        if (error_rad < config_.multilane.angle_done_rad) item.orienting_done = true;
        if (error_rad > 0.5F * config_.tolerance.angle_tol_rad) item.orienting_done = false;
      }
    } else if (unit >= 0) {
      // Between frames the encoders alone, scaled by what the item has been following.
      const std::size_t u = static_cast<std::size_t>(unit);
      const float scan_rotation_rad =
          (ctx.tracker.travel_mm(kRight[u]) - ctx.tracker.travel_mm(kLeft[u])) /
          config_.multilane.belt_track_mm;
      item.angle_rad = wrap_angle(item.angle_rad + item.turn_gain * scan_rotation_rad);
    }
    if (unit == 1) {
      // Only settled items measure the way to the final camera, not the loop's leftovers.
      item.exit_angle_rad = item.angle_rad;
      item.exit_angle_known = item.orienting_done;
    }
  }

  // An item within this of its target is acceptable: a unit does not spoil it for another.
  const float acceptable_rad = 0.5F * config_.tolerance.angle_tol_rad;
  for (std::size_t unit = 0; unit < kUnits; ++unit) {
    // The unit turns the item assigned to it, else one that the first unit did not finish
    // (the most downstream: it has the least of the unit left). Its belts turn every item
    // on them alike, so it holds while an acceptable item downstream of the one it would
    // turn is still on it: that one has no unit left to recover on, the other has.
    Item* assigned = nullptr;
    Item* carried = nullptr;
    float acceptable_s_mm = -1e9F;  // most downstream acceptable item on this unit
    for (Item& item : ctx.tracker.items()) {
      if (!item.active || item.reject_pending || item.multilane_unit < 0 ||
          unit_at(item.s_mm) != static_cast<int>(unit)) {
        continue;
      }
      const float error_rad = std::fabs(wrap_angle(aim_rad(item) - item.angle_rad));
      if (item.orienting_done || error_rad < acceptable_rad) {
        acceptable_s_mm = std::max(acceptable_s_mm, item.s_mm);
      }
      if (item.orienting_done) continue;
      const bool assigned_here = item.multilane_unit == static_cast<int>(unit);
      if (!assigned_here && unit == 0) continue;  // unit 1 finishes nothing for unit 2
      Item*& slot = assigned_here ? assigned : carried;
      if (slot == nullptr || item.s_mm > slot->s_mm) slot = &item;
    }
    Item* controlled = assigned != nullptr ? assigned : carried;
    if (controlled != nullptr && acceptable_s_mm > controlled->s_mm) controlled = nullptr;
    controlled_[unit] = controlled != nullptr ? controlled->id : 0;
    const DriveLimits& limits = config_.limits[index(kLeft[unit])];
    UnitCommand command{config_.multilane.common_speed_mps, config_.multilane.common_speed_mps};
    if (controlled != nullptr) {
      const float error_rad = wrap_angle(aim_rad(*controlled) - controlled->angle_rad);
      // The heading runs on its prediction for up to a frame period; a frame is read at the
      // first scan after its delivery and the command acts from the scan after that.
      const CameraId camera = unit == 0 ? CameraId::kMultilane1 : CameraId::kMultilane2;
      const float blind_s =
          config_.cameras[index(camera)].period_s + 2.0F * config_.watchdog.cycle_period_s;
      command =
          orient_command(config_.multilane, limits, error_rad, controlled->turn_gain, blind_s);
    }
    set_drive(out, kLeft[unit], config_, command.left_mps, ctx.running);
    set_drive(out, kRight[unit], config_, command.right_mps, ctx.running);
  }
}

}  // namespace fl::logic
