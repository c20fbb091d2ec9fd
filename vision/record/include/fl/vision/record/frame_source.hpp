// Where recorded frames come from: the twin's renderer (twin_frame_source.hpp, a separate
// library so that this one does not link the twin), OpenCV VideoCapture (a video file or a
// camera device on the line PC), a directory of still images, and one camera's frames in an
// MCAP recording (to serve yesterday's frames again, as the camera node does in tests).
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fl/controller/process_image.hpp"
#include "fl/vision/calibration.hpp"

namespace fl::vision::record {

struct RecordedCamera;

struct SourceFrame {
  cv::Mat bgr;  // CV_8UC3
  std::int64_t time_ns = 0;
  std::uint32_t sequence = 0;  // the source's frame number from 0: +1 per frame it delivered
  std::string origin;          // file name, device frame number, ...
};

class FrameSource {
 public:
  FrameSource() = default;
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;
  virtual ~FrameSource() = default;

  // The next frame, or nothing at the end of the stream. Throws std::runtime_error naming the
  // file or device when a frame cannot be read (a corrupt image is an error, not an end).
  virtual std::optional<SourceFrame> next() = 0;
  [[nodiscard]] virtual std::string describe() const = 0;
  // The spacing of the frames' stamps where the source sets it (a directory's, a video file's
  // frame rate); 0 where frames are stamped as they arrive or the spacing is not known.
  [[nodiscard]] virtual std::int64_t period_ns() const { return 0; }
};

// Every image file (png, jpg, jpeg, bmp, tif, tiff, pgm, ppm) in a directory, in file-name order,
// stamped `period_ns` apart from 0. Grey images are expanded to BGR.
class DirectoryFrameSource final : public FrameSource {
 public:
  // Throws std::runtime_error when the directory does not exist or holds no image file.
  DirectoryFrameSource(const std::filesystem::path& directory, std::int64_t period_ns);
  std::optional<SourceFrame> next() override;
  [[nodiscard]] std::string describe() const override;
  [[nodiscard]] std::size_t size() const { return files_.size(); }
  [[nodiscard]] std::int64_t period_ns() const override { return period_ns_; }

 private:
  std::filesystem::path directory_;
  std::vector<std::filesystem::path> files_;
  std::int64_t period_ns_;
  std::size_t next_ = 0;
};

// cv::VideoCapture on a file or a device index. A file's frames are stamped from its frame
// rate (or `fallback_period_ns` when it reports none); a device's from the steady clock,
// relative to the first frame.
class VideoCaptureFrameSource final : public FrameSource {
 public:
  explicit VideoCaptureFrameSource(const std::filesystem::path& file,
                                   std::int64_t fallback_period_ns = 40'000'000);
  explicit VideoCaptureFrameSource(int device_index);
  ~VideoCaptureFrameSource() override;
  std::optional<SourceFrame> next() override;
  [[nodiscard]] std::string describe() const override { return description_; }
  // A file's frame spacing (its frame rate, or the fallback); 0 for a device.
  [[nodiscard]] std::int64_t period_ns() const override { return period_ns_; }

 private:
  struct Capture;
  std::unique_ptr<Capture> capture_;
  std::string description_;
  bool device_ = false;
  std::int64_t period_ns_ = 0;
  std::uint32_t sequence_ = 0;
  std::chrono::steady_clock::time_point first_{};
};

// One camera's frames in a recording (recording.hpp), in sequence order, stamped with their
// exposure relative to the first frame's; `sequence` is the recorded one less 1, so a frame
// the recorder lost stays a gap. Throws RecordingError when the file is unusable or has no
// frames of this camera, and (from next()) naming the frame when one does not decode.
class RecordingFrameSource final : public FrameSource {
 public:
  RecordingFrameSource(const std::filesystem::path& recording, CameraId camera);
  ~RecordingFrameSource() override;
  std::optional<SourceFrame> next() override;
  [[nodiscard]] std::string describe() const override { return description_; }
  // The belt calibration the frames were recorded with (the recording's attachment).
  [[nodiscard]] const std::optional<BeltCalibration>& calibration() const;
  [[nodiscard]] std::size_t size() const;
  // The median spacing of consecutive recorded frames (0 with a single frame).
  [[nodiscard]] std::int64_t median_period_ns() const { return median_period_ns_; }

 private:
  std::unique_ptr<RecordedCamera> camera_;
  std::int64_t median_period_ns_ = 0;
  std::string description_;
  std::uint32_t next_sequence_ = 0;  // the recorded sequence to deliver next (or the one after)
  bool exhausted_ = false;
  std::int64_t first_exposure_ns_ = 0;
};

}  // namespace fl::vision::record
