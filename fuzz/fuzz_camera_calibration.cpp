// YAML text into the camera calibration loader (vision, config/camera_<name>.yaml). The
// contract: a BeltCalibration or ConfigError; any other exception escapes and is a finding.
// A calibration the loader accepts must be usable: the estimator takes it (its constructor
// refuses a degenerate homography, which the loader promises to have refused first), and
// the image's corners map to finite belt positions and back to finite pixels.
#include <cmath>
#include <cstdint>
#include <string>

#include "fl/controller/config_loader.hpp"
#include "fl/vision/calibration.hpp"
#include "fl/vision/fillet_estimator.hpp"

namespace {

volatile double g_sink = 0.0;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  fl::vision::BeltCalibration calibration;
  try {
    calibration = fl::vision::parse_calibration(text, "fuzz_camera.yaml");
  } catch (const fl::ConfigError& error) {
    g_sink = g_sink + static_cast<double>(error.problems().size());
    return 0;
  }
  // Frames are not measured here (the estimator's working images come with the first frame);
  // constructing it runs its own checks of the calibration.
  const fl::vision::FilletEstimator estimator(calibration);
  const double width = calibration.image_width_px;
  const double height = calibration.image_height_px;
  for (const cv::Point2d pixel : {cv::Point2d(0, 0), cv::Point2d(width - 1, 0),
                                  cv::Point2d(0, height - 1), cv::Point2d(width - 1, height - 1)}) {
    const cv::Point2d belt = calibration.pixel_to_belt(pixel);
    if (!std::isfinite(belt.x) || !std::isfinite(belt.y)) __builtin_trap();
    const cv::Point2d back = calibration.belt_to_pixel(belt);
    if (!std::isfinite(back.x) || !std::isfinite(back.y)) __builtin_trap();
    g_sink = g_sink + back.x;
  }
  return 0;
}
