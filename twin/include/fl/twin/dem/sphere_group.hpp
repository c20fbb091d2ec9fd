// A body the engine moves as a group of spheres (a fillet from its template) as one pass over
// the engine state sees it: which state entries hold its spheres, their mean position and
// velocity, and their bounding box. The DEM plant and the bulk scene keep their fillets so.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "fl/twin/dem/laws.hpp"
#include "fl/twin/dem/state.hpp"

namespace fl::dem {

struct SphereGroup {
  std::vector<std::uint32_t> particles;  // state indices, valid until the next engine step
  Vec3 centroid_m = Vec3::Zero();
  Vec3 velocity_m_per_s = Vec3::Zero();
  Vec3 lower_m = Vec3::Zero();
  Vec3 upper_m = Vec3::Zero();
};

// Refills every group of `groups` (a SphereGroup or a type derived from it) from the state:
// group_of_body[body] is the index of the body's group, negative for a body of none.
template <typename Group>
void gather_sphere_groups(const State& s, const std::vector<std::int32_t>& group_of_body,
                          std::vector<Group>& groups) {
  for (SphereGroup& g : groups) {
    g.particles.clear();
    g.centroid_m.setZero();
    g.velocity_m_per_s.setZero();
    g.lower_m.setConstant(1e9);
    g.upper_m.setConstant(-1e9);
  }
  for (std::size_t k = 0; k < s.size(); ++k) {
    const std::uint32_t body = s.body[k];
    if (body >= group_of_body.size() || group_of_body[body] < 0) continue;
    SphereGroup& g = groups[static_cast<std::size_t>(group_of_body[body])];
    g.particles.push_back(static_cast<std::uint32_t>(k));
    g.centroid_m += s.position_m[k];
    g.velocity_m_per_s += s.velocity_m_per_s[k];
    const Vec3 r = Vec3::Constant(s.radius_m[k]);
    g.lower_m = g.lower_m.cwiseMin(s.position_m[k] - r);
    g.upper_m = g.upper_m.cwiseMax(s.position_m[k] + r);
  }
  for (SphereGroup& g : groups) {
    if (g.particles.empty()) continue;
    // Equal spheres: the mean is the centre of mass.
    const double inv = 1.0 / static_cast<double>(g.particles.size());
    g.centroid_m *= inv;
    g.velocity_m_per_s *= inv;
  }
}

}  // namespace fl::dem
