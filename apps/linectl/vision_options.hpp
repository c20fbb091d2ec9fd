// The options of linectl's vision commands (camera node, replay, vision eval): which camera,
// and estimator parameters over the defaults. Apart from cli_support so that the commands
// without vision (control, twin serve) build without OpenCV.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fl/controller/process_image.hpp"
#include "fl/vision/fillet_estimator.hpp"
#include "fl/vision/record/frame_source.hpp"

namespace fl::apps {

// --camera NAME (orientation, position, multilane1, multilane2, final); logs and returns
// nullopt for any other name.
std::optional<CameraId> camera_option(const std::string& name);

// --set NAME=VALUE estimator parameters over the defaults; logs and returns nullopt for an
// unknown name or a bad value.
std::optional<vision::EstimatorParams> estimator_options(const std::vector<std::string>& settings);

// A real camera's frames, as record and camera serve take them: a directory of images or a
// video file (each paced at period_ns), else VideoCapture device N. The caller has checked
// that exactly one is named; throws what the source throws when it cannot be opened.
std::unique_ptr<vision::record::FrameSource> open_camera_frames(const std::string& images_dir,
                                                                const std::string& video_file,
                                                                int device, std::int64_t period_ns);

}  // namespace fl::apps
