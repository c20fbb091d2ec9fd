// Machinery of the DEM plant: station actuators, the walls they move (belt surfaces at the
// shared drive emulator's speeds), and the events a fillet meets (feeding across the barrier,
// flips, squeeze, exits).
#include <algorithm>
#include <cmath>
#include <numbers>

#include "fl/twin/dem_plant/dem_plant.hpp"

namespace fl {
namespace {

using dem::Vec3;
constexpr double kMm = 1e-3;

// A wall jump larger than this is placed directly instead of moved (park <-> stroke start).
constexpr double kTeleportM = 0.005;

// The centring plates (pusher or jaws) move at most a full stroke in line.yaml's stroke time
// and accelerate at DemMachineryConfig::pusher_accel_mps2; the pusher brakes at
// pusher_brake_mps2 (the jaws stop where they grip).
double centring_top_speed_mmps(const LineConfig& line) {
  return line.centring.max_shift_mm /
         std::max(static_cast<double>(line.centring.stroke_time_s), 1e-6);
}
// A plate's acceleration or braking limit in mm/s^2, kept off zero.
double plate_rate_mmps2(float limit_mps2) {
  return std::max(static_cast<double>(limit_mps2), 1e-3) * 1000.0;
}

}  // namespace

void DemPlant::step_stations(double h_s, const OutputImage& out) {
  Stations& st = stations_;
  const double plate_rate = h_s / std::max(static_cast<double>(line_.flip.actuation_s), 1e-6);
  st.plate1_travel = approach(st.plate1_travel, out.flip_plate1_flip ? 1.0 : 0.0, plate_rate);
  st.plate2_travel = approach(st.plate2_travel, out.flip_plate2_flip ? 1.0 : 0.0, plate_rate);

  if (config_.machinery.centring_unit == DemCentringUnit::kJaws) {
    step_jaws(h_s, out);
  } else {
    step_pusher(h_s, out);
  }

  const double roller_rate = h_s / std::max(static_cast<double>(line_.squeeze.actuation_s), 1e-6);
  st.roller_travel = approach(st.roller_travel, out.squeeze_roller_down ? 1.0 : 0.0, roller_rate);
  const bool was_pressing = st.roller_pressing;
  st.roller_pressing =
      st.roller_travel >= static_cast<double>(config_.shared.squeeze.contact_fraction);
  st.roller_went_down = st.roller_pressing && !was_pressing;
  st.knife_blowing = out.final_reject;  // solenoid and air: immediate against the 10 ms scan
}

const DemPlant::Fillet* DemPlant::fillet_at_centring() const {
  const double cs_m = line_.centring.s_mm * kMm;
  const double window_m = config_.machinery.pusher_window_half_mm * kMm;
  const Fillet* nearest = nullptr;
  for (const Fillet& f : fillets_) {
    const double from_m = std::abs(f.centroid_m.x() - cs_m);
    if (from_m <= window_m &&
        (nearest == nullptr || from_m < std::abs(nearest->centroid_m.x() - cs_m))) {
      nearest = &f;
    }
  }
  return nearest;
}

void DemPlant::step_pusher(double h_s, const OutputImage& out) {
  Stations& st = stations_;
  // Centring pusher: a stroke engages at the edge of the fillet at the unit and travels the
  // commanded shift; it parks when the stroke ends and the pusher is back.
  const double max_shift_mm = line_.centring.max_shift_mm;
  const double shift_mm =
      std::clamp(static_cast<double>(out.centring_shift_mm), -max_shift_mm, max_shift_mm);
  if (out.centring_stroke && st.pusher_side == 0 && std::abs(shift_mm) > 0.0) {
    const Fillet* nearest = fillet_at_centring();
    if (nearest != nullptr) {
      st.pusher_side = shift_mm < 0.0 ? 1 : -1;
      st.pusher_edge_m = st.pusher_side > 0 ? nearest->upper_m.y() : nearest->lower_m.y();
    }
  }
  const double pusher_target_mm = out.centring_stroke && st.pusher_side != 0 ? shift_mm : 0.0;
  const double pusher_speed_mmps = centring_top_speed_mmps(line_);
  // Trapezoidal profile: top speed from the stroke time, acceleration and braking limited
  // (DemMachineryConfig::pusher_accel_mps2, pusher_brake_mps2). A plate that brakes harder
  // than friction can stop the fillet leaves it sliding on.
  const double accel_mmps2 = plate_rate_mmps2(config_.machinery.pusher_accel_mps2);
  const double brake_mmps2 = plate_rate_mmps2(config_.machinery.pusher_brake_mps2);
  const double to_go_mm = pusher_target_mm - st.pusher_mm;
  // The braking curve sets the speed wanted near the target; the rate limit lets it follow.
  const double wanted_mmps = std::copysign(
      std::min(pusher_speed_mmps, std::sqrt(2.0 * brake_mmps2 * std::abs(to_go_mm))), to_go_mm);
  const bool speeding_up = std::abs(wanted_mmps) > std::abs(st.pusher_speed_mmps) &&
                           wanted_mmps * st.pusher_speed_mmps >= 0.0;
  st.pusher_speed_mmps =
      approach(st.pusher_speed_mmps, wanted_mmps, (speeding_up ? accel_mmps2 : brake_mmps2) * h_s);
  const double step_mm = st.pusher_speed_mmps * h_s;
  // Land exactly on the target instead of dithering around it at the last step.
  if (std::abs(step_mm) >= std::abs(to_go_mm) || std::abs(to_go_mm) < 1e-3) {
    st.pusher_mm = pusher_target_mm;
    st.pusher_speed_mmps = 0.0;
  } else {
    st.pusher_mm += step_mm;
  }
  if (!out.centring_stroke && st.pusher_mm == 0.0) st.pusher_side = 0;
}

void DemPlant::step_jaws(double h_s, const OutputImage& out) {
  Stations& st = stations_;
  const DemMachineryConfig& m = config_.machinery;
  using Jaws = Stations::Jaws;
  if (!out.centring_stroke) {
    st.jaws = Jaws::kParked;
    st.jaw_speed_mps = 0.0;
    st.pusher_mm = 0.0;
    return;
  }
  if (st.jaws == Jaws::kParked) {
    const Fillet* nearest = fillet_at_centring();
    if (nearest == nullptr) return;
    // Both jaws start just outside the fillet's outermost side: the nearer jaw meets it at
    // once, the other closes the same way from the far side.
    constexpr double kStartClearanceM = 0.003;
    st.jaw_half_gap_m =
        std::max(std::abs(nearest->upper_m.y()), std::abs(nearest->lower_m.y())) + kStartClearanceM;
    st.jaw_speed_mps = 0.0;
    st.jaws = Jaws::kClosing;
  }
  if (st.jaws == Jaws::kClosing) {
    const dem::State& s = sim_->state();
    const double grip_n = m.jaw_grip_force_n;
    if (std::abs(s.wall_force_n[wall_pusher_].y()) >= grip_n &&
        std::abs(s.wall_force_n[wall_jaw_].y()) >= grip_n) {
      st.jaws = Jaws::kGripping;
      st.jaw_speed_mps = 0.0;
    } else {
      st.jaw_speed_mps = approach(st.jaw_speed_mps, centring_top_speed_mmps(line_) * kMm,
                                  plate_rate_mmps2(m.pusher_accel_mps2) * kMm * h_s);
      st.jaw_half_gap_m = std::max(st.jaw_half_gap_m - st.jaw_speed_mps * h_s,
                                   static_cast<double>(m.jaw_min_half_gap_mm) * kMm);
    }
  }
  // The controller holds the stroke until the unit reports the commanded shift: a gripping
  // unit has centred the fillet, which is what the shift asked for.
  st.pusher_mm = st.jaws == Jaws::kGripping ? static_cast<double>(out.centring_shift_mm) : 0.0;
}

void DemPlant::command_walls(double h_s) {
  dem::State& s = sim_->mutable_state();
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    if (wall_belt_[d] == static_cast<std::size_t>(-1)) continue;
    s.walls[wall_belt_[d]].surface_velocity_m_per_s =
        Vec3(drives_.speed_mps(static_cast<DriveId>(d)), 0.0, 0.0);
  }
  // The plates' surfaces convey at the guide's speed down their slopes, as the guide's own
  // belt; plate 1 swings about its hinge (the belt's right edge, along the slope) to open.
  const double guide_mps = drives_.speed_mps(DriveId::kGuide);
  const Vec3 down_plate1 = plate_layout().slide_direction;
  dem::WallState& plate1 = s.walls[wall_plate1_];
  const double swing_rad = stations_.plate1_travel *
                           static_cast<double>(config_.machinery.plate_swing_deg) *
                           std::numbers::pi / 180.0;
  if (swing_rad != stations_.plate1_angle_rad) {
    // Start the step from the pose the last one aimed at (no drift of the integrated
    // rotation), then turn at the rate that reaches this step's angle at its end.
    plate1.rotation =
        Eigen::Quaterniond(Eigen::AngleAxisd(stations_.plate1_angle_rad, down_plate1));
    plate1.angular_velocity_rad_per_s =
        down_plate1 * (swing_rad - stations_.plate1_angle_rad) / h_s;
    stations_.plate1_angle_rad = swing_rad;
  } else {
    plate1.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(swing_rad, down_plate1));
    plate1.angular_velocity_rad_per_s.setZero();
  }
  plate1.surface_velocity_m_per_s = plate1.rotation * down_plate1 * guide_mps;
  s.walls[wall_landing_].surface_velocity_m_per_s = Vec3(guide_mps, 0.0, 0.0);
  // The pusher's face runs with the centring belt (a belt-faced pusher): it shifts the fillet
  // sideways only. A still steel face (mu 0.5) braked the side it touched, turned the fillet
  // by 0.77 rad during one stroke and threw its centroid 30 mm past the centre line.
  s.walls[wall_pusher_].surface_velocity_m_per_s =
      Vec3(drives_.speed_mps(DriveId::kCentring), 0.0, 0.0);
  s.walls[wall_jaw_].surface_velocity_m_per_s = s.walls[wall_pusher_].surface_velocity_m_per_s;

  bool teleported = false;
  // Kinematic walls: the velocity that lands on the target at the control step's end.
  auto drive_wall = [&](dem::WallState& wall, const Vec3& target_m) {
    const Vec3 delta = target_m - wall.translation_m;
    if (delta.norm() > kTeleportM) {
      wall.translation_m = target_m;
      wall.linear_velocity_m_per_s.setZero();
      teleported = true;
    } else {
      wall.linear_velocity_m_per_s = delta / h_s;
    }
  };
  const DemMachineryConfig& m = config_.machinery;
  const Stations& st = stations_;
  const double park_m = m.belt_half_width_mm * kMm + 0.15;
  if (m.centring_unit == DemCentringUnit::kJaws) {
    const double half_gap_m = st.jaws == Stations::Jaws::kParked ? park_m : st.jaw_half_gap_m;
    drive_wall(s.walls[wall_pusher_], Vec3(0.0, half_gap_m, 0.0));
    drive_wall(s.walls[wall_jaw_], Vec3(0.0, -half_gap_m, 0.0));
  } else {
    const double pusher_y_m = st.pusher_side == 0 ? park_m : st.pusher_edge_m + st.pusher_mm * kMm;
    drive_wall(s.walls[wall_pusher_], Vec3(0.0, pusher_y_m, 0.0));
  }
  const double drop_m = (m.roller_up_gap_mm - m.roller_down_gap_mm) * kMm;
  dem::WallState& roller = s.walls[wall_roller_];
  drive_wall(roller, Vec3(0.0, 0.0, -drop_m * st.roller_travel));
  // Rolling with the squeeze belt: the bottom line moves at the belt's speed.
  roller.angular_velocity_rad_per_s =
      Vec3(0.0, -drives_.speed_mps(DriveId::kSqueeze) / (m.roller_radius_mm * kMm), 0.0);
  if (teleported) sim_->prepare();  // new wall geometry without a motion step
}

void DemPlant::flip_sideways(Fillet& fillet) {
  // Simplification (see the header): plate 2 turns the fillet over in one go, a rigid
  // rotation by pi through its centroid about the travel direction down the plate's slope (the
  // heading a becomes -a, as a twisting conveyor turns it). Its lowest point stays where it
  // was; the spheres keep the fillet's mean velocity, spins stop.
  dem::State& s = sim_->mutable_state();
  const Vec3 axis = Vec3(1.0, 0.0, deck_slope(fillet.centroid_m.x())).normalized();
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(std::numbers::pi, axis).toRotationMatrix();
  double low_before = 1e9;
  double low_after = 1e9;
  for (const std::uint32_t k : fillet.particles) {
    low_before = std::min(low_before, s.position_m[k].z() - s.radius_m[k]);
    s.position_m[k] = fillet.centroid_m + turn * (s.position_m[k] - fillet.centroid_m);
    low_after = std::min(low_after, s.position_m[k].z() - s.radius_m[k]);
  }
  for (const std::uint32_t k : fillet.particles) {
    s.position_m[k].z() += low_before - low_after;
    s.velocity_m_per_s[k] = fillet.velocity_m_per_s;
    s.angular_velocity_rad_per_s[k].setZero();
  }
}

void DemPlant::apply_events(const OutputImage& out) {
  (void)out;
  const double plate1_m = line_.flip.plate1_s_mm * kMm;
  const double plate2_m = line_.flip.plate2_s_mm * kMm;
  const double roller_m = line_.squeeze.roller_s_mm * kMm;
  const double knife_m = line_.tolerance.final_reject_s_mm * kMm;
  const double knife_window_m = config_.shared.final_reject.window_half_mm * kMm;
  const double reject_start_m = line_.sections[index(DriveId::kReject)].start_mm * kMm;
  const double reject_end_m = line_.sections[index(DriveId::kReject)].end_mm * kMm;
  const double reject_mps = drives_.speed_mps(DriveId::kReject);
  const double placed_m = line_.placed_at_s_mm * kMm;
  const DemLossConfig& losses = config_.losses;
  const double half_w = config_.machinery.belt_half_width_mm * kMm;
  const PlateLayout plates = plate_layout();
  bool moved = false;
  for (Fillet& f : fillets_) {
    if (f.particles.empty()) continue;
    const double s_m = f.centroid_m.x();
    if (!f.fed && s_m >= 0.0) {
      f.fed = true;
      ++counters_.fillets_fed;
    }
    // Plate 1 is physical: whether the fillet turns over is the contact's business. A fillet
    // that reaches it while it swings is counted, as the fast plant counts a misflip.
    if (f.previous_s_m < plate1_m && s_m >= plate1_m && stations_.plate1_travel > 0.0 &&
        stations_.plate1_travel < 1.0) {
      ++counters_.misflips;
    }
    // Turned over on the plates or not: the fitted side as it left the guide and as it
    // reaches the reject belt.
    if (f.previous_s_m < plates.start_m && s_m >= plates.start_m) {
      f.side_before_plates = fit_pose(f).side;
    }
    if (f.previous_s_m < plates.end_m && s_m >= plates.end_m &&
        f.side_before_plates != SideUp::kUnknown && fit_pose(f).side != f.side_before_plates) {
      ++counters_.flips;
    }
    if (f.previous_s_m < plate2_m && s_m >= plate2_m) {
      const double travel = stations_.plate2_travel;
      bool do_flip = travel >= 1.0;
      if (travel > 0.0 && travel < 1.0) {
        // Plate in mid-travel: flips or not by chance and throws the heading (fast plant).
        ++counters_.misflips;
        do_flip = body_rng_.bernoulli(travel);
        const double throw_rad = config_.shared.flip.misflip_angle_rad;
        const Eigen::Matrix3d yaw =
            Eigen::AngleAxisd(body_rng_.uniform(-throw_rad, throw_rad), Vec3::UnitZ())
                .toRotationMatrix();
        dem::State& s = sim_->mutable_state();
        for (const std::uint32_t k : f.particles) {
          s.position_m[k] = f.centroid_m + yaw * (s.position_m[k] - f.centroid_m);
        }
        moved = true;
      }
      if (do_flip) {
        flip_sideways(f);
        moved = true;
      }
    }
    // Squeeze roller (thesis 6.2): lowered behind the thickest section is a good squeeze.
    if (std::abs(s_m - roller_m) < 0.25) {
      const Pose pose = fit_pose(f);
      const double length_m = 2.0 * templates_[f.variant].half_extent_m.x();
      // Thickest section at 0.3 of the length from the thick end (-x): body x = -0.2 L.
      const double thick_m = s_m - 0.2 * length_m * pose.rotation(0, 0);
      if (!f.thick_passed_roller && thick_m >= roller_m) f.thick_passed_roller = true;
      if (stations_.roller_went_down && f.thick_passed_roller && f.lower_m.x() < roller_m &&
          f.upper_m.x() > roller_m) {
        f.squeezed_ok = true;
      }
    }
    // Progress for the stuck check.
    if (s_m > f.progress_s_m + losses.stuck_progress_mm * kMm) {
      f.progress_s_m = s_m;
      f.progress_ns = time_ns_;
    }
    const double carried_mps = carrying_speed(
        line_, s_m / kMm, [this](DriveId drive) { return drives_.speed_mps(drive); });
    const bool belt_runs = std::abs(carried_mps) > 0.05;
    if (!belt_runs) f.progress_ns = time_ns_;  // a held belt is not a stuck fillet
    // Exits.
    if (stations_.knife_blowing && std::abs(s_m - knife_m) <= knife_window_m) {
      record_exit(f, TrueExit::kFinalReject);
      f.remove = true;
    } else if (reject_mps < 0.0 && f.velocity_m_per_s.x() < 0.0 && s_m < reject_end_m &&
               f.upper_m.x() > reject_start_m &&
               f.lower_m.x() < reject_start_m - losses.crate_overhang_mm * kMm) {
      // Only a fillet the reversing belt carries back over its upstream edge: its front still
      // over the reject belt. Without that test every fillet upstream (on the plates, the
      // held guide, the takt belt) that rocked backwards during a reversal went to the crate.
      record_exit(f, TrueExit::kRejectCrate);
      f.remove = true;
    } else if (s_m >= placed_m) {
      record_exit(f, TrueExit::kOutfeed);
      f.remove = true;
    } else if (f.centroid_m.z() < losses.fell_below_mm * kMm ||
               std::abs(f.centroid_m.y()) > half_w + 0.05 ||
               (f.fed && static_cast<double>(time_ns_ - f.progress_ns) * 1e-9 >
                             static_cast<double>(losses.stuck_after_s))) {
      record_exit(f, TrueExit::kFellOff);
      f.remove = true;
    }
    f.previous_s_m = s_m;
  }
  if (moved) {
    sim_->prepare();
    // prepare() may re-order the particles by cell: the fillets' particle indices are stale
    scan_particles();
  }
  take_out_removed();
}

}  // namespace fl
