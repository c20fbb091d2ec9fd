// fl_calibrate: camera calibration from checkerboard pictures to config/camera_<name>.yaml.
//
//   fl_calibrate --camera orientation --board 9x6 --square-mm 20 --belt board_on_belt.png
//                [--intrinsics view1.png view2.png view3.png ... [--fix-distortion]]
//                [--board-origin-mm X,Y] [--board-yaw-deg D] --out config/camera_orientation.yaml
//   fl_calibrate --check config/camera_orientation.yaml
//
// Exit codes: 0 done, 1 calibration failed (board not found, too few views), 2 bad arguments or
// an invalid calibration file (every problem named with file, key and line).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <numbers>
#include <opencv2/imgcodecs.hpp>

#include "fl/controller/yaml_reader.hpp"
#include "fl/vision/calibration.hpp"

namespace {

cv::Mat read_image(const std::string& path) {
  cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  if (image.empty()) throw fl::vision::CalibrationError("cannot read image " + path);
  return image;
}

}  // namespace

static int checked_main(int argc, char** argv) {
  CLI::App app{"Calibrates a line camera from checkerboard pictures (belt-plane homography)."};
  std::string camera_name;
  std::string board_text = "9x6";
  double square_mm = 20.0;
  std::string belt_image;
  std::vector<std::string> intrinsic_images;
  bool fix_distortion = false;
  std::vector<double> board_origin_mm;
  double board_yaw_deg = 0.0;
  std::string out_file;
  std::string check_file;
  app.add_option("--camera", camera_name, "camera name: orientation, position, multilane1, ...");
  app.add_option("--board", board_text, "inner corners, x by y (x + y odd, x != y)");
  app.add_option("--square-mm", square_mm, "square size in mm")->check(CLI::PositiveNumber);
  app.add_option("--belt", belt_image, "picture of the board lying flat on the belt");
  app.add_option("--intrinsics", intrinsic_images, "pictures of the board in varied poses (>= 3)");
  app.add_flag("--fix-distortion", fix_distortion, "assume a distortion-free lens");
  app.add_option("--board-origin-mm", board_origin_mm,
                 "belt position of the board's first inner corner (default: origin under the "
                 "optical axis)")
      ->expected(2)
      ->delimiter(',');
  app.add_option("--board-yaw-deg", board_yaw_deg, "angle of the board's x axis against travel");
  app.add_option("--out", out_file, "YAML file to write");
  app.add_option("--check", check_file, "only validate a calibration file");
  CLI11_PARSE(app, argc, argv);

  try {
    if (!check_file.empty()) {
      const auto calibration = fl::vision::load_calibration(check_file);
      std::printf("%s: ok (camera %s, %d x %d px, %.4f mm/px at the centre)\n", check_file.c_str(),
                  calibration.camera_name.c_str(), calibration.image_width_px,
                  calibration.image_height_px, calibration.mm_per_px_at_centre());
      return 0;
    }
    if (camera_name.empty() || belt_image.empty() || out_file.empty()) {
      std::fprintf(stderr, "fl_calibrate: --camera, --belt and --out are required\n");
      return 2;
    }
    fl::vision::CheckerboardSpec board;
    if (std::sscanf(board_text.c_str(), "%dx%d", &board.inner_corners_x, &board.inner_corners_y) !=
        2) {
      std::fprintf(stderr, "fl_calibrate: --board must look like 9x6\n");
      return 2;
    }
    board.square_mm = square_mm;
    std::optional<fl::vision::IntrinsicsResult> intrinsics;
    if (!intrinsic_images.empty()) {
      std::vector<cv::Mat> views;
      views.reserve(intrinsic_images.size());
      for (const auto& path : intrinsic_images) views.push_back(read_image(path));
      intrinsics = fl::vision::calibrate_intrinsics(views, board, fix_distortion);
      std::printf("intrinsics: %d views, rms %.3f px, fx %.2f fy %.2f cx %.2f cy %.2f\n",
                  intrinsics->views_used, intrinsics->rms_px, intrinsics->camera_matrix(0, 0),
                  intrinsics->camera_matrix(1, 1), intrinsics->camera_matrix(0, 2),
                  intrinsics->camera_matrix(1, 2));
      std::printf(
          "distortion: k1 %.4f k2 %.4f p1 %.5f p2 %.5f; board corners covered %.0f %% "
          "of the image\n",
          intrinsics->distortion[0], intrinsics->distortion[1], intrinsics->distortion[2],
          intrinsics->distortion[3], 100.0 * intrinsics->covered_share);
      if (!fix_distortion && intrinsics->covered_share < fl::vision::kMinCoveredShare) {
        std::fprintf(stderr,
                     "warning: the views' board corners cover only %.0f %% of the image (%d x %d "
                     "cells); the lens model is extrapolated where they never were. Add views "
                     "with the board near each image corner and edge.\n",
                     100.0 * intrinsics->covered_share, fl::vision::kCoverageColumns,
                     fl::vision::kCoverageRows);
      }
    }
    fl::vision::BeltFrameDefinition frame;
    frame.board_yaw_rad = board_yaw_deg * std::numbers::pi / 180.0;
    if (board_origin_mm.size() == 2) {
      frame.board_origin_mm = cv::Point2d(board_origin_mm[0], board_origin_mm[1]);
    }
    const auto calibration = fl::vision::calibrate_belt_plane(read_image(belt_image), board,
                                                              intrinsics, frame, camera_name);
    fl::vision::save_calibration(out_file, calibration);
    // Read it back through the strict loader, so a file that would not load is never left.
    fl::vision::load_calibration(out_file);
    std::printf("%s: written (reprojection rms %.3f px, %.4f mm/px at the centre)\n",
                out_file.c_str(), calibration.reprojection_rms_px,
                calibration.mm_per_px_at_centre());
    return 0;
  } catch (const fl::ConfigError& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "fl_calibrate: %s\n", error.what());
    return 1;
  }
}

int main(int argc, char** argv) {
  // What escapes the commands' own handling (an option table that throws, memory): a message
  // and exit status 1 instead of std::terminate.
  try {
    return checked_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "fl_calibrate: %s\n", error.what());
  } catch (...) {
    std::fprintf(stderr, "fl_calibrate: unknown error\n");
  }
  return 1;
}
