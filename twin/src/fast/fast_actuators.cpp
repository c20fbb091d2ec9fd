// Station actuators: flip plates, centring pusher, squeeze roller and the final air knife
// (the belt drives are the shared DriveEmulator).
#include <algorithm>
#include <cmath>

#include "fl/twin/fast_plant.hpp"

namespace fl {

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
