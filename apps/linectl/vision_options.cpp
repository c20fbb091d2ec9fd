#include "vision_options.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>

#include "fl/vision/record/recording.hpp"
#include "fl/vision/record/replay.hpp"

namespace fl::apps {

std::optional<CameraId> camera_option(const std::string& name) {
  const std::optional<CameraId> camera = vision::record::camera_from_name(name);
  if (!camera) {
    spdlog::error(
        "--camera {}: unknown camera (orientation, position, multilane1, multilane2, final)", name);
  }
  return camera;
}

std::optional<vision::EstimatorParams> estimator_options(const std::vector<std::string>& settings) {
  vision::EstimatorParams params;
  try {
    for (const std::string& setting : settings) {
      vision::record::set_estimator_param(params, setting);
    }
  } catch (const std::invalid_argument& error) {
    spdlog::error("--set: {}", error.what());
    return std::nullopt;
  }
  return params;
}

std::unique_ptr<vision::record::FrameSource> open_camera_frames(const std::string& images_dir,
                                                                const std::string& video_file,
                                                                int device,
                                                                std::int64_t period_ns) {
  if (!images_dir.empty()) {
    return std::make_unique<vision::record::DirectoryFrameSource>(images_dir, period_ns);
  }
  if (!video_file.empty()) {
    return std::make_unique<vision::record::VideoCaptureFrameSource>(video_file, period_ns);
  }
  return std::make_unique<vision::record::VideoCaptureFrameSource>(device);
}

}  // namespace fl::apps
