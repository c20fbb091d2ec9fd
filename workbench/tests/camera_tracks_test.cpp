// Camera sightings joined into fillet tracks (a line recording's frames to a line-track
// dataset).
#include "fl/workbench/camera_tracks.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace fl::workbench {
namespace {

constexpr double kBeltMps = 0.6;   // the multilane units' nominal speed
constexpr double kFrameS = 0.025;  // the multilane cameras' period

BeltSpeedAt steady_belt(double speed_mps) {
  return [speed_mps](double /*s_m*/, double /*time_s*/) { return speed_mps; };
}

// Fillets at `start_s_m` carried by the belt, seen in frames `first`..`last` (inclusive), with
// a fixed +-`jitter_m` alternating error, as a camera's noise.
void add_fillet(std::vector<SightingFrame>& frames, double start_s_m, double y_m, int first,
                int last, double jitter_m = 0.0) {
  for (int k = first; k <= last; ++k) {
    const double t = k * kFrameS;
    const double error = (k % 2 == 0 ? 1.0 : -1.0) * jitter_m;
    frames[static_cast<std::size_t>(k)].fillets.push_back(
        {start_s_m + kBeltMps * t + error, y_m - error, 0.1 * k});
  }
}

std::vector<SightingFrame> empty_frames(int count) {
  std::vector<SightingFrame> frames(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k) frames[static_cast<std::size_t>(k)].time_s = k * kFrameS;
  return frames;
}

TEST(CameraTracks, FilletsCarriedByTheBeltKeepTheirOwnTracks) {
  // Two fillets 100 mm apart along the belt and one beside the first, 80 mm across, each with
  // 3 mm of camera error: well inside the 30 mm gate, well apart from each other.
  std::vector<SightingFrame> frames = empty_frames(20);
  add_fillet(frames, 3.40, 0.04, 0, 19, 0.003);
  add_fillet(frames, 3.40, -0.04, 0, 19, 0.003);
  add_fillet(frames, 3.30, 0.0, 2, 19, 0.003);
  const std::vector<CameraTrack> tracks = track_fillets(frames, steady_belt(kBeltMps), {});
  ASSERT_EQ(tracks.size(), 3U);
  EXPECT_EQ(tracks[0].rows.size(), 20U);
  EXPECT_EQ(tracks[2].rows.size(), 18U);
  for (const CameraTrack& track : tracks) {
    // One fillet per track: its lateral place never jumps between the lanes.
    for (const Sighting& row : track.rows) {
      EXPECT_NEAR(row.y_m, track.rows.front().y_m, 0.007);
    }
  }
  EXPECT_NEAR(tracks[0].rows.front().y_m, 0.04 - 0.003, 1e-12);  // frame 0's error is +3 mm
  EXPECT_DOUBLE_EQ(tracks[2].time_s.front(), 2 * kFrameS);
}

TEST(CameraTracks, TheBeltsSpeedCarriesATrackOverALostFrameAndAGapClosesIt) {
  // Frames 5 and 6 lost: 75 ms, 45 mm of travel, beyond the gate unless the track is carried
  // with the belt. Then 0.2 s without a sighting: beyond max_gap, the fillet is taken as a new
  // one.
  std::vector<SightingFrame> frames = empty_frames(30);
  add_fillet(frames, 3.40, 0.0, 0, 4);
  add_fillet(frames, 3.40, 0.0, 7, 14);
  add_fillet(frames, 3.40, 0.0, 23, 29);
  const std::vector<CameraTrack> carried = track_fillets(frames, steady_belt(kBeltMps), {});
  ASSERT_EQ(carried.size(), 2U);
  EXPECT_EQ(carried[0].rows.size(), 13U);
  EXPECT_EQ(carried[1].rows.size(), 7U);
  // Predicted as standing still, the lost frames break the track (each piece still long enough).
  EXPECT_EQ(track_fillets(frames, steady_belt(0.0), {}).size(), 3U);
}

TEST(CameraTracks, ShortTracksAreDroppedAndFramesMustBeInOrder) {
  std::vector<SightingFrame> frames = empty_frames(10);
  add_fillet(frames, 3.40, 0.0, 0, 9);
  add_fillet(frames, 3.60, 0.05, 6, 9);  // entered the view in the last four frames
  TrackingSettings settings;
  EXPECT_EQ(track_fillets(frames, steady_belt(kBeltMps), settings).size(), 1U);
  settings.min_rows = 4;
  EXPECT_EQ(track_fillets(frames, steady_belt(kBeltMps), settings).size(), 2U);
  std::swap(frames[3], frames[4]);
  EXPECT_THROW((void)track_fillets(frames, steady_belt(kBeltMps), settings), std::invalid_argument);
}

TEST(CameraTracks, TheTableNumbersTheFilletsInTheTracksOrder) {
  std::vector<SightingFrame> frames = empty_frames(6);
  add_fillet(frames, 3.40, 0.0, 0, 5);
  add_fillet(frames, 3.25, 0.0, 1, 5);
  const Table table = tracks_table(track_fillets(frames, steady_belt(kBeltMps), {}), 7);
  ASSERT_EQ(table.rows(), 11U);
  EXPECT_EQ(table.at("fillet").values_si.front(), 7.0);
  EXPECT_EQ(table.at("fillet").values_si.back(), 8.0);
  EXPECT_EQ(table.at("x").unit.symbol, "mm");
  EXPECT_DOUBLE_EQ(table.at("x").values_si[6], 3.25 + kBeltMps * kFrameS);  // fillet 8's first
}

}  // namespace
}  // namespace fl::workbench
