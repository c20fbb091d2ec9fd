// Squeeze roller, final inspection, air knife and the hand-off at the end of the line.
#include <algorithm>
#include <cmath>

#include "stations.hpp"

namespace fl::logic {

float thickest_section_s_mm(const Item& item, float thickest_from_rear) {
  const float cos_heading = item.angle_known ? std::cos(item.angle_rad) : 1.0F;
  return item.s_mm - (0.5F - thickest_from_rear) * item.length_mm * cos_heading;
}

float rear_s_mm(const Item& item) {
  const float cos_heading = item.angle_known ? std::cos(item.angle_rad) : 1.0F;
  return item.s_mm - 0.5F * item.length_mm * std::fabs(cos_heading);
}

void SqueezeStation::update(const ScanContext& ctx, OutputImage& out) {
  const SqueezeConfig& squeeze = config_.squeeze;
  // The roller must clear a thickest section by this much (tracking error plus the spread
  // of fillet lengths around the nominal one), so it never rides up the thick part.
  constexpr float kClearanceMm = 15.0F;
  const float speed_mps = ctx.in.drives[index(DriveId::kSqueeze)].speed_mps;
  // Where items will be when a lift commanded now has taken effect.
  const float lift_lead_mm = 1000.0F * std::max(speed_mps, 0.0F) * squeeze.actuation_s;
  bool down = false;
  bool must_be_up = false;
  for (const Item& item : ctx.tracker.items()) {
    if (!item.active) continue;
    const float thickest_mm = thickest_section_s_mm(item, squeeze.thickest_from_rear);
    // Lowering waits until the thickest section is past now: the roller then touches down
    // behind it whatever its travel time, and presses the rest flat.
    if (thickest_mm >= squeeze.roller_s_mm + kClearanceMm &&
        rear_s_mm(item) < squeeze.roller_s_mm) {
      down = true;
    }
    // A thickest section that will be under the roller before a lift completes overrides:
    // up, or the fillet jams behind it.
    const float thickest_ahead_mm = thickest_mm + lift_lead_mm;
    if (thickest_mm < squeeze.roller_s_mm + kClearanceMm &&
        thickest_ahead_mm > squeeze.roller_s_mm - item.length_mm) {
      must_be_up = true;
    }
  }
  out.squeeze_roller_down = down && !must_be_up;
}

float FinalStation::decision_s_mm() const {
  const CameraMount& camera = config_.cameras[index(CameraId::kFinal)];
  // Leave the camera's last frames of the item before deciding, but stay well ahead of
  // the air knife so the verdict is in before the item gets there.
  return std::min(camera.s_mm + 0.5F * camera.field_of_view_mm - 30.0F,
                  config_.tolerance.final_reject_s_mm - 60.0F);
}

void FinalStation::inspect(Item& item) const {
  item.final_checked = true;
  const CameraEvidence& evidence = item.evidence[index(CameraId::kFinal)];
  if (item.reject_pending) {  // missed by the reversal: never placed
    item.final_reject = true;
    return;
  }
  if (evidence.frames == 0) {
    item.final_reject = true;
    item.reject_reason = Outcome::kRejectedUnverified;
    return;
  }
  const ToleranceConfig& tolerance = config_.tolerance;
  const float angle_rad = evidence.mean_angle_rad();
  item.record.final_angle_rad = angle_rad;
  item.record.final_y_mm = evidence.mean_y_mm();
  const bool angle_ok =
      std::fabs(wrap_angle(angle_rad - item.target_angle_rad)) <= tolerance.angle_tol_rad;
  const bool lateral_ok = std::fabs(evidence.mean_y_mm()) <= tolerance.lateral_tol_mm;
  const bool side_ok = evidence.side() == config_.flip.target_side;
  const bool hand_ok = evidence.hand() == item.hand;  // a changed hand means a mix-up
  if (!(angle_ok && lateral_ok && side_ok && hand_ok && evidence.singulated())) {
    item.final_reject = true;
    item.reject_reason = Outcome::kRejectedMisaligned;
  }
}

void FinalStation::update(const ScanContext& ctx, OutputImage& out) {
  const float knife_s_mm = config_.tolerance.final_reject_s_mm;
  // The knife blows while a rejected item's centre is within this of it.
  constexpr float kKnifeWindowMm = 40.0F;
  const float decide_at = decision_s_mm();
  out.final_reject = false;
  for (Item& item : ctx.tracker.items()) {
    if (!item.active) continue;
    if (!item.final_checked && item.s_mm >= decide_at) inspect(item);
    if (item.final_reject && std::fabs(item.s_mm - knife_s_mm) <= kKnifeWindowMm) {
      out.final_reject = true;
    }
    if (item.final_reject && item.s_mm > knife_s_mm + kKnifeWindowMm) {
      const bool never_seen = item.evidence[index(CameraId::kOrientation)].frames == 0 &&
                              item.evidence[index(CameraId::kPosition)].frames == 0 &&
                              item.evidence[index(CameraId::kFinal)].frames == 0;
      if (never_seen) {
        ctx.tracker.close(item, ctx.in.time_ns, Outcome::kLost, LostReason::kNotSeenByCamera,
                          ctx.records, ctx.events);
      } else {
        ctx.tracker.close(item, ctx.in.time_ns, item.reject_reason, LostReason::kNone, ctx.records,
                          ctx.events);
      }
      continue;
    }
    if (!item.final_reject && item.s_mm >= config_.placed_at_s_mm) {
      ctx.tracker.close(item, ctx.in.time_ns, Outcome::kPlaced, LostReason::kNone, ctx.records,
                        ctx.events);
    }
  }
}

}  // namespace fl::logic
