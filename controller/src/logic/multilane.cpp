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

}  // namespace

UnitCommand orient_command(const MultilaneConfig& config, const DriveLimits& limits,
                           float error_rad) {
  const float track_m = 0.001F * config.belt_track_mm;
  const float max_rate_radps = config.max_differential_mps / track_m;
  // Both belts ramp at the drive limit in opposite senses, so the differential speed, and
  // with it the turn rate, changes at twice the drive's acceleration.
  const float max_turn_accel_radps2 = 2.0F * limits.max_accel_mps2 / track_m;
  // Fastest rate from which the turn can still stop at the target (bang-bang envelope),
  // so the loop arrives without overshoot despite the ramp.
  const float braking_rate_radps = std::sqrt(2.0F * max_turn_accel_radps2 * std::fabs(error_rad));
  const float rate_radps = std::copysign(std::min({config.angle_gain_per_s * std::fabs(error_rad),
                                                   braking_rate_radps, max_rate_radps}),
                                         error_rad);
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
        item.angle_rad +=
            rotation_since_rad(static_cast<std::size_t>(unit), item.measured_angle_ns);
      }
      item.angle_rad = wrap_angle(item.angle_rad);
      item.angle_known = true;
      if (unit >= 0) {
        item.orienting_done = std::fabs(wrap_angle(item.target_angle_rad - item.angle_rad)) <
                              config_.multilane.angle_done_rad;
      }
    } else if (unit >= 0) {
      const std::size_t u = static_cast<std::size_t>(unit);
      const float scan_rotation_rad =
          (ctx.tracker.travel_mm(kRight[u]) - ctx.tracker.travel_mm(kLeft[u])) /
          config_.multilane.belt_track_mm;
      item.angle_rad = wrap_angle(item.angle_rad + scan_rotation_rad);
    }
  }

  for (std::size_t unit = 0; unit < kUnits; ++unit) {
    // The unit turns the item assigned to it, or one that the first unit did not finish.
    Item* controlled = nullptr;
    for (Item& item : ctx.tracker.items()) {
      if (!item.active || item.reject_pending || item.orienting_done || item.multilane_unit < 0 ||
          unit_at(item.s_mm) != static_cast<int>(unit)) {
        continue;
      }
      const bool assigned_here = item.multilane_unit == static_cast<int>(unit);
      const bool carried_over = unit == 1 && item.multilane_unit == 0;
      if (assigned_here || (carried_over && controlled == nullptr)) controlled = &item;
    }
    controlled_[unit] = controlled != nullptr ? controlled->id : 0;
    const DriveLimits& limits = config_.limits[index(kLeft[unit])];
    UnitCommand command{config_.multilane.common_speed_mps, config_.multilane.common_speed_mps};
    if (controlled != nullptr) {
      const float error_rad = wrap_angle(controlled->target_angle_rad - controlled->angle_rad);
      command = orient_command(config_.multilane, limits, error_rad);
    }
    set_drive(out, kLeft[unit], config_, command.left_mps, ctx.running);
    set_drive(out, kRight[unit], config_, command.right_mps, ctx.running);
  }
}

}  // namespace fl::logic
