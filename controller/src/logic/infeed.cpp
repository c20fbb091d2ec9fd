// Stations upstream of the takt barrier and the takt itself.
#include <algorithm>

#include "stations.hpp"

namespace fl::logic {

void set_drive(OutputImage& out, DriveId drive, const LineConfig& config, float speed_mps,
               bool enable) {
  const DriveLimits& limits = config.limits[index(drive)];
  DriveCommand& command = out.drives[index(drive)];
  command.enable = enable;
  command.speed_mps =
      enable ? std::clamp(speed_mps, -limits.max_speed_mps, limits.max_speed_mps) : 0.0F;
  command.accel_mps2 = limits.max_accel_mps2;
}

void BulkFeedStation::reset() {
  integral_mps_ = 0.0F;
  starved_s_ = 0.0F;
  unblock_remaining_s_ = 0.0F;
}

void BulkFeedStation::update(const ScanContext& ctx, OutputImage& out) {
  const BulkConfig& bulk = config_.bulk;
  out.hopper_opening_mm = bulk.hopper_opening_mm;
  if (!ctx.infeed_enabled) {
    integral_mps_ = 0.0F;
    starved_s_ = 0.0F;
    unblock_remaining_s_ = 0.0F;
    set_drive(out, DriveId::kBulk, config_, 0.0F, ctx.running);
    return;
  }
  const float error_mm = bulk.level_setpoint_mm - ctx.in.level_mm;
  const float proportional_mps = bulk.level_kp_mps_per_mm * error_mm;
  const float unclamped =
      proportional_mps + integral_mps_ + bulk.level_ki_mps_per_mm_s * error_mm * ctx.dt_s;
  // Conditional integration: the integral only moves while the output is not saturated
  // in the direction of the error (anti-windup).
  const bool saturated_high = unclamped > bulk.max_speed_mps && error_mm > 0.0F;
  const bool saturated_low = unclamped < bulk.min_speed_mps && error_mm < 0.0F;
  if (!saturated_high && !saturated_low) {
    integral_mps_ += bulk.level_ki_mps_per_mm_s * error_mm * ctx.dt_s;
  }
  const float speed_mps =
      std::clamp(proportional_mps + integral_mps_, bulk.min_speed_mps, bulk.max_speed_mps);

  // Starved: full bulk speed yet the level stays low, the hopper has bridged (thesis 6.1).
  // Open the hopper wider for a moment to break the bridge.
  const bool starved =
      ctx.in.level_mm < 0.5F * bulk.level_setpoint_mm && speed_mps >= bulk.max_speed_mps * 0.999F;
  starved_s_ = starved ? starved_s_ + ctx.dt_s : 0.0F;
  if (starved_s_ >= bulk.starved_after_s && unblock_remaining_s_ <= 0.0F) {
    unblock_remaining_s_ = bulk.unblock_duration_s;
    starved_s_ = 0.0F;
  }
  if (unblock_remaining_s_ > 0.0F) {
    out.hopper_opening_mm = bulk.hopper_unblock_opening_mm;
    unblock_remaining_s_ -= ctx.dt_s;
  }
  set_drive(out, DriveId::kBulk, config_, speed_mps, true);
}

bool LevellerStation::update(const ScanContext& ctx, OutputImage& out) {
  const LevellerConfig& leveller = config_.leveller;
  if (!ctx.infeed_enabled) {
    out.leveller_speed_rpm = 0.0F;
    running_s_ = 0.0F;
    return ctx.in.leveller_overload;
  }
  out.leveller_speed_rpm = leveller.speed_rpm;
  running_s_ += ctx.dt_s;
  const bool jammed =
      running_s_ > leveller.spin_up_s && ctx.in.leveller_speed_rpm < leveller.min_running_rpm;
  return jammed || ctx.in.leveller_overload;
}

void TaktStation::reset() {
  phase_ = Phase::kIndex;
  beam_stable_s_ = 0.0F;
  beam_clear_s_ = 0.0F;
  armed_ = true;
  travel_rearm_used_ = false;
  beam_was_broken_ = false;
  broke_after_pull_ = false;
  travel_since_stroke_mm_ = 0.0F;
  travel_since_break_mm_ = 0.0F;
  since_stroke_s_ = 1e9F;
  pulled_mm_ = 0.0F;
}

bool TaktStation::gap_clear(const ScanContext& ctx) const {
  if (since_stroke_s_ < config_.takt.min_period_s) return false;
  // The previous item must have moved min_gap past the barrier, else the next row would
  // land on top of it.
  for (const Item& item : ctx.tracker.items()) {
    if (item.active && !item.adopted && item.s_mm < config_.takt.min_gap_mm &&
        item.s_mm > -item.length_mm) {
      return false;
    }
  }
  return true;
}

void TaktStation::update(const ScanContext& ctx, OutputImage& out) {
  const TaktConfig& takt = config_.takt;
  since_stroke_s_ += ctx.dt_s;
  const float travel_mm = ctx.tracker.travel_mm(DriveId::kTakt);
  travel_since_stroke_mm_ += travel_mm;
  travel_since_break_mm_ += travel_mm;
  if (ctx.in.takt_beam_broken && !beam_was_broken_) {
    travel_since_break_mm_ = 0.0F;
    broke_after_pull_ = phase_ == Phase::kIndex;
  }
  beam_was_broken_ = ctx.in.takt_beam_broken;
  beam_stable_s_ = ctx.in.takt_beam_broken ? beam_stable_s_ + ctx.dt_s : 0.0F;
  beam_clear_s_ = ctx.in.takt_beam_broken ? 0.0F : beam_clear_s_ + ctx.dt_s;
  if (!ctx.infeed_enabled) {
    // A stroke in progress finishes, so that the item it created leaves the takt belt
    // instead of waiting on it, tracked, until the next start.
    if (phase_ == Phase::kPull && ctx.running) {
      pulled_mm_ += travel_mm;
      if (pulled_mm_ < takt.pull_distance_mm) {
        set_drive(out, DriveId::kTakt, config_, takt.takt_speed_mps, true);
        return;
      }
    }
    phase_ = Phase::kIndex;
    set_drive(out, DriveId::kTakt, config_, 0.0F, ctx.running);
    return;
  }
  const bool beam = beam_stable_s_ >= takt.beam_debounce_s;
  const bool beam_clear = beam_clear_s_ >= takt.beam_debounce_s;

  if (phase_ == Phase::kPull) {
    pulled_mm_ += travel_mm;
    if (pulled_mm_ >= takt.pull_distance_mm) phase_ = Phase::kIndex;
  }
  if (phase_ == Phase::kIndex && beam_clear) travel_rearm_used_ = false;
  if (phase_ == Phase::kIndex && !armed_ && !travel_rearm_used_ && takt.rearm_travel_mm > 0.0F &&
      travel_since_stroke_mm_ >= takt.rearm_travel_mm) {
    armed_ = true;
    travel_rearm_used_ = true;
  }
  // Only a clear beam after the pull re-arms (or a whole fillet's travel, above): the row
  // held at the barrier can sit a few mm short of the beam when the stroke starts (a soft
  // fillet settling as the belt stops, a thin tip under the beam), so the beam may be clear
  // at the start of a pull and then be broken by the very fillet being pulled; arming on
  // that would take its body for the next row and create an item for a fillet that is not
  // at the barrier.
  if (phase_ == Phase::kIndex && beam_clear) armed_ = true;
  // A row that left the beam while held (settled back, or the previous fillet's tail that
  // the transition belt pulled away) is not at the barrier: creep on at standard speed
  // until something breaks the beam again, rather than stroke at a clear beam.
  if (phase_ == Phase::kWaitGap && beam_clear) phase_ = Phase::kIndex;
  if (phase_ == Phase::kIndex && beam && armed_) phase_ = Phase::kWaitGap;
  if (phase_ == Phase::kWaitGap && gap_clear(ctx)) {
    // The front of the row is at the barrier; its centre half a length behind. A row taken
    // by travel has its front past the barrier: by the travel since the beam broke again
    // after the pull, or, touching the pulled fillet, by the travel beyond a nominal fillet.
    const float nominal_mm = config_.tracking.nominal_length_mm;
    float front_mm = 0.0F;
    if (armed_by_travel() && beam) {
      front_mm = broke_after_pull_ ? travel_since_break_mm_
                                   : std::max(0.0F, travel_since_stroke_mm_ - nominal_mm);
    }
    Item* item = ctx.tracker.create(ctx.in.time_ns, front_mm - 0.5F * nominal_mm, false);
    ++ctx.counters.takt_strokes;
    if (armed_by_travel()) ++ctx.counters.takt_strokes_by_travel;
    if (item != nullptr) {
      ++ctx.counters.items_created;
      ctx.events.push(Event{ctx.in.time_ns, EventCode::kItemCreated, item->id, 0, 0.0F});
    }
    phase_ = Phase::kPull;
    armed_ = false;
    broke_after_pull_ = false;
    pulled_mm_ = 0.0F;
    travel_since_stroke_mm_ = 0.0F;
    since_stroke_s_ = 0.0F;
  }

  DriveCommand& command = out.drives[index(DriveId::kTakt)];
  switch (phase_) {
    case Phase::kIndex:
      set_drive(out, DriveId::kTakt, config_, takt.standard_speed_mps, true);
      break;
    case Phase::kWaitGap:  // hold the row at the barrier until the line ahead is clear
      set_drive(out, DriveId::kTakt, config_, 0.0F, true);
      break;
    case Phase::kPull:
      set_drive(out, DriveId::kTakt, config_, takt.takt_speed_mps, true);
      command.accel_mps2 = std::min(takt.takt_accel_mps2, command.accel_mps2);
      break;
  }
}

}  // namespace fl::logic
