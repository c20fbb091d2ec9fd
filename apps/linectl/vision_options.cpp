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
    for (const std::string& setting : settings)
      vision::record::set_estimator_param(params, setting);
  } catch (const std::invalid_argument& error) {
    spdlog::error("--set: {}", error.what());
    return std::nullopt;
  }
  return params;
}

}  // namespace fl::apps
