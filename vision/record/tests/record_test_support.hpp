// Shared by the recording tests: scratch files and a tiny camera calibration.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "fl/vision/calibration.hpp"

namespace fl::vision::record::test {

// A file name in the temporary folder, unique per test process and `prefix`.
inline std::filesystem::path temp_file(const std::string& prefix, const std::string& name) {
  return std::filesystem::temp_directory_path() /
         (prefix + "_" + std::to_string(::getpid()) + "_" + name);
}

inline BeltCalibration small_calibration() {
  BeltCalibration calibration;
  calibration.camera_name = "orientation";
  calibration.image_width_px = 64;  // tiny frames: the file format does not care
  calibration.image_height_px = 48;
  // 1 mm/px, origin at the image centre, belt y up the image (as the twin's top-down camera).
  calibration.image_to_belt = cv::Matx33d(1, 0, -32, 0, -1, 24, 0, 0, 1);
  return calibration;
}

}  // namespace fl::vision::record::test
