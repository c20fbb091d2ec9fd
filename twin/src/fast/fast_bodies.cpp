// Bodies on the product path: belt following, the stations that act on them, their exits,
// and the contacts that keep them from passing through each other.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "fl/twin/fast_plant.hpp"

namespace fl {
namespace {

bool toggles(SideUp side) { return side == SideUp::kSkin || side == SideUp::kBone; }

void toggle_sides(FilletBody& body) {
  for (std::uint8_t m = 0; m < body.member_count; ++m) {
    SideUp& side = body.members[m].side;
    if (toggles(side)) side = side == SideUp::kSkin ? SideUp::kBone : SideUp::kSkin;
  }
}

DriveId right_drive_of(BodyZone zone) {
  return zone == BodyZone::kMultilane1 ? DriveId::kMultilane1Right : DriveId::kMultilane2Right;
}

}  // namespace

void FastPlant::build_segments() {
  segment_count_ = 0;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const auto id = static_cast<DriveId>(d);
    // The bulk belt is upstream of s = 0; the right multilane belts share the left's section.
    if (!has_section(id)) continue;
    const BeltSection& section = line_.sections[d];
    if (!(section.end_mm > section.start_mm)) continue;
    Segment segment;
    segment.start_mm = section.start_mm;
    segment.end_mm = section.end_mm;
    segment.drive = id;
    segment.zone = BodyZone::kBelt;
    if (id == DriveId::kGuide) segment.zone = BodyZone::kGuide;
    if (id == DriveId::kMultilane1Left) {
      segment.zone = BodyZone::kMultilane1;
      segment.right_drive = DriveId::kMultilane1Right;
    }
    if (id == DriveId::kMultilane2Left) {
      segment.zone = BodyZone::kMultilane2;
      segment.right_drive = DriveId::kMultilane2Right;
    }
    segments_[segment_count_++] = segment;
  }
  // The flip plates: passive slides between the guide belt and the reject belt.
  const BeltSection& guide = line_.sections[index(DriveId::kGuide)];
  const BeltSection& reject = line_.sections[index(DriveId::kReject)];
  if (reject.start_mm > guide.end_mm) {
    Segment plates;
    plates.start_mm = guide.end_mm;
    plates.end_mm = reject.start_mm;
    plates.zone = BodyZone::kPlates;
    plates.drive = DriveId::kGuide;
    segments_[segment_count_++] = plates;
  }
  std::sort(segments_.begin(), segments_.begin() + static_cast<std::ptrdiff_t>(segment_count_),
            [](const Segment& a, const Segment& b) { return a.start_mm < b.start_mm; });
}

void FastPlant::locate(FilletBody& body) const {
  body.zone = BodyZone::kNone;
  for (std::size_t i = 0; i < segment_count_; ++i) {
    const Segment& segment = segments_[i];
    if (body.s_mm >= segment.start_mm && body.s_mm < segment.end_mm) {
      body.zone = segment.zone;
      body.drive = segment.drive;
      return;
    }
  }
}

void FastPlant::step_bodies(double h_s, const OutputImage& out) {
  const double max_dv_mps = static_cast<double>(config_.belts.mu_belt) *
                            static_cast<double>(config_.belts.gravity_mps2) * h_s;
  const FastMultilaneConfig& multilane = config_.multilane;
  const double omega_alpha =
      1.0 - std::exp(-h_s / std::max(static_cast<double>(multilane.omega_lag_s), 1e-6));
  const double lateral_alpha = 1.0 - std::exp(-h_s * config_.guide.lateral_rate_per_s);
  const double heading_alpha = 1.0 - std::exp(-h_s * config_.guide.heading_rate_per_s);
  const double sqrt_h = std::sqrt(h_s);
  const double band_mm = config_.guide.band_half_width_mm;
  const double track_mm = std::max(static_cast<double>(line_.multilane.belt_track_mm), 1e-6);
  const double max_omega = multilane.max_omega_radps;
  const double reject_start_mm = line_.sections[index(DriveId::kReject)].start_mm;
  const double reject_mps = drives_.speed_mps(DriveId::kReject);
  const double roller_mm = line_.squeeze.roller_s_mm;
  const double knife_mm = line_.tolerance.final_reject_s_mm;
  const double centring_mm = line_.centring.s_mm;
  const double centring_window_mm = config_.centring.window_half_mm;
  const FastStationState& stations = state_.stations;

  std::size_t i = 0;
  while (i < bodies_.size()) {
    FilletBody& body = bodies_[i];
    locate(body);

    // Squeeze roller lowered onto this body: a good squeeze if its thickest section has
    // already passed under the roller and the body is still under it (thesis 6.2).
    if (roller_went_down_ && body.thick_passed_roller &&
        body.s_mm - body.half_extent_s_mm < roller_mm &&
        body.s_mm + body.half_extent_s_mm > roller_mm) {
      body.squeezed_ok = true;
    }

    if (body.stuck_at_roller) {
      // Held behind the lowered roller: the belt slides under it and it pivots.
      body.v_mps = 0.0;
      body.omega_radps = 0.0;
      set_body_angle(body, body.angle_rad + config_.squeeze.stuck_disturbance_rad_per_sqrt_s *
                                                sqrt_h * body_rng_.normal());
      body.s_mm = roller_mm - 0.01 +
                  (0.5 - static_cast<double>(body.thickest_from_thick_end)) * body.length_mm *
                      body.cos_angle;
      if (!stations.roller_pressing) body.stuck_at_roller = false;
      ++i;
      continue;
    }

    // Surface speed under the centre and the rotation the belts impose.
    bool has_surface = true;
    bool on_reject_belt = false;
    double surface_mps = body.v_mps;
    double omega_target = 0.0;
    double vl_mps = 0.0;
    double vr_mps = 0.0;
    switch (body.zone) {
      case BodyZone::kNone:
        has_surface = false;
        break;
      case BodyZone::kBelt:
      case BodyZone::kGuide:
        surface_mps = drives_.speed_mps(body.drive);
        on_reject_belt = body.drive == DriveId::kReject;
        break;
      case BodyZone::kPlates:
        // Items slide over the plates at the guide belt's speed; a reversing reject belt
        // drags back an item whose front edge is on it (collateral of a reversal).
        surface_mps = drives_.speed_mps(DriveId::kGuide);
        if (reject_mps < 0.0 && body.s_mm + body.half_extent_s_mm > reject_start_mm) {
          surface_mps = reject_mps;
          on_reject_belt = true;
        }
        break;
      case BodyZone::kMultilane1:
      case BodyZone::kMultilane2: {
        vl_mps = drives_.speed_mps(body.drive);
        vr_mps = drives_.speed_mps(right_drive_of(body.zone));
        surface_mps = 0.5 * (vl_mps + vr_mps);
        // Rigid rotation at omega (CCW, seen from above) moves the item's right side
        // (y < 0) forward at v + omega * track / 2 and the left at v - omega * track / 2,
        // so omega = (v_right - v_left) / track: a faster right belt turns the item CCW,
        // the angle grows. One belt loses grip on an item that is off centre.
        const double grip = std::abs(body.y_mm) > multilane.grip_lateral_mm
                                ? static_cast<double>(multilane.off_centre_rotation_fraction)
                                : 1.0;
        omega_target = grip * (vr_mps - vl_mps) * 1000.0 / track_mm;
        break;
      }
    }

    // Friction-limited following: the item's speed moves towards the surface speed by at
    // most mu * g per second.
    const double old_mps = body.v_mps;
    if (has_surface) {
      body.v_mps += std::clamp(surface_mps - body.v_mps, -max_dv_mps, max_dv_mps);
    }
    const double s_prev_mm = body.s_mm;
    const double thick_prev_mm = thickest_section_s_mm(body);
    body.s_mm += 0.5 * (old_mps + body.v_mps) * h_s * 1000.0;

    // Rotation: slip-limited first-order lag; random disturbance while on a unit.
    body.omega_radps += (omega_target - body.omega_radps) * omega_alpha;
    body.omega_radps = std::clamp(body.omega_radps, -max_omega, max_omega);
    double turn_rad = body.omega_radps * h_s;
    if (body.zone == BodyZone::kMultilane1 || body.zone == BodyZone::kMultilane2) {
      turn_rad += multilane.disturbance_rad_per_sqrt_s * sqrt_h * body_rng_.normal();
    }
    if (body.zone == BodyZone::kGuide) {
      // Rails: lateral offset beyond the centre band and heading error to 0 or pi decay.
      const double banded_mm = std::clamp(body.y_mm, -band_mm, band_mm);
      body.y_mm += (banded_mm - body.y_mm) * lateral_alpha;
      const double base_rad =
          std::abs(body.angle_rad) <= 0.5 * std::numbers::pi ? 0.0 : std::numbers::pi;
      const double error_rad = wrap_angle_rad(base_rad + body.rail_residual_rad - body.angle_rad);
      turn_rad += error_rad * heading_alpha;
    }
    if (turn_rad != 0.0) set_body_angle(body, body.angle_rad + turn_rad);

    // ---- events, in the order an item meets them.
    if (!body.fed && body.s_mm >= 0.0) {
      body.fed = true;
      counters_.fillets_fed += body.member_count;
    }

    // Flip plates: the plate's state as the centre crosses it decides.
    for (int plate = 1; plate <= 2; ++plate) {
      const double plate_mm = plate == 1 ? line_.flip.plate1_s_mm : line_.flip.plate2_s_mm;
      if (!(s_prev_mm < plate_mm && body.s_mm >= plate_mm)) continue;
      const double travel = plate == 1 ? stations.plate1_travel : stations.plate2_travel;
      bool flip = travel >= 1.0;
      if (travel > 0.0 && travel < 1.0) {
        // Plate in mid-travel: flips or not by chance and throws the heading.
        ++counters_.misflips;
        body.misflipped = true;
        flip = body_rng_.bernoulli(travel);
        const double throw_rad = config_.flip.misflip_angle_rad;
        set_body_angle(body, body.angle_rad + body_rng_.uniform(-throw_rad, throw_rad));
      }
      if (!flip) continue;
      toggle_sides(body);
      if (plate == 1) {
        // End over end (about the lateral axis): x -> -x, tip direction a -> pi - a.
        set_body_angle(body, std::numbers::pi - body.angle_rad);
        body.plate1_flipped = true;
      } else {
        // Sideways (about the travel axis): y -> -y, tip direction a -> -a.
        set_body_angle(body, -body.angle_rad);
        body.plate2_flipped = true;
      }
    }

    // Centring: the pusher shifts an item in its window while stroking; it pushes, never
    // pulls back, and the shift is frozen once the item leaves the window.
    const double from_centring_mm = std::abs(body.s_mm - centring_mm);
    if (body.centring_phase == 0 && from_centring_mm <= centring_window_mm) {
      body.centring_phase = 1;
      body.centring_entry_y_mm = body.y_mm;
      body.centring_applied_mm = 0.0;
    }
    if (body.centring_phase == 1) {
      if (from_centring_mm > centring_window_mm) {
        body.centring_phase = 2;
      } else if (out.centring_stroke &&
                 std::abs(stations.pusher_mm) > std::abs(body.centring_applied_mm)) {
        body.centring_applied_mm = stations.pusher_mm;
        body.y_mm = body.centring_entry_y_mm + body.centring_applied_mm;
      }
    }

    // Squeeze roller: the thickest section reaching a lowered roller jams the fillet.
    if (!body.thick_passed_roller) {
      const double thick_mm = thickest_section_s_mm(body);
      if (thick_prev_mm < roller_mm && thick_mm >= roller_mm) {
        if (stations.roller_pressing) {
          body.stuck_at_roller = true;
          body.was_stuck = true;
          ++counters_.roller_stuck;
          body.v_mps = 0.0;
          body.omega_radps = 0.0;
          body.s_mm -= thick_mm - (roller_mm - 0.01);
        } else {
          body.thick_passed_roller = true;
        }
      }
    }

    // Exits.
    bool gone = false;
    if (stations.final_reject_blowing &&
        std::abs(body.s_mm - knife_mm) <= config_.final_reject.window_half_mm) {
      record_exit(body, TrueExit::kFinalReject);
      gone = true;
    } else if (on_reject_belt && body.v_mps < 0.0 &&
               body.s_mm + body.half_extent_s_mm <= reject_start_mm) {
      // Carried back over the reject belt's upstream edge into the crate.
      record_exit(body, TrueExit::kRejectCrate);
      gone = true;
    } else if (body.s_mm >= line_.placed_at_s_mm) {
      record_exit(body, TrueExit::kOutfeed);
      gone = true;
    } else if (std::abs(body.y_mm) > config_.belts.belt_half_width_mm) {
      record_exit(body, TrueExit::kFellOff);
      gone = true;
    }
    if (gone) {
      remove_body(i);
    } else {
      ++i;
    }
  }
}

void FastPlant::resolve_contacts() {
  // Bodies are sorted downstream first. A body may not overlap one ahead of it that it
  // overlaps laterally: it is pushed back to touch it and cannot be faster than it. This is
  // what piles items up behind a stuck fillet and lets a reversing belt push items back.
  constexpr double kReachMm = 400.0;  // beyond any two half extents: stop looking further
  const std::size_t count = bodies_.size();
  for (std::size_t i = 1; i < count; ++i) {
    FilletBody& follower = bodies_[i];
    double limit_mm = follower.s_mm;
    double limit_mps = follower.v_mps;
    bool touching = false;
    for (std::size_t j = i; j-- > 0;) {
      const FilletBody& leader = bodies_[j];
      if (leader.s_mm - follower.s_mm > kReachMm) break;
      if (std::abs(leader.y_mm - follower.y_mm) >=
          leader.half_extent_y_mm + follower.half_extent_y_mm) {
        continue;
      }
      const double allowed_mm = leader.s_mm - leader.half_extent_s_mm - follower.half_extent_s_mm;
      if (allowed_mm < limit_mm) {
        limit_mm = allowed_mm;
        limit_mps = std::min(limit_mps, leader.v_mps);
        touching = true;
      }
    }
    if (touching) {
      follower.s_mm = limit_mm;
      follower.v_mps = limit_mps;
    }
  }
}

void FastPlant::sort_bodies() {
  // Insertion sort, downstream first: the pool is almost always sorted already.
  for (std::size_t i = 1; i < bodies_.size(); ++i) {
    if (bodies_[i].s_mm <= bodies_[i - 1].s_mm) continue;
    FilletBody moving = bodies_[i];
    std::size_t j = i;
    while (j > 0 && bodies_[j - 1].s_mm < moving.s_mm) {
      bodies_[j] = bodies_[j - 1];
      --j;
    }
    bodies_[j] = moving;
  }
}

bool FastPlant::beam_broken() const {
  const double window_mm = config_.infeed.takt_beam_window_mm;
  for (const FilletBody& body : bodies_) {
    if (body.s_mm - body.half_extent_s_mm <= 0.0 &&
        body.s_mm + body.half_extent_s_mm >= -window_mm) {
      return true;
    }
  }
  return false;
}

}  // namespace fl
