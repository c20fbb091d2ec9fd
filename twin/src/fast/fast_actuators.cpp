// Drives and station actuators: belt motors with ramps and encoders, flip plates, centring
// pusher, squeeze roller and the final air knife.
#include <algorithm>
#include <cmath>

#include "fl/twin/fast_plant.hpp"

namespace fl {
namespace {

// Moves `value` towards `target` by at most `max_step`.
double approach(double value, double target, double max_step) {
  if (value < target) return std::min(value + max_step, target);
  return std::max(value - max_step, target);
}

}  // namespace

void FastPlant::step_drives(double h_s, const OutputImage& delayed) {
  // The safety chain cuts every drive (STO): it stops and reports not ready.
  const bool powered = !faults_.estop_open;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    FastDriveState& drive = state_.drives[d];
    const DriveLimits& limits = line_.limits[d];
    const DriveCommand& command = delayed.drives[d];
    drive.fault = faults_.drive_fault[d];
    const bool enabled = powered && command.enable && !drive.fault;
    const double max_accel_mps2 = limits.max_accel_mps2;
    double target_mps = 0.0;
    // Disabled or tripped: quick-stop ramp at the drive's limit.
    double accel_mps2 = max_accel_mps2;
    if (enabled) {
      const double max_speed_mps = limits.max_speed_mps;
      target_mps =
          std::clamp(static_cast<double>(command.speed_mps), -max_speed_mps, max_speed_mps);
      // A command ramp of zero (or less) means "as fast as allowed".
      if (command.accel_mps2 > 0.0F) {
        accel_mps2 = std::min(static_cast<double>(command.accel_mps2), max_accel_mps2);
      }
    }
    const double old_mps = drive.speed_mps;
    drive.speed_mps = approach(old_mps, target_mps, accel_mps2 * h_s);
    // Trapezoid: exact for the piecewise-linear speed of a ramp.
    drive.position_mm += 0.5 * (old_mps + drive.speed_mps) * h_s * 1000.0;
    drive.encoder_counts =
        static_cast<std::int64_t>(std::floor(drive.position_mm * limits.counts_per_mm));
    drive.ready = enabled;
  }
}

void FastPlant::step_stations(double h_s, const OutputImage& out) {
  FastStationState& stations = state_.stations;

  const double plate_rate = h_s / std::max(static_cast<double>(line_.flip.actuation_s), 1e-6);
  stations.plate1_travel =
      approach(stations.plate1_travel, out.flip_plate1_flip ? 1.0 : 0.0, plate_rate);
  stations.plate2_travel =
      approach(stations.plate2_travel, out.flip_plate2_flip ? 1.0 : 0.0, plate_rate);

  // The pusher strokes to the commanded shift (within its travel) and parks at 0.
  const double max_shift_mm = line_.centring.max_shift_mm;
  const double pusher_target_mm =
      out.centring_stroke
          ? std::clamp(static_cast<double>(out.centring_shift_mm), -max_shift_mm, max_shift_mm)
          : 0.0;
  const double pusher_speed_mmps =
      max_shift_mm / std::max(static_cast<double>(line_.centring.stroke_time_s), 1e-6);
  stations.pusher_mm = approach(stations.pusher_mm, pusher_target_mm, pusher_speed_mmps * h_s);

  const double roller_rate = h_s / std::max(static_cast<double>(line_.squeeze.actuation_s), 1e-6);
  stations.roller_travel =
      approach(stations.roller_travel, out.squeeze_roller_down ? 1.0 : 0.0, roller_rate);
  const bool was_pressing = stations.roller_pressing;
  stations.roller_pressing =
      stations.roller_travel >= static_cast<double>(config_.squeeze.contact_fraction);
  roller_went_down_ = stations.roller_pressing && !was_pressing;

  // Solenoid valve and air: fast against the 10 ms scan, modelled as immediate.
  stations.final_reject_blowing = out.final_reject;
}

}  // namespace fl
