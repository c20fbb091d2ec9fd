// Infeed upstream of the takt barrier (thesis 5.3, figures 5.17-5.19): the mailbox hopper
// with its cylinder, the bulk belt carrying fillets out of it, the heap in front of the
// universal leveller (its height is the level sensor's reading), the leveller rotor, and the
// levelled single layer handed to the takt conveyor as bodies.
//
// Interpretation: the hopper and the heap are counts, not bodies. The takt conveyor's
// upstream end runs under the leveller and pulls the bottom layer out, so a fillet passes
// the leveller when the rotor clears the layer and there is room at the takt belt's upstream
// end; the bulk belt only refills the heap.
#include <algorithm>
#include <cmath>

#include "fl/twin/fast_plant.hpp"

namespace fl {

FilletBody FastPlant::make_body(std::uint8_t members, FastRng& rng) {
  const FastFilletConfig& fillet = config_.fillet;
  const FastInfeedConfig& infeed = config_.infeed;
  FilletBody body{};
  body.member_count = members;
  for (std::uint8_t m = 0; m < members; ++m) {
    FilletMember& member = body.members[m];
    member.variant = static_cast<std::uint8_t>(rng.below(kFilletSizeVariants));
    const FilletSizeVariant& size = fillet.variants[member.variant];
    const float scale = static_cast<float>(
        1.0 + rng.uniform(-fillet.scale_spread, static_cast<double>(fillet.scale_spread)));
    member.length_mm = size.length_mm * scale;
    member.width_mm = size.width_mm * scale;
    member.thickness_mm = size.thickness_mm * scale;
    member.hand = rng.bernoulli(0.5) ? Hand::kLeft : Hand::kRight;
    member.side = rng.bernoulli(0.5) ? SideUp::kSkin : SideUp::kBone;
  }
  // A touching pair lies side by side: one blob, as long as the longer, as wide as both.
  body.length_mm = body.members[0].length_mm;
  body.width_mm = body.members[0].width_mm;
  body.thickness_mm = body.members[0].thickness_mm;
  if (members > 1) {
    body.length_mm = std::max(body.length_mm, body.members[1].length_mm);
    body.width_mm += body.members[1].width_mm;
    body.thickness_mm = std::max(body.thickness_mm, body.members[1].thickness_mm);
  }
  body.thickest_from_thick_end = static_cast<float>(
      fillet.thickest_from_thick_end +
      rng.uniform(-fillet.thickest_spread, static_cast<double>(fillet.thickest_spread)));
  body.thick_end_ratio = fillet.thick_end_ratio;
  body.tip_ratio = fillet.tip_ratio;
  body.y_mm = rng.uniform(-infeed.takt_lateral_spread_mm,
                          static_cast<double>(infeed.takt_lateral_spread_mm));
  const double base_rad = rng.bernoulli(0.5) ? 0.0 : std::numbers::pi;
  set_body_angle(body, base_rad + infeed.takt_heading_sigma_rad * rng.normal());
  body.rail_residual_rad =
      static_cast<float>(config_.guide.heading_residual_sigma_rad * rng.normal());
  return body;
}

void FastPlant::draw_next_feed() {
  const FastInfeedConfig& infeed = config_.infeed;
  const std::uint8_t members = feed_rng_.bernoulli(config_.fillet.touching_pair_prob) ? 2 : 1;
  next_feed_.body = make_body(members, feed_rng_);
  next_feed_.gap_mm =
      feed_rng_.uniform(infeed.takt_gap_min_mm, static_cast<double>(infeed.takt_gap_max_mm));
}

void FastPlant::step_infeed(double h_s, const OutputImage& out) {
  const FastInfeedConfig& config = config_.infeed;
  FastInfeedState& infeed = state_.infeed;

  // Hopper cylinder.
  const double opening_target_mm = std::clamp(static_cast<double>(out.hopper_opening_mm),
                                              static_cast<double>(config.hopper_min_opening_mm),
                                              static_cast<double>(config.hopper_max_opening_mm));
  infeed.hopper_opening_mm = approach(infeed.hopper_opening_mm, opening_target_mm,
                                      config.hopper_cylinder_speed_mmps * h_s);

  // Blockage (thesis 6.1): likely at a small opening while the belt pulls, cleared by opening
  // further or, rarely, by itself.
  const double bulk_mps = drives_.speed_mps(DriveId::kBulk);
  if (infeed.hopper_blocked) {
    const bool opened =
        infeed.hopper_opening_mm >= infeed.blocked_at_opening_mm + config.unblock_opening_delta_mm;
    if (opened || feed_rng_.bernoulli(config.unblock_hazard_per_s * h_s)) {
      infeed.hopper_blocked = false;
    }
  } else if (bulk_mps > 0.0) {
    const double span_mm =
        std::max(1e-6, static_cast<double>(config.flow_opening_mm - config.block_opening_mm));
    const double share =
        std::clamp((config.flow_opening_mm - infeed.hopper_opening_mm) / span_mm, 0.0, 1.0);
    const double hazard_per_s = config.block_hazard_per_s * share;
    if (hazard_per_s > 0.0 && feed_rng_.bernoulli(hazard_per_s * h_s)) {
      infeed.hopper_blocked = true;
      infeed.blocked_at_opening_mm = infeed.hopper_opening_mm;
      ++counters_.hopper_blockages;
    }
  }

  // Outflow onto the bulk belt, into the heap in front of the leveller.
  const bool flowing = !infeed.hopper_blocked && !faults_.hopper_blocked && bulk_mps > 0.0 &&
                       infeed.layer_mm < config.layer_max_mm && infeed.hopper_fillets > 0;
  if (flowing) {
    infeed.outflow_fillets +=
        config.outflow_fillets_per_m_mm * bulk_mps * infeed.hopper_opening_mm * h_s;
    const double whole = std::floor(infeed.outflow_fillets);
    if (whole >= 1.0) {
      const auto moved =
          static_cast<std::uint32_t>(std::min(whole, static_cast<double>(infeed.hopper_fillets)));
      infeed.hopper_fillets -= moved;
      infeed.layer_fillets += moved;
      infeed.outflow_fillets -= whole;
    }
  }
  infeed.layer_mm = infeed.layer_fillets * config.layer_mm_per_fillet;

  // Leveller rotor: a heap taller than the blades can start against stalls a rotor that is
  // not already spinning (overload); an overloaded or unpowered rotor runs down.
  const bool stalled = infeed.layer_mm > config.leveller_overload_layer_mm &&
                       infeed.leveller_rpm < config.leveller_stall_rpm;
  infeed.leveller_overload = faults_.leveller_overload || stalled;
  const double rpm_target = (faults_.estop_open || infeed.leveller_overload)
                                ? 0.0
                                : std::max(0.0, static_cast<double>(out.leveller_speed_rpm));
  const double tau_s = std::max(static_cast<double>(config.leveller_time_constant_s), 1e-6);
  infeed.leveller_rpm += (rpm_target - infeed.leveller_rpm) * (1.0 - std::exp(-h_s / tau_s));

  // Pass one levelled fillet (or touching pair) onto the takt conveyor when there is room.
  const FilletBody& next = next_feed_.body;
  if (infeed.leveller_rpm < config.leveller_pass_min_rpm ||
      infeed.layer_fillets < static_cast<double>(next.member_count)) {
    return;
  }
  const double entry_mm = -static_cast<double>(line_.takt_belt_length_mm);
  const double needed_front_mm = entry_mm + 2.0 * next.half_extent_s_mm + next_feed_.gap_mm;
  if (!bodies_.empty()) {
    const FilletBody& last = bodies_.back();  // most upstream
    if (last.s_mm - last.half_extent_s_mm < needed_front_mm) return;
  }
  if (bodies_.size() >= config_.max_bodies) {
    if (!pool_was_full_) ++counters_.pool_full_refusals;
    pool_was_full_ = true;
    return;
  }
  pool_was_full_ = false;
  FilletBody body = next;
  body.group_id = next_group_id();
  for (std::uint8_t m = 0; m < body.member_count; ++m) body.members[m].plant_id = next_plant_id();
  body.s_mm = entry_mm + body.half_extent_s_mm;
  body.v_mps = drives_.speed_mps(DriveId::kTakt);
  locate(body);
  infeed.layer_fillets -= body.member_count;
  infeed.layer_mm = infeed.layer_fillets * config.layer_mm_per_fillet;
  counters_.fillets_spawned += body.member_count;
  if (body.member_count > 1) ++counters_.groups_spawned;
  insert_body(body);
  draw_next_feed();
}

}  // namespace fl
