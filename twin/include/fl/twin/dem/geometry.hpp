// Geometry helpers of the DEM engine.
#pragma once

#include "fl/twin/dem/laws.hpp"

namespace fl::dem {

enum class TriangleFeature : std::uint8_t { kFace, kEdge, kVertex };

struct ClosestPoint {
  Vec3 point_m;
  TriangleFeature feature;
};

// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5), with
// the feature (face interior, edge or vertex) it lies on.
ClosestPoint closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace fl::dem
