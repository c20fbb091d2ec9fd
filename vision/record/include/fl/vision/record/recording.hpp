// Camera and line recordings in MCAP (docs/vision.md, "Recordings"): per camera the frames
// as lossless PNG and the camera's estimates, and per scan the controller's inputs (sensors,
// drive feedback) and outputs (command, status), so that `linectl replay` can run the vision
// and the controller logic again and compare their decisions.
//
// Channels (message encoding cdr unless said otherwise):
//   /camera/<name>/image      sensor_msgs/msg/CompressedImage (ros2msg), format "png";
//                             MCAP sequence = the camera's frame sequence, log time = exposure
//   /camera/<name>/estimates  fl::CameraEstimates (omgidl); log time = the scan at which the
//                             controller received them
//   /line/sensors             fl::LineSensors (omgidl), one per scan
//   /line/drive_feedback      fl::DriveFeedback (omgidl), one per drive per scan
//   /line/command             fl::LineCommand (omgidl), one per scan
//   /line/status              fl::LineStatus (omgidl), one per scan
//   /camera/<name>/truth      twin recordings only: the fillets as they truly lay in each
//                             frame (message encoding json, schema fl.CameraTruth in
//                             jsonschema); MCAP sequence = the frame's; for linectl vision eval
// Attachments: camera_<name>.yaml (the camera's belt calibration, as config/), line.yaml (the
// line configuration the controller ran with). Metadata "fl_recording": what made it.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "fl/controller/process_image.hpp"
#include "fl/vision/accuracy.hpp"
#include "fl/vision/calibration.hpp"
#include "fl/vision/record/cdr.hpp"

namespace fl::mcap {
class Writer;
}

namespace fl::vision::record {

inline constexpr std::string_view kRecordingFormatVersion = "1";
inline constexpr std::string_view kSensorsTopic = "/line/sensors";
inline constexpr std::string_view kDriveFeedbackTopic = "/line/drive_feedback";
inline constexpr std::string_view kCommandTopic = "/line/command";
inline constexpr std::string_view kStatusTopic = "/line/status";
inline constexpr std::string_view kLineConfigAttachment = "line.yaml";
inline constexpr std::string_view kInfoMetadataName = "fl_recording";

// "orientation", "position", "multilane1", "multilane2", "final" (config/line.yaml's names).
std::string_view camera_name(CameraId camera);
std::optional<CameraId> camera_from_name(std::string_view name);
std::string image_topic(CameraId camera);
std::string estimates_topic(CameraId camera);
std::string truth_topic(CameraId camera);
std::string calibration_attachment(CameraId camera);

// The schema texts written into recordings. fillet_line.idl holds every omgidl type of a
// recording, fl::LineSensors included.
std::string_view fillet_line_idl();  // drivers/dds/idl/fillet_line.idl
std::string_view compressed_image_msg();

// A recording that cannot be read: names the file, the record (channel, sequence, log time
// or byte offset) and what is wrong.
class RecordingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct WriterSettings {
  int png_compression = 6;                  // 0..9: 9 for recordings checked into the repository
  std::map<std::string, std::string> info;  // into the "fl_recording" metadata
};

class RecordingWriter {
 public:
  RecordingWriter(const std::filesystem::path& path, WriterSettings settings);
  ~RecordingWriter();
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  // A camera whose estimates are recorded; with `calibration`, its frames too (the
  // calibration is attached so that a replay measures with it).
  void add_camera(CameraId camera, const std::optional<BeltCalibration>& calibration);
  void attach_line_config(const std::string& yaml_text);

  // 8-bit BGR or grey; stored as PNG.
  void write_frame(CameraId camera, std::uint32_t sequence, std::int64_t exposure_ns,
                   const cv::Mat& image);
  void write_estimates(CameraId camera, std::int64_t log_time_ns, const CameraFrame& frame);
  // The twin's ground truth of a frame written with write_frame (same sequence and time).
  void write_truth(CameraId camera, std::uint32_t sequence, std::int64_t exposure_ns,
                   const std::vector<TrueFillet>& fillets);
  // The scan's input image (sensors and drives; cameras go through write_estimates) and the
  // controller's output image.
  void write_scan(std::uint64_t scan, const InputImage& in, const OutputImage& out);
  void close();

  [[nodiscard]] std::uint64_t frames_written() const { return frames_written_; }
  [[nodiscard]] std::uint64_t frame_bytes() const { return frame_bytes_; }
  [[nodiscard]] std::uint64_t bytes_written() const;

 private:
  std::uint16_t schema(std::string_view name);
  void write(std::uint16_t channel, std::uint32_t sequence, std::int64_t log_time_ns,
             const Bytes& data);

  std::unique_ptr<mcap::Writer> writer_;
  WriterSettings settings_;
  std::map<std::string, std::uint16_t, std::less<>> schemas_;
  std::array<std::uint16_t, kCameraCount> image_channel_{};
  std::array<std::uint16_t, kCameraCount> estimates_channel_{};
  std::array<std::uint16_t, kCameraCount> truth_channel_{};  // 0 until the first truth
  std::array<std::uint32_t, kCameraCount> estimates_sequence_{};
  std::uint16_t sensors_channel_ = 0;
  std::uint16_t drive_channel_ = 0;
  std::uint16_t command_channel_ = 0;
  std::uint16_t status_channel_ = 0;
  std::uint32_t scan_sequence_ = 0;
  std::uint64_t frames_written_ = 0;
  std::uint64_t frame_bytes_ = 0;
  std::vector<std::uint8_t> png_;
};

// ------------------------------------------------------------------ reading

struct RecordedFrame {
  std::uint32_t sequence = 0;
  std::int64_t exposure_ns = 0;
  std::string format;
  Bytes data;
  std::string where;  // "/camera/orientation/image message 17 (log time 0.680000000 s)"
};

struct RecordedEstimates {
  CameraId camera = CameraId::kOrientation;
  std::int64_t log_time_ns = 0;
  CameraFrame frame;
  std::string where;
};

struct RecordedScan {
  std::uint64_t scan = 0;
  InputImage input;  // sensors and drives; cameras empty
  std::optional<OutputImage> recorded_output;
};

struct RecordedCamera {
  bool has_frames = false;
  std::optional<BeltCalibration> calibration;     // from the attachment, when it has frames
  std::map<std::uint32_t, RecordedFrame> frames;  // by sequence
  std::map<std::uint32_t, std::vector<TrueFillet>> truth;  // by frame sequence (twin only)
};

struct Recording {
  std::filesystem::path path;
  std::map<std::string, std::string> info;
  std::optional<std::string> line_config_yaml;
  std::array<RecordedCamera, kCameraCount> cameras{};
  std::vector<RecordedEstimates> estimates;  // log-time order
  std::vector<RecordedScan> scans;           // scan order, consecutive from 0
  std::uint64_t message_count = 0;
};

// Reads a whole recording (indexed reader; CRCs checked) and checks it: every channel has a
// known schema, every sample decodes, every scan has its sensors and all drives. Throws
// RecordingError naming the file and the record.
Recording load_recording(const std::filesystem::path& path);

// Joins the frames of a camera node's recording (linectl camera serve --record) to a
// recording of the controller (linectl control --record), which holds the estimates as they
// reached it: the replay then measures each frame again where the controller received its
// estimates. Every camera with frames in `frames` is taken over with its calibration. Throws
// RecordingError naming both files when `line` has frames of that camera already, or when
// an estimate `line` recorded names a frame sequence `frames` does not hold (a recording
// of another run or another camera).
void join_frames(Recording& line, const Recording& frames);

// Decodes a recorded PNG frame to BGR; RecordingError (naming the frame) when it does not.
cv::Mat decode_frame(const RecordedFrame& frame);

}  // namespace fl::vision::record
