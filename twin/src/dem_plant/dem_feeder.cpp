// Feeder of the DEM plant. Simplification of mailbox hopper, bulk belt and leveller (their
// flow is not simulated with particles): the hopper's outflow, bulk speed x opening as in the
// fast plant, fills a backlog counted in fillets in front of the leveller; the level sensor
// reads the backlog as heap height. A running leveller hands the next fillet (or touching
// pair) to the takt belt's upstream end when there is room behind the last one, at the takt
// belt's speed: the levelled layer the fast plant feeds, here as DEM bodies.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "fl/twin/dem_plant/dem_plant.hpp"

namespace fl {
namespace {

constexpr double kMm = 1e-3;

}  // namespace

void DemPlant::draw_next_feed() {
  const FastInfeedConfig& infeed = config_.shared.infeed;
  const auto variants = static_cast<std::uint32_t>(templates_.size());
  NextFeed& next = next_feed_;
  next.pair = feed_rng_.bernoulli(config_.shared.fillet.touching_pair_prob);
  next.variant = static_cast<std::uint8_t>(feed_rng_.below(variants));
  next.side = feed_rng_.bernoulli(0.5) ? SideUp::kSkin : SideUp::kBone;
  next.y_mm = feed_rng_.uniform(-infeed.takt_lateral_spread_mm,
                                static_cast<double>(infeed.takt_lateral_spread_mm));
  const double base_rad = feed_rng_.bernoulli(0.5) ? 0.0 : std::numbers::pi;
  next.angle_rad = wrap_angle_rad(base_rad + infeed.takt_heading_sigma_rad * feed_rng_.normal());
  next.gap_mm =
      feed_rng_.uniform(infeed.takt_gap_min_mm, static_cast<double>(infeed.takt_gap_max_mm));
}

void DemPlant::step_infeed(double h_s, const OutputImage& out) {
  const FastInfeedConfig& config = config_.shared.infeed;
  const double opening_target_mm = std::clamp(static_cast<double>(out.hopper_opening_mm),
                                              static_cast<double>(config.hopper_min_opening_mm),
                                              static_cast<double>(config.hopper_max_opening_mm));
  infeed_.hopper_opening_mm = approach(infeed_.hopper_opening_mm, opening_target_mm,
                                       config.hopper_cylinder_speed_mmps * h_s);
  const double bulk_mps = drives_.speed_mps(DriveId::kBulk);
  const double layer_mm = infeed_.backlog_fillets * config.layer_mm_per_fillet;
  if (bulk_mps > 0.0 && layer_mm < config.layer_max_mm) {
    infeed_.backlog_fillets +=
        config.outflow_fillets_per_m_mm * bulk_mps * infeed_.hopper_opening_mm * h_s;
  }
  const double rpm_target =
      faults_.estop_open ? 0.0 : std::max(0.0, static_cast<double>(out.leveller_speed_rpm));
  const double tau_s = std::max(static_cast<double>(config.leveller_time_constant_s), 1e-6);
  infeed_.leveller_rpm += (rpm_target - infeed_.leveller_rpm) * (1.0 - std::exp(-h_s / tau_s));

  const NextFeed& next = next_feed_;
  const double members = next.pair ? 2.0 : 1.0;
  if (infeed_.leveller_rpm < config.leveller_pass_min_rpm || infeed_.backlog_fillets < members) {
    return;
  }
  if (fillets_.size() + (next.pair ? 2U : 1U) > config_.simulation.max_fillets) return;
  // Room at the upstream end: the extent of the new fillet along the belt plus its gap.
  const dem::FilletTemplate& t = templates_[next.variant];
  const double c = std::abs(std::cos(next.angle_rad));
  const double sn = std::abs(std::sin(next.angle_rad));
  const double half_s_m = t.half_extent_m.x() * c + t.half_extent_m.y() * sn;
  const double entry_m = -static_cast<double>(line_.takt_belt_length_mm) * kMm;
  const double needed_m = entry_m + 2.0 * half_s_m + next.gap_mm * kMm;
  for (const Fillet& f : fillets_) {
    if (f.lower_m.x() < needed_m) return;
  }
  // Keep it (and a pair's partner, to its left) clear of the side walls. The template's
  // half extent across is the worst case for any heading near 0 or pi.
  const double half_w_mm = config_.machinery.belt_half_width_mm;
  const double half_y_mm = t.half_extent_m.y() / kMm;
  const double y_mm = std::clamp(next.y_mm, -half_w_mm + half_y_mm + 5.0,
                                 half_w_mm - half_y_mm - (next.pair ? 2.0 * half_y_mm : 0.0) - 5.0);
  DemFilletSpawn spawn;
  spawn.s_mm = (entry_m + half_s_m + 0.002) / kMm;
  spawn.y_mm = y_mm;
  spawn.angle_rad = next.angle_rad;
  spawn.v_mps = drives_.speed_mps(DriveId::kTakt);
  spawn.variant = next.variant;
  spawn.side = next.side;
  spawn.touching_pair = next.pair;
  if (spawn_fillet(spawn)) {
    infeed_.backlog_fillets -= members;
    draw_next_feed();
  }
}

}  // namespace fl
