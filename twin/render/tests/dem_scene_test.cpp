// Pictures and videos of a DEM run: a sphere shows where it is in both views, videos read back.
#include "fl/twin/render/dem_scene.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <opencv2/videoio.hpp>

namespace fl::render {
namespace {

std::shared_ptr<const dem::Model> one_ball_model() {
  dem::ModelSpec spec;
  spec.materials = {{"fillet", 3.7e5, 0.37, 940.0}};
  spec.types = {{"ball", 0}, {"wall", 0}};
  spec.interactions = {{0, 0, {{"hertz_mindlin", {{"restitution", 0.5}}}}, std::nullopt, false}};
  spec.planes = {{"floor", 1, dem::Vec3::Zero(), dem::Vec3::UnitZ()}};
  spec.gravity_m_per_s2 = dem::Vec3::Zero();
  return std::make_shared<dem::Model>(spec);
}

// 1 m window at 1000 px: 1 px per mm, so positions are easy to predict.
DemSceneView one_metre_view() {
  DemSceneView view;
  view.x_min_m = 0.0;
  view.x_max_m = 1.0;
  view.y_half_width_m = 0.1;  // top view 200 px
  view.z_min_m = -0.05;       // side view 150 px
  view.z_max_m = 0.1;
  view.width_px = 1000;
  return view;
}

bool is_background(const cv::Vec3b& pixel) { return pixel == cv::Vec3b(245, 245, 245); }

TEST(DemScene, SphereAppearsWhereItIsInBothViews) {
  dem::Simulation sim(one_ball_model());
  sim.add_sphere({dem::Vec3(0.6, 0.05, 0.03), 0.01, 0});  // 10 mm radius: a 21 px disc
  const cv::Mat image = render_dem_scene(sim, one_metre_view());
  ASSERT_EQ(image.cols, 1000);
  ASSERT_EQ(image.rows, 200 + 4 + 150);
  // top view: x 600 px, y 0.05 m left of the centre line -> row 100 - 50
  EXPECT_FALSE(is_background(image.at<cv::Vec3b>(50, 600)));
  EXPECT_TRUE(is_background(image.at<cv::Vec3b>(150, 600)));  // mirrored across: nothing
  // side view starts at row 204: z 0.03 m below the top (0.1) by 70 px
  EXPECT_FALSE(is_background(image.at<cv::Vec3b>(204 + 70, 600)));
  // the floor (z = 0) is a grey line 100 px below the side view's top
  EXPECT_EQ(image.at<cv::Vec3b>(204 + 100, 100), cv::Vec3b(150, 150, 150));
}

TEST(DemScene, EmptyWindowIsRejected) {
  dem::Simulation sim(one_ball_model());
  DemSceneView view = one_metre_view();
  view.x_max_m = view.x_min_m;
  EXPECT_THROW((void)render_dem_scene(sim, view), std::invalid_argument);
}

TEST(DemScene, LosslessVideoReadsBackFrameForFrame) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() /
                                     ("fl_dem_scene_" + std::to_string(::getpid()) + ".mkv");
  dem::Simulation sim(one_ball_model());
  sim.add_sphere({dem::Vec3(0.2, 0.0, 0.01), 0.01, 0, dem::Vec3(1.0, 0.0, 0.0)});
  const DemSceneView view = one_metre_view();
  std::vector<cv::Mat> written;
  {
    const cv::Mat first = render_dem_scene(sim, view);
    DemVideoWriter video(file, 10.0, first.size());
    for (int frame = 0; frame < 3; ++frame) {
      written.push_back(render_dem_scene(sim, view));
      video.write(written.back());
      sim.step(100);  // 1 m/s for 100 default steps: the ball moves on between frames
    }
    EXPECT_EQ(video.frames(), 3U);
    EXPECT_THROW(video.write(cv::Mat(10, 10, CV_8UC3)), std::invalid_argument);
  }
  cv::VideoCapture capture(file.string(), cv::CAP_FFMPEG);
  ASSERT_TRUE(capture.isOpened());
  for (const cv::Mat& expected : written) {
    cv::Mat frame;
    ASSERT_TRUE(capture.read(frame));
    EXPECT_EQ(cv::norm(frame, expected, cv::NORM_INF), 0.0);  // FFV1 is lossless
  }
  std::filesystem::remove(file);
}

TEST(DemScene, UnknownVideoExtensionIsAClearError) {
  try {
    DemVideoWriter video("/tmp/run.gif", 10.0, cv::Size(64, 64));
    FAIL() << "expected an error";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("run.gif"), std::string::npos);
  }
}

}  // namespace
}  // namespace fl::render
