#include "fl/vision/record/replay.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "fl/vision/record/frame_source.hpp"
#include "fl/vision/record/recording.hpp"
#include "fl/vision/record/twin_frame_source.hpp"

namespace fl::vision::record {
namespace {

class OneFilletScene final : public TwinScene {
 public:
  std::int64_t time_ns() const override { return time_ns_; }
  std::vector<render::FilletInstance> fillets() const override {
    render::FilletInstance fillet;
    // Moves 20 mm per frame along travel, as on the guide belt at 0.5 m/s and 25 Hz.
    fillet.x_mm = -40.0 + 20.0 * static_cast<double>(time_ns_) / 40e6;
    fillet.angle_rad = 2.0;
    return {fillet};
  }
  std::int64_t time_ns_ = 0;
};

// A vision-only recording (no line state), as `linectl record --images` makes. With
// `lose_frame`, the image of that sequence is missing while its estimates are recorded (a
// frame a recorder dropped, or a file cut between the two messages).
std::filesystem::path write_vision_recording(std::uint32_t lose_frame = 0) {
  auto path = std::filesystem::temp_directory_path() /
              ("fl_replay_test_" + std::to_string(::getpid()) + ".mcap");
  OneFilletScene scene;
  TwinCameraSettings settings;
  settings.width_px = 320;  // as the checked-in recordings
  settings.height_px = 240;
  TwinFrameSource source(std::make_shared<render::FilletRenderer>(), scene, settings,
                         "orientation");
  RecordingWriter writer(path, {6, {{"source", "replay_test"}}});
  writer.add_camera(CameraId::kOrientation, source.calibration());
  FilletEstimator estimator(source.calibration());
  for (int i = 0; i < 3; ++i) {
    scene.time_ns_ = i * 40'000'000LL;
    const SourceFrame frame = *source.next();
    const auto sequence = frame.sequence + 1;
    if (sequence != lose_frame) {
      writer.write_frame(CameraId::kOrientation, sequence, frame.time_ns, frame.bgr);
    }
    writer.write_estimates(
        CameraId::kOrientation, frame.time_ns,
        estimator.estimate(frame.bgr, frame.time_ns, sequence).to_camera_frame());
  }
  writer.close();
  return path;
}

TEST(Replay, VisionOnlyRecordingReplaysEveryFrameAsRecorded) {
  const auto path = write_vision_recording();
  const Recording recording = load_recording(path);
  const ReplayResult result = replay(recording, {});
  EXPECT_EQ(result.frames, 3U);
  EXPECT_EQ(result.scans, 0U);
  EXPECT_EQ(result.frames_differing_from_recording, 0U);  // same estimator, same frames
  ASSERT_EQ(result.entries.size(), 3U);
  EXPECT_EQ(result.entries[1].header, "frame orientation 2 t=0.040000000");
  ASSERT_EQ(result.entries[1].lines.size(), 2U);  // status and the one fillet
  EXPECT_EQ(result.entries[1].lines[0], "status ok");

  // Through text and back, and equal to itself.
  const auto parsed = parse_golden(format_golden(result.entries, "test\nsecond line"), "test");
  EXPECT_EQ(parsed, result.entries);
  EXPECT_TRUE(compare_golden(parsed, result.entries).empty());

  // A perturbed threshold is a difference: every fillet becomes "not singulated".
  ReplayOptions perturbed;
  set_estimator_param(perturbed.estimator, "max_single_area_mm2=3000");
  const ReplayResult changed = replay(recording, perturbed);
  const auto differences = compare_golden(result.entries, changed.entries);
  EXPECT_EQ(differences.size(), 3U);
  EXPECT_NE(format_difference(differences[0]).find("singulated=0"), std::string::npos)
      << format_difference(differences[0]);
  std::filesystem::remove(path);
}

// Estimates that name a frame the recording does not hold: replay stops with an error that
// names the estimates message and the image topic, rather than skip the frame or measure
// another one in its place.
TEST(Replay, EstimatesOfAMissingFrameAreAnErrorNamingBoth) {
  const auto path = write_vision_recording(2);
  const Recording recording = load_recording(path);
  try {
    (void)replay(recording, {});
    FAIL() << "a replay went on past a missing frame";
  } catch (const RecordingError& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find("names frame 2"), std::string::npos) << what;
    EXPECT_NE(what.find("/camera/orientation/image"), std::string::npos) << what;
    EXPECT_NE(what.find("/camera/orientation/estimates"), std::string::npos) << what;
  }
  std::filesystem::remove(path);
}

// Frames are measured ahead on several threads in batches (16 frames per thread): the
// checked-in line recording (hundreds of frames, many batches) replays to the same entries
// on 1 and on 3 threads, 3 being more than this machine's cores so that threads interleave.
TEST(Replay, ResultDoesNotDependOnTheMeasuringThreads) {
  const Recording recording = load_recording(std::filesystem::path(FL_SOURCE_DIR) /
                                             "vision/record/testdata/fast_seed1_orientation.mcap");
  ReplayOptions one_thread;
  one_thread.measure_threads = 1;
  ReplayOptions three_threads;
  three_threads.measure_threads = 3;
  const ReplayResult sequential = replay(recording, one_thread);
  const ReplayResult parallel = replay(recording, three_threads);
  EXPECT_GT(sequential.frames, 3U * 16U);  // more than one batch of the 3 threads
  EXPECT_EQ(parallel.frames, sequential.frames);
  EXPECT_EQ(parallel.entries, sequential.entries);
}

// On the line PC the controller (control --record) and the camera node (camera serve
// --record) record apart: the first the estimates as they arrived, the second the frames.
// Split the checked-in twin recording that way and join it again: the replay is the same,
// and every scan decides as recorded.
TEST(Replay, FramesJoinedFromACameraNodeRecordingReplayAsOne) {
  const Recording whole = load_recording(std::filesystem::path(FL_SOURCE_DIR) /
                                         "vision/record/testdata/fast_seed1_orientation.mcap");
  const std::size_t orientation = index(CameraId::kOrientation);
  ASSERT_TRUE(whole.cameras[orientation].has_frames);
  Recording line = whole;
  line.path = "line.mcap";
  line.cameras[orientation] = RecordedCamera{};
  Recording frames = whole;
  frames.path = "camera.mcap";
  frames.scans.clear();
  frames.estimates.clear();

  Recording joined = line;
  join_frames(joined, frames);
  const ReplayResult expected = replay(whole, {});
  const ReplayResult result = replay(joined, {});
  EXPECT_EQ(result.entries, expected.entries);
  EXPECT_GT(result.frames, 0U);
  EXPECT_EQ(result.scans_with_recorded_output, whole.scans.size());
  EXPECT_EQ(result.scans_differing_from_recording, 0U);

  // Frames of that camera twice: refused, naming both files.
  try {
    join_frames(joined, frames);
    FAIL() << "joined a camera's frames twice";
  } catch (const RecordingError& error) {
    EXPECT_NE(std::string(error.what()).find("line.mcap and camera.mcap: both hold frames"),
              std::string::npos)
        << error.what();
  }
  // A frame the controller received estimates of is not in the camera's recording.
  Recording other_run = frames;
  const std::uint32_t missing = line.estimates.front().frame.sequence;
  other_run.cameras[orientation].frames.erase(missing);
  Recording incomplete = line;
  try {
    join_frames(incomplete, other_run);
    FAIL() << "joined a recording that lacks a frame the controller saw";
  } catch (const RecordingError& error) {
    EXPECT_NE(std::string(error.what()).find("names frame " + std::to_string(missing)),
              std::string::npos)
        << error.what();
  }
}

TEST(Golden, DifferencesAreListedInTimeOrder) {
  const std::vector<GoldenEntry> expected = {
      {"frame orientation 1 t=0.000000000", {"status ok"}},
      {"scan 3 t=0.030000000", {"out flip_plate1_flip 1", "event item_created"}},
      {"end t=0.050000000", {"scans=6"}}};
  const std::vector<GoldenEntry> actual = {{"frame orientation 1 t=0.000000000", {"status ok"}},
                                           {"scan 2 t=0.020000000", {"out flip_plate1_flip 1"}},
                                           {"scan 3 t=0.030000000", {"event item_created"}},
                                           {"end t=0.050000000", {"scans=6"}}};
  const auto differences = compare_golden(expected, actual);
  ASSERT_EQ(differences.size(), 2U);
  EXPECT_EQ(differences[0].header, "scan 2 t=0.020000000");
  EXPECT_FALSE(differences[0].expected.has_value());
  EXPECT_EQ(differences[1].header, "scan 3 t=0.030000000");
  EXPECT_EQ(format_difference(differences[1]),
            "scan 3 t=0.030000000: changed\n  - out flip_plate1_flip 1\n");
}

TEST(Golden, MalformedGoldenNamesTheLine) {
  EXPECT_THROW(parse_golden("  orphan line\n", "g.txt"), std::runtime_error);
  EXPECT_THROW(parse_golden("scan 1 t=0\n   three spaces\n", "g.txt"), std::runtime_error);
  EXPECT_EQ(parse_golden("# comment\n\nend t=0\n  scans=1\n", "g.txt").size(), 1U);
}

TEST(Replay, EstimatorSettingsAreChecked) {
  EstimatorParams params;
  set_estimator_param(params, "min_solidity=0.95");
  EXPECT_EQ(params.min_solidity, 0.95);
  set_estimator_param(params, "border_margin_px=3");
  EXPECT_EQ(params.border_margin_px, 3);
  EXPECT_THROW(set_estimator_param(params, "min_solidity"), std::invalid_argument);
  EXPECT_THROW(set_estimator_param(params, "no_such_param=1"), std::invalid_argument);
  EXPECT_THROW(set_estimator_param(params, "min_solidity=abc"), std::invalid_argument);
  EXPECT_THROW(set_estimator_param(params, "min_solidity=nan"), std::invalid_argument);
  // The bend fit (fillet_estimator.hpp, item 6b): its pass count is a whole number.
  set_estimator_param(params, "bend_fit_passes=0");
  EXPECT_EQ(params.bend_fit_passes, 0);
  set_estimator_param(params, "max_bend_per_mm=0.01");
  EXPECT_EQ(params.max_bend_per_mm, 0.01);
  EXPECT_THROW(set_estimator_param(params, "bend_fit_passes=1.5"), std::invalid_argument);
  EXPECT_THROW(set_estimator_param(params, "bend_fit_passes=11"), std::invalid_argument);
}

}  // namespace
}  // namespace fl::vision::record
