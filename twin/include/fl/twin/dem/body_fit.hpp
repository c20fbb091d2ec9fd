// A fillet body's pose as the engine holds it: the rigid rotation of its template onto its
// spheres now. The DEM plant and the bulk scene keep their fillets as sphere groups
// (sphere_group.hpp) and read their poses so.
#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>

#include "fl/twin/dem/fillet_bend.hpp"
#include "fl/twin/dem/fillet_template.hpp"
#include "fl/twin/dem/state.hpp"

namespace fl::dem {

// Template coordinates to world ones for the body whose spheres sit at state indices
// `particles` (from the last pass over the state) about `centroid_m`; `first_id` is the
// engine id of its template sphere 0. A stale index (the state re-ordered since the pass) is
// a programming error: std::logic_error naming `owner`.
inline Eigen::Matrix3d fit_template_rotation(const State& s,
                                             std::span<const std::uint32_t> particles,
                                             const FilletTemplate& t, std::uint32_t first_id,
                                             const Vec3& centroid_m, const std::string& owner) {
  TemplateRotationFit fit;
  for (const std::uint32_t k : particles) {
    const std::uint32_t i = k < s.size() ? s.id[k] - first_id : 0U;
    if (k >= s.size() || i >= t.positions_m.size()) {
      throw std::logic_error(owner + " holds a stale particle index");
    }
    fit.add(t.positions_m[i], s.position_m[k] - centroid_m);
  }
  return fit.rotation();
}

}  // namespace fl::dem
