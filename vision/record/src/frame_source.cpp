#include "fl/vision/record/frame_source.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <stdexcept>

#include "fl/vision/record/recording.hpp"

namespace fl::vision::record {
namespace {

bool is_image_file(const std::filesystem::path& path) {
  static constexpr std::array<std::string_view, 8> kExtensions = {".png", ".jpg",  ".jpeg", ".bmp",
                                                                  ".tif", ".tiff", ".pgm",  ".ppm"};
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return std::find(kExtensions.begin(), kExtensions.end(), extension) != kExtensions.end();
}

// Grey, grey with alpha and BGRA frames become BGR: the estimator and the recording take
// BGR. Any other channel count is refused by the caller's error path.
cv::Mat to_bgr(const cv::Mat& image) {
  if (image.channels() == 3) return image;
  cv::Mat bgr;
  if (image.channels() == 2) {
    cv::Mat grey;
    cv::extractChannel(image, grey, 0);
    cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  } else {
    cv::cvtColor(image, bgr, image.channels() == 1 ? cv::COLOR_GRAY2BGR : cv::COLOR_BGRA2BGR);
  }
  return bgr;
}

}  // namespace

// ------------------------------------------------------------------ directory

DirectoryFrameSource::DirectoryFrameSource(const std::filesystem::path& directory,
                                           std::int64_t period_ns)
    : directory_(directory), period_ns_(period_ns) {
  if (period_ns <= 0) throw std::invalid_argument("frame period must be positive");
  if (!std::filesystem::is_directory(directory)) {
    throw std::runtime_error(directory.string() + ": not a directory");
  }
  for (const auto& entry : std::filesystem::directory_iterator(directory)) {
    if (entry.is_regular_file() && is_image_file(entry.path())) files_.push_back(entry.path());
  }
  if (files_.empty()) {
    throw std::runtime_error(directory.string() +
                             ": no image files (png, jpg, bmp, tif, pgm, ppm) in it");
  }
  std::sort(files_.begin(), files_.end());
}

std::optional<SourceFrame> DirectoryFrameSource::next() {
  if (next_ >= files_.size()) return std::nullopt;
  // Past this file before reading it: after an unreadable file the caller may go on with
  // the next one (the camera node does), and the gap stays in the sequence and the time.
  const std::size_t index = next_++;
  const std::filesystem::path& file = files_[index];
  // IMREAD_UNCHANGED keeps a 16-bit file 16-bit, so that it is refused below instead of
  // being scaled silently.
  cv::Mat image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  if (image.empty()) throw std::runtime_error(file.string() + ": not a readable image");
  if (image.depth() != CV_8U) {
    throw std::runtime_error(file.string() + ": not an 8-bit image (recordings are 8-bit)");
  }
  SourceFrame frame;
  frame.bgr = to_bgr(image);
  frame.sequence = static_cast<std::uint32_t>(index);
  frame.time_ns = static_cast<std::int64_t>(index) * period_ns_;
  frame.origin = file.filename().string();
  return frame;
}

std::string DirectoryFrameSource::describe() const {
  return "directory " + directory_.string() + " (" + std::to_string(files_.size()) + " images)";
}

// ------------------------------------------------------------------ VideoCapture

struct VideoCaptureFrameSource::Capture {
  cv::VideoCapture capture;
  cv::Mat frame;
};

VideoCaptureFrameSource::VideoCaptureFrameSource(const std::filesystem::path& file,
                                                 std::int64_t fallback_period_ns)
    : capture_(std::make_unique<Capture>()), description_("video file " + file.string()) {
  if (!std::filesystem::is_regular_file(file)) {
    throw std::runtime_error(file.string() + ": no such video file");
  }
  if (!capture_->capture.open(file.string(), cv::CAP_FFMPEG) &&
      !capture_->capture.open(file.string())) {
    throw std::runtime_error(file.string() + ": VideoCapture cannot open it");
  }
  const double fps = capture_->capture.get(cv::CAP_PROP_FPS);
  period_ns_ = std::isfinite(fps) && fps > 0.0 ? static_cast<std::int64_t>(std::llround(1e9 / fps))
                                               : fallback_period_ns;
}

VideoCaptureFrameSource::VideoCaptureFrameSource(int device_index)
    : capture_(std::make_unique<Capture>()),
      description_("camera device " + std::to_string(device_index)),
      device_(true) {
  if (capture_->capture.open(device_index)) {
    // One frame in the driver's queue: a frame stamped on arrival is then at most one period
    // old, not the four V4L2 buffers by default.
    capture_->capture.set(cv::CAP_PROP_BUFFERSIZE, 1);
  } else {
    throw std::runtime_error("camera device " + std::to_string(device_index) +
                             ": VideoCapture cannot open it (/dev/video" +
                             std::to_string(device_index) + ")");
  }
}

VideoCaptureFrameSource::~VideoCaptureFrameSource() = default;

std::optional<SourceFrame> VideoCaptureFrameSource::next() {
  if (!capture_->capture.read(capture_->frame) || capture_->frame.empty()) return std::nullopt;
  if (capture_->frame.depth() != CV_8U) {
    throw std::runtime_error(description_ + ": frame " + std::to_string(sequence_) +
                             " is not 8-bit");
  }
  SourceFrame frame;
  frame.bgr = to_bgr(capture_->frame).clone();
  frame.sequence = sequence_;
  if (device_) {
    const auto now = std::chrono::steady_clock::now();
    if (sequence_ == 0) first_ = now;
    frame.time_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(now - first_).count();
  } else {
    frame.time_ns = static_cast<std::int64_t>(sequence_) * period_ns_;
  }
  frame.origin = description_ + " frame " + std::to_string(sequence_);
  ++sequence_;
  return frame;
}

// ------------------------------------------------------------------ recording

RecordingFrameSource::RecordingFrameSource(const std::filesystem::path& recording, CameraId camera)
    : camera_(std::make_unique<RecordedCamera>()) {
  Recording loaded = load_recording(recording);
  *camera_ = std::move(loaded.cameras[static_cast<std::size_t>(camera)]);
  if (camera_->frames.empty()) {
    throw RecordingError(recording.string() + ": no frames of camera " +
                         std::string(camera_name(camera)));
  }
  first_exposure_ns_ = camera_->frames.begin()->second.exposure_ns;
  std::vector<std::int64_t> spacing_ns;
  std::int64_t previous_ns = first_exposure_ns_;
  for (auto it = std::next(camera_->frames.begin()); it != camera_->frames.end(); ++it) {
    spacing_ns.push_back(it->second.exposure_ns - previous_ns);
    previous_ns = it->second.exposure_ns;
  }
  if (!spacing_ns.empty()) {
    const auto middle =
        spacing_ns.begin() + static_cast<std::ptrdiff_t>((spacing_ns.size() - 1) / 2);
    std::nth_element(spacing_ns.begin(), middle, spacing_ns.end());
    median_period_ns_ = *middle;
  }
  description_ = "recording " + recording.string() + " (camera " +
                 std::string(camera_name(camera)) + ", " + std::to_string(camera_->frames.size()) +
                 " frames)";
}

RecordingFrameSource::~RecordingFrameSource() = default;

std::optional<SourceFrame> RecordingFrameSource::next() {
  if (exhausted_) return std::nullopt;
  const auto found = camera_->frames.lower_bound(next_sequence_);
  if (found == camera_->frames.end()) return std::nullopt;
  const RecordedFrame& recorded = found->second;
  // The last possible sequence: nothing can follow it (and + 1 would start over at 0).
  exhausted_ = recorded.sequence == std::numeric_limits<std::uint32_t>::max();
  next_sequence_ = exhausted_ ? recorded.sequence : recorded.sequence + 1;
  SourceFrame frame;
  frame.bgr = decode_frame(recorded);
  // Recorded sequences count from 1 (0 is "no frame yet" on the wire).
  frame.sequence = recorded.sequence > 0 ? recorded.sequence - 1 : 0;
  frame.time_ns = recorded.exposure_ns - first_exposure_ns_;
  frame.origin = recorded.where;
  return frame;
}

const std::optional<BeltCalibration>& RecordingFrameSource::calibration() const {
  return camera_->calibration;
}

std::size_t RecordingFrameSource::size() const { return camera_->frames.size(); }

}  // namespace fl::vision::record
