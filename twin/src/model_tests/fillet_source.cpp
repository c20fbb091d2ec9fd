// Fillet templates for the model tests (fl/twin/model_tests/fillet_source.hpp). This file
// must not include the engine headers (see the header).
#include "fl/twin/model_tests/fillet_source.hpp"

#include <stdexcept>

#include "fl/twin/dem/fillet_generator.hpp"
#include "fl/twin/dem/stl.hpp"

namespace fl::model_tests {

std::shared_ptr<const dem::TriangleMesh> load_fillet_mesh(const std::filesystem::path& stl_mm) {
  dem::StlReadOptions options;
  options.scale = 1e-3;  // millimetre file -> metres
  return std::make_shared<const dem::TriangleMesh>(dem::read_stl(stl_mm, options).mesh);
}

std::size_t fillet_variant_count() { return dem::thesis_fillet_variants().size(); }

std::string fillet_variant_name(std::size_t variant) {
  const auto variants = dem::thesis_fillet_variants();
  return variant < variants.size() ? variants[variant].name : std::string("?");
}

dem::FilletTemplate make_fillet_template(const dem::TriangleMesh* base, double radius_m,
                                         std::size_t variant, double scale) {
  const auto variants = dem::thesis_fillet_variants();
  if (variant >= variants.size()) {
    throw std::invalid_argument("model tests: fillet variant " + std::to_string(variant) +
                                " not in 0.." + std::to_string(variants.size() - 1));
  }
  if (!(radius_m > 0.0) || !(scale > 0.0)) {
    throw std::invalid_argument("model tests: sub-particle radius and scale must be > 0");
  }
  const dem::TriangleMesh mesh = base != nullptr ? *base : dem::make_fillet_mesh();
  dem::FilletGeneratorOptions options;
  options.sub_particle_radius_m = radius_m;
  dem::FilletTemplate fillet = dem::generate_fillet_template(
      dem::make_variant_mesh(mesh, variants[variant]), variants[variant].name, options);
  if (scale != 1.0) {
    for (auto& p : fillet.positions_m) p *= scale;
    for (auto& r : fillet.radii_m) r *= scale;
    for (auto& b : fillet.bonds) {
      b.contact_radius_m *= scale;
      b.thickness_m *= scale;
    }
    fillet.half_extent_m *= scale;
    fillet.mass_kg *= scale * scale * scale;
  }
  return fillet;
}

}  // namespace fl::model_tests
