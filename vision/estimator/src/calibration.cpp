// Checkerboard calibration and its YAML file (fl/vision/calibration.hpp).
#include "fl/vision/calibration.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "fl/controller/yaml_reader.hpp"

namespace fl::vision {
namespace {

cv::Point2d apply_homography(const cv::Matx33d& h, cv::Point2d p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1.0);
  return {q[0] / q[2], q[1] / q[2]};
}

cv::Mat to_grey(const cv::Mat& image) {
  if (image.type() == CV_8UC1) return image;
  if (image.type() == CV_8UC3) {
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    return grey;
  }
  throw CalibrationError("checkerboard image must be 8-bit grey or BGR");
}

double mean_around(const cv::Mat& grey, cv::Point2d p, int half) {
  const cv::Rect window(static_cast<int>(std::lround(p.x)) - half,
                        static_cast<int>(std::lround(p.y)) - half, 2 * half + 1, 2 * half + 1);
  const cv::Rect clipped = window & cv::Rect(0, 0, grey.cols, grey.rows);
  if (clipped.area() == 0) return std::numeric_limits<double>::quiet_NaN();
  return cv::mean(grey(clipped))[0];
}

std::vector<cv::Point3f> board_points(const CheckerboardSpec& board) {
  std::vector<cv::Point3f> points;
  for (int j = 0; j < board.inner_corners_y; ++j) {
    for (int i = 0; i < board.inner_corners_x; ++i) {
      points.emplace_back(static_cast<float>(i * board.square_mm),
                          static_cast<float>(j * board.square_mm), 0.0F);
    }
  }
  return points;
}

void check_board(const CheckerboardSpec& board) {
  if (board.inner_corners_x < 3 || board.inner_corners_y < 3 || !(board.square_mm > 0.0) ||
      board.inner_corners_x == board.inner_corners_y ||
      (board.inner_corners_x + board.inner_corners_y) % 2 == 0) {
    throw CalibrationError(
        "checkerboard must have >= 3 x 3 inner corners, x != y and x + y odd (e.g. 9 x 6) so "
        "that its orientation is unambiguous, and a positive square size");
  }
}

std::vector<cv::Point2f> undistorted(const std::vector<cv::Point2f>& pixels,
                                     const IntrinsicsResult& intrinsics) {
  std::vector<cv::Point2f> out;
  cv::undistortPoints(pixels, out, intrinsics.camera_matrix, intrinsics.distortion, cv::noArray(),
                      intrinsics.camera_matrix);
  return out;
}

}  // namespace

cv::Point2d BeltCalibration::pixel_to_belt(cv::Point2d pixel) const {
  if (has_intrinsics) {
    std::vector<cv::Point2d> in{pixel}, out;
    cv::undistortPoints(in, out, camera_matrix, distortion, cv::noArray(), camera_matrix);
    pixel = out[0];
  }
  return apply_homography(image_to_belt, pixel);
}

cv::Point2d BeltCalibration::belt_to_pixel(cv::Point2d belt_mm) const {
  const cv::Point2d ideal = apply_homography(image_to_belt.inv(), belt_mm);
  if (!has_intrinsics) return ideal;
  const double fx = camera_matrix(0, 0), fy = camera_matrix(1, 1);
  const double cx = camera_matrix(0, 2), cy = camera_matrix(1, 2);
  std::vector<cv::Point3d> normalised{{(ideal.x - cx) / fx, (ideal.y - cy) / fy, 1.0}};
  std::vector<cv::Point2d> out;
  cv::projectPoints(normalised, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_matrix, distortion,
                    out);
  return out[0];
}

double BeltCalibration::mm_per_px_at_centre() const {
  const cv::Point2d centre(0.5 * (image_width_px - 1), 0.5 * (image_height_px - 1));
  const cv::Point2d a = pixel_to_belt(centre);
  const cv::Point2d du = pixel_to_belt(centre + cv::Point2d(1.0, 0.0));
  const cv::Point2d dv = pixel_to_belt(centre + cv::Point2d(0.0, 1.0));
  return std::sqrt(cv::norm(du - a) * cv::norm(dv - a));
}

std::optional<std::vector<cv::Point2f>> find_checkerboard(const cv::Mat& image,
                                                          const CheckerboardSpec& board) {
  check_board(board);
  if (image.empty()) return std::nullopt;
  const cv::Mat grey = to_grey(image);
  const cv::Size pattern(board.inner_corners_x, board.inner_corners_y);
  std::vector<cv::Point2f> corners;
  if (!cv::findChessboardCorners(
          grey, pattern, corners,
          cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK)) {
    return std::nullopt;
  }
  const auto at = [&](int i, int j) -> cv::Point2f& {
    return corners[static_cast<std::size_t>(j * board.inner_corners_x + i)];
  };
  // Sub-pixel window: a quarter of a square, so it never reaches the next corner.
  const double square_px = cv::norm(at(1, 0) - at(0, 0));
  const int half_window = std::clamp(static_cast<int>(square_px / 4.0), 2, 11);
  cv::cornerSubPix(grey, corners, cv::Size(half_window, half_window), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));

  // Handedness: the board is seen from its printed face, from above, so its (x, y) axes appear
  // clockwise in the image (v points down): the cross product of x and y is negative. A
  // positive one means the rows are in mirrored order.
  const cv::Point2f ax = at(1, 0) - at(0, 0);
  const cv::Point2f ay = at(0, 1) - at(0, 0);
  if (ax.x * ay.y - ax.y * ay.x > 0.0F) {
    for (int j = 0; j < board.inner_corners_y; ++j) {
      auto row = corners.begin() + j * board.inner_corners_x;
      std::reverse(row, row + board.inner_corners_x);
    }
  }
  // 180-degree ambiguity: the square diagonally outside corner (0, 0) must be black, i.e.
  // darker than its neighbour outside the first row.
  const cv::Point2d c0 = at(0, 0);
  const cv::Point2d ex = cv::Point2d(at(1, 0)) - c0;
  const cv::Point2d ey = cv::Point2d(at(0, 1)) - c0;
  const int half = std::max(1, static_cast<int>(square_px / 8.0));
  const double outside = mean_around(grey, c0 - 0.5 * ex - 0.5 * ey, half);
  const double neighbour = mean_around(grey, c0 + 0.5 * ex - 0.5 * ey, half);
  if (!(outside < neighbour)) std::reverse(corners.begin(), corners.end());
  return corners;
}

IntrinsicsResult calibrate_intrinsics(const std::vector<cv::Mat>& views,
                                      const CheckerboardSpec& board, bool fix_distortion) {
  check_board(board);
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  cv::Size image_size;
  std::string missing;
  for (std::size_t i = 0; i < views.size(); ++i) {
    if (views[i].empty()) {
      missing += " " + std::to_string(i) + "(empty)";
      continue;
    }
    if (image_size.area() == 0) image_size = views[i].size();
    if (views[i].size() != image_size) {
      throw CalibrationError("calibration view " + std::to_string(i) +
                             " has a different size from view 0");
    }
    auto corners = find_checkerboard(views[i], board);
    if (!corners) {
      missing += " " + std::to_string(i);
      continue;
    }
    image_points.push_back(std::move(*corners));
    object_points.push_back(board_points(board));
  }
  if (image_points.size() < 3) {
    throw CalibrationError("intrinsics need the board found in at least 3 views; found in " +
                           std::to_string(image_points.size()) + " of " +
                           std::to_string(views.size()) + " (not found in views:" + missing + ")");
  }
  int flags = cv::CALIB_FIX_K3;
  if (fix_distortion) {
    flags |= cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
  }
  cv::Mat camera_matrix, distortion;
  std::vector<cv::Mat> rvecs, tvecs;
  IntrinsicsResult result;
  result.rms_px = cv::calibrateCamera(object_points, image_points, image_size, camera_matrix,
                                      distortion, rvecs, tvecs, flags);
  result.camera_matrix = cv::Matx33d(camera_matrix);
  for (int i = 0; i < 5 && i < static_cast<int>(distortion.total()); ++i) {
    result.distortion[i] = distortion.at<double>(i);
  }
  result.views_used = static_cast<int>(image_points.size());
  std::array<bool, kCoverageColumns * kCoverageRows> covered{};
  for (const auto& view : image_points) {
    for (const cv::Point2f& corner : view) {
      const int column = std::clamp(
          static_cast<int>(corner.x * kCoverageColumns / static_cast<float>(image_size.width)), 0,
          kCoverageColumns - 1);
      const int row = std::clamp(
          static_cast<int>(corner.y * kCoverageRows / static_cast<float>(image_size.height)), 0,
          kCoverageRows - 1);
      covered[static_cast<std::size_t>(row * kCoverageColumns + column)] = true;
    }
  }
  result.covered_share = static_cast<double>(std::count(covered.begin(), covered.end(), true)) /
                         static_cast<double>(covered.size());
  return result;
}

BeltCalibration calibrate_belt_plane(const cv::Mat& board_on_belt, const CheckerboardSpec& board,
                                     const std::optional<IntrinsicsResult>& intrinsics,
                                     const BeltFrameDefinition& frame,
                                     const std::string& camera_name) {
  check_board(board);
  if (board_on_belt.empty()) throw CalibrationError("belt-plane calibration: empty image");
  const auto corners = find_checkerboard(board_on_belt, board);
  if (!corners) {
    throw CalibrationError("belt-plane calibration: checkerboard " +
                           std::to_string(board.inner_corners_x) + " x " +
                           std::to_string(board.inner_corners_y) + " not found in the image");
  }
  const std::vector<cv::Point2f> ideal = intrinsics ? undistorted(*corners, *intrinsics) : *corners;
  std::vector<cv::Point2f> board_mm;
  for (const auto& p : board_points(board)) board_mm.emplace_back(p.x, p.y);
  const cv::Mat h = cv::findHomography(ideal, board_mm, 0);
  if (h.empty()) throw CalibrationError("belt-plane calibration: homography failed");
  const cv::Matx33d image_to_board(h);

  const double c = std::cos(frame.board_yaw_rad);
  const double s = std::sin(frame.board_yaw_rad);
  cv::Point2d offset;
  BeltCalibration calibration;
  calibration.camera_name = camera_name;
  calibration.image_width_px = board_on_belt.cols;
  calibration.image_height_px = board_on_belt.rows;
  if (intrinsics) {
    calibration.has_intrinsics = true;
    calibration.camera_matrix = intrinsics->camera_matrix;
    calibration.distortion = intrinsics->distortion;
  }
  if (frame.board_origin_mm) {
    offset = *frame.board_origin_mm;
  } else {
    const cv::Point2d principal =
        intrinsics ? cv::Point2d(intrinsics->camera_matrix(0, 2), intrinsics->camera_matrix(1, 2))
                   : cv::Point2d(0.5 * (board_on_belt.cols - 1), 0.5 * (board_on_belt.rows - 1));
    const cv::Point2d b0 = apply_homography(image_to_board, principal);
    offset = -cv::Point2d(c * b0.x - s * b0.y, s * b0.x + c * b0.y);
  }
  const cv::Matx33d belt_from_board(c, -s, offset.x, s, c, offset.y, 0, 0, 1);
  calibration.image_to_belt = belt_from_board * image_to_board;
  calibration.image_to_belt *= 1.0 / calibration.image_to_belt(2, 2);

  double sum2 = 0.0;
  for (std::size_t k = 0; k < corners->size(); ++k) {
    const cv::Point2d board_point(board_mm[k].x, board_mm[k].y);
    const cv::Point2d belt_point(c * board_point.x - s * board_point.y + offset.x,
                                 s * board_point.x + c * board_point.y + offset.y);
    const cv::Point2d reprojected = calibration.belt_to_pixel(belt_point);
    const cv::Point2d measured((*corners)[k].x, (*corners)[k].y);
    sum2 += std::pow(cv::norm(reprojected - measured), 2);
  }
  calibration.reprojection_rms_px = std::sqrt(sum2 / static_cast<double>(corners->size()));
  return calibration;
}

// ---------------------------------------------------------------- YAML

namespace {

std::string format_list(const double* values, int count) {
  std::ostringstream out;
  out << std::setprecision(17) << "[";
  for (int i = 0; i < count; ++i) out << (i ? ", " : "") << values[i];
  out << "]";
  return out.str();
}

// Sanity of a homography over the image: finite, the same side of the horizon everywhere,
// seen from above (image axes clockwise on the belt), a plausible scale.
std::string homography_problem(const cv::Matx33d& image_to_belt, int width, int height) {
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(image_to_belt.val[i])) return "has a non-finite entry";
  }
  const double det = cv::determinant(image_to_belt);
  if (!(std::abs(det) > 1e-12)) return "is singular";
  const std::array<cv::Point2d, 4> corners{cv::Point2d(0, 0), cv::Point2d(width - 1, 0),
                                           cv::Point2d(width - 1, height - 1),
                                           cv::Point2d(0, height - 1)};
  double first_w = 0.0;
  for (const auto& corner : corners) {
    const cv::Vec3d q = image_to_belt * cv::Vec3d(corner.x, corner.y, 1.0);
    if (first_w == 0.0) first_w = q[2];
    if (!(q[2] * first_w > 0.0)) return "puts the belt horizon inside the image";
  }
  const cv::Point2d centre(0.5 * (width - 1), 0.5 * (height - 1));
  const cv::Point2d a = apply_homography(image_to_belt, centre);
  const cv::Point2d du = apply_homography(image_to_belt, centre + cv::Point2d(1, 0)) - a;
  const cv::Point2d dv = apply_homography(image_to_belt, centre + cv::Point2d(0, 1)) - a;
  const double jacobian = du.x * dv.y - du.y * dv.x;
  if (!(jacobian < 0.0)) {
    return "maps the image mirrored onto the belt (a camera looking down sees the belt's x, y "
           "axes clockwise); check the board's orientation";
  }
  const double mm_per_px = std::sqrt(-jacobian);
  if (!(mm_per_px > 0.01 && mm_per_px < 10.0)) {
    return "gives " + fl::format_number(mm_per_px) +
           " mm per pixel at the image centre, outside 0.01 .. 10";
  }
  return {};
}

}  // namespace

void save_calibration(const std::filesystem::path& file, const BeltCalibration& calibration) {
  std::ostringstream out;
  out << "# Belt-plane calibration of camera \"" << calibration.camera_name
      << "\" (fl_calibrate; vision/estimator/include/fl/vision/calibration.hpp).\n"
      << "# image_to_belt: row-major homography from (undistorted) pixels (u right, v down) to\n"
      << "# belt millimetres (x along travel, y to the left looking downstream).\n"
      << "camera: " << calibration.camera_name << "\n"
      << "image_width_px: " << calibration.image_width_px << "\n"
      << "image_height_px: " << calibration.image_height_px << "\n";
  if (calibration.has_intrinsics) {
    out << "intrinsics:\n"
        << "  camera_matrix: " << format_list(calibration.camera_matrix.val, 9) << "\n"
        << "  distortion: " << format_list(calibration.distortion.val, 5)
        << "  # k1, k2, p1, p2, k3\n";
  }
  out << "image_to_belt: " << format_list(calibration.image_to_belt.val, 9) << "\n"
      << "reprojection_rms_px: " << std::setprecision(17) << calibration.reprojection_rms_px
      << "\n";
  std::ofstream stream(file);
  stream << out.str();
  stream.close();
  if (!stream) throw CalibrationError("cannot write calibration file " + file.string());
}

namespace {

BeltCalibration read_calibration(fl::YamlReader& reader) {
  BeltCalibration calibration;
  {
    fl::YamlMapReader root = reader.root();
    calibration.camera_name = root.read_string("camera");
    if (calibration.camera_name.empty() ||
        !std::all_of(calibration.camera_name.begin(), calibration.camera_name.end(), [](char ch) {
          return (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '_';
        })) {
      root.report("camera", fl::ProblemKind::kInvalidValue,
                  "must be a lower-case name of letters, digits and '_'");
    }
    calibration.image_width_px = root.read_int<int>("image_width_px", fl::Range::closed(16, 20000));
    calibration.image_height_px =
        root.read_int<int>("image_height_px", fl::Range::closed(16, 20000));
    if (root.has("intrinsics")) {
      calibration.has_intrinsics = true;
      fl::YamlMapReader intrinsics = root.map("intrinsics");
      const auto k = intrinsics.read_doubles("camera_matrix", fl::Range::any(), 9);
      const auto d = intrinsics.read_doubles("distortion", fl::Range::closed(-100.0, 100.0), 5);
      if (k.size() == 9) {
        for (int i = 0; i < 9; ++i) {
          calibration.camera_matrix.val[i] = k[static_cast<std::size_t>(i)];
        }
        const auto& m = calibration.camera_matrix;
        if (!(m(0, 0) > 0.0 && m(1, 1) > 0.0 && m(0, 1) == 0.0 && m(1, 0) == 0.0 &&
              m(2, 0) == 0.0 && m(2, 1) == 0.0 && m(2, 2) == 1.0)) {
          intrinsics.report("camera_matrix", fl::ProblemKind::kInvalidValue,
                            "must be [fx, 0, cx, 0, fy, cy, 0, 0, 1] with fx, fy > 0");
        }
      }
      if (d.size() == 5) {
        for (int i = 0; i < 5; ++i) calibration.distortion[i] = d[static_cast<std::size_t>(i)];
      }
      intrinsics.finish();
    }
    const auto h = root.read_doubles("image_to_belt", fl::Range::any(), 9);
    if (h.size() == 9) {
      for (int i = 0; i < 9; ++i) calibration.image_to_belt.val[i] = h[static_cast<std::size_t>(i)];
    }
    calibration.reprojection_rms_px =
        root.read_double("reprojection_rms_px", fl::Range::closed(0.0, 5.0));
    root.finish();
  }
  if (reader.all_read_ok({"image_to_belt", "image_width_px", "image_height_px"})) {
    const std::string problem = homography_problem(
        calibration.image_to_belt, calibration.image_width_px, calibration.image_height_px);
    if (!problem.empty()) {
      reader.report_at("image_to_belt", fl::ProblemKind::kInconsistent,
                       "the homography " + problem);
    }
  }
  reader.throw_if_problems();
  return calibration;
}

}  // namespace

BeltCalibration parse_calibration(const std::string& yaml_text, const std::string& source_name) {
  fl::YamlReader reader = fl::YamlReader::from_text(yaml_text, source_name);
  return read_calibration(reader);
}

BeltCalibration load_calibration(const std::filesystem::path& file) {
  fl::YamlReader reader = fl::YamlReader::from_file(file);
  return read_calibration(reader);
}

}  // namespace fl::vision
