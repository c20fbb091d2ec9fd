#include "bulk_templates.hpp"

#include "fl/twin/dem/fillet_generator.hpp"

namespace fl::dem_bulk_detail {

std::vector<dem::FilletTemplate> make_templates(double sub_particle_radius_m) {
  dem::FilletGeneratorOptions options;
  options.sub_particle_radius_m = sub_particle_radius_m;
  return dem::generate_thesis_fillets(dem::make_fillet_mesh(), options);
}

}  // namespace fl::dem_bulk_detail
