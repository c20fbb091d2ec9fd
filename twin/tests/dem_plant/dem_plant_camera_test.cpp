// Cameras of the DEM plant report a known fillet's pose within their noise.
#include <gtest/gtest.h>

#include <cmath>

#include "dem_plant_test_support.hpp"

namespace fl::test {
namespace {

TEST(DemPlantCamera, OrientationCameraReportsTheSpawnedPose) {
  DemPlantConfig config = test_config();
  FastCameraConfig& camera = config.shared.cameras[index(CameraId::kOrientation)];
  camera.miss_prob = 0.0F;  // the comparison needs every frame and the true classes
  camera.hand_flip_prob = 0.0F;
  camera.side_flip_prob = 0.0F;
  camera.singulation_error_prob = 0.0F;
  DemRig rig(config);
  rig.out = OutputImage{};  // belts stopped: the fillet stays under the camera
  DemFilletSpawn spawn;
  spawn.s_mm = 1850.0;  // under camera 1
  spawn.y_mm = 20.0;
  spawn.angle_rad = 0.2;
  spawn.variant = 3;  // 172 x 72 x 32, right
  spawn.side = SideUp::kBone;
  ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  rig.run(0.3);  // settles; period 40 ms + latency 50 ms: several frames delivered
  const CameraFrame& frame = rig.in.cameras[index(CameraId::kOrientation)];
  ASSERT_GT(frame.sequence, 0U);
  ASSERT_EQ(frame.count, 1U);
  const FilletEstimate& e = frame.estimates[0];
  // 4 sigma of the camera's noise (2 mm, 0.03 rad) plus what settling on the belt may move
  // (a few mm, 0.02 rad).
  EXPECT_NEAR(e.x_mm, 0.0, 4.0 * 2.0 + 5.0);
  EXPECT_NEAR(e.y_mm, 20.0, 4.0 * 2.0 + 5.0);
  EXPECT_NEAR(e.angle_rad, 0.2, 4.0 * 0.03 + 0.02);
  EXPECT_EQ(e.hand, Hand::kRight);
  EXPECT_EQ(e.side, SideUp::kBone);
  EXPECT_TRUE(e.singulated);
  EXPECT_GE(e.confidence, camera.confidence_ok_min);
  // Camera 2 sees nothing: the fillet is 1.1 m upstream of it.
  EXPECT_EQ(rig.in.cameras[index(CameraId::kPosition)].count, 0U);
}

TEST(DemPlantCamera, TouchingPairIsNotSingulated) {
  DemPlantConfig config = test_config();
  config.shared.cameras[index(CameraId::kOrientation)].miss_prob = 0.0F;
  config.shared.cameras[index(CameraId::kOrientation)].singulation_error_prob = 0.0F;
  DemRig rig(config);
  rig.out = OutputImage{};
  DemFilletSpawn spawn;
  spawn.s_mm = 1850.0;
  spawn.y_mm = -40.0;
  spawn.touching_pair = true;
  ASSERT_TRUE(rig.plant->spawn_fillet(spawn));
  rig.run(0.3);
  const CameraFrame& frame = rig.in.cameras[index(CameraId::kOrientation)];
  ASSERT_EQ(frame.count, 2U);
  EXPECT_FALSE(frame.estimates[0].singulated);
  EXPECT_FALSE(frame.estimates[1].singulated);
}

}  // namespace
}  // namespace fl::test
