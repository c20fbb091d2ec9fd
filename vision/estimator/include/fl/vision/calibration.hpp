// Camera calibration for the line cameras: intrinsics (optional) and the belt-plane
// homography from pictures of a plain checkerboard, saved to and loaded from YAML
// (config/camera_<name>.yaml) with strict validation.
//
// Belt frame (FilletEstimate's): x along travel, y to the left looking downstream, millimetres,
// origin under the optical axis. The board lying on the belt defines it: its x axis is laid
// along travel (an operator squares it against the belt edge; BeltFrameDefinition takes a
// known residual yaw), and the origin is either the belt point seen at the principal point
// (the image centre without intrinsics) or a known belt position of the board's first corner.
//
// Board convention (unambiguous with inner corners x + y odd and x != y, e.g. 9 x 6): inner
// corner (i, j) lies at board (i, j) x square; the square diagonally outside corner (0, 0) is
// black. findChessboardCorners may return the corners in either of the two 180-degree orders;
// the order is fixed by looking at that square.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace fl::vision {

struct CheckerboardSpec {
  int inner_corners_x = 9;
  int inner_corners_y = 6;
  double square_mm = 20.0;
};

struct BeltCalibration {
  std::string camera_name;  // "orientation", "position", ...
  int image_width_px = 0;
  int image_height_px = 0;
  // Intrinsics; without them the camera is treated as distortion-free and the homography
  // takes raw pixels.
  bool has_intrinsics = false;
  cv::Matx33d camera_matrix = cv::Matx33d::eye();
  cv::Vec<double, 5> distortion{0, 0, 0, 0, 0};  // k1 k2 p1 p2 k3 (OpenCV)
  // Undistorted pixel (u, v, 1) -> belt millimetres (homogeneous).
  cv::Matx33d image_to_belt = cv::Matx33d::eye();
  double reprojection_rms_px = 0.0;  // of the board corners through the homography

  // Pixel -> belt mm (applies the distortion model when there are intrinsics).
  [[nodiscard]] cv::Point2d pixel_to_belt(cv::Point2d pixel) const;
  // Belt mm -> pixel (distorts when there are intrinsics).
  [[nodiscard]] cv::Point2d belt_to_pixel(cv::Point2d belt_mm) const;
  // Millimetres per pixel at the image centre (geometric mean of both axes).
  [[nodiscard]] double mm_per_px_at_centre() const;
};

// Thrown by calibration and by the YAML loader for a bad file (the loader throws
// fl::ConfigError, which names file, key and line, for format problems).
class CalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Inner corners with sub-pixel refinement in the board's convention (see above); nullopt when
// the board is not found. Accepts 8-bit grey or BGR.
std::optional<std::vector<cv::Point2f>> find_checkerboard(const cv::Mat& image,
                                                          const CheckerboardSpec& board);

struct IntrinsicsResult {
  cv::Matx33d camera_matrix = cv::Matx33d::eye();
  cv::Vec<double, 5> distortion{0, 0, 0, 0, 0};
  double rms_px = 0.0;
  int views_used = 0;
  // Share of the image (in a kCoverageCells grid) that held a board corner in some view. The
  // distortion model is fitted where the corners were; beyond them a polynomial extrapolates
  // freely, so a low share means corners of the image whose mapping nobody measured.
  double covered_share = 0.0;
};
inline constexpr int kCoverageColumns = 8;
inline constexpr int kCoverageRows = 6;
// Below this the views leave image regions unmeasured and fl_calibrate warns. Three
// quarters: a whole board in view cannot put a corner into every outermost cell, and views
// that covered 79 % kept the belt mapping within 2 px over the whole image (test
// Calibration.BarrelDistortionIsFittedAndUndoneThroughToTheEstimate).
inline constexpr double kMinCoveredShare = 0.75;

// cv::calibrateCamera over views of the board in different poses (at least 3 where it is
// found). Radial k1, k2 and tangential p1, p2 are fitted; k3 stays zero, as for any lens that
// is not a fisheye: with k3 free the fit chases the corners' noise and diverges outside them.
// `fix_distortion` keeps all at zero (for a lens known to be rectilinear, or for few views).
// Throws CalibrationError naming the views where the board was not found.
IntrinsicsResult calibrate_intrinsics(const std::vector<cv::Mat>& views,
                                      const CheckerboardSpec& board, bool fix_distortion = false);

struct BeltFrameDefinition {
  // The belt yaw of the board's x axis (0: squared with travel).
  double board_yaw_rad = 0.0;
  // When set: belt position of the board's first inner corner. Otherwise the origin is the belt
  // point seen at the principal point (the image centre without intrinsics).
  std::optional<cv::Point2d> board_origin_mm;
};

// Belt-plane homography from one picture of the board lying on the belt (findHomography over
// all inner corners, undistorted first when `intrinsics` are given).
BeltCalibration calibrate_belt_plane(const cv::Mat& board_on_belt, const CheckerboardSpec& board,
                                     const std::optional<IntrinsicsResult>& intrinsics,
                                     const BeltFrameDefinition& frame,
                                     const std::string& camera_name);

// YAML (config/camera_<name>.yaml). save writes every value with round-trip precision; load
// checks every key (fl::YamlReader: unknown, missing, wrong type, out of range, naming file,
// key and line) and the homography's sanity (finite, invertible, maps the image onto a belt
// area of the right orientation), and throws fl::ConfigError.
void save_calibration(const std::filesystem::path& file, const BeltCalibration& calibration);
BeltCalibration load_calibration(const std::filesystem::path& file);
BeltCalibration parse_calibration(const std::string& yaml_text, const std::string& source_name);

}  // namespace fl::vision
