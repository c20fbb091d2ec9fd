// TriangleMesh measures and transforms against analytic values.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "fl/twin/dem/mesh.hpp"

namespace fl::dem {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(MeshGeometry, UnitCubeVolumeAreaBoxCentroid) {
  const auto cube = make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  // Exact: every determinant is of small integers.
  EXPECT_DOUBLE_EQ(signed_volume(cube), 1.0);
  EXPECT_DOUBLE_EQ(surface_area(cube), 6.0);
  const auto box = bounding_box(cube);
  EXPECT_EQ(box.min, Eigen::Vector3d::Zero());
  EXPECT_EQ(box.max, Eigen::Vector3d::Ones());
  EXPECT_TRUE(volume_centroid(cube).isApprox(Eigen::Vector3d::Constant(0.5), 1e-15));
  EXPECT_TRUE(check_topology(cube).closed_manifold());
  EXPECT_TRUE(is_closed_outward(cube));
  EXPECT_EQ(check_topology(cube).edge_count, 18U);  // 12 cube edges + 6 face diagonals
}

TEST(MeshGeometry, BoxVolumeIsTranslationInvariant) {
  // Far from the origin the tetrahedra get large and cancel; 1e-9 relative covers the
  // cancellation of terms ~1e3^3 = 1e9 times the volume 6 at double precision.
  const Eigen::Vector3d offset(1000.0, -2000.0, 500.0);
  const auto box = make_box(offset, offset + Eigen::Vector3d(1.0, 2.0, 3.0));
  EXPECT_NEAR(signed_volume(box), 6.0, 6.0 * 1e-9);
  EXPECT_NEAR(surface_area(box), 2.0 * (2.0 + 3.0 + 6.0), 1e-9);
  EXPECT_TRUE(volume_centroid(box).isApprox(offset + Eigen::Vector3d(0.5, 1.0, 1.5), 1e-12));
}

TEST(MeshGeometry, IcosphereApproachesSphere) {
  const double radius = 2.0;
  const auto sphere = make_icosphere(radius, 5);  // 20 x 4^5 = 20480 triangles
  ASSERT_EQ(sphere.triangles.size(), 20480U);
  EXPECT_TRUE(is_closed_outward(sphere));
  // An inscribed polyhedron is smaller than the sphere. With edge length ~ 0.034 R at level 5
  // the sagitta is ~1.5e-4 R, so volume and area fall short by a few 1e-4: bounds 1e-3 below,
  // never above.
  const double sphere_volume = 4.0 / 3.0 * kPi * std::pow(radius, 3);
  const double sphere_area = 4.0 * kPi * radius * radius;
  EXPECT_LT(signed_volume(sphere), sphere_volume);
  EXPECT_GT(signed_volume(sphere), sphere_volume * (1.0 - 1e-3));
  EXPECT_LT(surface_area(sphere), sphere_area);
  EXPECT_GT(surface_area(sphere), sphere_area * (1.0 - 1e-3));
  // Symmetric under the icosahedron's group: centroid at the origin up to rounding.
  EXPECT_LT(volume_centroid(sphere).norm(), 1e-12);
}

TEST(MeshGeometry, IcosphereConvergesQuadratically) {
  // The volume deficit of an inscribed subdivision shrinks ~4x per level (h^2); between levels
  // 3 -> 4 the ratio must be between 3.5 and 4.5.
  const double exact = 4.0 / 3.0 * kPi;
  const double deficit3 = exact - signed_volume(make_icosphere(1.0, 3));
  const double deficit4 = exact - signed_volume(make_icosphere(1.0, 4));
  EXPECT_GT(deficit3 / deficit4, 3.5);
  EXPECT_LT(deficit3 / deficit4, 4.5);
}

TEST(MeshGeometry, TopologyFindsHolesFlipsAndNonManifoldEdges) {
  auto cube = make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  auto holed = cube;
  holed.triangles.pop_back();  // removes one triangle: its 3 edges become boundary edges
  EXPECT_EQ(check_topology(holed).boundary_edges, 3U);
  EXPECT_FALSE(check_topology(holed).closed_manifold());
  EXPECT_EQ(check_topology(holed).describe(), "3 boundary edges");

  auto one_flipped = cube;
  std::swap(one_flipped.triangles[0][1], one_flipped.triangles[0][2]);  // 3 edges now clash
  EXPECT_EQ(check_topology(one_flipped).misoriented_edges, 3U);

  auto doubled = cube;
  doubled.triangles.push_back(cube.triangles[0]);  // 3 edges used three times
  EXPECT_EQ(check_topology(doubled).non_manifold_edges, 3U);

  auto bad_index = cube;
  bad_index.triangles[0][0] = 99;
  EXPECT_EQ(check_topology(bad_index).out_of_range_indices, 1U);
  EXPECT_FALSE(check_topology(TriangleMesh{}).closed_manifold());
}

TEST(MeshGeometry, InwardMeshHasNegativeVolumeAndIsRefused) {
  const auto cube = flipped(make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()));
  EXPECT_TRUE(check_topology(cube).closed_manifold());  // consistent, just inward
  EXPECT_DOUBLE_EQ(signed_volume(cube), -1.0);
  EXPECT_FALSE(is_closed_outward(cube));
}

TEST(MeshGeometry, PointInMeshOnKnownPoints) {
  const auto cube = make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  EXPECT_TRUE(contains_point(cube, Eigen::Vector3d(0.5, 0.5, 0.5)));
  EXPECT_NEAR(winding_number(cube, Eigen::Vector3d(0.5, 0.5, 0.5)), 1.0, 1e-12);
  EXPECT_NEAR(winding_number(cube, Eigen::Vector3d(3.0, 0.5, 0.5)), 0.0, 1e-12);
  // Points a ray cast along an axis would send through vertices and edges of the box.
  EXPECT_TRUE(contains_point(cube, Eigen::Vector3d(0.5, 0.5, 0.5)));
  EXPECT_TRUE(contains_point(cube, Eigen::Vector3d(0.25, 0.25, 0.25)));  // on a face diagonal line
  EXPECT_FALSE(contains_point(cube, Eigen::Vector3d(-1.0, 0.0, 0.0)));   // in line with an edge
  EXPECT_FALSE(contains_point(cube, Eigen::Vector3d(2.0, 1.0, 1.0)));    // in line with a vertex
  EXPECT_TRUE(contains_point(cube, Eigen::Vector3d(1e-9, 1e-9, 1e-9)));  // just inside a corner
  EXPECT_FALSE(contains_point(cube, Eigen::Vector3d(-1e-9, 0.5, 0.5)));  // just outside a face

  const auto sphere = make_icosphere(1.0, 3);
  // Level-3 icosphere: the faces are at least 0.995 from the centre (sagitta ~ 3e-3), so 0.99
  // is inside and 1.01 outside in every direction.
  for (const Eigen::Vector3d& direction :
       {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(1, 1, 1).normalized(),
        Eigen::Vector3d(-0.3, 0.2, -0.9).normalized()}) {
    EXPECT_TRUE(contains_point(sphere, 0.99 * direction));
    EXPECT_FALSE(contains_point(sphere, 1.01 * direction));
  }
}

TEST(MeshGeometry, DistanceToSurface) {
  const auto cube = make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  EXPECT_NEAR(distance_to_surface(cube, Eigen::Vector3d(0.5, 0.5, 0.5)), 0.5, 1e-15);
  EXPECT_NEAR(distance_to_surface(cube, Eigen::Vector3d(0.5, 0.2, 0.9)), 0.1, 1e-15);
  EXPECT_NEAR(distance_to_surface(cube, Eigen::Vector3d(2.0, 2.0, 0.5)), std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(distance_to_surface(cube, Eigen::Vector3d(2.0, 2.0, 2.0)), std::sqrt(3.0), 1e-15);
}

TEST(MeshGeometry, NonUniformScalingScalesVolumeByTheDeterminant) {
  const auto sphere = make_icosphere(1.0, 3);
  const Eigen::Vector3d factors(2.0, 0.5, 3.0);
  const auto ellipsoid = scaled(sphere, factors);
  EXPECT_TRUE(is_closed_outward(ellipsoid));
  EXPECT_NEAR(signed_volume(ellipsoid), signed_volume(sphere) * 3.0, 1e-12);
  EXPECT_TRUE(bounding_box(ellipsoid).size().isApprox(2.0 * factors, 1e-12));
}

TEST(MeshGeometry, MirroringKeepsVolumeAndOutwardOrientation) {
  // An asymmetric solid: a box with one corner pulled out.
  auto box = make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 2.0, 3.0));
  box.vertices[7] += Eigen::Vector3d(0.5, 0.5, 0.5);  // corner (max, max, max)
  ASSERT_TRUE(is_closed_outward(box));
  for (int axis = 0; axis < 3; ++axis) {
    const auto mirror = mirrored(box, axis);
    EXPECT_TRUE(is_closed_outward(mirror)) << "axis " << axis;
    EXPECT_DOUBLE_EQ(signed_volume(mirror), signed_volume(box));
    Eigen::Vector3d expected = volume_centroid(box);
    expected[axis] = -expected[axis];
    EXPECT_TRUE(volume_centroid(mirror).isApprox(expected, 1e-12));
  }
  // A reflection by scaling (one negative factor) also stays outward.
  EXPECT_TRUE(is_closed_outward(scaled(box, Eigen::Vector3d(1.0, -2.0, 1.0))));
  // Two negative factors are a rotation: no flip needed, still outward.
  EXPECT_TRUE(is_closed_outward(scaled(box, Eigen::Vector3d(-1.0, -1.0, 1.0))));
}

TEST(MeshGeometry, BadArgumentsThrow) {
  const auto cube = make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  EXPECT_THROW(mirrored(cube, 3), std::invalid_argument);
  EXPECT_THROW(scaled(cube, Eigen::Vector3d(1.0, 0.0, 1.0)), std::invalid_argument);
  EXPECT_THROW(make_icosphere(-1.0, 2), std::invalid_argument);
  EXPECT_THROW(volume_centroid(TriangleMesh{}), std::invalid_argument);
}

}  // namespace
}  // namespace fl::dem
