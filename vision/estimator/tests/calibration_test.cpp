// Calibration from rendered checkerboards: the belt homography comes back to a fraction of a
// millimetre (corners are found to ~0.1 px at 0.47 mm/px), intrinsics within a percent, and the
// YAML file round-trips and is validated strictly.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "fl/controller/yaml_reader.hpp"
#include "render_support.hpp"

namespace fl::vision {
namespace {

using testing::camera_640;
using testing::renderer;

constexpr double kDeg = std::numbers::pi / 180.0;

BeltFrameDefinition frame_with(double yaw_rad, std::optional<cv::Point2d> origin_mm) {
  BeltFrameDefinition frame;
  frame.board_yaw_rad = yaw_rad;
  frame.board_origin_mm = origin_mm;
  return frame;
}

render::CheckerboardOnBelt board_at(double x_mm, double y_mm, double yaw_rad) {
  render::CheckerboardOnBelt board;  // 9 x 6 inner corners, 20 mm squares
  board.origin_x_mm = x_mm;
  board.origin_y_mm = y_mm;
  board.yaw_rad = yaw_rad;
  return board;
}

// Largest belt error over a grid of pixels covering the image.
double max_error_mm(const BeltCalibration& calibration, const render::RenderCamera& camera) {
  double worst = 0.0;
  for (int v = 0; v < camera.height_px; v += 40) {
    for (int u = 0; u < camera.width_px; u += 40) {
      const cv::Point2d truth = render::pixel_to_belt(camera, {double(u), double(v)});
      worst = std::max(worst, cv::norm(calibration.pixel_to_belt({double(u), double(v)}) - truth));
    }
  }
  return worst;
}

// Board at a known belt position: the homography over the whole image within 0.5 mm (about a
// pixel; extrapolating beyond the board's 200 x 140 mm doubles the corner error at the edges).
TEST(Calibration, RecoversTheHomographyFromAKnownBoardPose) {
  const auto camera = camera_640();
  const auto board = board_at(-85.0, -55.0, 3.0 * kDeg);
  render::ImagingConditions imaging;
  imaging.noise_sigma = 2.0;
  const cv::Mat image = renderer().render_checkerboard(camera, board, {}, imaging, 1);
  const BeltCalibration calibration = calibrate_belt_plane(
      image, {}, std::nullopt, frame_with(board.yaw_rad, cv::Point2d(-85.0, -55.0)), "orientation");
  EXPECT_LT(calibration.reprojection_rms_px, 0.2);
  EXPECT_LT(max_error_mm(calibration, camera), 0.5);
  EXPECT_NEAR(calibration.mm_per_px_at_centre(), 300.0 / 640.0, 0.002);
}

// Origin under the optical axis: the image centre maps to the belt origin; the board turned
// half round (so findChessboardCorners' order flips) gives the same homography.
TEST(Calibration, PrincipalPointOriginAndHalfTurnedBoard) {
  const auto camera = camera_640();
  for (const double yaw : {2.0 * kDeg, std::numbers::pi + 2.0 * kDeg}) {
    SCOPED_TRACE("yaw " + std::to_string(yaw));
    const auto board = board_at(yaw > 1.0 ? 95.0 : -95.0, yaw > 1.0 ? 60.0 : -60.0, yaw);
    const cv::Mat image = renderer().render_checkerboard(camera, board, {}, {}, 2);
    const auto corners = find_checkerboard(image, {});
    ASSERT_TRUE(corners.has_value());
    const cv::Point2d first =
        render::belt_to_pixel(camera, render::checkerboard_corner_mm(board, 0, 0));
    EXPECT_LT(cv::norm(cv::Point2d((*corners)[0]) - first), 0.3);
    const auto calibration =
        calibrate_belt_plane(image, {}, std::nullopt, frame_with(yaw, std::nullopt), "orientation");
    EXPECT_LT(max_error_mm(calibration, camera), 0.5);
  }
}

// Eight views from cameras orbiting the board (the board moved relative to the camera):
// calibrateCamera recovers f within 1 % and the principal point within 3 px.
TEST(Calibration, IntrinsicsFromTiltedViews) {
  const cv::Matx33d k(820, 0, 318, 0, 820, 243, 0, 0, 1);
  std::vector<cv::Mat> views;
  for (int i = 0; i < 8; ++i) {
    // Tilts of 10 .. 31 degrees about both axes: enough perspective to separate f from the
    // distance.
    const double tilt_x = (i % 2 ? 1 : -1) * (10.0 + 3.0 * i) * kDeg;
    const double tilt_y = (i % 3 - 1) * 15.0 * kDeg;
    const auto camera = render::make_orbit_camera(640, 480, k, 480.0, tilt_x, tilt_y, 0.1 * i);
    views.push_back(renderer().render_checkerboard(camera, board_at(-80.0, -50.0, 0.0), {}, {}, 3));
  }
  const auto intrinsics = calibrate_intrinsics(views, {}, true);
  EXPECT_EQ(intrinsics.views_used, 8);
  EXPECT_NEAR(intrinsics.camera_matrix(0, 0), 820.0, 8.2);
  EXPECT_NEAR(intrinsics.camera_matrix(1, 1), 820.0, 8.2);
  EXPECT_NEAR(intrinsics.camera_matrix(0, 2), 318.0, 3.0);
  EXPECT_NEAR(intrinsics.camera_matrix(1, 2), 243.0, 3.0);
  EXPECT_LT(intrinsics.rms_px, 0.3);
}

// A perspective camera calibrated from the rendered board, then the estimator through that
// calibration: the fillet within 2 mm and 2 degrees.
TEST(Calibration, EstimatorThroughACalibratedPerspectiveCamera) {
  const cv::Matx33d k(900, 0, 320, 0, 900, 240, 0, 0, 1);
  const auto camera = render::make_tilted_camera(640, 480, k, 600.0, 7.0 * kDeg, 4.0 * kDeg);
  const cv::Mat image =
      renderer().render_checkerboard(camera, board_at(-80.0, -50.0, 0.0), {}, {}, 4);
  const auto calibration = calibrate_belt_plane(
      image, {}, std::nullopt, frame_with(0.0, cv::Point2d(-80.0, -50.0)), "orientation");
  EXPECT_LT(max_error_mm(calibration, camera), 0.6);
  FilletEstimator estimator(calibration);
  render::Scene scene;
  render::FilletInstance fillet;
  fillet.x_mm = 10.0;
  fillet.angle_rad = -2.0;
  fillet.hand = Hand::kRight;
  fillet.side = SideUp::kBone;
  scene.fillets = {fillet};
  const auto frame = renderer().render(camera, scene);
  const auto camera_frame = estimator.estimate(frame.bgr, 0, 0).to_camera_frame();
  ASSERT_EQ(camera_frame.count, 1);
  EXPECT_NEAR(camera_frame.estimates[0].x_mm, 10.0, 2.0);
  EXPECT_NEAR(camera_frame.estimates[0].y_mm, 0.0, 2.0);
  EXPECT_LT(testing::angle_difference_rad(camera_frame.estimates[0].angle_rad, -2.0), 2.0 * kDeg);
}

// What a lens with barrel distortion (k1, k2) does to a pinhole picture: every pixel of the
// distorted image shows the point of the pinhole image that the distortion moved there.
cv::Mat distort(const cv::Mat& pinhole, const cv::Matx33d& k, const cv::Vec<double, 5>& d) {
  std::vector<cv::Point2f> distorted;
  for (int v = 0; v < pinhole.rows; ++v) {
    for (int u = 0; u < pinhole.cols; ++u) distorted.emplace_back(float(u), float(v));
  }
  std::vector<cv::Point2f> undistorted;
  cv::undistortPoints(distorted, undistorted, k, d, cv::noArray(), k);
  cv::Mat map_x(pinhole.size(), CV_32FC1);
  cv::Mat map_y(pinhole.size(), CV_32FC1);
  for (int v = 0; v < pinhole.rows; ++v) {
    for (int u = 0; u < pinhole.cols; ++u) {
      const cv::Point2f& source = undistorted[static_cast<std::size_t>(v * pinhole.cols + u)];
      map_x.at<float>(v, u) = source.x;
      map_y.at<float>(v, u) = source.y;
    }
  }
  cv::Mat out;
  // Barrel distortion pulls the picture in: the corners show what lay outside it, here the
  // edge's belt colour repeated (a black corner would be no belt at all).
  cv::remap(pinhole, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

// The barrel lens of the tests below (k1 -0.25, k2 0.08) on a 640 x 480 camera.
const cv::Matx33d kLensCamera(820, 0, 318, 0, 820, 243, 0, 0, 1);
const cv::Vec<double, 5> kBarrelLens(-0.25, 0.08, 0.0, 0.0, 0.0);

// Nine views through that lens: the board (200 x 140 mm, about 340 x 240 px at 480 mm) at
// the centre and towards each corner and edge, under tilts of 8 to 20 degrees.
std::vector<cv::Mat> barrel_lens_views() {
  const std::array<cv::Point2d, 9> origins = {{{-80, -50},
                                               {-150, -100},
                                               {-10, -100},
                                               {-150, 0},
                                               {-10, 0},
                                               {-80, -100},
                                               {-80, 0},
                                               {-150, -50},
                                               {-10, -50}}};
  std::vector<cv::Mat> views;
  for (std::size_t i = 0; i < origins.size(); ++i) {
    const double tilt_x = (i % 2 ? 1 : -1) * (8.0 + 1.5 * static_cast<double>(i)) * kDeg;
    const double tilt_y = (static_cast<double>(i % 3) - 1.0) * 10.0 * kDeg;
    const auto camera = render::make_orbit_camera(640, 480, kLensCamera, 480.0, tilt_x, tilt_y,
                                                  0.1 * static_cast<double>(i));
    views.push_back(distort(renderer().render_checkerboard(
                                camera, board_at(origins[i].x, origins[i].y, 0.0), {}, {}, 3),
                            kLensCamera, kBarrelLens));
  }
  return views;
}

// The line camera through that lens: tilted over the belt.
render::RenderCamera barrel_belt_camera() {
  return render::make_tilted_camera(640, 480, kLensCamera, 600.0, 7.0 * kDeg, 4.0 * kDeg);
}

// Largest belt error of a calibration of the barrel camera over the image. Truth for a pixel
// of the distorted image: where the lens took it from, then the pinhole camera's ray.
double barrel_error_mm(const BeltCalibration& calibration) {
  const auto camera = barrel_belt_camera();
  double worst = 0.0;
  for (int v = 20; v < camera.height_px; v += 40) {
    for (int u = 20; u < camera.width_px; u += 40) {
      std::vector<cv::Point2f> pixel{cv::Point2f(float(u), float(v))};
      std::vector<cv::Point2f> source;
      cv::undistortPoints(pixel, source, kLensCamera, kBarrelLens, cv::noArray(), kLensCamera);
      const cv::Point2d truth = render::pixel_to_belt(camera, cv::Point2d(source[0]));
      worst = std::max(worst, cv::norm(calibration.pixel_to_belt({double(u), double(v)}) - truth));
    }
  }
  return worst;
}

// A lens with barrel distortion (k1 -0.25, k2 0.08: about 20 px at the corners of 640 x 480,
// a common wide-angle lens): the intrinsics calibration fits it, and the belt calibration and
// the estimator undo it. The same pictures taken as distortion-free leave errors of several
// millimetres at the edges, so the fit is what makes the difference. The views put the board
// into every region of the image, as a commissioning engineer is told to: the lens model is
// only measured where corners were (with them all near the centre, k2 and k3 ran away and
// the image corners came out 100 mm wrong, which is why k3 is now fixed and coverage shown).
TEST(Calibration, BarrelDistortionIsFittedAndUndoneThroughToTheEstimate) {
  const cv::Matx33d& k = kLensCamera;
  const cv::Vec<double, 5>& lens = kBarrelLens;
  const std::vector<cv::Mat> views = barrel_lens_views();
  const auto fitted = calibrate_intrinsics(views, {}, false);
  EXPECT_EQ(fitted.views_used, 9);
  EXPECT_GE(fitted.covered_share, kMinCoveredShare);
  EXPECT_LT(fitted.rms_px, 0.3);
  EXPECT_NEAR(fitted.camera_matrix(0, 0), 820.0, 8.2);  // 1 %, as without distortion
  EXPECT_NEAR(fitted.distortion[0], lens[0], 0.03);     // k1 within about a tenth
  EXPECT_EQ(fitted.distortion[4], 0.0);                 // k3 fixed
  const auto pinhole_fit = calibrate_intrinsics(views, {}, true);
  EXPECT_GT(pinhole_fit.rms_px, 3.0 * fitted.rms_px) << "the lens was not distorting at all";

  // The belt: a camera tilted over the belt with the same lens.
  const auto camera = barrel_belt_camera();
  const cv::Mat board = distort(
      renderer().render_checkerboard(camera, board_at(-80.0, -50.0, 0.0), {}, {}, 4), k, lens);
  const BeltFrameDefinition frame = frame_with(0.0, cv::Point2d(-80.0, -50.0));
  const auto calibration = calibrate_belt_plane(board, {}, fitted, frame, "orientation");
  const auto pinhole_calibration =
      calibrate_belt_plane(board, {}, std::nullopt, frame, "orientation");
  ASSERT_TRUE(calibration.has_intrinsics);
  // Two pixels (0.73 mm/px here) anywhere in the image, its corners included, where the
  // views' corners did not quite reach.
  EXPECT_LT(barrel_error_mm(calibration), 1.5);
  EXPECT_GT(barrel_error_mm(pinhole_calibration), 3.0);

  // A fillet in the lower left quarter of the image (pixel 190, 350), through the estimator.
  render::Scene scene;
  render::FilletInstance fillet;
  fillet.x_mm = -140.0;
  fillet.y_mm = -155.0;
  fillet.angle_rad = 0.6;
  fillet.hand = Hand::kLeft;
  fillet.side = SideUp::kSkin;
  scene.fillets = {fillet};
  const cv::Mat picture = distort(renderer().render(camera, scene).bgr, k, lens);

  FilletEstimator estimator(calibration);
  const auto estimated = estimator.estimate(picture, 0, 0).to_camera_frame();
  ASSERT_EQ(estimated.count, 1);
  EXPECT_NEAR(estimated.estimates[0].x_mm, -140.0, 2.0);
  EXPECT_NEAR(estimated.estimates[0].y_mm, -155.0, 2.0);
  EXPECT_LT(testing::angle_difference_rad(estimated.estimates[0].angle_rad, 0.6), 2.0 * kDeg);
}

// fl_calibrate, the commissioning command, end to end on the barrel lens's pictures as PNG
// files: it fits the lens, writes a file the strict loader takes and that maps the image as
// the in-process calibration does; it warns when the views leave the image's edges
// unmeasured; and --check refuses a broken file naming the key.
TEST(FlCalibrateCommand, CalibratesFromPicturesWarnsOfThinCoverageAndChecksFiles) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("fl_calibrate_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto run = [&](const std::string& arguments, const std::string& log) {
    const std::string command =
        std::string(FL_CALIBRATE) + " " + arguments + " > " + (dir / log).string() + " 2>&1";
    const int status = std::system(command.c_str());
    std::ifstream in(dir / log);
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    return std::pair{WIFEXITED(status) ? WEXITSTATUS(status) : -1, text};
  };
  const std::vector<cv::Mat> views = barrel_lens_views();
  std::string view_files;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const auto file = dir / ("view" + std::to_string(i) + ".png");
    cv::imwrite(file.string(), views[i]);
    view_files += " " + file.string();
  }
  const auto belt = dir / "belt.png";
  cv::imwrite(belt.string(),
              distort(renderer().render_checkerboard(barrel_belt_camera(),
                                                     board_at(-80.0, -50.0, 0.0), {}, {}, 4),
                      kLensCamera, kBarrelLens));
  const std::string common = "--camera orientation --board 9x6 --square-mm 20 --belt " +
                             belt.string() + " --board-origin-mm -80,-50";

  const auto [ok_exit, ok_log] = run(
      common + " --intrinsics" + view_files + " --out " + (dir / "cam.yaml").string(), "ok.log");
  ASSERT_EQ(ok_exit, 0) << ok_log;
  EXPECT_NE(ok_log.find("distortion: k1 -0.2"), std::string::npos) << ok_log;
  EXPECT_EQ(ok_log.find("warning"), std::string::npos) << ok_log;
  const BeltCalibration written = load_calibration(dir / "cam.yaml");
  EXPECT_TRUE(written.has_intrinsics);
  EXPECT_LT(barrel_error_mm(written), 1.5);  // as in process (BarrelDistortion... above)

  // Three views with the board at the centre only: the corners of the image are guessed.
  std::string central_files;
  for (const std::size_t i : {0U, 5U, 6U}) {
    central_files += " " + (dir / ("view" + std::to_string(i) + ".png")).string();
  }
  const auto [thin_exit, thin_log] =
      run(common + " --intrinsics" + central_files + " --out " + (dir / "thin.yaml").string(),
          "thin.log");
  EXPECT_EQ(thin_exit, 0) << thin_log;
  EXPECT_NE(thin_log.find("warning: the views' board corners cover only"), std::string::npos)
      << thin_log;

  std::ifstream good(dir / "cam.yaml");
  std::string yaml{std::istreambuf_iterator<char>(good), std::istreambuf_iterator<char>()};
  const std::string key = "image_width_px: 640";
  ASSERT_NE(yaml.find(key), std::string::npos);
  yaml.replace(yaml.find(key), key.size(), "image_width_px: 3");
  std::ofstream(dir / "broken.yaml") << yaml;
  const auto [check_exit, check_log] =
      run("--check " + (dir / "broken.yaml").string(), "check.log");
  EXPECT_EQ(check_exit, 2) << check_log;
  EXPECT_NE(check_log.find("image_width_px"), std::string::npos) << check_log;
  const auto [good_exit, good_log] = run("--check " + (dir / "cam.yaml").string(), "good.log");
  EXPECT_EQ(good_exit, 0) << good_log;
  std::filesystem::remove_all(dir);
}

TEST(Calibration, BoardNotFoundIsAnError) {
  const cv::Mat blank(480, 640, CV_8UC3, cv::Scalar(160, 100, 40));
  EXPECT_FALSE(find_checkerboard(blank, {}).has_value());
  EXPECT_THROW(calibrate_belt_plane(blank, {}, std::nullopt, {}, "orientation"), CalibrationError);
  EXPECT_THROW(calibrate_intrinsics({blank, blank, blank}, {}), CalibrationError);
  // A square board (x == y) is ambiguous and refused.
  EXPECT_THROW(
      find_checkerboard(blank, {.inner_corners_x = 7, .inner_corners_y = 7, .square_mm = 20.0}),
      CalibrationError);
}

std::filesystem::path temp_file(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("fl_vision_" + name);
}

TEST(CalibrationYaml, RoundTripsExactly) {
  BeltCalibration calibration;
  calibration.camera_name = "orientation";
  calibration.image_width_px = 1280;
  calibration.image_height_px = 1024;
  calibration.has_intrinsics = true;
  calibration.camera_matrix = cv::Matx33d(1800.5, 0, 640.25, 0, 1801.0, 511.75, 0, 0, 1);
  calibration.distortion = {-0.1, 0.02, 0.001, -0.0005, 0.0};
  calibration.image_to_belt =
      cv::Matx33d(0.234375, 0.001, -150.0, 0.0005, -0.234375, 119.9, 1e-7, -2e-7, 1.0);
  calibration.reprojection_rms_px = 0.07;
  const auto file = temp_file("round_trip.yaml");
  save_calibration(file, calibration);
  const auto loaded = load_calibration(file);
  EXPECT_EQ(loaded.camera_name, "orientation");
  EXPECT_EQ(loaded.image_width_px, 1280);
  EXPECT_TRUE(loaded.has_intrinsics);
  for (int i = 0; i < 9; ++i) {
    EXPECT_EQ(loaded.image_to_belt.val[i], calibration.image_to_belt.val[i]);
    EXPECT_EQ(loaded.camera_matrix.val[i], calibration.camera_matrix.val[i]);
  }
  for (int i = 0; i < 5; ++i) EXPECT_EQ(loaded.distortion[i], calibration.distortion[i]);
  std::filesystem::remove(file);
}

// Each broken file names the file, the key and what is wrong.
TEST(CalibrationYaml, StrictValidationNamesFileAndKey) {
  const std::string good =
      "camera: orientation\nimage_width_px: 640\nimage_height_px: 480\n"
      "image_to_belt: [0.46875, 0, -149.765625, 0, -0.46875, 112.265625, 0, 0, 1]\n"
      "reprojection_rms_px: 0.1\n";
  EXPECT_NO_THROW(parse_calibration(good, "camera_orientation.yaml"));
  struct Case {
    std::string text;
    std::string key;
    std::string reason;
  };
  const std::vector<Case> cases{
      {"camera: orientation\nimage_width_px: 640\nimage_height_px: 480\nreprojection_rms_px: 0.1\n",
       "image_to_belt", "missing"},
      {good + "image_widht_px: 640\n", "image_widht_px", "unknown"},
      {"camera: orientation\nimage_width_px: 640\nimage_height_px: 480\n"
       "image_to_belt: [1, 0, 0, 0, 1, 0, 0, 0]\nreprojection_rms_px: 0.1\n",
       "image_to_belt", "8"},
      {"camera: orientation\nimage_width_px: -640\nimage_height_px: 480\n"
       "image_to_belt: [0.46875, 0, -149.765625, 0, -0.46875, 112.265625, 0, 0, 1]\n"
       "reprojection_rms_px: 0.1\n",
       "image_width_px", "out of range"},
      {"camera: orientation\nimage_width_px: 640\nimage_height_px: 480\n"
       "image_to_belt: [0.46875, 0, -149.765625, 0, 0.46875, -112.265625, 0, 0, 1]\n"
       "reprojection_rms_px: 0.1\n",
       "image_to_belt", "mirrored"},
      {"camera: Orientation 1\nimage_width_px: 640\nimage_height_px: 480\n"
       "image_to_belt: [0.46875, 0, -149.765625, 0, -0.46875, 112.265625, 0, 0, 1]\n"
       "reprojection_rms_px: 0.1\n",
       "camera", "lower-case"},
  };
  for (const auto& c : cases) {
    try {
      parse_calibration(c.text, "camera_orientation.yaml");
      ADD_FAILURE() << "accepted:\n" << c.text;
    } catch (const fl::ConfigError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find("camera_orientation.yaml"), std::string::npos) << message;
      EXPECT_NE(message.find(c.key), std::string::npos) << message;
      EXPECT_NE(message.find(c.reason), std::string::npos) << message;
    }
  }
  EXPECT_THROW(load_calibration(temp_file("does_not_exist.yaml")), fl::ConfigError);
}

// The checked-in line camera file loads, has the binned line camera's size, and maps its
// pixels onto the belt as the camera model does: within 0.5 mm (about a pixel) over the image.
TEST(CalibrationYaml, CheckedInOrientationCameraLoads) {
  const auto calibration =
      load_calibration(std::filesystem::path(FL_SOURCE_DIR) / "config" / "camera_orientation.yaml");
  const auto camera = render::make_line_camera();
  EXPECT_EQ(calibration.image_width_px, render::kLineCameraWidthPx);
  EXPECT_EQ(calibration.image_height_px, render::kLineCameraHeightPx);
  EXPECT_NEAR(calibration.mm_per_px_at_centre(), 300.0 / 640.0, 0.003);
  EXPECT_LT(max_error_mm(calibration, camera), 0.5);
}

}  // namespace
}  // namespace fl::vision
