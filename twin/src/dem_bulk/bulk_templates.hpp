// The six thesis fillet templates at one sub-particle radius. Its own translation unit: the
// fillet generator's mesh header and the engine's model header both declare dem::Triangle.
#pragma once

#include <vector>

#include "fl/twin/dem/fillet_template.hpp"

namespace fl::dem_bulk_detail {

std::vector<dem::FilletTemplate> make_templates(double sub_particle_radius_m);

}  // namespace fl::dem_bulk_detail
