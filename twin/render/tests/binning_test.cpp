// A binned camera: the line cameras' 1280 x 1024 sensor averaged 2 x 2 into 640 x 512 frames.
// Light, blur and noise are imaged on the sensor's pixels and each block's 8-bit values are
// averaged, so the binned frame must be, to the bit, the full readout area-averaged by
// cv::resize (INTER_AREA at an integer factor), and the truth must sit where the delivered
// pixels put it.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "fl/twin/render/fillet_renderer.hpp"

namespace fl::render {
namespace {

const FilletRenderer& renderer() {
  static const FilletRenderer instance;
  return instance;
}

cv::Mat area_halved(const cv::Mat& full) {
  cv::Mat half;
  cv::resize(full, half, cv::Size(full.cols / 2, full.rows / 2), 0.0, 0.0, cv::INTER_AREA);
  return half;
}

TEST(BinnedCamera, ItsSensorSeesTheSameFieldWithEachBlockCentredOnItsPixel) {
  const RenderCamera binned = make_line_camera();
  EXPECT_EQ(binned.width_px, 640);
  EXPECT_EQ(binned.height_px, 512);
  EXPECT_EQ(binned.binning, 2);
  const RenderCamera sensor = sensor_of(binned);
  EXPECT_EQ(sensor.width_px, kLineSensorWidthPx);
  EXPECT_EQ(sensor.height_px, kLineSensorHeightPx);
  EXPECT_EQ(sensor.binning, 1);
  // The full readout of the same camera is that sensor.
  const RenderCamera full = make_line_camera(false);
  for (const cv::Point2d belt_mm :
       {cv::Point2d(0, 0), cv::Point2d(-140, 110), cv::Point2d(90, -60)}) {
    const cv::Point2d d = belt_to_pixel(binned, belt_mm);
    const cv::Point2d s = belt_to_pixel(sensor, belt_mm);
    // Delivered pixel u covers sensor pixels 2u and 2u + 1: its centre is the sensor's 2u + 0.5.
    EXPECT_NEAR(s.x, 2.0 * d.x + 0.5, 1e-9);
    EXPECT_NEAR(s.y, 2.0 * d.y + 0.5, 1e-9);
    const cv::Point2d f = belt_to_pixel(full, belt_mm);
    EXPECT_NEAR(f.x, s.x, 1e-9);
    EXPECT_NEAR(f.y, s.y, 1e-9);
  }
  // 300 mm along travel over 640 delivered pixels.
  EXPECT_NEAR(cv::norm(pixel_to_belt(binned, {1, 0}) - pixel_to_belt(binned, {0, 0})),
              300.0 / 640.0, 1e-12);
  RenderCamera broken = binned;
  broken.binning = 0;
  EXPECT_THROW((void)sensor_of(broken), std::invalid_argument);
  EXPECT_THROW((void)renderer().render(broken, Scene{}), std::invalid_argument);
}

TEST(BinnedCamera, FrameIsTheFullReadoutAveragedInBlocks) {
  Scene scene;
  scene.seed = 17;
  FilletInstance fillet;
  fillet.x_mm = 12.0;
  fillet.y_mm = -8.0;
  fillet.angle_rad = 0.7;
  fillet.side = SideUp::kBone;
  scene.fillets = {fillet};
  scene.imaging.noise_sigma = 4.0;  // noise on the sensor: averaging four halves it
  scene.imaging.lighting_gradient = 0.2;
  scene.imaging.vignetting = 0.1;
  scene.imaging.motion_blur_px = 1.5;  // delivered pixels: 3 sensor pixels
  const RenderedFrame binned = renderer().render(make_line_camera(), scene);
  Scene full_scene = scene;
  full_scene.imaging.motion_blur_px = 3.0;
  const RenderedFrame full = renderer().render(make_line_camera(false), full_scene);

  ASSERT_EQ(binned.bgr.size(), cv::Size(640, 512));
  ASSERT_EQ(binned.bgr.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(binned.bgr, area_halved(full.bgr), cv::NORM_INF), 0.0);
  // Noise added after the averaging, or blur of the same pixel count on the coarser grid,
  // would not give the same bits: the comparison sees the order of the chain.
  ASSERT_EQ(binned.truth.size(), 1U);
  ASSERT_EQ(full.truth.size(), 1U);
  EXPECT_NEAR(full.truth[0].centre_px.x, 2.0 * binned.truth[0].centre_px.x + 0.5, 1e-9);
  EXPECT_NEAR(full.truth[0].centre_px.y, 2.0 * binned.truth[0].centre_px.y + 0.5, 1e-9);
  EXPECT_TRUE(binned.truth[0].fully_visible);

  CheckerboardOnBelt board;
  board.origin_x_mm = -80.0;
  board.origin_y_mm = -50.0;
  ImagingConditions imaging;
  imaging.noise_sigma = 2.0;
  const cv::Mat binned_board =
      renderer().render_checkerboard(make_line_camera(), board, {}, imaging, 3);
  const cv::Mat full_board =
      renderer().render_checkerboard(make_line_camera(false), board, {}, imaging, 3);
  EXPECT_EQ(cv::norm(binned_board, area_halved(full_board), cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace fl::render
