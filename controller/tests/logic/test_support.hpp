// Helpers that build input images for station and controller tests.
#pragma once

#include <cmath>

#include "fl/controller/line_config.hpp"
#include "fl/controller/process_image.hpp"
#include "stations.hpp"

namespace fl::test {

// Moves a drive's encoder by `travel_mm` of belt, as the drive would over one scan.
inline void move_belt(InputImage& in, const LineConfig& config, DriveId drive, float travel_mm) {
  in.drives[index(drive)].encoder_counts +=
      std::llround(travel_mm * config.limits[index(drive)].counts_per_mm);
}

inline void all_drives_ready(InputImage& in) {
  for (DriveFeedback& drive : in.drives) drive.ready = true;
}

// Publishes one frame with a single estimate at line position s_mm.
inline void publish(InputImage& in, const LineConfig& config, CameraId camera, float s_mm,
                    FilletEstimate estimate) {
  CameraFrame& frame = in.cameras[index(camera)];
  ++frame.sequence;
  frame.frame_time_ns = in.time_ns;
  frame.count = 1;
  estimate.x_mm = s_mm - config.cameras[index(camera)].s_mm;
  frame.estimates[0] = estimate;
}

inline FilletEstimate good_estimate(Hand hand, SideUp side, float angle_rad) {
  FilletEstimate estimate;
  estimate.hand = hand;
  estimate.side = side;
  estimate.angle_rad = angle_rad;
  estimate.confidence = 0.95F;
  estimate.singulated = true;
  return estimate;
}

// A scan context over the given parts, running with the infeed enabled.
struct Harness {
  LineConfig config = default_line_config();
  logic::Tracker tracker{config};
  EventRing events;
  RecordRing records;
  ControllerCounters counters;
  InputImage in;
  OutputImage out;

  logic::ScanContext context(float dt_s = 0.01F, bool running = true, bool infeed = true) {
    return logic::ScanContext{in, dt_s, running, infeed, tracker, events, records, counters};
  }
};

}  // namespace fl::test
