// The in-plane bend of a fillet's spheres against a circular arc bent into a raster.
#include "fl/twin/dem/fillet_bend.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

namespace fl::dem {
namespace {

// A 172 x 72 x 32 mm block of spheres at 4 mm pitch (table 3.1's middle size, the default
// sub-particle radius) about its centroid.
std::vector<Eigen::Vector3d> block_raster() {
  std::vector<Eigen::Vector3d> points;
  constexpr double kPitchM = 0.004;
  for (int i = -21; i <= 21; ++i) {
    for (int j = -9; j <= 9; ++j) {
      for (int k = -4; k <= 4; ++k) points.emplace_back(i * kPitchM, j * kPitchM, k * kPitchM);
    }
  }
  return points;
}

// The template placed by `rotation`, then bent in the horizontal plane along a circular arc of
// `curvature_per_m` tangent to the placed axis at the centroid, and re-centred on its centroid.
std::vector<Eigen::Vector3d> placed_and_bent(const std::vector<Eigen::Vector3d>& raster,
                                             const Eigen::Matrix3d& rotation,
                                             double curvature_per_m) {
  const Eigen::Vector2d along = Eigen::Vector2d(rotation(0, 0), rotation(1, 0)).normalized();
  const Eigen::Vector2d across(-along.y(), along.x());
  std::vector<Eigen::Vector3d> world;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& t : raster) {
    const Eigen::Vector3d rigid = rotation * t;
    const double u = along.dot(rigid.head<2>());
    const double v = across.dot(rigid.head<2>());
    double bent_u = u, bent_v = v;
    if (curvature_per_m != 0.0) {
      const double radius = 1.0 / curvature_per_m;
      bent_u = (radius - v) * std::sin(u / radius);
      bent_v = radius - (radius - v) * std::cos(u / radius);
    }
    const Eigen::Vector2d xy = bent_u * along + bent_v * across;
    world.emplace_back(xy.x(), xy.y(), rigid.z());
    centroid += world.back();
  }
  centroid /= static_cast<double>(world.size());
  for (Eigen::Vector3d& p : world) p -= centroid;
  return world;
}

double fitted(const std::vector<Eigen::Vector3d>& raster, const Eigen::Matrix3d& rotation,
              const std::vector<Eigen::Vector3d>& world) {
  InPlaneBendFit fit(rotation);
  for (std::size_t i = 0; i < raster.size(); ++i) fit.add(raster[i], world[i]);
  return fit.curvature_per_m();
}

Eigen::Matrix3d heading(double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

// Turned over about its long axis (bone side up): y -> -y, z -> -z.
Eigen::Matrix3d bone_up(double angle_rad) {
  return heading(angle_rad) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
}

TEST(InPlaneBendFit, RigidPlacementHasNoBend) {
  const auto raster = block_raster();
  for (const double angle : {0.0, 0.7, 2.5, -1.9}) {
    for (const Eigen::Matrix3d& rotation : {heading(angle), bone_up(angle)}) {
      // 1e-9 / m: a radius of a million km, rounding only.
      EXPECT_NEAR(fitted(raster, rotation, placed_and_bent(raster, rotation, 0.0)), 0.0, 1e-9);
    }
  }
}

// Radii from 0.15 m (about the tightest a 172 mm fillet bends flat on a belt without folding)
// to 2 m, both ways, at headings round the circle and both sides up: the fit returns the arc's
// curvature within 3 % (the arc's higher-order terms over a 172 mm body at 0.15 m radius).
TEST(InPlaneBendFit, RecoversTheCurvatureOfAnArc) {
  const auto raster = block_raster();
  for (const double curvature : {1.0 / 0.15, 1.0 / 0.5, 1.0 / 2.0, -1.0 / 0.3}) {
    for (const double angle : {0.0, 1.2, 3.0, -2.2}) {
      for (const Eigen::Matrix3d& rotation : {heading(angle), bone_up(angle)}) {
        const double k = fitted(raster, rotation, placed_and_bent(raster, rotation, curvature));
        EXPECT_NEAR(k, curvature, 0.03 * std::abs(curvature))
            << "angle " << angle << " rotation z-axis " << rotation(2, 2);
      }
    }
  }
}

// Positive curvature turns the tip anticlockwise seen from above: heading +x, the tip's end
// of the spheres moves to +y.
TEST(InPlaneBendFit, PositiveCurvatureTurnsTheTipToTheLeft) {
  const auto raster = block_raster();
  const auto world = placed_and_bent(raster, heading(0.0), 1.0 / 0.4);
  double tip_y = 0.0, middle_y = 0.0;
  for (std::size_t i = 0; i < raster.size(); ++i) {
    if (raster[i].x() > 0.08) tip_y += world[i].y();
    if (std::abs(raster[i].x()) < 1e-9) middle_y += world[i].y();
  }
  EXPECT_GT(tip_y, middle_y);
  EXPECT_GT(fitted(raster, heading(0.0), world), 0.0);
}

// A fillet standing on end (on a flip plate) has no heading in the plane: no bend is made up.
TEST(InPlaneBendFit, StandingAxisGivesZero) {
  const auto raster = block_raster();
  const Eigen::Matrix3d standing =
      Eigen::AngleAxisd(-M_PI / 2.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  std::vector<Eigen::Vector3d> world;
  world.reserve(raster.size());
  for (const auto& t : raster) world.push_back(standing * t + Eigen::Vector3d(0.001, 0.0, 0.0));
  EXPECT_EQ(fitted(raster, standing, world), 0.0);
}

TEST(InPlaneBendFit, TooFewSpheresGiveZero) {
  InPlaneBendFit fit(heading(0.0));
  fit.add({0.01, 0.0, 0.0}, {0.01, 0.001, 0.0});
  fit.add({-0.01, 0.0, 0.0}, {-0.01, 0.001, 0.0});
  EXPECT_EQ(fit.curvature_per_m(), 0.0);
}

}  // namespace
}  // namespace fl::dem
