// Fillet tracks from a line camera's frames: what turns a recording of the line (each frame's
// estimates, each scan's belt speeds) into a line-track dataset taken on the line (machine: line,
// docs/measurements.md). A camera reports the fillets it sees in each frame without naming them;
// the tracks join each fillet's sightings from frame to frame.
//
//   const std::vector<CameraTrack> tracks = track_fillets(frames, belt_speed, {});
//   trial.data = tracks_table(tracks);
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "fl/controller/process_image.hpp"
#include "fl/workbench/dataset.hpp"

namespace fl::workbench {

// One fillet in one frame, in line coordinates: s along the product path from the takt barrier,
// y to the left looking downstream, the angle from the thick end to the tip counter-clockwise
// from the travel.
struct Sighting {
  double s_m = 0.0;
  double y_m = 0.0;
  double angle_rad = 0.0;
  Hand hand = Hand::kUnknown;  // as the camera classified it in this frame
};

struct SightingFrame {
  double time_s = 0.0;  // the exposure
  std::vector<Sighting> fillets;
};

struct TrackingSettings {
  // A sighting continues a track when its centre lies this close to where the belt under the
  // track carried its last sighting. A 25 ms frame at 0.6 m/s moves a fillet 15 mm; a fillet
  // turning or slipping moves its centre by a few millimetres a frame, while the next fillet is
  // at least a fillet's width (72 mm) away.
  double gate_m = 0.03;
  // A track not seen for this long has left the camera's view (a frame or two may be lost).
  double max_gap_s = 0.1;
  // Shorter tracks are dropped: a fillet cut by the view's edge, or a false sighting.
  std::size_t min_rows = 5;
};

struct CameraTrack {
  std::vector<double> time_s;
  std::vector<Sighting> rows;
};

// The belt's surface speed under a point of the path at a time (m/s).
using BeltSpeedAt = std::function<double(double s_m, double time_s)>;

// Joins sightings frame by frame (frames in time order; throws std::invalid_argument when not):
// each track is predicted to where the belt carried it since its last sighting, and the pairs
// of track and sighting within the gate are joined closest first, each at most once; a sighting
// left over starts a track. Tracks come out in the order they started.
std::vector<CameraTrack> track_fillets(const std::vector<SightingFrame>& frames,
                                       const BeltSpeedAt& belt_speed,
                                       const TrackingSettings& settings);

// The hand most of a track's sightings give (a tie or none: unknown).
Hand track_hand(const CameraTrack& track);

// A line-track data table of the tracks (time s, fillet 1, x mm, y mm, angle deg), fillets
// numbered from `first_fillet` in the tracks' order, rows per fillet in time order.
Table tracks_table(const std::vector<CameraTrack>& tracks, int first_fillet = 1);

}  // namespace fl::workbench
