// Feeders of the DEM plant: what puts fillets on the takt belt's upstream end
// (DemFeederConfig::source).
// - levelled_layer: a simplification of mailbox hopper, bulk belt and leveller (their flow is
//   not simulated with particles). The hopper's outflow, bulk speed x opening as in the fast
//   plant, fills a backlog counted in fillets in front of the leveller; the level sensor reads
//   the backlog as heap height. A running leveller hands the next fillet (or touching pair) to
//   the takt belt's upstream end when there is room behind the last one, at the takt belt's
//   speed: the levelled layer the fast plant feeds, here as DEM bodies.
// - dem_bulk_end: the hopper, bulk belt and leveller as a DEM scene (BulkScene), driven by the
//   same commands; its fillets wait at the scene's end on the stopped leveller's belt and move
//   onto the takt belt one by one, behind or beside the fillets there.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "fl/twin/dem_plant/dem_plant.hpp"

namespace fl {
namespace {

constexpr double kMm = 1e-3;
// A handed-over fillet's centroid is placed this far past the takt belt's upstream end beyond
// its own half extent, as a spawned one is.
constexpr double kEntryMarginM = 0.002;
// A fillet is placed this far inside the side walls.
constexpr double kWallClearanceMm = 5.0;

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
  // The leveller's motor: the same lag whichever rotor it turns; a tripped one runs down.
  const double rpm_target = faults_.estop_open || infeed_.leveller_overload
                                ? 0.0
                                : std::max(0.0, static_cast<double>(out.leveller_speed_rpm));
  const double tau_s = std::max(static_cast<double>(config.leveller_time_constant_s), 1e-6);
  infeed_.leveller_rpm += (rpm_target - infeed_.leveller_rpm) * (1.0 - std::exp(-h_s / tau_s));
  if (bulk_) {
    step_bulk_end(out);
  } else {
    step_layer_infeed(h_s, out);
  }
}

std::optional<double> DemPlant::entry_room_m(const dem::FilletTemplate& t, double angle_rad,
                                             double gap_m, std::optional<double> y_mm) const {
  // Room at the upstream end: the extent of the new fillet along the belt plus its gap; with
  // its place across given, beside a fillet that is clear of it across (plus the gap) too.
  const double c = std::abs(std::cos(angle_rad));
  const double sn = std::abs(std::sin(angle_rad));
  const double half_s_m = t.half_extent_m.x() * c + t.half_extent_m.y() * sn;
  const double half_y_m = t.half_extent_m.x() * sn + t.half_extent_m.y() * c;
  const double entry_m = -static_cast<double>(line_.takt_belt_length_mm) * kMm;
  const double needed_m = entry_m + 2.0 * half_s_m + gap_m;
  for (const Fillet& f : fillets_) {
    if (f.lower_m.x() >= needed_m) continue;
    if (y_mm && (f.lower_m.y() > *y_mm * kMm + half_y_m + gap_m ||
                 f.upper_m.y() < *y_mm * kMm - half_y_m - gap_m)) {
      continue;
    }
    return std::nullopt;
  }
  return entry_m + half_s_m + kEntryMarginM;
}

double DemPlant::entry_y_mm(const dem::FilletTemplate& t, double angle_rad, double y_mm,
                            double partner_dy_mm) const {
  // Its extent across the belt at its heading; a pair's partner lies beside it to its left, on
  // the side partner_dy_mm points to across the belt.
  const double half_w_mm = config_.machinery.belt_half_width_mm;
  const double half_y_mm = (t.half_extent_m.x() * std::abs(std::sin(angle_rad)) +
                            t.half_extent_m.y() * std::abs(std::cos(angle_rad))) /
                           kMm;
  return std::clamp(y_mm, -half_w_mm + half_y_mm + kWallClearanceMm + std::max(0.0, -partner_dy_mm),
                    half_w_mm - half_y_mm - kWallClearanceMm - std::max(0.0, partner_dy_mm));
}

void DemPlant::step_layer_infeed(double h_s, const OutputImage& out) {
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

  const NextFeed& next = next_feed_;
  const double members = next.pair ? 2.0 : 1.0;
  if (infeed_.leveller_rpm < config.leveller_pass_min_rpm || infeed_.backlog_fillets < members) {
    return;
  }
  if (fillets_.size() + (next.pair ? 2U : 1U) > config_.simulation.max_fillets) return;
  const dem::FilletTemplate& t = templates_[next.variant];
  // A pair's partner lies to the first fillet's left, which at a heading off the travel is also
  // along the belt: heading near pi, up to 40 mm upstream, where it would hang over the belt's
  // end, tip off and hold the entry shut for good. Room for both, and the pair placed so that
  // the partner's centre is no further upstream than the first's.
  const double partner_m = next.pair ? pair_offset_m(next.variant, next.side) : 0.0;
  const double partner_ds_m = -std::sin(next.angle_rad) * partner_m;
  const std::optional<double> s_m =
      entry_room_m(t, next.angle_rad, next.gap_mm * kMm + std::abs(partner_ds_m));
  if (!s_m) return;
  DemFilletSpawn spawn;
  spawn.s_mm = (*s_m + std::max(0.0, -partner_ds_m)) / kMm;
  spawn.y_mm = entry_y_mm(t, next.angle_rad, next.y_mm, std::cos(next.angle_rad) * partner_m / kMm);
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

void DemPlant::start_bulk_end(std::uint64_t seed) {
  BulkDemConfig config = config_.bulk_end;
  config.belt.hold_at_discharge = true;
  // Its own stream of fillet poses from the plant's seed; the commands start it.
  config.simulation.seed = stream_seed(seed, 4);
  config.belt.speed_mps = 0.0;
  config.leveller.speed_rpm = 0.0;
  config.gate.opening_mm =
      std::clamp(infeed_.hopper_opening_mm, config.gate.min_opening_mm, config.gate.max_opening_mm);
  bulk_ = std::make_unique<BulkScene>(config);
  last_handover_.reset();
  bulk_due_ns_ = std::max<std::int64_t>(1, std::llround(config.simulation.control_step_s * 1e9));
  infeed_.hopper_opening_mm = bulk_->gate_opening_mm();
}

void DemPlant::step_bulk_end(const OutputImage& out) {
  const FastInfeedConfig& config = config_.shared.infeed;
  // The cylinder's end stops are the line's; the scene moves the gate at its own speed.
  bulk_->set_gate_opening_mm(std::clamp(static_cast<double>(out.hopper_opening_mm),
                                        static_cast<double>(config.hopper_min_opening_mm),
                                        static_cast<double>(config.hopper_max_opening_mm)));
  bulk_->set_belt_speed_mps(drives_.speed_mps(DriveId::kBulk));
  bulk_->set_leveller_rpm(infeed_.leveller_rpm);
  // Whole control steps of the scene up to the plant's time (checked at load: its step is a
  // whole number of the plant's).
  const double scene_step_s = bulk_->config().simulation.control_step_s;
  const std::int64_t scene_step_ns = std::max<std::int64_t>(1, std::llround(scene_step_s * 1e9));
  while (bulk_due_ns_ <= time_ns_) {
    bulk_->step(scene_step_s);
    bulk_due_ns_ += scene_step_ns;
  }
  infeed_.hopper_opening_mm = bulk_->gate_opening_mm();
  // The rotor's load against the motor: over the trip torque the motor protection trips, and
  // it stays tripped until the leveller is commanded off (its reset).
  if (bulk_->leveller_load_mean().torque_nm >
      static_cast<double>(config_.feeder.leveller_trip_torque_nm)) {
    infeed_.leveller_overload = true;
  } else if (out.leveller_speed_rpm <= 0.0F) {
    infeed_.leveller_overload = false;
  }

  // The transfer: the fillet at the stop plate moves onto the takt belt when there is room.
  const std::optional<BulkHandover> front = bulk_->front_at_discharge();
  if (!front || fillets_.size() + 1U > config_.simulation.max_fillets) return;
  const Eigen::Matrix3d& r = front->rotation;
  const double angle_rad = wrap_angle_rad(std::atan2(r(1, 0), r(0, 0)));
  const dem::FilletTemplate& t = templates_[front->variant];
  // Where it lay across the leveller's belt: fillets side by side there go on side by side.
  const double y_mm = entry_y_mm(t, angle_rad, front->centroid_m.y() / kMm, 0.0);
  const std::optional<double> s_m =
      entry_room_m(t, angle_rad, static_cast<double>(config_.feeder.handover_gap_mm) * kMm, y_mm);
  if (!s_m) return;
  DemFilletSpawn spawn;
  spawn.s_mm = *s_m / kMm;
  spawn.y_mm = y_mm;
  spawn.angle_rad = angle_rad;
  spawn.v_mps = drives_.speed_mps(DriveId::kTakt);
  spawn.variant = front->variant;
  spawn.side = r(2, 2) >= 0.0 ? SideUp::kSkin : SideUp::kBone;
  const std::optional<std::uint32_t> plant_id = spawn_fillet(spawn);
  if (plant_id) {
    (void)bulk_->hand_over_front();
    ++counters_.handed_over;
    last_handover_ = Handover{*front, *plant_id};
  }
}

dem::Vec3 DemPlant::bulk_end_offset_m() const {
  const double entry_m = -static_cast<double>(line_.takt_belt_length_mm) * kMm;
  return {entry_m - config_.bulk_end.belt.discharge_mm * kMm, 0.0, deck_z_m(entry_m)};
}

double DemPlant::level_mm() {
  const FastInfeedConfig& infeed = config_.shared.infeed;
  const double heap_mm = bulk_ ? bulk_->heap_height_mm(config_.feeder.level_sensor_from_mm,
                                                       config_.feeder.level_sensor_to_mm)
                               : infeed_.backlog_fillets * infeed.layer_mm_per_fillet;
  return std::max(0.0, heap_mm + static_cast<double>(infeed.level_noise_mm) * sensor_rng_.normal());
}

}  // namespace fl
