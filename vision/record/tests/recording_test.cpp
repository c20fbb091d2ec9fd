// Recording round trip and the malformed recordings a replay must refuse with an error that
// names the record: truncated file, corrupted chunk (CRC), unknown schema, a frame that does
// not decode; and a disk that fills up while recording.
#include "fl/vision/record/recording.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "fl/mcap/reader.hpp"
#include "fl/mcap/writer.hpp"
#include "fl/vision/record/replay.hpp"
#include "record_test_support.hpp"

namespace fl::vision::record {
namespace {

std::filesystem::path temp_file(const std::string& name) {
  return test::temp_file("fl_recording_test", name);
}

using test::small_calibration;

cv::Mat blue_belt() { return {48, 64, CV_8UC3, cv::Scalar(165, 105, 35)}; }

// Two scans, one frame with its estimates, on the orientation camera.
void write_small_recording(const std::filesystem::path& path) {
  RecordingWriter writer(path, {9, {{"source", "test"}}});
  writer.add_camera(CameraId::kOrientation, small_calibration());
  writer.add_camera(CameraId::kFinal, std::nullopt);
  writer.attach_line_config("line: {}\n");
  CameraFrame frame;
  frame.frame_time_ns = 0;
  frame.sequence = 1;
  writer.write_frame(CameraId::kOrientation, 1, 0, blue_belt());
  writer.write_estimates(CameraId::kOrientation, 10'000'000, frame);
  InputImage in;
  OutputImage out;
  for (std::uint64_t scan = 0; scan < 2; ++scan) {
    in.time_ns = static_cast<std::int64_t>(scan) * 10'000'000;
    in.drives[3].encoder_counts = static_cast<std::int64_t>(scan) * 50;
    out.drives[3].speed_mps = 0.45F;
    out.state = LineState::kStarting;
    writer.write_scan(scan, in, out);
  }
  writer.close();
}

Bytes read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void write_bytes(const std::filesystem::path& path, const Bytes& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

std::string load_error(const std::filesystem::path& path) {
  try {
    (void)load_recording(path);
  } catch (const RecordingError& error) {
    return error.what();
  }
  return "";
}

TEST(Recording, RoundTripsFramesEstimatesAndScans) {
  const auto path = temp_file("round_trip.mcap");
  write_small_recording(path);
  const Recording recording = load_recording(path);
  EXPECT_EQ(recording.info.at("source"), "test");
  EXPECT_EQ(recording.info.at("format_version"), "1");
  ASSERT_TRUE(recording.line_config_yaml.has_value());
  const RecordedCamera& camera = recording.cameras[index(CameraId::kOrientation)];
  EXPECT_TRUE(camera.has_frames);
  ASSERT_TRUE(camera.calibration.has_value());
  EXPECT_EQ(camera.calibration->image_width_px, 64);
  ASSERT_EQ(camera.frames.size(), 1U);
  const cv::Mat decoded = decode_frame(camera.frames.at(1));
  EXPECT_EQ(cv::norm(decoded, blue_belt(), cv::NORM_INF), 0.0);  // PNG is lossless
  EXPECT_FALSE(recording.cameras[index(CameraId::kFinal)].has_frames);
  ASSERT_EQ(recording.estimates.size(), 1U);
  EXPECT_EQ(recording.estimates[0].log_time_ns, 10'000'000);
  ASSERT_EQ(recording.scans.size(), 2U);
  EXPECT_EQ(recording.scans[1].input.drives[3].encoder_counts, 50);
  ASSERT_TRUE(recording.scans[1].recorded_output.has_value());
  EXPECT_EQ(recording.scans[1].recorded_output->drives[3].speed_mps, 0.45F);
  EXPECT_EQ(recording.scans[1].recorded_output->state, LineState::kStarting);
  std::filesystem::remove(path);
}

TEST(Recording, TruncatedFileIsAnErrorNamingTheFile) {
  const auto path = temp_file("truncated.mcap");
  write_small_recording(path);
  Bytes bytes = read_bytes(path);
  bytes.resize(bytes.size() / 2);  // cut in the middle, as a recorder killed mid-write
  write_bytes(path, bytes);
  const std::string error = load_error(path);
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_NE(error.find("not a readable MCAP recording"), std::string::npos) << error;
  std::filesystem::remove(path);
}

TEST(Recording, CorruptedChunkFailsItsCrc) {
  const auto path = temp_file("crc.mcap");
  write_small_recording(path);
  Bytes bytes = read_bytes(path);
  // The first chunk's compressed records begin shortly after the header and the metadata:
  // find the zstd frame magic (28 b5 2f fd) and damage a byte a little after it.
  const Bytes magic = {0x28, 0xb5, 0x2f, 0xfd};
  const auto at = std::search(bytes.begin(), bytes.end(), magic.begin(), magic.end());
  ASSERT_NE(at, bytes.end());
  *(at + 12) ^= 0xFF;
  write_bytes(path, bytes);
  const std::string error = load_error(path);
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_FALSE(error.empty());
  std::filesystem::remove(path);
}

TEST(Recording, UnknownSchemaNamesTheChannel) {
  const auto path = temp_file("unknown_schema.mcap");
  {
    mcap::Writer writer(path, {});
    const std::string schema = "int32 x\n";
    const auto schema_id =
        writer.add_schema("std_msgs/msg/Int32", "ros2msg",
                          {reinterpret_cast<const std::uint8_t*>(schema.data()), schema.size()});
    writer.add_channel(schema_id, "/plc/counter", "cdr");
    writer.close();
  }
  const std::string error = load_error(path);
  EXPECT_NE(error.find("/plc/counter"), std::string::npos) << error;
  EXPECT_NE(error.find("std_msgs/msg/Int32"), std::string::npos) << error;
  std::filesystem::remove(path);
}

TEST(Recording, FrameThatDoesNotDecodeNamesTheFrame) {
  const auto path = temp_file("bad_frame.mcap");
  write_small_recording(path);
  Recording recording = load_recording(path);
  RecordedFrame& frame = recording.cameras[index(CameraId::kOrientation)].frames.at(1);
  frame.data.resize(frame.data.size() / 2);  // a PNG cut short
  try {
    (void)decode_frame(frame);
    FAIL() << "a cut PNG decoded";
  } catch (const RecordingError& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find("/camera/orientation/image message 1"), std::string::npos) << what;
    EXPECT_NE(what.find("does not decode"), std::string::npos) << what;
  }
  std::filesystem::remove(path);
}

// Caps the size of any file this process writes (RLIMIT_FSIZE) while it lives, with SIGXFSZ
// ignored: write(2) past the cap then fails with EFBIG, as it fails with ENOSPC on a full
// disk, on the real file system and through the real stream, instead of killing the process.
class FileSizeCap {
 public:
  explicit FileSizeCap(rlim_t bytes) {
    EXPECT_EQ(::getrlimit(RLIMIT_FSIZE, &saved_), 0);
    previous_ = std::signal(SIGXFSZ, SIG_IGN);
    rlimit cap = saved_;
    cap.rlim_cur = bytes;
    EXPECT_EQ(::setrlimit(RLIMIT_FSIZE, &cap), 0);
  }
  ~FileSizeCap() {
    ::setrlimit(RLIMIT_FSIZE, &saved_);
    std::signal(SIGXFSZ, previous_);
  }
  FileSizeCap(const FileSizeCap&) = delete;
  FileSizeCap& operator=(const FileSizeCap&) = delete;

 private:
  rlimit saved_{};
  void (*previous_)(int) = nullptr;
};

// The disk fills up in the middle of a recording: the writer throws an error naming the file
// and the failed write, refuses every later write without crashing, and the chunks that
// reached the disk stay readable by the recovery scan.
TEST(Recording, DiskFullIsAnErrorNamingTheFileAndKeepsTheFlushedChunks) {
  const auto path = temp_file("disk_full.mcap");
  // 256 x 256 BGR noise: a PNG of about 197 kB that no compression shrinks, so a 1 MiB chunk
  // closes with its 6th frame (5 are 986 kB).
  constexpr int kSidePx = 256;
  BeltCalibration calibration = small_calibration();
  calibration.image_width_px = kSidePx;
  calibration.image_height_px = kSidePx;
  cv::Mat noise(kSidePx, kSidePx, CV_8UC3);
  // A linear congruential sequence's high bits, new for every frame (zstd would find a
  // repeated frame within a chunk): the same bytes every run, and no pattern PNG or zstd can
  // use.
  std::uint32_t state = 7;
  const auto next_noise = [&]() -> const cv::Mat& {
    for (auto pixel = noise.begin<cv::Vec3b>(); pixel != noise.end<cv::Vec3b>(); ++pixel) {
      for (int channel = 0; channel < 3; ++channel) {
        state = state * 1103515245U + 12345U;
        (*pixel)[channel] = static_cast<std::uint8_t>(state >> 24U);
      }
    }
    return noise;
  };
  // Room for the first 1 MiB chunk and its indexes, not for the second.
  constexpr rlim_t kCapBytes = 1536 * 1024;
  std::string error;
  std::uint32_t frames_accepted = 0;
  {
    FileSizeCap cap(kCapBytes);
    RecordingWriter writer(path, {1, {{"source", "test"}}});
    writer.add_camera(CameraId::kOrientation, calibration);
    // 40 frames are 7.9 MB: far past the cap.
    try {
      for (std::uint32_t sequence = 1; sequence <= 40; ++sequence) {
        writer.write_frame(CameraId::kOrientation, sequence, sequence * 40'000'000LL, next_noise());
        ++frames_accepted;
      }
    } catch (const std::runtime_error& caught) {
      error = caught.what();
    }
    ASSERT_FALSE(error.empty()) << "40 frames fitted under the cap";
    // Still refused, still no crash; closing (here and in the destructor) fails the same way.
    EXPECT_THROW(writer.write_frame(CameraId::kOrientation, 99, 4'000'000'000LL, next_noise()),
                 std::runtime_error);
    EXPECT_THROW(writer.close(), std::runtime_error);
  }
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_NE(error.find("failed at byte"), std::string::npos) << error;
  EXPECT_NE(error.find("File too large"), std::string::npos) << error;  // EFBIG's reason
  EXPECT_LE(std::filesystem::file_size(path), kCapBytes);

  const mcap::ScanResult recovered = mcap::scan_file(path);
  EXPECT_FALSE(recovered.complete);
  std::uint32_t frames_recovered = 0;
  for (const mcap::Message& message : recovered.messages) {
    const auto channel = recovered.channels.find(message.channel_id);
    ASSERT_NE(channel, recovered.channels.end());
    if (channel->second.topic == image_topic(CameraId::kOrientation)) {
      EXPECT_EQ(message.sequence, frames_recovered + 1);  // in order, none skipped
      ++frames_recovered;
    }
  }
  // The first chunk (6 frames) is on disk; the frames after it were lost with the chunk that
  // did not fit, never more than one chunk's worth (6 frames).
  EXPECT_GE(frames_recovered, 5U);
  EXPECT_LE(frames_recovered, frames_accepted);
  EXPECT_LE(frames_accepted - frames_recovered, 6U);
  // The indexed reader (replay) refuses the file and names it.
  EXPECT_NE(load_error(path).find(path.string()), std::string::npos);
  std::filesystem::remove(path);
}

TEST(Recording, MissingFileIsAnError) {
  EXPECT_NE(load_error(temp_file("does_not_exist.mcap")).find("no such recording"),
            std::string::npos);
}

}  // namespace
}  // namespace fl::vision::record
