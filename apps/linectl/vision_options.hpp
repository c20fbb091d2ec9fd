// The options of linectl's vision commands (camera node, replay, vision eval): which camera,
// and estimator parameters over the defaults. Apart from cli_support so that the commands
// without vision (control, twin serve) build without OpenCV.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fl/controller/process_image.hpp"
#include "fl/vision/fillet_estimator.hpp"

namespace fl::apps {

// --camera NAME (orientation, position, multilane1, multilane2, final); logs and returns
// nullopt for any other name.
std::optional<CameraId> camera_option(const std::string& name);

// --set NAME=VALUE estimator parameters over the defaults; logs and returns nullopt for an
// unknown name or a bad value.
std::optional<vision::EstimatorParams> estimator_options(const std::vector<std::string>& settings);

}  // namespace fl::apps
