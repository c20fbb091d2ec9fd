// Camera 1 decisions, the flip plates, the reject reversal and the centring unit.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "stations.hpp"

namespace fl::logic {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kHalfPi = 0.5F * kPi;

SideUp other_side(SideUp side) {
  if (side == SideUp::kSkin) return SideUp::kBone;
  if (side == SideUp::kBone) return SideUp::kSkin;
  return SideUp::kUnknown;
}

}  // namespace

FlipPlan plan_flips(SideUp seen, float angle_rad, SideUp target) {
  const bool flip_side = seen != target;
  const bool reverse = std::fabs(wrap_angle(angle_rad)) > kHalfPi;  // thick end leads
  // Plate 1 (end over end) toggles the side and reverses; plate 2 (sideways) toggles the
  // side only. Both: reversed with the side unchanged. That covers the four cases.
  if (flip_side && reverse) return FlipPlan{true, false};
  if (flip_side) return FlipPlan{false, true};
  if (reverse) return FlipPlan{true, true};
  return FlipPlan{false, false};
}

void apply_plate(bool end_over_end, bool flipping, SideUp& side, float& angle_rad) {
  if (!flipping) return;
  side = other_side(side);
  angle_rad = wrap_angle(end_over_end ? kPi - angle_rad : -angle_rad);
}

void FlipStation::reset() {
  plate1_command_ = false;
  plate2_command_ = false;
}

float FlipStation::decision_s_mm() const {
  // Decide early enough that plate 1 can travel before the item reaches it, with half the
  // actuation time again as margin for the belt speed.
  const float guide_speed_mps = config_.sections[index(DriveId::kGuide)].nominal_speed_mps;
  return config_.flip.plate1_s_mm - config_.flip.clearance_mm -
         1.5F * 1000.0F * guide_speed_mps * config_.flip.actuation_s;
}

void FlipStation::classify(Item& item) const {
  item.classified = true;
  const CameraEvidence& evidence = item.evidence[index(CameraId::kOrientation)];
  item.record.singulated = evidence.frames == 0 || evidence.singulated();
  if (item.reject_pending) return;  // adopted items are rejected whatever they look like
  auto reject = [&](Outcome reason) {
    item.reject_pending = true;
    item.reject_reason = reason;
  };
  if (evidence.frames == 0) return reject(Outcome::kRejectedUnclassified);
  if (!evidence.singulated()) return reject(Outcome::kRejectedNotSingulated);
  item.hand = evidence.hand();
  item.side = evidence.side();
  item.angle_rad = evidence.mean_angle_rad();
  item.angle_known = true;
  item.record.hand = item.hand;
  item.record.side_seen = item.side;
  item.record.angle_at_camera1_rad = item.angle_rad;
  if (item.hand == Hand::kUnknown || item.side == SideUp::kUnknown ||
      evidence.mean_confidence() < config_.reject.min_confidence) {
    return reject(Outcome::kRejectedUnclassified);
  }
  const FlipPlan plan = plan_flips(item.side, item.angle_rad, config_.flip.target_side);
  item.flip1 = plan.plate1;
  item.flip2 = plan.plate2;
  const float target = config_.tolerance.target_angle_rad;
  item.target_angle_rad =
      (item.hand == Hand::kLeft && config_.tolerance.mirror_for_left) ? -target : target;
}

void FlipStation::schedule_plate(const ScanContext& ctx, bool end_over_end, bool& command) {
  const float plate_s = end_over_end ? config_.flip.plate1_s_mm : config_.flip.plate2_s_mm;
  // The next item to cross this plate is the most downstream one still before it.
  Item* next = nullptr;
  for (Item& item : ctx.tracker.items()) {
    if (!item.active || item.s_mm >= plate_s) continue;
    if (next == nullptr || item.s_mm > next->s_mm) next = &item;
  }
  if (next == nullptr || !next->classified || next->reject_pending) return;  // don't care
  const bool wanted = end_over_end ? next->flip1 : next->flip2;
  if (wanted == command) return;
  const float speed_mps = std::max(ctx.tracker.speed_at_mps(ctx.in, next->s_mm), 0.05F);
  const float time_to_plate_s = (plate_s - next->s_mm) / (1000.0F * speed_mps);
  if (time_to_plate_s < config_.flip.actuation_s) {
    ++ctx.counters.flip_conflicts;
    ctx.events.push(Event{ctx.in.time_ns, EventCode::kFlipConflict, next->id,
                          static_cast<std::uint8_t>(end_over_end ? 1 : 2), time_to_plate_s});
  }
  command = wanted;
}

void FlipStation::update(const ScanContext& ctx, OutputImage& out) {
  const float decide_at = decision_s_mm();
  for (Item& item : ctx.tracker.items()) {
    if (!item.active) continue;
    if (!item.classified && item.s_mm >= decide_at) classify(item);
    // Track the plates' effect with the plates' own end switches, so a late plate shows
    // up as a wrong side at the final camera rather than as a silent guess.
    if (!item.passed_plate1 && item.s_mm >= config_.flip.plate1_s_mm) {
      item.passed_plate1 = true;
      apply_plate(true, ctx.in.flip_plate1_flipping, item.side, item.angle_rad);
    }
    if (!item.passed_plate2 && item.s_mm >= config_.flip.plate2_s_mm) {
      item.passed_plate2 = true;
      apply_plate(false, ctx.in.flip_plate2_flipping, item.side, item.angle_rad);
    }
  }
  schedule_plate(ctx, true, plate1_command_);
  schedule_plate(ctx, false, plate2_command_);
  out.flip_plate1_flip = plate1_command_;
  out.flip_plate2_flip = plate2_command_;
}

void RejectStation::reset() { target_id_ = 0; }

void RejectStation::update(const ScanContext& ctx, OutputImage& out, bool& hold_guide) {
  const BeltSection& belt = config_.sections[index(DriveId::kReject)];
  const float forward_mps = belt.nominal_speed_mps;
  hold_guide = false;

  if (target_id_ == 0) {
    // Reverse once a flagged item is wholly on the reject belt and still on it.
    for (Item& item : ctx.tracker.items()) {
      if (!item.active || !item.reject_pending) continue;
      const float half_mm = 0.5F * item.length_mm;
      if (item.s_mm >= belt.start_mm + half_mm && item.s_mm < belt.end_mm) {
        target_id_ = item.id;
        ++ctx.counters.reject_reversals;
        ctx.events.push(Event{ctx.in.time_ns, EventCode::kRejectReversal, item.id, 0, item.s_mm});
        break;
      }
    }
  }
  if (target_id_ == 0) {
    set_drive(out, DriveId::kReject, config_, forward_mps, ctx.running);
    return;
  }

  bool keep_reversing = false;
  const float reverse_travel_mm = -ctx.tracker.travel_mm(DriveId::kReject);
  for (Item& item : ctx.tracker.items()) {
    if (!item.active) continue;
    const bool on_belt = item.passed_plate2 && item.s_mm < belt.end_mm;
    if (on_belt && !item.dropping && item.s_mm < belt.start_mm) {
      item.dropping = true;
      item.drop_travel_mm = 0.0F;
    }
    if (item.dropping) {
      item.drop_travel_mm += reverse_travel_mm;
      if (item.drop_travel_mm >= 0.5F * item.length_mm + config_.reject.drop_margin_mm) {
        const Outcome outcome =
            item.reject_pending ? item.reject_reason : Outcome::kRejectedCollateral;
        ctx.tracker.close(item, ctx.in.time_ns, outcome, LostReason::kNone, ctx.records,
                          ctx.events);
        continue;
      }
      keep_reversing = true;
    }
    if (item.id == target_id_) keep_reversing = true;
    // Items still on the plates wait on the guide until the belt runs forward again.
    if (!item.passed_plate2 &&
        item.s_mm > config_.flip.plate2_s_mm - 0.5F * item.length_mm - 80.0F) {
      hold_guide = true;
    }
  }
  if (!keep_reversing) {
    target_id_ = 0;
    hold_guide = false;
    set_drive(out, DriveId::kReject, config_, forward_mps, ctx.running);
    return;
  }
  set_drive(out, DriveId::kReject, config_, -config_.reject.reverse_speed_mps, ctx.running);
}

void CentringStation::update(const ScanContext& ctx, OutputImage& out) {
  const CentringConfig& centring = config_.centring;
  // The stroke window: the unit acts on an item while its centre is this close.
  constexpr float kStrokeWindowMm = 20.0F;
  // The pusher pre-positions for an item this far ahead of the unit.
  constexpr float kApproachMm = 150.0F;
  // A stroke that started in the window is held until the pusher reports the commanded
  // shift (or the item is this far past the unit): a real pusher needs its stroke time and
  // more when it brakes gently enough not to throw the fillet, longer than the item takes
  // through the window (40 mm, 80 ms at 0.5 m/s, against 0.12 s for a full stroke).
  constexpr float kStrokeHoldMm = 150.0F;
  // The pusher is at the commanded shift, or home, within this (its positioning, and float
  // rounding).
  constexpr float kPusherArrivedMm = 1.0F;
  out.centring_stroke = false;
  out.centring_shift_mm = 0.0F;
  // A stroke in progress wins over pre-positioning and over the next item's stroke.
  bool holding = false;
  float held_shift_mm = 0.0F;
  for (Item& item : ctx.tracker.items()) {
    if (!item.active || item.centring_done) continue;
    if (item.s_mm <= centring.s_mm + kStrokeWindowMm) continue;
    const bool arrived =
        std::fabs(ctx.in.centring_position_mm - item.centring_shift_mm) < kPusherArrivedMm;
    if (item.centring_stroke_started && !arrived && item.s_mm < centring.s_mm + kStrokeHoldMm) {
      holding = true;
      held_shift_mm = item.centring_shift_mm;
      continue;
    }
    item.centring_done = true;
    // An item whose stroke never began (the pusher was still out for the one before) is
    // where the camera saw it.
    if (item.centring_stroke_started) item.y_mm += item.centring_shift_mm;
  }
  if (holding) {
    out.centring_shift_mm = held_shift_mm;
    out.centring_stroke = true;
    return;
  }
  // A new stroke starts only from home. The plate is wherever the last stroke left it: a
  // stroke commanded while it was still retracting pushed from the last fillet's side, and
  // a plate retracting through the new shift read as arrived (the DEM twin: 6 of 331 items
  // in six 60 s runs). The pusher retracts as soon as no stroke is commanded.
  const bool pusher_home = std::fabs(ctx.in.centring_position_mm) < kPusherArrivedMm;
  for (Item& item : ctx.tracker.items()) {
    if (!item.active || item.centring_done) continue;
    if (item.s_mm < centring.s_mm - kApproachMm) continue;
    if (item.s_mm > centring.s_mm + kStrokeWindowMm) continue;
    const CameraEvidence& evidence = item.evidence[index(CameraId::kPosition)];
    if (evidence.frames == 0) continue;  // not measured: leave it where it is
    item.y_mm = evidence.mean_y_mm();
    float shift_mm = std::clamp(-item.y_mm, -centring.max_shift_mm, centring.max_shift_mm);
    if (std::fabs(shift_mm) < centring.deadband_mm) shift_mm = 0.0F;
    item.centring_shift_mm = shift_mm;
    out.centring_shift_mm = shift_mm;
    const bool at_unit = item.s_mm >= centring.s_mm - kStrokeWindowMm;
    if (shift_mm != 0.0F && at_unit && (item.centring_stroke_started || pusher_home)) {
      item.centring_stroke_started = true;
      out.centring_stroke = true;
    }
  }
}

}  // namespace fl::logic
