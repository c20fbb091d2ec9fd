// Where recorded frames come from: the twin's renderer (twin_frame_source.hpp, a separate
// library so that this one does not link the twin), OpenCV VideoCapture (a video file or a
// camera device on the line PC) and a directory of still images.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace fl::vision::record {

struct SourceFrame {
  cv::Mat bgr;  // CV_8UC3
  std::int64_t time_ns = 0;
  std::uint32_t sequence = 0;  // +1 per frame from 0
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

 private:
  struct Capture;
  std::unique_ptr<Capture> capture_;
  std::string description_;
  bool device_ = false;
  std::int64_t period_ns_ = 0;
  std::uint32_t sequence_ = 0;
  std::chrono::steady_clock::time_point first_{};
};

}  // namespace fl::vision::record
