// Bad input never crashes and never makes up a pose: each case gets its status or no estimate.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "render_support.hpp"

namespace fl::vision {
namespace {

using testing::camera_640;
using testing::exact_calibration;
using testing::renderer;

FilletEstimator make_estimator() { return FilletEstimator(exact_calibration(camera_640())); }

TEST(BadInput, EmptyFrame) {
  auto estimator = make_estimator();
  const auto result = estimator.estimate(cv::Mat(), 5, 6);
  EXPECT_EQ(result.status, FrameStatus::kEmptyFrame);
  const auto frame = result.to_camera_frame();
  EXPECT_EQ(frame.count, 0);
  EXPECT_EQ(frame.frame_time_ns, 5);  // still passed through, so the controller sees the frame
  EXPECT_EQ(frame.sequence, 6U);
}

TEST(BadInput, WrongPixelType) {
  auto estimator = make_estimator();
  EXPECT_EQ(estimator.estimate(cv::Mat(480, 640, CV_8UC1, cv::Scalar(100)), 0, 0).status,
            FrameStatus::kWrongType);
  EXPECT_EQ(estimator.estimate(cv::Mat(480, 640, CV_32FC3, cv::Scalar::all(0.5)), 0, 0).status,
            FrameStatus::kWrongType);
}

TEST(BadInput, WrongResolutionNamesBothSizes) {
  auto estimator = make_estimator();
  const auto result = estimator.estimate(cv::Mat(1024, 1280, CV_8UC3, cv::Scalar::all(0)), 0, 0);
  EXPECT_EQ(result.status, FrameStatus::kWrongResolution);
  EXPECT_NE(result.message.find("1280 x 1024"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("640 x 480"), std::string::npos) << result.message;
}

// A covered lens (black), a grey wall, random noise, a blown-out frame: none looks like the
// belt, and none goes to the controller (not "no fillet": the camera saw nothing of the belt).
TEST(BadInput, NoBelt) {
  auto estimator = make_estimator();
  cv::Mat noise(480, 640, CV_8UC3);
  cv::RNG(3).fill(noise, cv::RNG::UNIFORM, 0, 256);
  for (const cv::Mat& image : {cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(0)),
                               cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(128)), noise,
                               cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(255))}) {
    const auto result = estimator.estimate(image, 0, 0);
    EXPECT_EQ(result.status, FrameStatus::kNoBelt);
    EXPECT_EQ(result.to_camera_frame().count, 0);
    EXPECT_FALSE(result.deliverable());
  }
}

// An empty belt with noise, a lighting gradient and hinge lines: ok, and no fillet.
TEST(BadInput, EmptyBeltGivesNoFillet) {
  auto estimator = make_estimator();
  render::Scene scene;
  scene.imaging.noise_sigma = 6.0;
  scene.imaging.lighting_gradient = 0.4;
  scene.imaging.vignetting = 0.2;
  const auto frame = renderer().render(camera_640(), scene);
  const auto result = estimator.estimate(frame.bgr, 0, 0);
  EXPECT_EQ(result.status, FrameStatus::kOk) << result.message;
  EXPECT_EQ(result.to_camera_frame().count, 0);
  EXPECT_TRUE(result.deliverable());  // an empty belt is news: no fillet
}

// Fillets cut by the image border are reported as cut, with no estimate; the fully visible one
// in the same frame is estimated.
TEST(BadInput, FilletsCutByTheBorderGetNoPose) {
  auto estimator = make_estimator();
  render::Scene scene;
  render::FilletInstance cut;
  cut.x_mm = 140.0;  // the field ends at 150 mm
  cut.angle_rad = 0.2;
  render::FilletInstance cut_side;
  cut_side.x_mm = -40.0;
  cut_side.y_mm = -110.0;  // the field ends at -112 mm
  cut_side.angle_rad = 1.4;
  scene.fillets = {cut, cut_side};
  const auto frame = renderer().render(camera_640(), scene);
  ASSERT_FALSE(frame.truth[0].fully_visible);
  ASSERT_FALSE(frame.truth[1].fully_visible);
  const auto result = estimator.estimate(frame.bgr, 0, 0);
  ASSERT_EQ(result.status, FrameStatus::kOk);
  int cut_blobs = 0;
  for (const auto& blob : result.blobs) {
    EXPECT_NE(blob.status, BlobStatus::kFillet);
    cut_blobs += blob.status == BlobStatus::kCutByBorder ? 1 : 0;
  }
  EXPECT_EQ(cut_blobs, 2);
  EXPECT_EQ(result.to_camera_frame().count, 0);
}

// A meat scrap of a tenth of a fillet's area is debris.
TEST(BadInput, DebrisIsIgnored) {
  auto estimator = make_estimator();
  render::Scene scene;
  render::FilletInstance scrap;
  scrap.scale = 0.3;  // ~800 mm^2, below min_blob_area_mm2 = 1500
  scene.fillets = {scrap};
  const auto frame = renderer().render(camera_640(), scene);
  const auto result = estimator.estimate(frame.bgr, 0, 0);
  ASSERT_EQ(result.status, FrameStatus::kOk);
  EXPECT_EQ(result.to_camera_frame().count, 0);
}

TEST(BadInput, CalibrationWithoutImageSizeIsRejected) {
  BeltCalibration calibration;
  EXPECT_THROW(FilletEstimator{calibration}, std::invalid_argument);
}

// A texture band that is empty or inverted, or a texture pixel size of zero (say from
// `linectl replay --set`), would measure no texture and call every fillet skin side up:
// refused when the estimator is built.
TEST(BadInput, EmptyOrInvertedTextureBandIsRejected) {
  const BeltCalibration calibration = exact_calibration(camera_640());
  EstimatorParams params;
  params.texture_fine_sigma_mm = 0.0;
  EXPECT_THROW((FilletEstimator{calibration, params}), std::invalid_argument);
  params.texture_fine_sigma_mm = params.texture_coarse_sigma_mm;
  EXPECT_THROW((FilletEstimator{calibration, params}), std::invalid_argument);
  params.texture_fine_sigma_mm = 0.7;
  params.texture_coarse_sigma_mm = std::numeric_limits<double>::infinity();
  EXPECT_THROW((FilletEstimator{calibration, params}), std::invalid_argument);
  params.texture_coarse_sigma_mm = 2.3;
  EXPECT_NO_THROW((FilletEstimator{calibration, params}));
  params.texture_mm_per_px = 0.0;  // no pixel size to reduce the blob to
  EXPECT_THROW((FilletEstimator{calibration, params}), std::invalid_argument);
}

// The bend fit's settings (item 6b) out of range are refused when the estimator is built, not
// met as a crash or a silent wrong straightening in the first frame.
TEST(BadInput, BendFitSettingsOutOfRangeAreRejected) {
  const BeltCalibration calibration = exact_calibration(camera_640());
  const auto refused = [&](auto change) {
    EstimatorParams params;
    change(params);
    EXPECT_THROW((FilletEstimator{calibration, params}), std::invalid_argument);
  };
  refused([](EstimatorParams& p) { p.bend_slice_mm = 0.0; });  // no slices
  refused([](EstimatorParams& p) { p.bend_slice_mm = std::numeric_limits<double>::quiet_NaN(); });
  refused([](EstimatorParams& p) { p.bend_min_slice_width_mm = -1.0; });
  refused([](EstimatorParams& p) { p.bend_fit_passes = -1; });
  // A 36 mm radius puts a 72 mm wide fillet's inner edge on the arc's centre.
  refused([](EstimatorParams& p) { p.max_bend_per_mm = 1.0 / 30.0; });
  EstimatorParams unbent;
  unbent.bend_fit_passes = 0;  // the fit off: the outline is read as it lies
  EXPECT_NO_THROW((FilletEstimator{calibration, unbent}));
}

}  // namespace
}  // namespace fl::vision
