#include "fl/workbench/camera_tracks.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

namespace fl::workbench {

std::vector<CameraTrack> track_fillets(const std::vector<SightingFrame>& frames,
                                       const BeltSpeedAt& belt_speed,
                                       const TrackingSettings& settings) {
  std::vector<CameraTrack> tracks;
  std::vector<std::size_t> open;  // tracks still in view
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const SightingFrame& frame = frames[f];
    if (f > 0 && frame.time_s < frames[f - 1].time_s) {
      throw std::invalid_argument("track_fillets: frame " + std::to_string(f) +
                                  " is earlier than the one before");
    }
    // Tracks out of view for too long are closed.
    std::erase_if(open, [&](std::size_t t) {
      return frame.time_s - tracks[t].time_s.back() > settings.max_gap_s;
    });
    // Every pair within the gate, closest first.
    std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;  // distance, open, sighting
    for (std::size_t o = 0; o < open.size(); ++o) {
      const CameraTrack& track = tracks[open[o]];
      const Sighting& last = track.rows.back();
      const double since_s = frame.time_s - track.time_s.back();
      const double predicted_s_m = last.s_m + belt_speed(last.s_m, track.time_s.back()) * since_s;
      for (std::size_t k = 0; k < frame.fillets.size(); ++k) {
        const Sighting& seen = frame.fillets[k];
        const double distance = std::hypot(seen.s_m - predicted_s_m, seen.y_m - last.y_m);
        if (distance <= settings.gate_m) pairs.emplace_back(distance, o, k);
      }
    }
    std::sort(pairs.begin(), pairs.end());
    std::vector<bool> track_taken(open.size(), false);
    std::vector<bool> sighting_taken(frame.fillets.size(), false);
    for (const auto& [distance, o, k] : pairs) {
      if (track_taken[o] || sighting_taken[k]) continue;
      track_taken[o] = true;
      sighting_taken[k] = true;
      tracks[open[o]].time_s.push_back(frame.time_s);
      tracks[open[o]].rows.push_back(frame.fillets[k]);
    }
    for (std::size_t k = 0; k < frame.fillets.size(); ++k) {
      if (sighting_taken[k]) continue;
      open.push_back(tracks.size());
      tracks.push_back({{frame.time_s}, {frame.fillets[k]}});
    }
  }
  std::erase_if(tracks, [&settings](const CameraTrack& track) {
    return track.rows.size() < settings.min_rows;
  });
  return tracks;
}

Hand track_hand(const CameraTrack& track) {
  std::ptrdiff_t left_minus_right = 0;
  for (const Sighting& row : track.rows) {
    if (row.hand == Hand::kLeft) ++left_minus_right;
    if (row.hand == Hand::kRight) --left_minus_right;
  }
  if (left_minus_right == 0) return Hand::kUnknown;
  return left_minus_right > 0 ? Hand::kLeft : Hand::kRight;
}

Table tracks_table(const std::vector<CameraTrack>& tracks, int first_fillet) {
  std::vector<double> time, fillet, x, y, angle;
  for (std::size_t t = 0; t < tracks.size(); ++t) {
    for (std::size_t k = 0; k < tracks[t].rows.size(); ++k) {
      time.push_back(tracks[t].time_s[k]);
      fillet.push_back(static_cast<double>(first_fillet) + static_cast<double>(t));
      x.push_back(tracks[t].rows[k].s_m);
      y.push_back(tracks[t].rows[k].y_m);
      angle.push_back(tracks[t].rows[k].angle_rad);
    }
  }
  return line_tracks_table(std::move(time), std::move(fillet), std::move(x), std::move(y),
                           std::move(angle));
}

}  // namespace fl::workbench
