// The six thesis fillet templates at one sub-particle radius. Its own translation unit: the
// generator stays out of the plant's other translation units.
#pragma once

#include <vector>

#include "fl/twin/dem/fillet_template.hpp"

namespace fl::dem_plant_detail {

std::vector<dem::FilletTemplate> make_templates(double sub_particle_radius_m);

}  // namespace fl::dem_plant_detail
